//! The subject's hand proportions from a sequence, with the overall size held at the prior.
//!
//! With one camera the hand's overall size is not observable (see [`super::scale`]), but
//! its proportions are: the keypoint network's metric 3D ([`NetworkCues::world_mm`]) gives
//! every bone's length in every frame, in the keypoints' own convention (where the network
//! puts the wrist and the knuckles, which is not where anatomical or other datasets' labels
//! put them). One frame's lengths are noisy, foreshortened bones most of all, so the
//! estimate is the **median of each bone's length over the frames**, then all 20 lengths
//! are scaled together so that their sum equals the template's: only the ratios are taken
//! from the video, the size stays the template's (the population average, or what
//! `--hand-scale` set).
//!
//! The estimate has **settled** when the medians of the first and of the second half of
//! the frames agree within [`SETTLED_CHANGE`] for every bone.

use crate::error::{CoreError, CoreResult};
use crate::hand_model::{HandSkeleton, BONES, NUM_JOINTS};
use crate::observation::NetworkCues;

/// Largest relative change of any bone between the medians of the two halves of the
/// frames for the estimate to count as settled (2 %: a round number, not tuned on any
/// data). `run` and `lift` use the estimator only when asked (`--proportion-frames`):
/// on real frames with 3D labels it makes the 3D worse, see `docs/accuracy.md`.
pub const SETTLED_CHANGE: f64 = 0.02;

/// Fewest frames an estimate is made from.
pub const MIN_FRAMES: usize = 5;

/// Result of [`estimate_proportions`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProportionEstimate {
    /// The template with the estimated proportions (same total bone length).
    pub skeleton: HandSkeleton,
    /// The 20 bone lengths in [`BONES`] order, mm.
    pub bone_lengths: [f64; BONES.len()],
    /// Frames whose network 3D was used.
    pub frames_used: usize,
    /// Largest relative difference of a bone between the two halves' medians.
    pub change: f64,
    /// `change` is at most [`SETTLED_CHANGE`].
    pub settled: bool,
}

/// "from N frames, settled (halves differ by up to x%; settled below 2%)": what the
/// estimate rests on, for a message to the user.
impl std::fmt::Display for ProportionEstimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "from {} frames, {} (halves differ by up to {:.1}%; settled below {:.0}%)",
            self.frames_used,
            if self.settled {
                "settled"
            } else {
                "not settled"
            },
            100.0 * self.change,
            100.0 * SETTLED_CHANGE
        )
    }
}

/// Estimates the proportions of `template` from the network cues of many frames of one
/// hand (frames without metric 3D are skipped).
///
/// ```
/// use monohand_core::fitting::estimate_proportions;
/// use monohand_core::observation::NetworkCues;
/// use monohand_core::prelude::*;
///
/// let template = HandSkeleton::default_for(HandSide::Left);
/// // A hand with 20 % longer fingers than the template, seen in several poses.
/// let mut lengths = template.bone_lengths();
/// for (i, l) in lengths.iter_mut().enumerate() {
///     if i % 4 != 0 { *l *= 1.2; }
/// }
/// let subject = template.with_bone_lengths(&lengths)?;
/// let frames: Vec<NetworkCues> = (0..8)
///     .map(|k| {
///         let mut pose = HandPose::default();
///         pose.angles[0] = 0.05 * k as f64;
///         let j = forward_kinematics(&subject, &pose);
///         NetworkCues { world_mm: Some(j.map(|x| [x.x, x.y, x.z])), depth_px: None }
///     })
///     .collect();
/// let est = estimate_proportions(&template, &frames)?;
/// assert!(est.settled);
/// // Same total length as the template, fingers longer relative to the palm.
/// let total = |l: &[f64; 20]| l.iter().sum::<f64>();
/// assert!((total(&est.bone_lengths) - total(&template.bone_lengths())).abs() < 1e-6);
/// let ratio = est.bone_lengths[5] / est.bone_lengths[4];
/// assert!((ratio / (lengths[5] / lengths[4]) - 1.0).abs() < 1e-9);
/// # Ok::<(), monohand_core::CoreError>(())
/// ```
pub fn estimate_proportions(
    template: &HandSkeleton,
    frames: &[NetworkCues],
) -> CoreResult<ProportionEstimate> {
    let lengths: Vec<[f64; BONES.len()]> = frames
        .iter()
        .filter_map(|c| c.world_mm)
        .filter(|w| w.iter().flatten().all(|v| v.is_finite()))
        .map(|w| bone_lengths(&w))
        .filter(|l| l.iter().all(|&x| x > 0.0))
        .collect();
    if lengths.len() < MIN_FRAMES {
        return Err(CoreError::InvalidKeypoints(format!(
            "hand proportions need the network's 3D in at least {MIN_FRAMES} frames, got {}",
            lengths.len()
        )));
    }
    let all = medians(&lengths);
    let half = lengths.len() / 2;
    let (a, b) = (medians(&lengths[..half]), medians(&lengths[half..]));
    let change = (0..BONES.len())
        .map(|i| (a[i] - b[i]).abs() / all[i])
        .fold(0.0, f64::max);
    let prior = template.bone_lengths();
    let factor = prior.iter().sum::<f64>() / all.iter().sum::<f64>();
    let scaled = all.map(|l| l * factor);
    let skeleton = template.with_bone_lengths(&scaled)?;
    Ok(ProportionEstimate {
        skeleton,
        bone_lengths: scaled,
        frames_used: lengths.len(),
        change,
        settled: change <= SETTLED_CHANGE,
    })
}

/// The 20 bone lengths of 21 points.
fn bone_lengths(p: &[[f64; 3]; NUM_JOINTS]) -> [f64; BONES.len()] {
    std::array::from_fn(|i| {
        let (a, b) = BONES[i];
        let d: [f64; 3] = std::array::from_fn(|k| p[b][k] - p[a][k]);
        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
    })
}

/// Per-bone medians over frames (the mean of the two middle values for an even count).
fn medians(lengths: &[[f64; BONES.len()]]) -> [f64; BONES.len()] {
    std::array::from_fn(|i| {
        let mut v: Vec<f64> = lengths.iter().map(|l| l[i]).collect();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hand_model::{HandPose, HandSide};
    use crate::kinematics::forward_kinematics;

    #[test]
    fn outliers_do_not_move_the_median_and_too_few_frames_are_refused() {
        let sk = HandSkeleton::default_for(HandSide::Right);
        let cue = |s: f64| {
            let j = forward_kinematics(&sk, &HandPose::default());
            NetworkCues {
                world_mm: Some(j.map(|x| [x.x * s, x.y * s, x.z * s])),
                depth_px: None,
            }
        };
        let mut frames: Vec<NetworkCues> = (0..9).map(|_| cue(0.001 * 1000.0)).collect();
        frames.push(cue(3.0));
        frames.push(NetworkCues::default());
        let est = estimate_proportions(&sk, &frames).expect("estimate");
        assert_eq!(est.frames_used, 10);
        for (a, b) in est.bone_lengths.iter().zip(sk.bone_lengths()) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        assert!(estimate_proportions(&sk, &frames[..4]).is_err());
    }
}
