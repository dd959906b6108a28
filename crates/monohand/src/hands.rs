//! Stage 3 over a video: one 3D tracker per hand identity, the left/right vote, the views'
//! association, smoothing and the hand size.

use crate::association::{associate, Candidate};
use crate::cameras::CameraChoice;
use crate::clock::Instant;
use crate::crops::{HandId, VisionFrame};
use crate::fit::{fit_views, learn_proportions, FitOutcome};
use crate::frame::{FittedFrame, TrackedHand};
use crate::notes::{Note, NoteTopic};
use crate::offline::{
    causal, depth_target, neighbours, CausalFrame, DepthFrame, Held, OfflineSettings,
};
use crate::tracks::{side_index, Tracks};
use monohand_core::filtering::{mean_depth, scale_to_depth, OneEuroParams};
use monohand_core::fitting::{estimate_hand_scale, ProportionEstimate, ScaleEstimate};
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use monohand_vision::DetectedHand;
use nalgebra::Vector3;
use std::collections::HashMap;

/// A hand is forgotten (its tracker, side vote and filter dropped) after this many frames
/// unseen.
pub const FORGET_AFTER_FRAMES: u64 = 30;

/// Smallest and largest hand size `--hand-scale auto` may find, relative to the template.
const SCALE_RANGE: (f64, f64) = (0.6, 1.6);

/// How the 3D stage fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitSettings {
    /// The hand models, left then right.
    pub skeletons: [HandSkeleton; 2],
    /// The fitter's settings.
    pub options: FitOptions,
    /// Each fit starts from the hand's previous one (video).
    pub tracking: bool,
    /// With two or more cameras, keep this many first frames back to measure the hand's
    /// size before fitting them (`None`: keep the skeletons' size).
    pub auto_scale_frames: Option<usize>,
    /// Keep this many first frames back to learn each side's hand proportions from the
    /// network's metric 3D ([`learn_proportions`]; the size stays the skeleton's), then
    /// fit every frame with them (`None`: keep the skeletons' proportions). Off by
    /// default: on the development set it makes the 3D worse, because the network marks
    /// the joints in another convention than anatomical labels (docs/accuracy.md).
    pub proportion_frames: Option<usize>,
    /// Smooth each hand's 3D joints over time with a One Euro filter.
    pub smoothing: Option<OneEuroParams>,
    /// Tracking with one camera: each hand's distance from the camera through a One Euro
    /// filter, the joints scaled about the camera's centre to it ([`monohand_core::filtering::DepthFilter`]: the
    /// pixels and the shape stay the fit's; the pose stays the fit's too). Default
    /// [`DEPTH_FILTER`]; `None` turns it off. Not used offline, where the refit with the
    /// frames around each frame steadies the hand itself.
    pub depth_filter: Option<OneEuroParams>,
    /// Refit each frame with the frames after it too, writing it `lag` frames later (`2 lag`
    /// with one camera and [`OfflineSettings::depth_pass`]; [`crate::offline`]; needs
    /// tracking, and replaces `smoothing`).
    pub offline: Option<OfflineSettings>,
}

impl Default for FitSettings {
    fn default() -> FitSettings {
        FitSettings {
            skeletons: [
                HandSkeleton::default_for(HandSide::Left),
                HandSkeleton::default_for(HandSide::Right),
            ],
            options: FitOptions::default(),
            tracking: true,
            auto_scale_frames: None,
            proportion_frames: None,
            smoothing: None,
            depth_filter: Some(DEPTH_FILTER),
            offline: None,
        }
    }
}

/// Default of [`FitSettings::depth_filter`]: minimum cutoff 2 Hz, 0.005 Hz per mm/s.
/// Chosen on the development set, both halves (docs/accuracy.md, "The depth filter"):
/// 18% less jitter, 0.5 mm less absolute error, the same PA.
pub const DEPTH_FILTER: OneEuroParams = OneEuroParams {
    min_cutoff: 2.0,
    beta: 0.005,
    d_cutoff: 1.0,
};

/// A hand of the first view: its id, side and the `(view, index)` pairs that see it.
type Anchored = (HandId, HandSide, Vec<(usize, usize)>);

/// The 3D stage of a session: takes the networks' frames in order and fits every hand.
///
/// It carries a payload of the caller's with each frame (`T`, for example the image for an
/// overlay), because with [`FitSettings::auto_scale_frames`] frames come back later than
/// they went in.
pub struct HandsFitter<T = ()> {
    /// The camera of each view, frame by frame.
    cameras: CameraChoice,
    prototypes: [HandTracker; 2],
    settings: FitSettings,
    /// Each hand seen: its identity, voted side, tracker and filters.
    tracks: Tracks,
    pending: Option<(usize, Vec<(VisionFrame, T)>)>,
    scale: Option<ScaleEstimate>,
    proportions: [Option<ProportionEstimate>; 2],
    notes: Vec<Note>,
    /// With [`FitSettings::offline`]: the frames fitted but not yet refitted, with their
    /// causal fits.
    fitted: Held<(FittedFrame, T), CausalFrame>,
    /// With [`FitSettings::offline`] and one camera: the frames refitted but not yet
    /// written, with their refitted distances.
    refitted: Held<(FittedFrame, T), DepthFrame>,
}

impl<T> HandsFitter<T> {
    /// A 3D stage for these cameras (one per view; the first is the reference whose frame
    /// the 3D is in). With no camera at all, each frame gets a camera for its image size:
    /// from the focal length its file states ([`VisionFrame::focal`]: a photo's EXIF, a
    /// video's QuickTime metadata), else the generic guess ([`Camera::generic`]); each kind
    /// is said once in [`Self::take_notes`].
    pub fn new(
        cameras: Vec<Camera>,
        settings: &crate::ResolvedSettings,
    ) -> Result<HandsFitter<T>, CoreError> {
        let settings = *settings.fit();
        for c in &cameras {
            c.validate()?;
        }
        let mut cameras = CameraChoice::new(cameras);
        let notes = cameras.take_notes();
        Ok(HandsFitter {
            cameras,
            prototypes: [
                HandTracker::new(settings.skeletons[0], settings.options)?,
                HandTracker::new(settings.skeletons[1], settings.options)?,
            ],
            pending: settings
                .auto_scale_frames
                .into_iter()
                .chain(settings.proportion_frames)
                .max()
                .map(|n| (n.max(1), Vec::new())),
            settings,
            tracks: Tracks::new(&settings),
            scale: None,
            proportions: [None, None],
            notes,
            fitted: Held::default(),
            refitted: Held::default(),
        })
    }

    /// The hand size measured with `auto_scale_frames`, once known.
    pub fn scale(&self) -> Option<&ScaleEstimate> {
        self.scale.as_ref()
    }

    /// The proportions learnt with `proportion_frames` for the left and the right hand,
    /// once known.
    pub fn proportions(&self) -> &[Option<ProportionEstimate>; 2] {
        &self.proportions
    }

    /// The cameras in use (after a generic one was made for the image size).
    pub fn cameras(&self) -> &[Camera] {
        self.cameras.cameras()
    }

    /// Messages for the user since the last call (assumptions made, hand size found).
    pub fn take_notes(&mut self) -> Vec<Note> {
        std::mem::take(&mut self.notes)
    }

    /// Fits one frame; returns the frames now ready, in order: one, or none while frames
    /// are kept back to measure the hand size, then all of those.
    pub fn push(&mut self, frame: VisionFrame, payload: T) -> Vec<(FittedFrame, T)> {
        let fitted = if let Some((n, pending)) = &mut self.pending {
            pending.push((frame, payload));
            if pending.len() < *n {
                return Vec::new();
            }
            self.finish_scale()
        } else {
            vec![(self.fit_frame(frame), payload)]
        };
        self.smooth(fitted, false)
    }

    /// Fits the frames still kept back, at the end of the input.
    pub fn flush(&mut self) -> Vec<(FittedFrame, T)> {
        let fitted = self.finish_scale();
        self.smooth(fitted, true)
    }

    /// With [`FitSettings::offline`]: takes the newly fitted frames and gives back,
    /// smoothed, those whose `lag` following frames are fitted (`2 lag` with one camera and
    /// [`OfflineSettings::depth_pass`]; all of them at the end): refitted towards their
    /// neighbours ([`neighbours`]), then their distance averaged ([`depth_target`]).
    fn smooth(&mut self, fitted: Vec<(FittedFrame, T)>, end: bool) -> Vec<(FittedFrame, T)> {
        let Some(settings) = self.settings.offline else {
            return fitted;
        };
        // Each frame's causal fits are taken once, as it enters the window.
        let fitted = fitted.into_iter().map(|f| {
            let c = causal(&f.0);
            (f, c)
        });
        let tracks = &mut self.tracks;
        let out = self
            .fitted
            .release(fitted, settings.lag, end, |(frame, _), own, window| {
                for hand in &mut frame.hands {
                    let Some(c) = own.get(&hand.id) else {
                        continue;
                    };
                    if let Some(n) = neighbours(&settings, window, hand.id, c) {
                        refit_hand(
                            tracks,
                            &frame.vision,
                            &frame.cameras,
                            hand,
                            &n,
                            &c.offset,
                            &settings,
                        );
                    }
                }
            });
        if !settings.depth_pass || self.cameras.cameras().len() > 1 {
            // Several cameras see the distance; one guesses it from the hand's size.
            return out;
        }
        // The distance's pass: each refitted hand's distance is taken as it enters.
        let refitted = out.into_iter().map(|f| {
            let depths = match f.0.cameras.as_slice() {
                [cam] => {
                    f.0.hands
                        .iter()
                        .filter_map(|h| Some((h.id, mean_depth(cam, &h.fit.as_ref()?.joints_3d)?)))
                        .collect()
                }
                _ => DepthFrame::new(),
            };
            (f, depths)
        });
        self.refitted
            .release(refitted, settings.lag, end, |(frame, _), own, window| {
                let [cam] = frame.cameras.as_slice() else {
                    return;
                };
                for hand in &mut frame.hands {
                    let (Some(fit), Some(&depth)) = (hand.fit.as_mut(), own.get(&hand.id)) else {
                        continue;
                    };
                    if let Some(target) = depth_target(&settings, window, hand.id, depth) {
                        scale_to_depth(cam, &mut fit.joints_3d, depth, target);
                    }
                }
            })
    }

    fn finish_scale(&mut self) -> Vec<(FittedFrame, T)> {
        let Some((_, pending)) = self.pending.take() else {
            return Vec::new();
        };
        if self.settings.auto_scale_frames.is_some() {
            self.measure_scale(&pending);
        }
        if let Some(n) = self.settings.proportion_frames {
            self.learn_proportions(&pending[..n.min(pending.len())]);
        }
        pending
            .into_iter()
            .map(|(f, p)| (self.fit_frame(f), p))
            .collect()
    }

    /// The hand size from the hand seen by two views in most of the kept frames.
    fn measure_scale(&mut self, frames: &[(VisionFrame, T)]) {
        if self.cameras.cameras().len() < 2 {
            self.notes.push(Note::new(
                NoteTopic::HandScale,
                "with one camera the hand size is not observable (a larger hand further away \
                 projects the same); keeping the default size (see docs/accuracy.md)",
            ));
            return;
        }
        let mut counts: HashMap<HandId, usize> = HashMap::new();
        let per_frame: Vec<Vec<Anchored>> = frames.iter().map(|(f, _)| self.associate(f)).collect();
        for hands in &per_frame {
            for (id, _, views) in hands {
                if views.len() >= 2 {
                    *counts.entry(*id).or_default() += 1;
                }
            }
        }
        let Some((&best, _)) = counts
            .iter()
            .max_by_key(|(id, c)| (**c, std::cmp::Reverse(**id)))
        else {
            self.notes.push(Note::new(
                NoteTopic::HandScale,
                "no hand was seen by two views in the first frames; keeping the default size",
            ));
            return;
        };
        let mut side = HandSide::Right;
        let mut seen: Vec<Vec<(usize, &DetectedHand)>> = Vec::new();
        for ((frame, _), hands) in frames.iter().zip(&per_frame) {
            for (id, s, views) in hands {
                if *id == best && views.len() >= 2 {
                    side = *s;
                    seen.push(
                        views
                            .iter()
                            .filter_map(|&(v, k)| detected(frame, v, k).map(|d| (v, d)))
                            .collect(),
                    );
                }
            }
        }
        let views: Vec<Vec<View>> = seen
            .iter()
            .map(|vs| {
                vs.iter()
                    .filter_map(|(v, d)| {
                        self.cameras
                            .cameras()
                            .get(*v)
                            .map(|c| View::new(c, &d.keypoints))
                    })
                    .collect()
            })
            .collect();
        let template = *self.prototypes[side_index(side)].fitter_mut().skeleton();
        let (lo, hi) = SCALE_RANGE;
        match estimate_hand_scale(&template, &self.settings.options, &views, lo, hi) {
            Ok(est) if est.observable => {
                self.notes.push(Note::new(NoteTopic::HandScale, format!(
                    "hand size {:.3} x the current model, from {} frames (hand length {:.0} mm)",
                    est.scale,
                    est.frames_used,
                    template.hand_length() * est.scale
                )));
                for proto in &mut self.prototypes {
                    let fitter = proto.fitter_mut();
                    let scaled = fitter.skeleton().scaled(est.scale);
                    if let Err(e) = scaled.and_then(|s| fitter.set_skeleton(s)) {
                        tracing::warn!("hand scale not applied: {e}");
                    }
                }
                self.scale = Some(est);
            }
            Ok(est) => self.notes.push(Note::new(NoteTopic::HandScale, format!(
                "the first frames do not tell the hand size (cost contrast {:.3}); keeping the default",
                est.cost_contrast
            ))),
            Err(e) => self.notes.push(Note::new(NoteTopic::HandScale, format!(
                "could not measure the hand size ({e}); keeping the default"
            ))),
        }
    }

    /// Each side's proportions from the network's metric 3D of its hands in `frames`
    /// (the first view that sees each), applied to that side's skeleton.
    fn learn_proportions(&mut self, frames: &[(VisionFrame, T)]) {
        let mut cues: [Vec<NetworkCues>; 2] = [Vec::new(), Vec::new()];
        for (frame, _) in frames {
            for (_, side, views) in self.associate(frame) {
                let first = views.first().and_then(|&(v, k)| detected(frame, v, k));
                if let Some(c) = first.and_then(|d| d.cues) {
                    cues[side_index(side)].push(c);
                }
            }
        }
        for side in [HandSide::Left, HandSide::Right] {
            let i = side_index(side);
            if cues[i].is_empty() {
                continue;
            }
            let fitter = self.prototypes[i].fitter_mut();
            let template = *fitter.skeleton();
            let (learnt, note) = learn_proportions(&template, side, &cues[i]);
            match learnt {
                Some(est) => match fitter.set_skeleton(est.skeleton) {
                    Err(e) => self.notes.push(Note::new(
                        NoteTopic::Proportions,
                        format!("{side} hand proportions not applied: {e}"),
                    )),
                    Ok(()) => {
                        self.notes.push(note);
                        self.proportions[i] = Some(est);
                    }
                },
                None => self.notes.push(note),
            }
        }
    }

    /// The frame's hands ([`associate`]): per hand its id, side (voted over its track) and
    /// the views that see it.
    fn associate(&self, frame: &VisionFrame) -> Vec<Anchored> {
        let side = |id: &HandId, h: &DetectedHand| self.tracks.side(*id).unwrap_or(h.side);
        let candidates: Vec<Vec<Candidate>> = frame
            .views
            .iter()
            .map(|v| match v {
                Ok(vh) => vh
                    .detections
                    .hands
                    .iter()
                    .zip(&vh.ids)
                    .map(|(h, id)| Candidate {
                        side: side(id, h),
                        score: f64::from(h.detection_score),
                    })
                    .collect(),
                Err(_) => Vec::new(),
            })
            .collect();
        let slices: Vec<&[Candidate]> = candidates.iter().map(Vec::as_slice).collect();
        associate(&slices)
            .into_iter()
            .filter_map(|views| {
                let (v, k) = *views.first()?;
                let id = *frame.views.get(v)?.as_ref().ok()?.ids.get(k)?;
                Some((id, candidates[v][k].side, views))
            })
            .collect()
    }

    fn fit_frame(&mut self, frame: VisionFrame) -> FittedFrame {
        let t = Instant::now();
        let mut out = FittedFrame {
            hands: Vec::new(),
            error: None,
            fit_ms: 0.0,
            vision: frame,
            cameras: Vec::new(),
            camera_origins: Vec::new(),
        };
        for (v, view) in out.vision.views.iter().enumerate().skip(1) {
            if let Err(e) = view {
                tracing::warn!("frame {}: view {} unreadable: {e}", out.vision.index, v + 1);
            }
        }
        match out.vision.views.first() {
            Some(Ok(_)) => {}
            Some(Err(e)) => {
                out.error = Some(e.to_string());
                return out;
            }
            None => return out,
        }
        let sizes: Vec<Option<(u32, u32)>> = out
            .vision
            .views
            .iter()
            .map(|v| v.as_ref().ok().map(|vh| vh.detections.image_size))
            .collect();
        let chosen = self.cameras.camera_for(&sizes, &out.vision.focal);
        self.notes.extend(self.cameras.take_notes());
        if let Err(e) = chosen {
            tracing::warn!("frame {}: {e}", out.vision.index);
            out.error = Some(e.to_string());
            return out;
        }
        out.cameras = self.cameras.cameras().to_vec();
        out.camera_origins = self.cameras.origins().to_vec();
        let index = out.vision.index;
        for view in out.vision.views.iter().flatten() {
            for (hand, &id) in view.detections.hands.iter().zip(&view.ids) {
                self.tracks.vote(id, hand, index, &self.prototypes);
            }
        }
        for (id, side, views) in self.associate(&out.vision) {
            let fit = self.fit_hand(id, &out.vision, &views);
            out.hands.push(TrackedHand {
                id,
                side,
                views,
                fit,
            });
        }
        self.tracks.forget_unseen(index);
        out.fit_ms = t.elapsed().as_secs_f64() * 1e3;
        out
    }

    fn fit_hand(
        &mut self,
        id: HandId,
        frame: &VisionFrame,
        views: &[(usize, usize)],
    ) -> Option<FitResult> {
        let track = self.tracks.get_mut(&id)?;
        if !self.settings.tracking {
            track.tracker.reset();
        }
        let views: Vec<View> = views
            .iter()
            .filter_map(|&(v, k)| {
                let d = detected(frame, v, k)?;
                let cam = self.cameras.cameras().get(v)?;
                Some(View::new(cam, &d.keypoints).with_cues(d.cues.as_ref()))
            })
            .collect();
        match fit_views(&mut track.tracker, &views) {
            FitOutcome::Fitted(mut fit) => {
                // One camera only: with several the distance is seen, not guessed.
                if let (Some(f), [cam]) = (track.depth.as_mut(), self.cameras.cameras()) {
                    f.apply(frame.time_s, cam, &mut fit.joints_3d);
                }
                if let Some(f) = track.filter.as_mut() {
                    let joints = f.filter(frame.time_s, &fit.joints_3d.map(|x| [x.x, x.y, x.z]));
                    fit.joints_3d = joints.map(Vector3::from);
                }
                Some(*fit)
            }
            FitOutcome::Diverged => {
                tracing::warn!(
                    "frame {}: hand {id}: the fit diverged, no 3D this frame",
                    frame.index
                );
                None
            }
            FitOutcome::Failed(e) => {
                tracing::debug!("frame {}: hand {id}: no 3D: {e}", frame.index);
                None
            }
        }
    }
}

/// Hand `k` of view `v` of a frame.
/// Refits `hand` of a frame towards its neighbours' joints, with its track's fitter; its
/// output joints get the neighbours' mean fusion offsets, its own refitted offset in its
/// own share.
fn refit_hand(
    tracks: &mut Tracks,
    vision: &VisionFrame,
    cameras: &[Camera],
    hand: &mut TrackedHand,
    n: &crate::offline::Neighbours,
    own_offset: &[Vector3<f64>; NUM_JOINTS],
    settings: &OfflineSettings,
) {
    let (Some(fit), Some(track)) = (hand.fit.as_mut(), tracks.get_mut(&hand.id)) else {
        return;
    };
    let views: Vec<View> = hand
        .views
        .iter()
        .filter_map(|&(v, k)| {
            let d = detected(vision, v, k)?;
            Some(View::new(cameras.get(v)?, &d.keypoints).with_cues(d.cues.as_ref()))
        })
        .collect();
    let fitter = track.tracker.fitter_mut();
    let Ok(mut refit) = fitter.refit_towards(&views, &fit.pose, &n.target, settings.weight) else {
        return;
    };
    if !crate::fit::is_finite(&refit) {
        return;
    }
    let model = refit.model_joints_3d;
    for (((out, m), mean), causal) in refit
        .joints_3d
        .iter_mut()
        .zip(&model)
        .zip(&n.offset)
        .zip(own_offset)
    {
        // The neighbours' mean offset, with this frame's share now its refit's own.
        let own = *out - m;
        *out = m + mean + (own - causal) * n.own_share;
    }
    *fit = refit;
}

fn detected(frame: &VisionFrame, v: usize, k: usize) -> Option<&DetectedHand> {
    frame.views.get(v)?.as_ref().ok()?.detections.hands.get(k)
}
