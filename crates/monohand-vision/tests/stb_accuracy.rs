//! Keypoints on the STB stereo benchmark frame `BB_left_0.png` against its 3D ground truth
//! projected with the left Bumblebee camera.

mod common;

use monohand_core::hand_model::HandSide;
use monohand_vision::{HandPipeline, ModelOptions, PipelineOptions};

/// STB `B1Counting_BB.mat`, `handPara[:, :, 0]ᵀ`: frame 0 joints in mm, left camera frame.
/// STB order: palm centre, then little, ring, middle, index, thumb (4 each, base to tip).
const STB_FRAME0_MM: [[f64; 3]; 21] = [
    [126.50229, 56.84319, 664.35295],
    [145.4968, 25.36095, 664.08166],
    [140.35836, -6.21632, 664.75134],
    [137.88195, -21.00779, 664.48053],
    [134.68616, -39.71621, 663.60263],
    [125.34847, 18.13323, 667.21381],
    [116.77838, -17.67732, 670.83826],
    [111.12595, -39.96433, 670.26907],
    [106.11869, -59.27077, 668.79427],
    [108.96329, 22.27134, 669.05965],
    [99.47618, -16.42493, 672.60464],
    [93.1115, -40.53121, 670.77249],
    [87.5756, -60.34487, 666.55927],
    [93.01393, 32.4575, 670.4252],
    [84.96446, -0.4878, 672.83188],
    [79.71088, -21.81815, 674.01779],
    [74.60726, -41.02528, 671.77636],
    [111.80784, 84.16038, 664.35543],
    [83.70504, 74.25133, 667.82741],
    [59.48861, 60.33182, 669.78108],
    [69.43521, 37.17138, 663.40704],
];
const FX: f64 = 822.79041;
const CX: f64 = 318.47345;
const CY: f64 = 250.31296;

/// For each MediaPipe joint, the STB joint it corresponds to (the wrist has none: STB's
/// joint 0 is the palm centre).
const MP_TO_STB: [Option<usize>; 21] = [
    None,
    Some(17),
    Some(18),
    Some(19),
    Some(20),
    Some(13),
    Some(14),
    Some(15),
    Some(16),
    Some(9),
    Some(10),
    Some(11),
    Some(12),
    Some(5),
    Some(6),
    Some(7),
    Some(8),
    Some(1),
    Some(2),
    Some(3),
    Some(4),
];
const NAMES: [&str; 21] = [
    "wrist",
    "thumb_cmc",
    "thumb_mcp",
    "thumb_ip",
    "thumb_tip",
    "index_mcp",
    "index_pip",
    "index_dip",
    "index_tip",
    "middle_mcp",
    "middle_pip",
    "middle_dip",
    "middle_tip",
    "ring_mcp",
    "ring_pip",
    "ring_dip",
    "ring_tip",
    "pinky_mcp",
    "pinky_pip",
    "pinky_dip",
    "pinky_tip",
];

fn project(p: [f64; 3]) -> [f64; 2] {
    [FX * p[0] / p[2] + CX, FX * p[1] / p[2] + CY]
}

#[test]
fn stb_frame0_keypoints_match_projected_ground_truth() {
    let Some(image) = common::shared("stb_b1counting/images/B1Counting/BB_left_0.png") else {
        return;
    };
    let Some(store) = common::models() else {
        return;
    };
    let models = ModelOptions {
        model_dir: Some(store.dir().to_path_buf()),
        ..Default::default()
    };
    for (label, refine) in [
        ("single pass (MediaPipe)", 0),
        ("one re-crop pass (default)", 1),
    ] {
        let options = PipelineOptions {
            refine_passes: refine,
            ..Default::default()
        };
        let pipeline = HandPipeline::new(&models, options).expect("pipeline");
        let found = pipeline.detect_file(&image).expect("detect");
        assert_eq!(
            found.hands.len(),
            1,
            "one hand in the STB frame: {:?}",
            found.hands
        );
        let hand = &found.hands[0];
        assert_eq!(
            hand.side,
            HandSide::Left,
            "STB B1Counting shows a left hand"
        );
        println!("STB BB_left_0, {label}: per-joint error (px) vs projected ground truth");
        let mut errs = Vec::new();
        for (j, stb) in MP_TO_STB.iter().enumerate() {
            let Some(s) = stb else { continue };
            let gt = project(STB_FRAME0_MM[*s]);
            let p = hand.keypoints.points[j];
            let e = ((p[0] - gt[0]).powi(2) + (p[1] - gt[1]).powi(2)).sqrt();
            println!(
                "  {:<11} err {:6.2}  conf {:.2}  ours ({:6.1}, {:6.1})  gt ({:6.1}, {:6.1})",
                NAMES[j], e, p[2], p[0], p[1], gt[0], gt[1]
            );
            errs.push((j, e));
        }
        let mean = errs.iter().map(|e| e.1).sum::<f64>() / errs.len() as f64;
        println!("  mean over {} joints: {mean:.2} px", errs.len());
        // Measured: 7.4 px (single pass), 7.2 px (re-crop). The larger residuals are systematic
        // label-convention differences (STB's MCPs sit ~10 px lower on the palm, its thumb base
        // is not MediaPipe's CMC), not noise: the fingertips and DIPs agree within ~2-6 px.
        assert!(mean < 9.0, "mean error {mean:.2} px");
        for (j, e) in &errs {
            assert!(*e < 18.0, "{} off by {e:.1} px", NAMES[*j]);
        }
    }
}
