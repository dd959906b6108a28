//! The landmark network's mirror pass: a crop's mirror image, read and turned back, describes
//! the same hand as the crop itself, and the default estimate is the mean of the two.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use monohand_vision::image_io::load_rgb;
use monohand_vision::landmarks::{HandLandmarks, LandmarkModel, LandmarkOptions};
use monohand_vision::{ModelFile, TfliteNet};

fn mean_dist(a: &[[f64; 3]], b: &[[f64; 3]], dims: usize) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (0..dims).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt())
        .sum::<f64>()
        / a.len() as f64
}

#[test]
fn the_mirrored_pass_turned_back_describes_the_same_hand() {
    let Some((store, pipeline)) = common::pipeline(false) else {
        return;
    };
    let bytes = store.load(ModelFile::HandLandmarkFull).expect("load");
    let net =
        TfliteNet::from_bytes(&bytes, &store.path_of(ModelFile::HandLandmarkFull)).expect("import");
    let model = LandmarkModel::new(net, LandmarkOptions::default()).expect("model");
    assert!(
        model.options.mirror_pass,
        "the mirror pass is on by default"
    );

    for photo in [
        "images/pinto/hand.png",
        "images/hamer/test5.jpg",
        "images/handmesh_freihand_crops/119_img.jpg",
    ] {
        let img = load_rgb(&common::shared(photo).expect("photo")).expect("decode");
        let found = pipeline.detect(&img).expect("detect");
        let hand = found.hands.first().expect("a hand in the photo");
        let roi = hand.roi;

        let plain = model.estimate_pass(&img, &roi, false).expect("plain pass");
        let mirrored = model
            .estimate_pass(&img, &roi, true)
            .expect("mirrored pass");
        // The two passes see the same hand: the network's own disagreement between a hand
        // and its mirror image is a few pixels and millimetres. Had the mirrored pass not
        // been turned back, its keypoints would be a crop width away and its world
        // landmarks' x negated (the hand is about 80 mm wide).
        let px = mean_dist(&plain.image, &mirrored.image, 2);
        let world_mm = 1000.0 * mean_dist(&plain.world, &mirrored.world, 3);
        let crop = roi.width;
        println!(
            "{photo}: crop {crop:.0} px, passes apart {px:.2} px and {world_mm:.1} mm, \
             handedness {:.3} / {:.3}",
            plain.handedness_raw, mirrored.handedness_raw
        );
        assert!(
            px < 0.03 * crop,
            "keypoints {px:.2} px apart (crop {crop:.0} px)"
        );
        assert!(world_mm < 12.0, "world landmarks {world_mm:.1} mm apart");
        // The handedness is read as the other hand's, then swapped back.
        assert!(
            (plain.handedness_raw - mirrored.handedness_raw).abs() < 0.2,
            "handedness {} against {}",
            plain.handedness_raw,
            mirrored.handedness_raw
        );

        // The estimate is the mean of the two passes.
        let both: HandLandmarks = model.estimate(&img, &roi).expect("estimate");
        for j in 0..21 {
            for k in 0..3 {
                let mean_img = 0.5 * (plain.image[j][k] + mirrored.image[j][k]);
                let mean_world = 0.5 * (plain.world[j][k] + mirrored.world[j][k]);
                assert!((both.image[j][k] - mean_img).abs() < 1e-3, "joint {j}");
                assert!((both.world[j][k] - mean_world).abs() < 1e-6, "joint {j}");
            }
        }
        let single = LandmarkModel::new(
            TfliteNet::from_bytes(&bytes, &store.path_of(ModelFile::HandLandmarkFull))
                .expect("import"),
            LandmarkOptions {
                mirror_pass: false,
                ..LandmarkOptions::default()
            },
        )
        .expect("model")
        .estimate(&img, &roi)
        .expect("single pass");
        assert_eq!(
            single.image, plain.image,
            "without the mirror pass: the plain pass"
        );
    }
}
