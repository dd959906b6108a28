//! The hand's shape learnt from the first frames: its size from two or more views
//! ([`FitSettings::auto_scale_frames`]) and each side's proportions from the network's metric
//! 3D ([`FitSettings::proportion_frames`]), applied to the skeletons every new hand starts
//! from.

use crate::base::frame::{detected, HandId, VisionFrame};
use crate::base::notes::{Note, NoteTopic};
use crate::stages::fitter::fit::learn_proportions;
use crate::stages::fitter::options::FitSettings;
use crate::stages::fitter::tracks::{side_index, Anchored};
use monohand_core::fitting::{estimate_hand_scale, ProportionEstimate, ScaleEstimate};
use monohand_core::hand_model::BONES;
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use monohand_core::triangulation::triangulate;
use monohand_io::hand::{HandFile, HandSource};
use nalgebra::{Point2, Vector3};
use std::collections::HashMap;

/// Smallest and largest hand size `--hand-scale auto` may find, relative to the template.
const SCALE_RANGE: (f64, f64) = (0.6, 1.6);

/// What was learnt of the hands' shape.
#[derive(Debug, Default)]
pub(crate) struct HandShape {
    /// The hand size measured, once known.
    pub scale: Option<ScaleEstimate>,
    /// The hand measured by the views, as a hand file says it, once known.
    pub measured: Option<HandFile>,
    /// Each side's proportions learnt (left, right), once known.
    pub proportions: [Option<ProportionEstimate>; 2],
}

impl HandShape {
    /// Learns what `settings` ask from the frames kept back (`anchored`: each frame's hands,
    /// as associated), applies it to `prototypes` (left, right) and says it in `notes`.
    pub(crate) fn learn<T>(
        &mut self,
        settings: &FitSettings,
        frames: &[(VisionFrame, T)],
        anchored: &[Vec<Anchored>],
        cameras: &[Camera],
        prototypes: &mut [HandTracker; 2],
        notes: &mut Vec<Note>,
    ) {
        if settings.auto_scale_frames.is_some() {
            self.measure_scale(settings, frames, anchored, cameras, prototypes, notes);
        }
        if let Some(n) = settings.proportion_frames {
            let n = n.min(frames.len());
            self.learn_proportions(&frames[..n], &anchored[..n], prototypes, notes);
        }
    }

    /// The hand size from the hand seen by two views in most of the kept frames.
    fn measure_scale<T>(
        &mut self,
        settings: &FitSettings,
        frames: &[(VisionFrame, T)],
        anchored: &[Vec<Anchored>],
        cameras: &[Camera],
        prototypes: &mut [HandTracker; 2],
        notes: &mut Vec<Note>,
    ) {
        let say =
            |notes: &mut Vec<Note>, text: String| notes.push(Note::new(NoteTopic::HandScale, text));
        if cameras.len() < 2 {
            say(
                notes,
                "with one camera the hand size is not observable (a larger hand further away \
                 projects the same); keeping the default size (see docs/accuracy.md)"
                    .into(),
            );
            return;
        }
        let Some((side, seen, views)) =
            best_seen_twice(frames, anchored, cameras, settings.tracking)
        else {
            say(
                notes,
                "no hand was seen by two views in the first frames; keeping the default size"
                    .into(),
            );
            return;
        };
        let template = *prototypes[side_index(side)].fitter().skeleton();
        let (lo, hi) = SCALE_RANGE;
        match estimate_hand_scale(&template, &settings.options, &views, lo, hi) {
            Ok(est) if est.observable => {
                say(notes, format!(
                    "hand size {:.3} x the current model, from {} frames (hand length {:.0} mm)",
                    est.scale,
                    est.frames_used,
                    template.hand_length() * est.scale
                ));
                for proto in prototypes.iter_mut() {
                    let scaled = proto.fitter().skeleton().scaled(est.scale);
                    if let Err(e) = scaled.and_then(|s| proto.set_skeleton(s)) {
                        tracing::warn!("hand scale not applied: {e}");
                    }
                }
                self.measured = Some(measured_hand(
                    &template, settings, &est, side, &seen, &views, cameras.len(),
                ));
                self.scale = Some(est);
            }
            Ok(est) => say(notes, format!(
                "the first frames do not tell the hand size (cost contrast {:.3}); keeping the default",
                est.cost_contrast
            )),
            Err(e) => say(notes, format!(
                "could not measure the hand size ({e}); keeping the default"
            )),
        }
    }

    /// Each side's proportions from the network's metric 3D of its hands in `frames`
    /// (the first view that sees each), applied to that side's skeleton.
    fn learn_proportions<T>(
        &mut self,
        frames: &[(VisionFrame, T)],
        anchored: &[Vec<Anchored>],
        prototypes: &mut [HandTracker; 2],
        notes: &mut Vec<Note>,
    ) {
        let mut cues: [Vec<NetworkCues>; 2] = [Vec::new(), Vec::new()];
        for ((frame, _), hands) in frames.iter().zip(anchored) {
            for (_, side, views) in hands {
                let first = views.first().and_then(|&(v, k)| detected(frame, v, k));
                if let Some(c) = first.and_then(|d| d.cues) {
                    cues[side_index(*side)].push(c);
                }
            }
        }
        for side in [HandSide::Left, HandSide::Right] {
            let i = side_index(side);
            if cues[i].is_empty() {
                continue;
            }
            let tracker = &mut prototypes[i];
            let template = *tracker.fitter().skeleton();
            let (learnt, note) = learn_proportions(&template, side, &cues[i]);
            match learnt {
                Some(est) => match tracker.set_skeleton(est.skeleton) {
                    Err(e) => notes.push(Note::new(
                        NoteTopic::Proportions,
                        format!("{side} hand proportions not applied: {e}"),
                    )),
                    Ok(()) => {
                        notes.push(note);
                        self.proportions[i] = Some(est);
                    }
                },
                None => notes.push(note),
            }
        }
    }
}

/// The hand seen by two views in the most kept frames (ties: the lowest key): its side,
/// those frames' indices and, per such frame, its views. Tracked, a hand is its id; untracked
/// (a folder of photos per camera), every frame's hands get new ids, so a hand is its side.
fn best_seen_twice<'a, T>(
    frames: &'a [(VisionFrame, T)],
    anchored: &[Vec<Anchored>],
    cameras: &'a [Camera],
    tracking: bool,
) -> Option<(HandSide, Vec<u64>, Vec<Vec<View<'a>>>)> {
    let key = |id: HandId, side: HandSide| {
        if tracking {
            id
        } else {
            side_index(side) as HandId
        }
    };
    let mut counts: HashMap<HandId, usize> = HashMap::new();
    for hands in anchored {
        for (id, side, views) in hands {
            if views.len() >= 2 {
                *counts.entry(key(*id, *side)).or_default() += 1;
            }
        }
    }
    let (&best, _) = counts
        .iter()
        .max_by_key(|(id, c)| (**c, std::cmp::Reverse(**id)))?;
    let mut side = HandSide::Right;
    let mut indices = Vec::new();
    let mut seen: Vec<Vec<View<'a>>> = Vec::new();
    for ((frame, _), hands) in frames.iter().zip(anchored) {
        for (id, s, views) in hands {
            if key(*id, *s) == best && views.len() >= 2 {
                side = *s;
                indices.push(frame.index);
                seen.push(
                    views
                        .iter()
                        .filter_map(|&(v, k)| {
                            let d = detected(frame, v, k)?;
                            Some(View::new(cameras.get(v)?, &d.keypoints))
                        })
                        .collect(),
                );
            }
        }
    }
    Some((side, indices, seen))
}

/// Fewest frames a bone's length is taken from ([`measured_hand`]).
const MIN_BONE_FRAMES: usize = 5;

/// Fewest frames in each half for the two halves' sizes to give the size's uncertainty.
const MIN_HALF_FRAMES: usize = 3;

/// Keypoints at least this confident are triangulated for the bones' lengths.
const TRIANGULATE_CONFIDENCE: f64 = 0.5;

/// The hand the views measured (`est`, on the frames `seen` with their `views`), as a
/// hand file says it: its size, the size's uncertainty (half the difference of the sizes
/// the two halves of the frames give, where each has [`MIN_HALF_FRAMES`]), and each bone's
/// length where the keypoints of two or more views triangulate it in [`MIN_BONE_FRAMES`]
/// frames or more (the median over the frames, with the median absolute deviation's
/// standard error).
fn measured_hand(
    template: &HandSkeleton,
    settings: &FitSettings,
    est: &ScaleEstimate,
    side: HandSide,
    seen: &[u64],
    views: &[Vec<View<'_>>],
    cameras: usize,
) -> HandFile {
    let (lo, hi) = SCALE_RANGE;
    let half = views.len() / 2;
    let sigma = (half >= MIN_HALF_FRAMES).then(|| {
        let size = |part: &[Vec<View<'_>>]| {
            estimate_hand_scale(template, &settings.options, part, lo, hi)
                .ok()
                .map(|e| e.scale)
        };
        Some((size(&views[..half])? - size(&views[half..])?).abs() / 2.0)
    });
    let relative = template_scale(template, side);
    let mut lengths: Vec<Vec<f64>> = vec![Vec::new(); BONES.len()];
    for frame in views {
        let joints: [Option<Vector3<f64>>; NUM_JOINTS] = std::array::from_fn(|j| {
            let rays: Vec<_> = frame
                .iter()
                .filter_map(|v| {
                    let [u, w, p] = v.keypoints.points[j];
                    let dir = v.camera.ray(Point2::new(u, w))?;
                    let to_ref = v.camera.extrinsics.rotation.inverse();
                    (p >= TRIANGULATE_CONFIDENCE).then(|| (v.camera.centre(), to_ref * dir, 1.0))
                })
                .collect();
            triangulate(&rays)
        });
        for (b, &(p, c)) in BONES.iter().enumerate() {
            if let (Some(a), Some(z)) = (joints[p], joints[c]) {
                lengths[b].push((z - a).norm());
            }
        }
    }
    let mut bone_lengths = [None; BONES.len()];
    let mut bone_sigma = [None; BONES.len()];
    for (b, l) in lengths.iter_mut().enumerate() {
        if l.len() >= MIN_BONE_FRAMES {
            let mid = median(l);
            let mut dev: Vec<f64> = l.iter().map(|x| (x - mid).abs()).collect();
            // The median's standard error: 1.2533 sigma / sqrt(n), sigma = 1.4826 MAD.
            let n = l.len() as f64;
            bone_lengths[b] = Some(mid);
            bone_sigma[b] = Some(1.4826 * median(&mut dev) * 1.2533 / n.sqrt());
        }
    }
    HandFile {
        scale_sigma: sigma.flatten().map(|s| s * relative),
        side: Some(side),
        views: Some(cameras),
        frames: seen.to_vec(),
        bone_lengths_mm: Some(bone_lengths),
        bone_sigma_mm: Some(bone_sigma),
        ..HandFile::new(
            HandSource::Views,
            est.scale * relative,
            template.hand_length() * est.scale,
        )
    }
}

/// The scale of `template` relative to the default hand of `side` (the measurement is
/// relative to the skeleton the run started from, which `--hand-scale` or a hand file may
/// have sized).
pub(crate) fn template_scale(template: &HandSkeleton, side: HandSide) -> f64 {
    template.hand_length() / HandSkeleton::default_for(side).hand_length()
}

/// The median of `x` (sorted in place; NaN if empty).
fn median(x: &mut [f64]) -> f64 {
    x.sort_by(f64::total_cmp);
    match x.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => x[n / 2],
        n => (x[n / 2 - 1] + x[n / 2]) / 2.0,
    }
}
