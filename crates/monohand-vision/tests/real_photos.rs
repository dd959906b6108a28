//! Hands are found where hands are on the project's real photos. Expected boxes were checked
//! by eye on overlays once (`examples/detect.rs --overlay`) and pinned here; a detection
//! matches when its keypoint bounds overlap the pinned box with IoU > 0.5.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

mod common;

use monohand_core::bbox::BBox;
use monohand_core::hand_model::HandSide;

/// (image, minimum and maximum hand count, pinned hands: keypoint bounds and the physical side
/// where it is certain from the photo, minimum and maximum head count).
type Case = (
    &'static str,
    usize,
    usize,
    &'static [([f64; 4], Option<HandSide>)],
    usize,
    usize,
);

const CASES: &[Case] = &[
    // Webcam frame, one open left palm, fingers to the right.
    (
        "images/pinto/hand.png",
        1,
        1,
        &[([57.0, 123.0, 319.0, 316.0], None)],
        0,
        0,
    ),
    // STB: the subject's left palm (thumb on the image left, palm to the camera).
    (
        "stb_b1counting/images/B1Counting/BB_left_0.png",
        1,
        1,
        &[([406.0, 182.0, 500.0, 373.0], Some(HandSide::Left))],
        1,
        1,
    ),
    // Woman facing the camera making an OK sign with her right hand, plus the listener's hand.
    (
        "images/hamer/test1.jpg",
        2,
        2,
        &[
            ([265.0, 165.0, 373.0, 333.0], Some(HandSide::Right)),
            ([400.0, 295.0, 492.0, 410.0], None),
        ],
        1,
        1,
    ),
    // Both hands over the face of a woman facing the camera: her right hand on the image left.
    (
        "images/hamer/test5.jpg",
        2,
        2,
        &[
            ([408.0, 509.0, 579.0, 898.0], Some(HandSide::Right)),
            ([595.0, 486.0, 776.0, 883.0], Some(HandSide::Left)),
        ],
        1,
        1,
    ),
    // Drawing of a palm whose fingers are small hands: the big palm and three small ones.
    (
        "images/wilor/test2.png",
        3,
        6,
        &[([360.0, 364.0, 1311.0, 1415.0], None)],
        0,
        0,
    ),
    // Man eating: both hands at the mouth.
    (
        "images/interwild/image.jpg",
        2,
        2,
        &[([146.0, 273.0, 203.0, 344.0], None)],
        1,
        1,
    ),
    // 3072x4096 photo of an open hand (exercises the supersampled letterbox).
    (
        "images/wolterlw/test_img.jpg",
        1,
        1,
        &[([817.0, 1250.0, 2743.0, 2541.0], None)],
        0,
        0,
    ),
];

#[test]
fn hands_are_found_where_hands_are() {
    let Some((_, pipeline)) = common::pipeline(true) else {
        return;
    };
    let mut checked = 0;
    for (rel, min, max, pinned, hmin, hmax) in CASES {
        let Some(path) = common::shared(rel) else {
            continue;
        };
        let found = pipeline.detect_file(&path).expect(rel);
        let n = found.hands.len();
        println!("{rel}: {n} hands, {} heads", found.heads.len());
        assert!(
            (*min..=*max).contains(&n),
            "{rel}: {n} hands, expected {min}..={max}"
        );
        assert!(
            (*hmin..=*hmax).contains(&found.heads.len()),
            "{rel}: {} heads",
            found.heads.len()
        );
        for (bbox, side) in pinned.iter() {
            let best = found
                .hands
                .iter()
                .map(|h| (h.keypoints.bounds().iou(&BBox::from(*bbox)), h))
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .expect("at least one hand");
            assert!(
                best.0 > 0.5,
                "{rel}: no hand near {bbox:?} (best IoU {:.2})",
                best.0
            );
            if let Some(side) = side {
                assert_eq!(best.1.side, *side, "{rel}: side of the hand at {bbox:?}");
            }
            assert!(best
                .1
                .keypoints
                .points
                .iter()
                .all(|p| p[2] > 0.0 && p[2] <= 1.0));
        }
        checked += 1;
    }
    assert!(
        checked > 0 || common::shared("images").is_none(),
        "no case ran"
    );
}
