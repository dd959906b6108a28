//! The keypoints do not depend on the frame's resolution (issue 34): a real photo and the
//! same photo enlarged 3 times give the same hand, once the 3x keypoints are scaled back.
//! At 3x every crop shrinks its image by more than 2, so it is read through the box
//! reduction (`warp.rs`, `reduce.rs`), while at 1x the crops are plain bilinear.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use image::imageops::FilterType;
use monohand_vision::image_io::load_rgb;

#[test]
fn keypoints_of_a_photo_and_of_it_enlarged_three_times_agree() {
    let Some((_, pipeline)) = common::pipeline(false) else {
        return;
    };
    for photo in ["images/pinto/hand.png", "images/hamer/test1.jpg"] {
        let img = load_rgb(&common::shared(photo).expect("photo")).expect("decode");
        let big = image::imageops::resize(
            &img,
            img.width() * 3,
            img.height() * 3,
            FilterType::Triangle,
        );
        let small = pipeline.detect(&img).expect("detect 1x");
        let large = pipeline.detect(&big).expect("detect 3x");
        let a = small.hands.first().expect("a hand at 1x");
        // The same hand at 3x: the one whose wrist lands nearest.
        let back = |p: [f64; 3]| [(p[0] + 0.5) / 3.0 - 0.5, (p[1] + 0.5) / 3.0 - 0.5];
        let dist =
            |p: [f64; 2], q: [f64; 3]| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
        let b = large
            .hands
            .iter()
            .min_by(|x, y| {
                let dx = dist(back(x.keypoints.points[0]), a.keypoints.points[0]);
                let dy = dist(back(y.keypoints.points[0]), a.keypoints.points[0]);
                dx.total_cmp(&dy)
            })
            .expect("a hand at 3x");
        let apart: Vec<f64> = a
            .keypoints
            .points
            .iter()
            .zip(&b.keypoints.points)
            .map(|(p, q)| dist(back(*q), *p))
            .collect();
        let mean = apart.iter().sum::<f64>() / apart.len() as f64;
        let worst = apart.iter().cloned().fold(0.0, f64::max);
        let size = a
            .keypoints
            .bounds()
            .width()
            .max(a.keypoints.bounds().height());
        println!("{photo}: hand {size:.0} px; 1x and 3x keypoints apart by {mean:.2} px on average, {worst:.2} px at most");
        assert_eq!(a.side, b.side, "{photo}: the same hand");
        // The network's own jitter between two slightly different crops of one hand is a
        // pixel or two at this size; a crop read without anti-aliasing, or from the wrong
        // place, moves the keypoints by far more.
        assert!(
            mean < 0.02 * size,
            "{photo}: {mean:.2} px apart on a {size:.0} px hand"
        );
        assert!(
            worst < 0.06 * size,
            "{photo}: {worst:.2} px apart at worst on a {size:.0} px hand"
        );
    }
}
