//! Keypoints on the STB stereo benchmark frame `BB_left_0.png` against its 3D ground truth
//! projected with the left Bumblebee camera. Needs `../shared/data` and the MediaPipe
//! weights (fetched with pip on first use): without them the test fails.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use monohand::vision::{HandPipeline, ModelOptions, PipelineOptions};
use monohand_core::hand_model::{HandSide, JOINT_NAMES};
use monohand_eval::stb::{stb_cameras, StbSequence};
use monohand_testkit::stb_dir;

#[test]
fn stb_frame0_keypoints_match_projected_ground_truth() {
    let stb = stb_dir();
    let image = stb.join("images/B1Counting/BB_left_0.png");
    assert!(image.is_file(), "{} not found", image.display());
    // Frame 0's labels in our joint order (index 0 is STB's palm centre, not a wrist, so
    // it is not compared) and the left Bumblebee camera.
    let truth = StbSequence::load(stb.join("labels/B1Counting_BB.mat"))
        .expect("STB labels")
        .frames[0]
        .joints;
    let (camera, _) = stb_cameras(stb.join("camera_params.json")).expect("STB cameras");
    let models = ModelOptions::default();
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
        for j in 1..21 {
            let gt = camera
                .project(&truth[j])
                .expect("label in front of the camera");
            let gt = [gt.x, gt.y];
            let p = hand.keypoints.points[j];
            let e = ((p[0] - gt[0]).powi(2) + (p[1] - gt[1]).powi(2)).sqrt();
            println!(
                "  {:<11} err {:6.2}  conf {:.2}  ours ({:6.1}, {:6.1})  gt ({:6.1}, {:6.1})",
                JOINT_NAMES[j], e, p[2], p[0], p[1], gt[0], gt[1]
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
            assert!(*e < 18.0, "{} off by {e:.1} px", JOINT_NAMES[*j]);
        }
    }
}
