//! Stage 3 over a video: one 3D tracker per hand identity, the left/right vote, the views'
//! association, smoothing and the hand size.

use crate::association::{associate, Candidate};
use crate::crops::{HandId, VisionFrame};
use crate::fit::{fit_views, learn_proportions, FitOutcome};
use crate::notes::{Note, NoteTopic};
use monohand_core::filtering::{OneEuroFilter, OneEuroParams};
use monohand_core::fitting::{estimate_hand_scale, ProportionEstimate, ScaleEstimate};
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use monohand_io::jsonl::CameraSource;
use monohand_vision::image_io::PhotoFocal;
use monohand_vision::DetectedHand;
use nalgebra::Vector3;
use std::collections::HashMap;
use std::time::Instant;

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
        }
    }
}

/// One hand of a frame, with its 3D.
#[derive(Debug, Clone)]
pub struct TrackedHand {
    /// Identity over the frames.
    pub id: HandId,
    /// Side, as voted over the hand's frames (it can differ from this frame's network).
    pub side: HandSide,
    /// The `(view, index into that view's detections)` pairs that see this hand, its
    /// anchor first: the first view, unless only later views see the hand.
    pub views: Vec<(usize, usize)>,
    /// The fitted hand, `None` when it could not be fitted this frame.
    pub fit: Option<FitResult>,
}

/// One frame after the 3D stage.
#[derive(Debug, Clone)]
pub struct FittedFrame {
    /// What the networks found.
    pub vision: VisionFrame,
    /// The hands ([`associate`]): the first view's, in the order of its detections, then
    /// those only later views see.
    pub hands: Vec<TrackedHand>,
    /// Why the frame has no 3D at all (the first view failed, or its image size does not
    /// match the calibration).
    pub error: Option<String>,
    /// Time the fits took, ms.
    pub fit_ms: f64,
    /// The camera of each view the frame was fitted with (empty when it was not fitted),
    /// and where they came from. Every drawing of the frame uses these.
    pub cameras: Vec<Camera>,
    /// Where [`FittedFrame::cameras`] came from.
    pub camera_source: CameraSource,
}

/// One hand followed over the frames.
struct Track {
    tracker: HandTracker,
    side: HandSide,
    /// Sum of the log-odds of "right" over the frames seen: one uncertain frame does not
    /// flip a hand.
    right_log_odds: f64,
    last_seen: u64,
    filter: Option<OneEuroFilter<NUM_JOINTS>>,
}

/// A hand of the first view: its id, side and the `(view, index)` pairs that see it.
type Anchored = (HandId, HandSide, Vec<(usize, usize)>);

fn side_index(side: HandSide) -> usize {
    match side {
        HandSide::Left => 0,
        HandSide::Right => 1,
    }
}

/// The 3D stage of a session: takes the networks' frames in order and fits every hand.
///
/// It carries a payload of the caller's with each frame (`T`, for example the image for an
/// overlay), because with [`FitSettings::auto_scale_frames`] frames come back later than
/// they went in.
pub struct HandsFitter<T = ()> {
    cameras: Vec<Camera>,
    /// Where `cameras` came from (for a generic or EXIF camera: the last frame's).
    camera_source: CameraSource,
    generic: bool,
    /// Whether the generic guess and an EXIF focal length were announced.
    said: [bool; 2],
    prototypes: [HandTracker; 2],
    settings: FitSettings,
    tracks: HashMap<HandId, Track>,
    pending: Option<(usize, Vec<(VisionFrame, T)>)>,
    scale: Option<ScaleEstimate>,
    proportions: [Option<ProportionEstimate>; 2],
    notes: Vec<Note>,
}

impl<T> HandsFitter<T> {
    /// A 3D stage for these cameras (one per view; the first is the reference whose frame
    /// the 3D is in). With no camera at all, each frame gets a camera for its image size:
    /// from the focal length its file states ([`VisionFrame::focal`], EXIF), else the
    /// generic guess ([`Camera::generic`]); each kind is said once in [`Self::take_notes`].
    pub fn new(cameras: Vec<Camera>, settings: FitSettings) -> Result<HandsFitter<T>, CoreError> {
        for c in &cameras {
            c.validate()?;
        }
        settings.options.validate()?;
        Ok(HandsFitter {
            generic: cameras.is_empty(),
            camera_source: if cameras.is_empty() {
                CameraSource::Generic
            } else {
                CameraSource::File
            },
            said: [false; 2],
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
            tracks: HashMap::new(),
            scale: None,
            proportions: [None, None],
            notes: Vec::new(),
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
        &self.cameras
    }

    /// Messages for the user since the last call (assumptions made, hand size found).
    pub fn take_notes(&mut self) -> Vec<Note> {
        std::mem::take(&mut self.notes)
    }

    /// Fits one frame; returns the frames now ready, in order: one, or none while frames
    /// are kept back to measure the hand size, then all of those.
    pub fn push(&mut self, frame: VisionFrame, payload: T) -> Vec<(FittedFrame, T)> {
        if let Some((n, pending)) = &mut self.pending {
            pending.push((frame, payload));
            if pending.len() < *n {
                return Vec::new();
            }
            return self.finish_scale();
        }
        let fitted = self.fit_frame(frame);
        vec![(fitted, payload)]
    }

    /// Fits the frames still kept back, at the end of the input.
    pub fn flush(&mut self) -> Vec<(FittedFrame, T)> {
        self.finish_scale()
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
        if self.cameras.len() < 2 {
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
                    .filter_map(|(v, d)| self.cameras.get(*v).map(|c| View::new(c, &d.keypoints)))
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
        let side = |id: &HandId, h: &DetectedHand| self.tracks.get(id).map_or(h.side, |t| t.side);
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

    /// Makes the camera fit the frame: without calibrated cameras, one for its size (from
    /// the focal length its file states, else the generic guess); with them, a check that
    /// the size is the calibrated one.
    fn camera_for(&mut self, size: (u32, u32), focal: Option<&PhotoFocal>) -> Result<(), String> {
        let (w, h) = size;
        if self.generic {
            let cam = match focal {
                Some(f) => Camera::centred(f.px, w, h),
                None => Camera::generic(w, h),
            }
            .map_err(|e| e.to_string())?;
            if self.cameras.first().map(|c| &c.intrinsics) != Some(&cam.intrinsics) {
                let kind = usize::from(focal.is_some());
                if !self.said[kind] {
                    self.said[kind] = true;
                    let message = match focal {
                        Some(f) => format!(
                            "the camera comes from the photo's {}: fx = fy = {:.1} \
                             px for {w}x{h} ({:.1} degree horizontal field of view; photos \
                             without it get the generic 60 degree guess)",
                            f.source,
                            f.px,
                            2.0 * (0.5 * w as f64 / f.px).atan().to_degrees()
                        ),
                        None => format!(
                            "assuming a generic camera for {w}x{h} (60 degree horizontal field \
                             of view); absolute depth is only as right as this guess \
                             (docs/calibration.md)"
                        ),
                    };
                    self.notes.push(Note::new(NoteTopic::Camera, message));
                }
                self.cameras = vec![cam];
            }
            self.camera_source = if focal.is_some() {
                CameraSource::Exif
            } else {
                CameraSource::Generic
            };
            return Ok(());
        }
        match self.cameras.first() {
            Some(c) if (c.intrinsics.width, c.intrinsics.height) != (w, h) => Err(format!(
                "the image is {w}x{h} but the camera is calibrated for {}x{}; no 3D for this frame",
                c.intrinsics.width, c.intrinsics.height
            )),
            _ => Ok(()),
        }
    }

    fn fit_frame(&mut self, frame: VisionFrame) -> FittedFrame {
        let t = Instant::now();
        let mut out = FittedFrame {
            hands: Vec::new(),
            error: None,
            fit_ms: 0.0,
            vision: frame,
            cameras: Vec::new(),
            camera_source: self.camera_source,
        };
        for (v, view) in out.vision.views.iter().enumerate().skip(1) {
            if let Err(e) = view {
                tracing::warn!("frame {}: view {} unreadable: {e}", out.vision.index, v + 1);
            }
        }
        let size = match out.vision.views.first() {
            Some(Ok(first)) => first.detections.image_size,
            Some(Err(e)) => {
                out.error = Some(e.clone());
                return out;
            }
            None => return out,
        };
        if let Err(e) = self.camera_for(size, out.vision.focal.as_ref()) {
            tracing::warn!("frame {}: {e}", out.vision.index);
            out.error = Some(e);
            return out;
        }
        out.cameras.clone_from(&self.cameras);
        out.camera_source = self.camera_source;
        let index = out.vision.index;
        for view in out.vision.views.iter().flatten() {
            for (hand, &id) in view.detections.hands.iter().zip(&view.ids) {
                self.vote_side(id, hand, index);
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
        self.tracks
            .retain(|_, t| index.saturating_sub(t.last_seen) < FORGET_AFTER_FRAMES);
        out.fit_ms = t.elapsed().as_secs_f64() * 1e3;
        out
    }

    fn vote_side(&mut self, id: HandId, hand: &DetectedHand, index: u64) {
        let p = f64::from(hand.side_score).clamp(0.5, 0.999);
        let p_right = if hand.side == HandSide::Right {
            p
        } else {
            1.0 - p
        };
        let log_odds = (p_right / (1.0 - p_right)).ln();
        let prototypes = &self.prototypes;
        let smoothing = self.settings.smoothing;
        let track = self.tracks.entry(id).or_insert_with(|| Track {
            tracker: prototypes[side_index(hand.side)].clone(),
            side: hand.side,
            right_log_odds: 0.0,
            last_seen: index,
            filter: smoothing.map(OneEuroFilter::new),
        });
        track.right_log_odds += log_odds;
        track.last_seen = index;
        let voted = if track.right_log_odds >= 0.0 {
            HandSide::Right
        } else {
            HandSide::Left
        };
        if voted != track.side {
            track.side = voted;
            track.tracker = self.prototypes[side_index(voted)].clone();
            if let Some(f) = &mut track.filter {
                f.reset();
            }
        }
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
                let cam = self.cameras.get(v)?;
                Some(View::new(cam, &d.keypoints).with_cues(d.cues.as_ref()))
            })
            .collect();
        match fit_views(&mut track.tracker, &views) {
            FitOutcome::Fitted(mut fit) => {
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
fn detected(frame: &VisionFrame, v: usize, k: usize) -> Option<&DetectedHand> {
    frame.views.get(v)?.as_ref().ok()?.detections.hands.get(k)
}
