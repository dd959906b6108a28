//! The per-frame work of `monohand run`: the networks (stage 1 and 2, with tracking of the
//! crops and of hand identities) and the 3D fit (stage 3, one tracker per hand).

use crate::hand_args::is_finite;
use crate::vision::frame_record;
use monohand_core::filtering::{OneEuroFilter, OneEuroParams};
use monohand_core::fitting::{estimate_hand_scale, ScaleEstimate};
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use monohand_io::jsonl::FrameRecord;
use monohand_vision::{DetectedHand, Detections, HandPipeline, RgbImage};
use std::collections::HashMap;
use std::time::Instant;

/// Identity of a tracked hand.
pub(crate) type HandId = u64;

/// One hand of a frame across views: its id, side, and `(view, keypoints, network cues)` per
/// view that sees it.
type HandViews = (HandId, HandSide, Vec<SeenIn>);

/// A hand as seen in one view: the view's index, its keypoints and the network's 3D cues.
type SeenIn = (usize, Keypoints2d, Option<NetworkCues>);

/// A fitted frame and, for overlays, its first view's image.
pub(crate) type Done = (FrameRecord, Option<RgbImage>);

/// Per view: the hands of the previous frame, for the next crops.
#[derive(Default)]
struct ViewTracks {
    previous: Vec<DetectedHand>,
    ids: Vec<HandId>,
    frames_since_detection: usize,
}

/// Stage 1 and 2 over all views, with the crop tracking of MediaPipe.
pub(crate) struct VisionStage {
    pipeline: std::sync::Arc<HandPipeline>,
    views: Vec<ViewTracks>,
    tracking: bool,
    detect_every: usize,
    next_id: HandId,
}

/// What the networks found in one frame.
pub(crate) struct VisionFrame {
    /// Frame index.
    pub index: u64,
    /// File name, if any.
    pub source: Option<String>,
    /// Seconds.
    pub timestamp_s: f64,
    /// Whether the frame came from a video (its time is then written out).
    pub is_video: bool,
    /// Per view: detections and the hand id of each detection, or why the view failed.
    pub views: Vec<Result<(Detections, Vec<HandId>), String>>,
    /// The first view's image (for overlays), when kept.
    pub image: Option<RgbImage>,
    /// Stage timings, ms.
    pub timings_ms: Vec<(String, f64)>,
}

impl VisionStage {
    pub fn new(
        pipeline: std::sync::Arc<HandPipeline>,
        views: usize,
        tracking: bool,
        detect_every: usize,
    ) -> VisionStage {
        VisionStage {
            pipeline,
            views: (0..views).map(|_| ViewTracks::default()).collect(),
            tracking,
            detect_every: detect_every.max(1),
            next_id: 0,
        }
    }

    /// Wraps the detections of an independent image (no tracking, one view): every hand
    /// gets a new id.
    pub fn assign(
        &mut self,
        index: u64,
        source: Option<String>,
        timestamp_s: f64,
        detections: Result<Detections, String>,
        vision_ms: f64,
    ) -> VisionFrame {
        let view = detections.map(|d| {
            let ids = (0..d.hands.len() as u64)
                .map(|k| self.next_id + k)
                .collect();
            self.next_id += d.hands.len() as u64;
            (d, ids)
        });
        VisionFrame {
            index,
            source,
            timestamp_s,
            is_video: false,
            views: vec![view],
            image: None,
            timings_ms: vec![("vision".into(), vision_ms)],
        }
    }

    /// Runs the networks on one frame of every view. `images[v]` is view `v`'s frame.
    pub fn process(
        &mut self,
        index: u64,
        source: Option<String>,
        timestamp_s: f64,
        images: Vec<Result<RgbImage, String>>,
        keep_image: bool,
    ) -> VisionFrame {
        let t = Instant::now();
        let mut out = Vec::with_capacity(images.len());
        let max_hands = self.pipeline.options.max_hands;
        for (v, image) in images.iter().enumerate() {
            let state = &mut self.views[v];
            let image = match image {
                Ok(i) => i,
                Err(e) => {
                    // A frame that cannot be read breaks the continuity of the video.
                    state.previous.clear();
                    state.ids.clear();
                    out.push(Err(e.clone()));
                    continue;
                }
            };
            let result = if self.tracking {
                let detect_new = state.previous.is_empty()
                    || (state.previous.len() < max_hands
                        && state.frames_since_detection + 1 >= self.detect_every);
                self.pipeline
                    .track(image, &state.previous, detect_new)
                    .map(|(d, origin)| (d, origin, detect_new))
            } else {
                self.pipeline.detect(image).map(|d| (d, Vec::new(), true))
            };
            match result {
                Ok((detections, origin, detected)) => {
                    let ids: Vec<HandId> = (0..detections.hands.len())
                        .map(|h| match origin.get(h).copied().flatten() {
                            Some(prev) => state.ids[prev],
                            None => {
                                self.next_id += 1;
                                self.next_id - 1
                            }
                        })
                        .collect();
                    state.frames_since_detection = if detected {
                        0
                    } else {
                        state.frames_since_detection + 1
                    };
                    if self.tracking {
                        state.previous = detections.hands.clone();
                        state.ids = ids.clone();
                    }
                    out.push(Ok((detections, ids)));
                }
                Err(e) => {
                    state.previous.clear();
                    state.ids.clear();
                    out.push(Err(e.to_string()));
                }
            }
        }
        let vision_ms = t.elapsed().as_secs_f64() * 1e3;
        let image = if keep_image {
            images.into_iter().next().and_then(Result::ok)
        } else {
            None
        };
        VisionFrame {
            index,
            source,
            timestamp_s,
            is_video: self.tracking,
            views: out,
            image,
            timings_ms: vec![("vision".into(), vision_ms)],
        }
    }
}

/// One hand followed by the fit stage.
struct HandTrack {
    tracker: HandTracker,
    side: HandSide,
    /// Sum of the log-odds of "right" over the frames seen: the side is voted, so one
    /// uncertain frame does not flip a hand.
    right_log_odds: f64,
    last_seen: u64,
    /// Temporal smoothing of the 3D joints (`--smooth`).
    filter: Option<OneEuroFilter<NUM_JOINTS>>,
}

/// Stage 3: fits every hand, one tracker per hand id.
pub(crate) struct FitStage {
    cameras: Vec<Camera>,
    /// A fresh tracker per side (left, right), cloned for each new hand.
    prototypes: [HandTracker; 2],
    options: FitOptions,
    tracking: bool,
    tracks: HashMap<HandId, HandTrack>,
    /// Frames kept back until the hand scale is measured (`--hand-scale auto`).
    scale_pending: Option<(usize, Vec<VisionFrame>)>,
    /// The measured scale, once known.
    pub scale: Option<ScaleEstimate>,
    /// No calibration: a generic camera is made for each image size.
    generic: bool,
    /// One Euro filter settings for new hands (`--smooth`).
    smoothing: Option<OneEuroParams>,
}

fn side_index(side: HandSide) -> usize {
    match side {
        HandSide::Left => 0,
        HandSide::Right => 1,
    }
}

impl FitStage {
    /// `auto_scale_frames`: keep this many frames back to measure the hand size first.
    pub fn new(
        cameras: Vec<Camera>,
        skeletons: [HandSkeleton; 2],
        options: FitOptions,
        tracking: bool,
        auto_scale_frames: Option<usize>,
    ) -> Result<FitStage, CoreError> {
        Ok(FitStage {
            cameras,
            prototypes: [
                HandTracker::new(skeletons[0], options)?,
                HandTracker::new(skeletons[1], options)?,
            ],
            options,
            tracking,
            tracks: HashMap::new(),
            scale_pending: auto_scale_frames.map(|n| (n, Vec::new())),
            scale: None,
            generic: false,
            smoothing: None,
        })
    }

    /// Smooths every hand's 3D joints over time with a One Euro filter.
    pub fn smooth(&mut self, params: OneEuroParams) {
        self.smoothing = Some(params);
    }

    /// Without calibration: assume [`Camera::generic`] for each frame's size, and say so.
    pub fn use_generic_camera(&mut self) {
        self.generic = true;
    }

    /// Makes the camera fit the frame: a generic camera for its size, or a check that the
    /// calibration's size matches.
    fn camera_for(&mut self, size: Option<[u32; 2]>) -> Result<(), String> {
        let Some([w, h]) = size else { return Ok(()) };
        if self.generic {
            let current = self
                .cameras
                .first()
                .map(|c| (c.intrinsics.width, c.intrinsics.height));
            if current != Some((w, h)) {
                let cam = Camera::generic(w, h).map_err(|e| e.to_string())?;
                if self.cameras.is_empty() {
                    crate::say(&format!(
                        "no --camera: assuming a generic camera for {w}x{h} (60 degree horizontal \
                         field of view); absolute depth is only as right as this guess \
                         (docs/calibration.md)"
                    ));
                }
                self.cameras = vec![cam];
            }
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

    /// Fits one frame; returns the frames now ready (more than one after the hand size was
    /// measured, none while frames are kept back for it).
    pub fn push(&mut self, frame: VisionFrame) -> Vec<Done> {
        if let Some((n, pending)) = &mut self.scale_pending {
            pending.push(frame);
            if pending.len() < *n {
                return Vec::new();
            }
            return self.finish_scale();
        }
        vec![self.fit_frame(frame)]
    }

    /// Fits the frames still kept back (at the end of the input).
    pub fn flush(&mut self) -> Vec<Done> {
        if self.scale_pending.is_some() {
            self.finish_scale()
        } else {
            Vec::new()
        }
    }

    fn finish_scale(&mut self) -> Vec<Done> {
        let Some((_, pending)) = self.scale_pending.take() else {
            return Vec::new();
        };
        self.measure_scale(&pending);
        pending.into_iter().map(|f| self.fit_frame(f)).collect()
    }

    /// `--hand-scale auto`: the size of the hand seen in most of the kept frames.
    fn measure_scale(&mut self, frames: &[VisionFrame]) {
        if self.cameras.len() < 2 {
            crate::say(
                "--hand-scale auto: with one camera the hand size is not observable (a larger hand \
                 further away projects the same); keeping the default size (see docs/accuracy.md)",
            );
            return;
        }
        // The hand id seen in the most frames, in at least two views.
        let mut counts: HashMap<HandId, usize> = HashMap::new();
        let per_frame: Vec<Vec<HandViews>> = frames.iter().map(|f| self.associate(f)).collect();
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
            crate::say("--hand-scale auto: no hand was seen by two views in the first frames; keeping the default size");
            return;
        };
        let mut side = HandSide::Right;
        let mut obs: Vec<Vec<SeenIn>> = Vec::new();
        for hands in per_frame {
            for (id, s, views) in hands {
                if id == best && views.len() >= 2 {
                    side = s;
                    obs.push(views);
                }
            }
        }
        let views: Vec<Vec<View>> = obs
            .iter()
            .map(|vs| {
                vs.iter()
                    .map(|(v, kp, _)| View::new(&self.cameras[*v], kp))
                    .collect()
            })
            .collect();
        let template = *self.prototypes[side_index(side)].fitter_mut().skeleton();
        match estimate_hand_scale(&template, &self.options, &views, 0.6, 1.6) {
            Ok(est) if est.observable => {
                crate::say(&format!(
                    "--hand-scale auto: hand size {:.3} x the current model, from {} frames (hand length {:.0} mm)",
                    est.scale,
                    est.frames_used,
                    template.hand_length() * est.scale
                ));
                for proto in &mut self.prototypes {
                    let fitter = proto.fitter_mut();
                    let scaled = fitter.skeleton().scaled(est.scale);
                    if let Err(e) = scaled.and_then(|s| fitter.set_skeleton(s)) {
                        tracing::warn!("hand scale not applied: {e}");
                    }
                }
                self.scale = Some(est);
            }
            Ok(est) => crate::say(&format!(
                "--hand-scale auto: the first frames do not tell the hand size (cost contrast {:.3}); keeping the default",
                est.cost_contrast
            )),
            Err(e) => crate::say(&format!(
                "--hand-scale auto: could not measure the hand size ({e}); keeping the default"
            )),
        }
    }

    /// Per hand of the first view: its id, side and its keypoints in every view that sees
    /// it. A hand in another view is matched by side (the most confident of that side).
    fn associate(&self, frame: &VisionFrame) -> Vec<HandViews> {
        let Some(Ok((first, ids))) = frame.views.first() else {
            return Vec::new();
        };
        let mut used: Vec<Vec<bool>> = frame
            .views
            .iter()
            .map(|v| match v {
                Ok((d, _)) => vec![false; d.hands.len()],
                Err(_) => Vec::new(),
            })
            .collect();
        let mut out = Vec::new();
        for (h, hand) in first.hands.iter().enumerate() {
            let side = self.tracks.get(&ids[h]).map_or(hand.side, |t| t.side);
            let mut views = vec![(0, hand.keypoints, hand.cues)];
            for (v, view) in frame.views.iter().enumerate().skip(1) {
                let Ok((d, _)) = view else { continue };
                let best = d
                    .hands
                    .iter()
                    .enumerate()
                    .filter(|(k, o)| o.side == side && !used[v][*k])
                    .max_by(|a, b| a.1.detection_score.total_cmp(&b.1.detection_score));
                if let Some((k, o)) = best {
                    used[v][k] = true;
                    views.push((v, o.keypoints, o.cues));
                }
            }
            out.push((ids[h], side, views));
        }
        out
    }

    fn fit_frame(&mut self, frame: VisionFrame) -> Done {
        let t = Instant::now();
        let mut record = match frame.views.first() {
            Some(Ok((d, _))) => frame_record(frame.index, frame.source.clone(), d),
            Some(Err(e)) => FrameRecord {
                frame: frame.index,
                source: frame.source.clone(),
                error: Some(e.clone()),
                ..FrameRecord::default()
            },
            None => FrameRecord::default(),
        };
        // Views other than the first that failed are reported but do not stop the frame.
        for (v, view) in frame.views.iter().enumerate().skip(1) {
            if let Err(e) = view {
                tracing::warn!("frame {}: view {} unreadable: {e}", frame.index, v + 1);
            }
        }
        if let Err(e) = self.camera_for(record.image_size) {
            tracing::warn!("frame {}: {e}", frame.index);
            record.error = Some(e);
            return (record, frame.image);
        }
        if let Some(Ok((first, ids))) = frame.views.first() {
            // Vote on the side of each hand before associating views.
            for (h, hand) in first.hands.iter().enumerate() {
                self.vote_side(ids[h], hand, frame.index);
            }
            // `record.hands` holds the first view's detections in the order of `first.hands`,
            // which `associate` keeps.
            let hands = self.associate(&frame);
            for ((id, side, views), rec) in hands.into_iter().zip(record.hands.iter_mut()) {
                rec.id = Some(id);
                if side != rec.side {
                    // The vote over the track overrules this frame's network.
                    rec.side = side;
                    rec.side_score = rec.side_score.map(|p| 1.0 - p);
                }
                if let Some(fit) = self.fit_hand(id, &views, frame.index) {
                    let mut joints = fit.joints_3d.map(|x| [x.x, x.y, x.z]);
                    if let Some(f) = self.tracks.get_mut(&id).and_then(|t| t.filter.as_mut()) {
                        joints = f.filter(frame.timestamp_s, &joints);
                    }
                    rec.joints_3d_mm = Some(joints);
                    rec.pose = Some(monohand_io::jsonl::PoseRecord::from_pose(&fit.pose));
                    rec.reprojection_error_px = Some(fit.reprojection_error_px);
                    rec.converged = Some(fit.converged);
                    rec.iterations = Some(fit.iterations);
                }
            }
        }
        // Forget hands not seen for a while.
        let now = frame.index;
        self.tracks
            .retain(|_, t| now.saturating_sub(t.last_seen) < 30);
        if frame.is_video {
            record.time_s = Some(frame.timestamp_s);
        }
        let mut timings = frame.timings_ms.clone();
        timings.push(("fit".into(), t.elapsed().as_secs_f64() * 1e3));
        record.timings_ms = Some(timings.into_iter().collect());
        (record, frame.image)
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
        let smoothing = self.smoothing;
        let track = self.tracks.entry(id).or_insert_with(|| HandTrack {
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

    fn fit_hand(&mut self, id: HandId, views: &[SeenIn], index: u64) -> Option<FitResult> {
        let track = self.tracks.get_mut(&id)?;
        if !self.tracking {
            track.tracker.reset();
        }
        let views: Vec<View> = views
            .iter()
            .map(|(v, kp, cues)| View::new(&self.cameras[*v], kp).with_cues(cues.as_ref()))
            .collect();
        match track.tracker.update(&views) {
            Ok(fit) if is_finite(&fit) => Some(fit),
            Ok(_) => {
                tracing::warn!("frame {index}: hand {id}: the fit diverged, no 3D this frame");
                track.tracker.reset();
                None
            }
            Err(e) => {
                tracing::debug!("frame {index}: hand {id}: no 3D: {e}");
                None
            }
        }
    }
}
