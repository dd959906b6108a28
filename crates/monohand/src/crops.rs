//! Stages 1 and 2 over every view, with MediaPipe's crop tracking and hand identities.

use crate::cameras::StatedCamera;
use crate::clock::Instant;
use monohand_core::camera::Camera;
use monohand_vision::{Detections, HandPipeline, RgbImage};
use std::sync::Arc;

/// Identity of a tracked hand, unique within a session.
pub type HandId = u64;

/// Why a view gave no hands in a frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ViewError {
    /// Its image could not be read.
    #[error(transparent)]
    Unreadable(#[from] crate::engine::SourceError),
    /// The networks failed on it (their message).
    #[error("{0}")]
    Networks(String),
}

impl From<monohand_vision::VisionError> for ViewError {
    fn from(e: monohand_vision::VisionError) -> ViewError {
        ViewError::Networks(e.to_string())
    }
}

/// One view's hands in one frame: the networks' detections and each one's identity.
#[derive(Debug, Clone)]
pub struct ViewHands {
    /// What the networks found.
    pub detections: Detections,
    /// The identity of each of `detections.hands`, in order.
    pub ids: Vec<HandId>,
}

/// What the networks found in one frame of every view.
#[derive(Debug, Clone)]
pub struct VisionFrame {
    /// Frame number, from 0.
    pub index: u64,
    /// Time of the frame, seconds.
    pub time_s: f64,
    /// Per view: its hands, or why the view gave none this frame (an unreadable image, a
    /// network failure).
    pub views: Vec<Result<ViewHands, ViewError>>,
    /// Time the networks took, ms.
    pub vision_ms: f64,
    /// What the first view's file states about its camera (a photo's EXIF focal length, a
    /// video's QuickTime metadata), set by whoever read the file. Without calibrated
    /// cameras, the 3D stage builds that view's camera from it instead of the generic guess
    /// ([`crate::HandsFitter::new`]).
    pub focal: StatedCamera,
}

/// Per view: the hands of the previous frame, for the next crops.
#[derive(Debug, Default)]
struct ViewTracks {
    previous: Vec<monohand_vision::DetectedHand>,
    ids: Vec<HandId>,
    frames_since_detection: usize,
}

/// Runs the networks on the frames of one or several views and keeps each hand's identity.
///
/// With tracking (video), each hand of the previous frame is looked for again in the crop
/// its keypoints predict, the palm detector runs only when a hand is lost or every
/// `detect_every` frames while fewer than the most hands are tracked, and a continued hand
/// keeps its id. Without tracking, every frame is detected on its own and every hand gets a
/// new id.
pub struct CropTracker {
    pipeline: Arc<HandPipeline>,
    views: Vec<ViewTracks>,
    /// Per view, the camera whose rectified views the hands are read in
    /// ([`HandPipeline::track_through`]); `None`: crops of the image as it is.
    lenses: Vec<Option<Camera>>,
    tracking: bool,
    detect_every: usize,
    next_id: HandId,
}

impl CropTracker {
    /// A tracker for `views` cameras, tracking or not and looking for new hands as the
    /// resolved settings say.
    pub fn new(
        pipeline: Arc<HandPipeline>,
        views: usize,
        settings: &crate::ResolvedSettings,
    ) -> CropTracker {
        CropTracker {
            pipeline,
            views: (0..views).map(|_| ViewTracks::default()).collect(),
            lenses: Vec::new(),
            tracking: settings.tracking(),
            detect_every: settings.detect_every(),
            next_id: 0,
        }
    }

    /// Reads each view's hands in rectified views through its camera (`None`: crops of the
    /// image as it is); a camera for another frame size is scaled to the frames
    /// ([`Camera::scaled_to`]; a view whose frames it cannot describe is read unrectified).
    pub fn rectify_through(&mut self, lenses: Vec<Option<Camera>>) {
        self.lenses = lenses;
    }

    /// The camera view `v`'s hands are read through, for a frame of `size`.
    pub fn lens(&self, v: usize, size: (u32, u32)) -> Option<Camera> {
        let cam = self.lenses.get(v).copied().flatten()?;
        let k = &cam.intrinsics;
        if (k.width, k.height) == size {
            Some(cam)
        } else {
            cam.scaled_to(size.0, size.1).ok()
        }
    }

    /// Whether frames are tracked (video) rather than detected each on its own.
    pub fn is_tracking(&self) -> bool {
        self.tracking
    }

    /// Wraps the detections of an independent image of one view, made elsewhere (for
    /// example on a thread pool): every hand gets a new id.
    pub fn assign(
        &mut self,
        index: u64,
        time_s: f64,
        detections: Result<Detections, ViewError>,
        vision_ms: f64,
    ) -> VisionFrame {
        let view = detections.map(|d| {
            let ids = (0..d.hands.len() as u64)
                .map(|k| self.next_id + k)
                .collect();
            self.next_id += d.hands.len() as u64;
            ViewHands { detections: d, ids }
        });
        VisionFrame {
            index,
            time_s,
            views: vec![view],
            vision_ms,
            focal: StatedCamera::None,
        }
    }

    /// Runs the networks on one frame of every view; `images[v]` is view `v`'s frame, or
    /// why it could not be read (which breaks that view's tracking).
    pub fn process(
        &mut self,
        index: u64,
        time_s: f64,
        images: &[Result<&RgbImage, crate::engine::SourceError>],
    ) -> VisionFrame {
        let t = Instant::now();
        let mut out = Vec::with_capacity(images.len());
        let max_hands = self.pipeline.options.max_hands;
        if self.views.len() < images.len() {
            self.views.resize_with(images.len(), ViewTracks::default);
        }
        for (v, image) in images.iter().enumerate() {
            let lens = match image {
                Ok(i) => self.lens(v, i.dimensions()),
                Err(_) => None,
            };
            let state = &mut self.views[v];
            let image = match image {
                Ok(i) => *i,
                Err(e) => {
                    state.previous.clear();
                    state.ids.clear();
                    out.push(Err(ViewError::Unreadable(e.clone())));
                    continue;
                }
            };
            let result = if self.tracking {
                let detect_new = state.previous.is_empty()
                    || (state.previous.len() < max_hands
                        && state.frames_since_detection + 1 >= self.detect_every);
                self.pipeline
                    .track_through(image, lens.as_ref(), &state.previous, detect_new)
                    .map(|(d, origin)| (d, origin, detect_new))
            } else {
                self.pipeline
                    .detect_through(image, lens.as_ref())
                    .map(|d| (d, Vec::new(), true))
            };
            match result {
                Ok((detections, origin, detected)) => {
                    let ids: Vec<HandId> = (0..detections.hands.len())
                        .map(|h| {
                            match origin
                                .get(h)
                                .copied()
                                .flatten()
                                .and_then(|prev| state.ids.get(prev))
                            {
                                Some(&id) => id,
                                None => {
                                    self.next_id += 1;
                                    self.next_id - 1
                                }
                            }
                        })
                        .collect();
                    state.frames_since_detection = if detected {
                        0
                    } else {
                        state.frames_since_detection + 1
                    };
                    if self.tracking {
                        state.previous.clone_from(&detections.hands);
                        state.ids.clone_from(&ids);
                    }
                    out.push(Ok(ViewHands { detections, ids }));
                }
                Err(e) => {
                    state.previous.clear();
                    state.ids.clear();
                    out.push(Err(ViewError::from(e)));
                }
            }
        }
        VisionFrame {
            index,
            time_s,
            views: out,
            vision_ms: t.elapsed().as_secs_f64() * 1e3,
            focal: StatedCamera::None,
        }
    }
}
