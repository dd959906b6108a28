//! The session: frames of one or several cameras in, tracked absolute 3D hands out.

use crate::base::camera::StatedCamera;
use crate::base::frame::FittedFrame;
use crate::settings::Settings;
use crate::stages::crops::CropTracker;
use crate::stages::fitter::HandsFitter;
use crate::{SessionError, SessionResult};
use monohand_core::filtering::OneEuroParams;
use monohand_core::prelude::*;
use monohand_vision::{HandPipeline, ModelOptions, RgbImage};
use std::path::PathBuf;
use std::sync::Arc;

/// Settings of a [`Session`], built with chained setters from [`SessionOptions::default`]:
/// which weights, and the plain [`Settings`] (resolved by the session).
#[derive(Debug, Clone, Default)]
pub struct SessionOptions {
    /// Which weights, from where (fetched with pip on first use).
    pub models: ModelOptions,
    /// The networks' thresholds, the 3D stage and the detection cadence; defaults: video
    /// tracking of up to 2 hands with the default adult hand.
    pub settings: Settings,
}

impl SessionOptions {
    /// The most hands per frame.
    pub fn hands(mut self, n: usize) -> Self {
        self.settings.pipeline.max_hands = n;
        self
    }

    /// Track over a video (default) or treat every frame on its own.
    pub fn tracking(mut self, on: bool) -> Self {
        self.settings.fit.tracking = on;
        self
    }

    /// While tracking, look for new hands every `n` frames (default 10).
    pub fn detect_every(mut self, n: usize) -> Self {
        self.settings.detect_every = n;
        self
    }

    /// Where the weights are cached (default: `$MONOHAND_MODEL_DIR`, else the user cache).
    pub fn model_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.models.model_dir = Some(dir.into());
        self
    }

    /// The fitter's settings.
    pub fn fit_options(mut self, options: FitOptions) -> Self {
        self.settings.fit.options = options;
        self
    }

    /// The hand models, left then right (default: the average adult hand).
    pub fn skeletons(mut self, skeletons: [HandSkeleton; 2]) -> Self {
        self.settings.fit.skeletons = skeletons;
        self
    }

    /// Smooth the 3D joints over time with a One Euro filter (needs tracking).
    pub fn smoothing(mut self, params: Option<OneEuroParams>) -> Self {
        self.settings.fit.smoothing = params;
        self
    }

    /// Whether the landmark network also reads each crop's mirror image, averaged in (on by
    /// default; see [`monohand_vision::landmarks::LandmarkOptions::mirror_pass`]).
    pub fn mirror_pass(mut self, on: bool) -> Self {
        self.settings.pipeline.landmarks.mirror_pass = on;
        self
    }

    /// The arithmetic of the palm and landmark networks (f32 by default; see
    /// [`monohand_vision::PipelineOptions::precision`]).
    pub fn precision(mut self, precision: monohand_vision::Precision) -> Self {
        self.settings.pipeline.precision = precision;
        self
    }

    /// Also report heads (the paper's context for left and right; about 3 ms per frame).
    pub fn heads(mut self, on: bool) -> Self {
        self.models.detect_heads = on;
        self
    }
}

/// Frames in, tracked absolute 3D hands out, on the calling thread.
///
/// One [`Session::process`] call per frame, with one image per camera (in the cameras'
/// order) and the frame's time. The networks find and track the hands, and each hand gets
/// an identity, a side voted over its frames and its fitted 3D in millimetres in the first
/// camera's frame. (`monohand run` runs the same two stages, [`CropTracker`] and
/// [`HandsFitter`], on threads of their own.)
///
/// ```no_run
/// use monohand::prelude::*;
/// use monohand::{Session, SessionOptions};
///
/// let camera = Camera::generic(1280, 720)?;
/// let mut session = Session::new(vec![camera], SessionOptions::default())?;
/// let frame = monohand::RgbImage::new(1280, 720); // a decoded video frame
/// for done in session.process(&[&frame], 0.0)? {
///     for hand in &done.hands {
///         if let Some(fit) = &hand.fit {
///             println!("hand {} ({:?}): wrist at {:?} mm", hand.id, hand.side, fit.joints_3d[0]);
///         }
///     }
/// }
/// # Ok::<(), monohand::SessionError>(())
/// ```
pub struct Session {
    crops: CropTracker,
    fitter: HandsFitter<()>,
    views: usize,
    next_index: u64,
}

impl Session {
    /// A session for these cameras (one per view; none: one view with a generic camera for
    /// the image size). Loads the networks, fetching the weights with pip if they are not
    /// cached yet.
    pub fn new(cameras: Vec<Camera>, options: SessionOptions) -> SessionResult<Session> {
        let pipeline = Session::load_pipeline(&options)?;
        Session::with_pipeline(cameras, Arc::new(pipeline), options)
    }

    /// The networks `options` ask for, loaded (fetching the weights with pip if they are
    /// not cached yet), with the options of the resolved settings ([`Settings::resolve`]:
    /// no refine pass when tracking, one for independent images).
    pub fn load_pipeline(options: &SessionOptions) -> SessionResult<HandPipeline> {
        let resolved = options.settings.clone().resolve()?;
        Ok(HandPipeline::new(&options.models, resolved.pipeline())?)
    }

    /// A session over networks already loaded (they can be shared between sessions).
    /// Refused ([`SessionError::Settings`]) when the networks do not run as `options` ask
    /// ([`crate::ResolvedSettings::check_pipeline`]: tracking or not, the most hands, the mirror
    /// pass, heads); which weights they were loaded from is theirs.
    pub fn with_pipeline(
        cameras: Vec<Camera>,
        pipeline: Arc<HandPipeline>,
        options: SessionOptions,
    ) -> SessionResult<Session> {
        let resolved = options.settings.resolve()?;
        resolved.check_pipeline(&pipeline, Some(options.models.detect_heads))?;
        let views = cameras.len().max(1);
        Ok(Session {
            crops: CropTracker::new(pipeline, views, resolved.crops(&cameras)),
            fitter: HandsFitter::new(cameras, *resolved.fit())?,
            views,
            next_index: 0,
        })
    }

    /// Processes one frame: `images[v]` is camera `v`'s image. Returns the frames now
    /// done: this one, except while the first frames are kept back to measure the hand size
    /// ([`crate::FitSettings::auto_scale_frames`]); call [`Session::finish`] at the end.
    pub fn process(
        &mut self,
        images: &[&RgbImage],
        time_s: f64,
    ) -> SessionResult<Vec<FittedFrame>> {
        self.process_with_focal(images, time_s, StatedCamera::None)
    }

    /// [`Session::process`] for one photo read with
    /// [`load_photo`](monohand_vision::image_io::load_photo): when the session has no
    /// calibrated camera, the focal length the photo's EXIF states gives its camera
    /// (said once in [`Session::take_notes`]) instead of the generic 60 degree guess.
    pub fn process_photo(
        &mut self,
        photo: &monohand_vision::image_io::Photo,
        time_s: f64,
    ) -> SessionResult<Vec<FittedFrame>> {
        self.process_with_focal(&[&photo.image], time_s, photo.focal.clone().into())
    }

    fn process_with_focal(
        &mut self,
        images: &[&RgbImage],
        time_s: f64,
        focal: StatedCamera,
    ) -> SessionResult<Vec<FittedFrame>> {
        if images.len() != self.views {
            return Err(SessionError::Views {
                images: images.len(),
                cameras: self.views,
            });
        }
        if !time_s.is_finite() {
            return Err(SessionError::FrameTime(time_s));
        }
        let images: Vec<Result<&RgbImage, crate::base::errors::SourceError>> =
            images.iter().map(|&i| Ok(i)).collect();
        let mut frame = self.crops.process(self.next_index, time_s, &images);
        frame.focal = focal;
        self.next_index += 1;
        let done = self.fitter.push(frame, ());
        if self.crops.is_guided() {
            self.crops.guide(self.fitter.guides());
        }
        Ok(done.into_iter().map(|(f, ())| f).collect())
    }

    /// The frames still kept back, at the end of the input.
    pub fn finish(&mut self) -> Vec<FittedFrame> {
        self.fitter.flush().into_iter().map(|(f, ())| f).collect()
    }

    /// Messages for the user since the last call (assumptions made, hand size found).
    pub fn take_notes(&mut self) -> Vec<String> {
        self.fitter
            .take_notes()
            .into_iter()
            .map(|n| n.message)
            .collect()
    }

    /// The cameras in use (a generic one, once the first image told its size, if none was
    /// given).
    pub fn cameras(&self) -> &[Camera] {
        self.fitter.cameras()
    }
}
