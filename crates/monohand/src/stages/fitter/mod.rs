//! Stage 3 over a video: [`HandsFitter`] composes the jobs, each with its own state: the
//! camera choice ([`CameraChoice`]), the hands followed with their side vote and the views'
//! association ([`Tracks`]), the shape learnt from the first frames ([`HandShape`]) and the
//! offline smoother ([`crate::offline`]); it fits each hand and keeps the notes.
//!
//! Its parts, each importing only the ones listed before it: [`options`] (how it fits),
//! [`fit`] (one hand's fit over its views, and the hand's size), [`tracks`] (the hands
//! followed) and [`shape`] (the size and proportions learnt from the first frames).

pub(crate) mod fit;
pub(crate) mod options;
pub(crate) mod shape;
pub(crate) mod tracks;

use crate::base::clock::Instant;
use crate::base::frame::{detected, FittedFrame, HandId, TrackedHand, VisionFrame};
use crate::base::notes::Note;
use crate::stages::cameras::{in_first_frame, CameraChoice};
use crate::stages::offline::{
    causal, depth_target, distance_correction, neighbours, CausalFrame, Depth, DepthFrame, Held,
    OfflineSettings,
};
use fit::{fit_views, FitOutcome, HandSizeSource};
use monohand_core::filtering::{mean_depth, scale_to_depth};
use monohand_core::fitting::{DistanceEvidence, ProportionEstimate, ScaleEstimate};
use monohand_core::prelude::*;
use monohand_io::jsonl::HandSizeRecord;
use nalgebra::Vector3;
use options::FitSettings;
use shape::HandShape;
use tracks::{Anchored, Tracks};

/// The 3D stage of a session: takes the networks' frames in order and fits every hand.
///
/// It carries a payload of the caller's with each frame (`T`, for example the image for an
/// overlay), because with [`FitSettings::auto_scale_frames`] frames come back later than
/// they went in.
pub struct HandsFitter<T = ()> {
    /// The camera of each view, frame by frame.
    cameras: CameraChoice,
    /// Each given camera's extrinsics (the user's world frame into it). The hands are
    /// fitted in the first camera's frame ([`in_first_frame`]) and mapped into the world
    /// frame as they leave, so that no start, prior or filter depends on where the world
    /// frame is.
    world: Vec<Extrinsics>,
    prototypes: [HandTracker; 2],
    settings: FitSettings,
    /// Each hand seen: its identity, voted side, tracker and filters.
    tracks: Tracks,
    pending: Option<(usize, Vec<(VisionFrame, T)>)>,
    /// The size and proportions learnt from the first frames.
    shape: HandShape,
    notes: Vec<Note>,
    /// With [`FitSettings::offline`]: the frames fitted but not yet refitted, with their
    /// causal fits.
    fitted: Held<(FittedFrame, T), CausalFrame>,
    /// With [`FitSettings::offline`] and one camera: the frames refitted but not yet
    /// written, with their refitted distances.
    refitted: Held<(FittedFrame, T), DepthFrame>,
    /// The number of the last frame fitted.
    last_fitted: Option<u64>,
    /// Per view after the first: the frame from which it has been unreadable, if it is now
    /// (said once when it starts and once when it ends, not on every frame).
    unreadable_since: Vec<Option<u64>>,
}

impl<T> HandsFitter<T> {
    /// A 3D stage for these cameras (one per view; the first is the reference whose frame
    /// the 3D is in). With no camera at all, each frame gets a camera for its image size:
    /// from the focal length its file states ([`VisionFrame::focal`]: a photo's EXIF, a
    /// video's QuickTime metadata), else the generic guess ([`Camera::generic`]); each kind
    /// is said once in [`Self::take_notes`].
    pub fn new(cameras: Vec<Camera>, settings: FitSettings) -> Result<HandsFitter<T>, CoreError> {
        for c in &cameras {
            c.validate()?;
        }
        let world = cameras.iter().map(|c| c.extrinsics).collect();
        let mut cameras = CameraChoice::new(cameras);
        let notes = cameras.take_notes();
        Ok(HandsFitter {
            cameras,
            world,
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
            shape: HandShape::default(),
            notes,
            fitted: Held::default(),
            refitted: Held::default(),
            last_fitted: None,
            unreadable_since: Vec::new(),
        })
    }

    /// The hand size measured with `auto_scale_frames`, once known.
    pub fn scale(&self) -> Option<&ScaleEstimate> {
        self.shape.scale.as_ref()
    }

    /// The hands fitted in the last frame fitted, predicted to the next frame, in the first
    /// camera's frame: for the next frame's crops ([`crate::CropTracker::guide`]). Empty
    /// while frames are kept back to measure the hand.
    pub fn guides(&self) -> Vec<crate::base::frame::FittedGuide> {
        match self.last_fitted {
            Some(index) => self.tracks.guides(index),
            None => Vec::new(),
        }
    }

    /// The hand size the fits use now (the right hand's model; the left mirrors it) and
    /// where it came from.
    pub fn hand_size(&self) -> HandSizeRecord {
        let sk = self.prototypes[1].fitter().skeleton();
        let source = match self.shape.scale {
            Some(_) => HandSizeSource::Measured,
            None => self.settings.hand_size,
        };
        HandSizeRecord {
            length_mm: sk.hand_length(),
            scale: shape::template_scale(sk, HandSide::Right),
            source: source.as_str().to_string(),
        }
    }

    /// The hand the views measured with `auto_scale_frames`, as a hand file says it, once
    /// known.
    pub fn measured_hand(&self) -> Option<&monohand_io::hand::HandFile> {
        self.shape.measured.as_ref()
    }

    /// The proportions learnt with `proportion_frames` for the left and the right hand,
    /// once known.
    pub fn proportions(&self) -> &[Option<ProportionEstimate>; 2] {
        &self.shape.proportions
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
        let done = self.smooth(fitted, false);
        self.in_world(done)
    }

    /// Fits the frames still kept back, at the end of the input.
    pub fn flush(&mut self) -> Vec<(FittedFrame, T)> {
        let fitted = self.finish_scale();
        let done = self.smooth(fitted, true);
        self.in_world(done)
    }

    /// Frames fitted in the first camera's frame, with their cameras and hands in the
    /// world frame of the given cameras (unchanged without calibrated cameras).
    fn in_world(&self, mut frames: Vec<(FittedFrame, T)>) -> Vec<(FittedFrame, T)> {
        let Some(first) = self.world.first().filter(|e| !e.is_identity()) else {
            return frames;
        };
        let to_world = first.inverse();
        for (frame, _) in &mut frames {
            for (camera, e) in frame.cameras.iter_mut().zip(&self.world) {
                camera.extrinsics = *e;
            }
            for fit in frame.hands.iter_mut().filter_map(|h| h.fit.as_mut()) {
                *fit = fit.transformed(&to_world);
            }
        }
        frames
    }

    /// With [`FitSettings::offline`]: takes the newly fitted frames and gives back,
    /// smoothed, those whose `lag` following frames are fitted (`lag + max(lag,
    /// distance_lag)` with one camera and [`OfflineSettings::depth_pass`]; all of them at
    /// the end): refitted towards their neighbours ([`neighbours`]), then their distance
    /// averaged ([`depth_target`]) and moved by the smoothed distance ([`distance_correction`]).
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
                        .filter_map(|h| {
                            let mean_mm = mean_depth(cam, &h.fit.as_ref()?.joints_3d)?;
                            let filtered = h.distance.map(|e| (e.fused_mm, e.fused_sigma_mm));
                            Some((h.id, Depth { mean_mm, filtered }))
                        })
                        .collect()
                }
                _ => DepthFrame::new(),
            };
            (f, depths)
        });
        let distance = self.settings.options.distance;
        let drift = distance.drift_per_frame;
        // Without the distance filter there is nothing to smooth ahead: no frames held for it.
        let lag = if distance.enabled() {
            settings.lag.max(settings.distance_lag)
        } else {
            settings.lag
        };
        self.refitted
            .release(refitted, lag, end, |(frame, _), own, window| {
                let [cam] = frame.cameras.as_slice() else {
                    return;
                };
                for hand in &mut frame.hands {
                    let (Some(fit), Some(depth)) = (hand.fit.as_mut(), own.get(&hand.id)) else {
                        continue;
                    };
                    let target = depth_target(&settings, window, hand.id, depth.mean_mm);
                    let ratio = depth.filtered.map_or(1.0, |own| {
                        distance_correction(&settings, window, hand.id, own, drift)
                    });
                    let target = target.unwrap_or(depth.mean_mm) * ratio;
                    if target != depth.mean_mm {
                        scale_to_depth(cam, &mut fit.joints_3d, depth.mean_mm, target);
                    }
                }
            })
    }

    fn finish_scale(&mut self) -> Vec<(FittedFrame, T)> {
        let Some((_, pending)) = self.pending.take() else {
            return Vec::new();
        };
        let cameras = in_first_frame(self.cameras.cameras());
        let min_confidence = self.settings.options.cost.min_confidence;
        let anchored: Vec<Vec<Anchored>> = pending
            .iter()
            .map(|(f, _)| self.tracks.associate(f, &cameras, min_confidence))
            .collect();
        self.shape.learn(
            &self.settings,
            &pending,
            &anchored,
            &in_first_frame(self.cameras.cameras()),
            &mut self.prototypes,
            &mut self.notes,
        );
        pending
            .into_iter()
            .map(|(f, p)| (self.fit_frame(f), p))
            .collect()
    }

    fn fit_frame(&mut self, frame: VisionFrame) -> FittedFrame {
        let t = Instant::now();
        self.last_fitted = Some(frame.index);
        let mut out = FittedFrame {
            hand_size: None,
            hands: Vec::new(),
            error: None,
            fit_ms: 0.0,
            vision: frame,
            cameras: Vec::new(),
            camera_origins: Vec::new(),
            min_confidence: self.settings.options.cost.min_confidence,
        };
        say_unreadable(
            &mut self.unreadable_since,
            out.vision.index,
            &out.vision.views,
        );
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
        out.cameras = in_first_frame(self.cameras.cameras());
        out.hand_size = Some(self.hand_size());
        out.camera_origins = self.cameras.origins().to_vec();
        let index = out.vision.index;
        for view in out.vision.views.iter().flatten() {
            for (hand, &id) in view.detections.hands.iter().zip(&view.ids) {
                self.tracks.vote(id, hand, index, &self.prototypes);
            }
        }
        let min_confidence = self.settings.options.cost.min_confidence;
        let mut hands = self
            .tracks
            .associate(&out.vision, &out.cameras, min_confidence);
        let vision = &out.vision;
        self.tracks
            .separate(&mut hands, index, &self.prototypes, |v, k| {
                detected(vision, v, k)
            });
        for (id, side, views) in hands {
            let (fit, distance) = match self.fit_hand(id, &out.vision, &out.cameras, &views) {
                Some((fit, distance)) => (Some(fit), distance),
                None => (None, None),
            };
            out.hands.push(TrackedHand {
                id,
                side,
                views,
                fit,
                distance,
            });
        }
        self.tracks.forget_unseen(index);
        out.fit_ms = t.elapsed().as_secs_f64() * 1e3;
        out
    }

    /// Fits hand `id` of `frame` seen in `views` with `cameras` (in the first camera's
    /// frame): the fit, with the distance evidence its tracker gathered (one camera).
    fn fit_hand(
        &mut self,
        id: HandId,
        frame: &VisionFrame,
        cameras: &[Camera],
        views: &[(usize, usize)],
    ) -> Option<(FitResult, Option<DistanceEvidence>)> {
        let track = self.tracks.get_mut(&id)?;
        if !self.settings.tracking {
            track.tracker.reset();
        }
        let views: Vec<View> = views
            .iter()
            .filter_map(|&(v, k)| {
                let d = detected(frame, v, k)?;
                let cam = cameras.get(v)?;
                Some(View::new(cam, &d.keypoints).with_cues(d.cues.as_ref()))
            })
            .collect();
        let outcome = fit_views(&mut track.tracker, &views);
        let evidence = track.tracker.distance_evidence().copied();
        if let Some(e) = &evidence {
            tracing::debug!(
                "distance: frame {} hand {id}: keypoints {:.1} sigma {:.1} cues {:.1} fused {:.1} sigma {:.1}",
                frame.index,
                e.keypoints_mm.unwrap_or(f64::NAN),
                e.keypoints_sigma_mm.unwrap_or(f64::NAN),
                e.cues_mm.unwrap_or(f64::NAN),
                e.fused_mm,
                e.fused_sigma_mm
            );
        }
        match outcome {
            FitOutcome::Fitted(mut fit) => {
                // One camera only: with several the distance is seen, not guessed.
                if let (Some(f), [cam]) = (track.depth.as_mut(), cameras) {
                    f.apply(frame.time_s, cam, &mut fit.joints_3d);
                }
                if let Some(f) = track.filter.as_mut() {
                    let joints = f.filter(frame.time_s, &fit.joints_3d.map(|x| [x.x, x.y, x.z]));
                    fit.joints_3d = joints.map(Vector3::from);
                }
                self.tracks.fitted(id, frame.index, &fit.joints_3d);
                Some((*fit, evidence))
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

/// Says in the log when a view after the first becomes unreadable (its first error) and
/// when it is readable again (how many frames it missed), not on every frame between: a view
/// that started late or a camera unplugged for a while gives two lines, not one a frame.
fn say_unreadable<V>(
    since: &mut Vec<Option<u64>>,
    index: u64,
    views: &[Result<V, crate::base::frame::ViewError>],
) {
    if since.len() < views.len() {
        since.resize(views.len(), None);
    }
    for (v, view) in views.iter().enumerate().skip(1) {
        match (view, since[v]) {
            (Err(e), None) => {
                tracing::warn!(
                    "frame {index}: view {} unreadable: {e} (said once: fitted without it until it is readable again)",
                    v + 1
                );
                since[v] = Some(index);
            }
            (Ok(_), Some(from)) => {
                tracing::info!(
                    "frame {index}: view {} readable again, after {} frames without it",
                    v + 1,
                    index.saturating_sub(from)
                );
                since[v] = None;
            }
            _ => {}
        }
    }
}

/// Refits `hand` of a frame towards its neighbours' joints, with its track's fitter; its
/// output joints get the neighbours' mean fusion offsets, its own refitted offset in its
/// own share.
fn refit_hand(
    tracks: &mut Tracks,
    vision: &VisionFrame,
    cameras: &[Camera],
    hand: &mut TrackedHand,
    n: &crate::stages::offline::Neighbours,
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
    if !fit::is_finite(&refit) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::errors::SourceError;
    use crate::base::frame::ViewError;

    #[test]
    fn an_unreadable_view_is_said_when_it_starts_and_when_it_ends() {
        let bad = || Err(ViewError::Unreadable(SourceError::Other("late".into())));
        let mut since = Vec::new();
        // View 2 has no frame for frames 0-4, view 3 always has; the first view is never said.
        for index in 0..5 {
            say_unreadable(&mut since, index, &[bad(), bad(), Ok(())]);
            assert_eq!(since, [None, Some(0), None], "frame {index}");
        }
        say_unreadable(&mut since, 5, &[Ok(()), Ok(()), Ok(())]);
        assert_eq!(since, [None, None, None]);
        // Unplugged again later: a new episode from its own first frame.
        say_unreadable(&mut since, 9, &[Ok(()), bad(), Ok(())]);
        assert_eq!(since, [None, Some(9), None]);
    }
}
