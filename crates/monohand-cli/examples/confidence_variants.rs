//! Which per-joint confidence helps the 3D fit? Runs the vision front end on the STB stereo
//! pair (the only real images with 3D labels in ../shared) with the agreement term's sigma
//! swept (infinite = presence only, the same weight for every joint), fits mono and stereo
//! with the default and the subject hand, and prints the mean 3D error over the 20 finger
//! joints. `cargo run --release -p monohand-cli --example confidence_variants`
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use monohand_core::hand_model::fit_skeleton;
use monohand_core::prelude::*;
use monohand_eval::stb::{stb_cameras, StbSequence};
use monohand_vision::landmarks::LandmarkOptions;
use monohand_vision::{HandPipeline, ModelOptions, PipelineOptions};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let stb = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/stb_b1counting");
    let seq = StbSequence::load(stb.join("labels/B1Counting_BB.mat"))?;
    let truth = seq.frames[0].joints;
    let all: Vec<_> = seq.frames.iter().map(|f| f.joints).collect();
    let (left, right) = stb_cameras(stb.join("camera_params.json"))?;
    let default = HandSkeleton::default_for(HandSide::Left);
    let subject = fit_skeleton(&all, &default)?.skeleton;
    let images = stb.join("images/B1Counting");
    println!("| sigma (crop px) | confidences (min..max) | skeleton | mono (mm) | stereo (mm) |");
    println!("|---|---|---|---|---|");
    for sigma in [f64::INFINITY, 12.0, 6.0, 3.0] {
        let options = PipelineOptions {
            landmarks: LandmarkOptions {
                agreement_sigma: sigma,
                ..LandmarkOptions::default()
            },
            ..PipelineOptions::default()
        };
        let pipeline = HandPipeline::new(&ModelOptions::default(), options)?;
        let l = pipeline.detect_file(&images.join("BB_left_0.png"))?;
        let r = pipeline.detect_file(&images.join("BB_right_0.png"))?;
        let (Some(kl), Some(kr)) = (l.hands.first(), r.hands.first()) else {
            println!("| {sigma} | hand not found | | | |");
            continue;
        };
        let (lo, hi) = kl
            .keypoints
            .points
            .iter()
            .fold((1.0f64, 0.0f64), |(lo, hi), p| (lo.min(p[2]), hi.max(p[2])));
        // The subject model's root is STB's palm centre, so the detected wrist is not used
        // with it.
        let mut kl_nowrist = kl.keypoints;
        let mut kr_nowrist = kr.keypoints;
        kl_nowrist.points[0][2] = 0.0;
        kr_nowrist.points[0][2] = 0.0;
        for (name, sk) in [("default", default), ("subject", subject)] {
            let (kpl, kpr) = if name == "subject" {
                (&kl_nowrist, &kr_nowrist)
            } else {
                (&kl.keypoints, &kr.keypoints)
            };
            let mut fitter = HandFitter::new(sk, FitOptions::default())?;
            let err = |fit: FitResult| {
                (1..21)
                    .map(|j| (fit.joints_3d[j] - truth[j]).norm())
                    .sum::<f64>()
                    / 20.0
            };
            let vl = View::new(&left, kpl);
            let vr = View::new(&right, kpr);
            let mono = err(fitter.fit(&[vl])?);
            let stereo = err(fitter.fit(&[vl, vr])?);
            println!("| {sigma} | {lo:.2}..{hi:.2} | {name} | {mono:.1} | {stereo:.1} |");
        }
    }
    Ok(())
}
