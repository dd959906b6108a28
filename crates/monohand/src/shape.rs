//! The hand's shape learnt from the first frames: its size from two or more views
//! ([`FitSettings::auto_scale_frames`]) and each side's proportions from the network's metric
//! 3D ([`FitSettings::proportion_frames`]), applied to the skeletons every new hand starts
//! from.

use crate::crops::VisionFrame;
use crate::fit::learn_proportions;
use crate::hands::FitSettings;
use crate::notes::{Note, NoteTopic};
use crate::tracks::{side_index, Anchored};
use monohand_core::fitting::{estimate_hand_scale, ProportionEstimate, ScaleEstimate};
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use monohand_vision::DetectedHand;
use std::collections::HashMap;

/// Smallest and largest hand size `--hand-scale auto` may find, relative to the template.
const SCALE_RANGE: (f64, f64) = (0.6, 1.6);

/// What was learnt of the hands' shape.
#[derive(Debug, Default)]
pub(crate) struct HandShape {
    /// The hand size measured, once known.
    pub scale: Option<ScaleEstimate>,
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
        let Some((side, views)) = best_seen_twice(frames, anchored, cameras) else {
            say(
                notes,
                "no hand was seen by two views in the first frames; keeping the default size"
                    .into(),
            );
            return;
        };
        let template = *prototypes[side_index(side)].fitter_mut().skeleton();
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
                    let fitter = proto.fitter_mut();
                    let scaled = fitter.skeleton().scaled(est.scale);
                    if let Err(e) = scaled.and_then(|s| fitter.set_skeleton(s)) {
                        tracing::warn!("hand scale not applied: {e}");
                    }
                }
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
            let fitter = prototypes[i].fitter_mut();
            let template = *fitter.skeleton();
            let (learnt, note) = learn_proportions(&template, side, &cues[i]);
            match learnt {
                Some(est) => match fitter.set_skeleton(est.skeleton) {
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

/// The hand seen by two views in the most kept frames (ties: the lowest id): its side and,
/// per such frame, its views.
fn best_seen_twice<'a, T>(
    frames: &'a [(VisionFrame, T)],
    anchored: &[Vec<Anchored>],
    cameras: &'a [Camera],
) -> Option<(HandSide, Vec<Vec<View<'a>>>)> {
    let mut counts: HashMap<crate::HandId, usize> = HashMap::new();
    for hands in anchored {
        for (id, _, views) in hands {
            if views.len() >= 2 {
                *counts.entry(*id).or_default() += 1;
            }
        }
    }
    let (&best, _) = counts
        .iter()
        .max_by_key(|(id, c)| (**c, std::cmp::Reverse(**id)))?;
    let mut side = HandSide::Right;
    let mut seen: Vec<Vec<View<'a>>> = Vec::new();
    for ((frame, _), hands) in frames.iter().zip(anchored) {
        for (id, s, views) in hands {
            if *id == best && views.len() >= 2 {
                side = *s;
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
    Some((side, seen))
}

/// Hand `k` of view `v` of a frame.
pub(crate) fn detected(frame: &VisionFrame, v: usize, k: usize) -> Option<&DetectedHand> {
    frame.views.get(v)?.as_ref().ok()?.detections.hands.get(k)
}
