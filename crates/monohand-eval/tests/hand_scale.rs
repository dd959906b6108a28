//! `--hand-scale auto` measured on STB B1Counting: the size of the subject's hand recovered
//! from the first frames with the default adult model, stereo (observable) and mono (not).
//!
//! STB's root is the palm centre, not a wrist, so joint 0 is given confidence 0 and left out
//! of the errors. The subject's proportions differ from the default model's (its phalanges
//! are ~11% shorter, its palm is not), so no single factor is "the" truth: the test checks
//! what the factor is for, that stereo fits of later frames with the measured size are much
//! closer to the labels than with the default size.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

// The geometry core's test helpers (random poses, projection, the STB rig), shared by path.
#[path = "../../monohand-core/tests/common/mod.rs"]
mod common;
use common::*;
use monohand_core::fitting::estimate_hand_scale;
use monohand_core::hand_model::fit_skeleton;
use monohand_core::prelude::*;
use monohand_testkit::stb_dir;

fn phalanges(sk: &HandSkeleton) -> f64 {
    sk.bone_lengths()
        .iter()
        .enumerate()
        .filter(|(i, _)| i % 4 != 0)
        .map(|(_, l)| l)
        .sum()
}

/// Mean 3D error over joints 1..21 of stereo fits from scratch.
fn stereo_error(
    sk: &HandSkeleton,
    frames: &[[nalgebra::Vector3<f64>; 21]],
    left: &Camera,
    right: &Camera,
) -> f64 {
    let mut fitter = HandFitter::new(*sk, FitOptions::default()).unwrap();
    let mut rng = rng(3);
    let mut sum = 0.0;
    for j in frames {
        let mut l = project(left, j, 0.0, &mut rng).unwrap();
        let mut r = project(right, j, 0.0, &mut rng).unwrap();
        l.points[0][2] = 0.0;
        r.points[0][2] = 0.0;
        let fit = fitter
            .fit(&[View::new(left, &l), View::new(right, &r)])
            .unwrap();
        sum += (1..21)
            .map(|k| (fit.joints_3d[k] - j[k]).norm())
            .sum::<f64>()
            / 20.0;
    }
    sum / frames.len() as f64
}

#[test]
fn hand_size_from_the_first_frames_of_stb() {
    let d = stb_dir();
    let seq = monohand_eval::stb::StbSequence::load(d.join("labels/B1Counting_BB.mat")).unwrap();
    let all: Vec<_> = seq.frames.iter().map(|f| f.joints).collect();
    let template = HandSkeleton::default_for(HandSide::Left);
    let subject = fit_skeleton(&all, &template).unwrap().skeleton;
    let phalanx_ratio = phalanges(&subject) / phalanges(&template);
    let (left, right) = stb_rig();
    let frames = &all[..30];
    for noise in [0.0, 2.0] {
        let mut rng = rng(7);
        let kps: Vec<[Keypoints2d; 2]> = frames
            .iter()
            .map(|j| {
                let mut l = project(&left, j, noise, &mut rng).unwrap();
                let mut r = project(&right, j, noise, &mut rng).unwrap();
                l.points[0][2] = 0.0;
                r.points[0][2] = 0.0;
                [l, r]
            })
            .collect();
        let stereo: Vec<Vec<View>> = kps
            .iter()
            .map(|[l, r]| vec![View::new(&left, l), View::new(&right, r)])
            .collect();
        let mono: Vec<Vec<View>> = stereo.iter().map(|v| v[..1].to_vec()).collect();
        let est =
            estimate_hand_scale(&template, &FitOptions::default(), &stereo, 0.6, 1.6).unwrap();
        let est_mono =
            estimate_hand_scale(&template, &FitOptions::default(), &mono, 0.6, 1.6).unwrap();
        println!(
            "STB first 30 frames, {noise} px: stereo estimate {:.3} (contrast {:.3}; subject/default phalanges {phalanx_ratio:.3}); mono estimate {:.3} (contrast {:.4}, observable {})",
            est.scale, est.cost_contrast, est_mono.scale, est_mono.cost_contrast, est_mono.observable
        );
        assert!(est.observable);
        assert!(
            (0.85..1.0).contains(&est.scale),
            "stereo scale {:.3}",
            est.scale
        );
        let later: Vec<_> = all[30..].iter().step_by(15).copied().collect();
        let before = stereo_error(&template, &later, &left, &right);
        let after = stereo_error(&template.scaled(est.scale).unwrap(), &later, &left, &right);
        let oracle = stereo_error(&subject, &later, &left, &right);
        println!(
            "  stereo 3D error on {} later frames: default size {before:.1} mm, measured size {after:.1} mm (subject model: {oracle:.1} mm)",
            later.len()
        );
        assert!(after < 0.8 * before, "{after:.1} mm vs {before:.1} mm");
        assert!(
            !est_mono.observable,
            "mono cannot tell the size: {est_mono:?}"
        );
    }
}
