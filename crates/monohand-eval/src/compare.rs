//! The fits side by side (`monohand eval --compare-fits`): the network's cues as before, the
//! paper's 2D cost, the fit given (by default the distance gathered over the frames), and
//! the ceiling of the first two (each frame, the better of them), per view and per half,
//! with the longest run of frames over twice the view's median error.

use crate::evaluate::RunResult;
use crate::metrics;
use monohand_core::fitting::FitOptions;
use monohand_core::hand_model::NUM_JOINTS;
use std::fmt::Write as _;

/// The fits compared, in the order of the table's columns.
pub const FIT_NAMES: [&str; 3] = ["cues", "paper", "given"];

/// `given` and the two fits it is compared with: the network's cues with one fit a frame
/// (the distance over the frames off), and the paper's cost (keypoints alone: every cue,
/// every fusion and the distance off).
pub fn fits_compared(given: FitOptions) -> [FitOptions; 3] {
    let mut cues = given;
    cues.distance.weight = 0.0;
    let mut paper = cues;
    paper.cost.world_weight = 0.0;
    paper.cost.depth_weight = 0.0;
    paper.cost.hand_frame_weight = 0.0;
    paper.fusion.fuse_world = 0.0;
    paper.fusion.fuse_depth = 0.0;
    paper.fusion.fuse_pixels = 0.0;
    [cues, paper, given]
}

/// One fit's numbers on one run (a view, or a half of it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitNumbers {
    /// Mean absolute error over the frames with a fit (mm).
    pub mpjpe: f64,
    /// Procrustes-aligned error (mm).
    pub pa_mpjpe: f64,
    /// The longest run of consecutive labelled frames whose error is over twice the
    /// run's median frame error.
    pub longest_bad_run: usize,
}

/// The per-frame absolute error of each hand of `run` (NaN where it has no fit).
fn frame_errors(run: &RunResult, mask: &[bool; NUM_JOINTS]) -> Vec<f64> {
    run.hands
        .iter()
        .map(|h| {
            h.errors
                .as_ref()
                .map_or(f64::NAN, |e| metrics::masked_mean(&e.absolute, mask))
        })
        .collect()
}

/// The longest run of consecutive frames (of one sequence) over twice the median of
/// `errors` (NaN, a frame without a fit, breaks a run).
pub fn longest_run_over_twice_median(run: &RunResult, errors: &[f64]) -> usize {
    let finite: Vec<f64> = errors.iter().copied().filter(|e| e.is_finite()).collect();
    if finite.is_empty() {
        return 0;
    }
    let limit = 2.0 * metrics::quantile(&finite, 0.5);
    let (mut best, mut current) = (0, 0);
    let mut last: Option<(&str, usize)> = None;
    for (h, &e) in run.hands.iter().zip(errors) {
        let follows = last.is_some_and(|(s, f)| s == h.sequence && f + 1 == h.frame);
        if e > limit {
            current = if follows || current == 0 {
                current + 1
            } else {
                1
            };
            best = best.max(current);
        } else {
            current = 0;
        }
        last = Some((&h.sequence, h.frame));
    }
    best
}

/// The numbers of one run.
pub fn numbers(run: &RunResult, mask: &[bool; NUM_JOINTS]) -> FitNumbers {
    let s = run.summary(mask);
    FitNumbers {
        mpjpe: s.mpjpe,
        pa_mpjpe: s.pa_mpjpe,
        longest_bad_run: longest_run_over_twice_median(run, &frame_errors(run, mask)),
    }
}

/// The mean over frames of the better of two runs' errors (the same hands in the same
/// order): what a perfect choice between the two fits, frame by frame, would give. A frame
/// one of them missed takes the other's error.
pub fn ceiling(a: &RunResult, b: &RunResult, mask: &[bool; NUM_JOINTS]) -> f64 {
    let (ea, eb) = (frame_errors(a, mask), frame_errors(b, mask));
    let best: Vec<f64> = ea
        .iter()
        .zip(&eb)
        .map(|(x, y)| x.min(*y))
        .filter(|e| e.is_finite())
        .collect();
    if best.is_empty() {
        f64::NAN
    } else {
        metrics::mean(&best)
    }
}

/// The table: one row per run label of the first fit's runs (a view, or all views) and
/// per half, each fit's absolute and PA error and longest bad run, then the ceiling of
/// the first two. `runs[f]` are fit `f`'s runs ([`FIT_NAMES`]), in the same order.
pub fn table(runs: &[Vec<RunResult>; 3], mask: &[bool; NUM_JOINTS]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| run | cues mm (PA, longest bad run) | paper mm (PA, run) | given mm (PA, run) | ceiling of cues and paper mm |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|");
    for (i, first) in runs[0].iter().enumerate() {
        if first.relative_only {
            continue;
        }
        let Some(trio) = [runs[1].get(i), runs[2].get(i)]
            .into_iter()
            .collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let [cues, paper, given] = [first, trio[0], trio[1]];
        let parts = [cues.halves(), paper.halves(), given.halves()];
        let whole = [(*cues).clone(), (*paper).clone(), (*given).clone()];
        let rows = [
            (first.label.clone(), whole),
            (
                format!("{}, 1st half", first.label),
                parts.clone().map(|[a, _]| a),
            ),
            (format!("{}, 2nd half", first.label), parts.map(|[_, b]| b)),
        ];
        for (label, fits) in rows {
            let n = fits.each_ref().map(|r| numbers(r, mask));
            let cell = |k: &FitNumbers| {
                format!("{:.1} ({:.1}, {})", k.mpjpe, k.pa_mpjpe, k.longest_bad_run)
            };
            let _ = writeln!(
                out,
                "| {label} | {} | {} | {} | {:.1} |",
                cell(&n[0]),
                cell(&n[1]),
                cell(&n[2]),
                ceiling(&fits[0], &fits[1], mask)
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluate::HandResult;
    use crate::metrics::HandErrors;
    use crate::ViewMode;
    use monohand_core::hand_model::HandSide;

    fn run(errors: &[f64]) -> RunResult {
        let gt = [[0.0, 0.0, 500.0]; NUM_JOINTS];
        RunResult {
            label: "v".into(),
            mode: ViewMode::Mono,
            source: String::new(),
            noise_px: None,
            relative_only: false,
            hands: errors
                .iter()
                .enumerate()
                .map(|(frame, &e)| {
                    let pred = gt.map(|p| [p[0] + e, p[1], p[2]]);
                    HandResult {
                        sequence: "s".into(),
                        frame,
                        side: HandSide::Right,
                        pred: Some(pred),
                        gt,
                        errors: Some(HandErrors::compute(&pred, &gt, &[true; NUM_JOINTS], 0)),
                        keypoints_px: None,
                        reprojection_px: None,
                        depth_ratio: None,
                        seconds: 0.0,
                    }
                })
                .collect(),
        }
    }

    #[test]
    fn the_ceiling_takes_the_better_fit_of_each_frame_and_runs_are_counted() {
        let mask = [true; NUM_JOINTS];
        let a = run(&[10.0, 10.0, 50.0, 60.0, 70.0, 10.0, 10.0]);
        let b = run(&[20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 5.0]);
        let c = ceiling(&a, &b, &mask);
        let expected = (10.0 + 10.0 + 20.0 + 20.0 + 20.0 + 10.0 + 5.0) / 7.0;
        assert!((c - expected).abs() < 1e-9, "{c}");
        // a's median is 10: frames 2-4 are over 20, a run of 3.
        assert_eq!(
            longest_run_over_twice_median(&a, &frame_errors(&a, &mask)),
            3
        );
        assert_eq!(
            longest_run_over_twice_median(&b, &frame_errors(&b, &mask)),
            0
        );
    }

    #[test]
    fn the_paper_fit_has_no_cue_and_the_cues_fit_no_distance() {
        let [cues, paper, given] = fits_compared(FitOptions::default());
        assert_eq!(given, FitOptions::default());
        assert_eq!(cues.distance.weight, 0.0);
        assert!(cues.cost.world_weight > 0.0);
        assert_eq!(paper.cost.world_weight + paper.cost.depth_weight, 0.0);
        assert_eq!(paper.cost.hand_frame_weight + paper.fusion.fuse_world, 0.0);
        assert_eq!(paper.distance.weight, 0.0);
    }
}
