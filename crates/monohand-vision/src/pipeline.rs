//! The whole front end: hand regions → 21 keypoints per hand (+ head boxes), behind two traits
//! so the pipeline does not care which networks run.
//!
//! Output coordinates follow the OpenCV/OpenPose convention: the centre of the top-left pixel
//! is `(0, 0)`, so keypoints compare directly with projections `K·X` of 3D points.
//!
//! ## Handedness
//! The landmark model's handedness output is the probability of MediaPipe's label index 0,
//! "Left", and MediaPipe labels assume mirrored (selfie) images. For an ordinary, unmirrored
//! photo the output is therefore the probability of a physical *right* hand — checked on the
//! STB frame (a left hand, output 0.095) and on photos with known sides. [`HandSide`] here is
//! the physical hand in the image as given, unless [`PipelineOptions::mirrored_input`] says the
//! images are selfie-mirrored.

use std::path::{Path, PathBuf};

use image::RgbImage;
use monohand_core::bbox::BBox;
use monohand_core::camera::Camera;
use monohand_core::hand_model::HandSide;
use monohand_core::observation::{HandObservation, Keypoints2d, NetworkCues};

use crate::error::Result;
use crate::face::{FaceDetector, HeadDetection};
use crate::geometry::{from_pixel_centres, normalize_angle, to_pixel_centres, RotatedRect};
use crate::landmarks::{HandLandmarks, LandmarkModel, LandmarkOptions, NUM_LANDMARKS};
use crate::models::{ModelFile, ModelStore};
use crate::network::TfliteNet;
use crate::palm::{PalmDetector, PalmOptions};
use crate::rectify::RectifiedView;

/// A region of the image believed to contain one hand, in image pixels (continuous
/// coordinates, see [`crate::geometry`]), as produced by a [`HandDetector`].
#[derive(Clone, Debug, PartialEq)]
pub struct HandRegion {
    /// Detector score in `[0, 1]`.
    pub score: f32,
    /// Square, rotated crop with the fingers pointing up in the crop.
    pub roi: RotatedRect,
}

/// Finds hand regions in an image.
pub trait HandDetector: Send + Sync {
    /// Hand regions, best first.
    fn detect_hands(&self, img: &RgbImage) -> Result<Vec<HandRegion>>;
}

// What a [`KeypointEstimator`] gives: defined below the pipeline (keypoints.rs), where the
// rectified views, which map keypoints back into the image, may use it too.
pub use crate::keypoints::HandKeypoints;

/// Estimates 21 keypoints for a hand region.
pub trait KeypointEstimator: Send + Sync {
    /// Keypoints for `region` of `img`. `side_hint` is the side a previous stage believes
    /// in, used by one-sided networks to decide whether to mirror the crop.
    fn estimate(
        &self,
        img: &RgbImage,
        region: &HandRegion,
        side_hint: Option<HandSide>,
    ) -> Result<HandKeypoints>;

    /// Keypoints for a region predicted from the previous frame's keypoints (video
    /// tracking): such a region is already tight, so estimators that re-crop around their own
    /// first answer may skip that. The default is [`KeypointEstimator::estimate`].
    fn estimate_tracked(
        &self,
        img: &RgbImage,
        region: &HandRegion,
        side_hint: Option<HandSide>,
    ) -> Result<HandKeypoints> {
        self.estimate(img, region, side_hint)
    }
}

impl HandDetector for PalmDetector {
    fn detect_hands(&self, img: &RgbImage) -> Result<Vec<HandRegion>> {
        Ok(self
            .detect(img)?
            .into_iter()
            .map(|p| HandRegion {
                score: p.score,
                roi: p.hand_roi(),
            })
            .collect())
    }
}

/// MediaPipe's landmark model as a [`KeypointEstimator`] (the side is read from its
/// handedness head assuming unmirrored input; use [`MediaPipeKeypoints`] to choose).
impl KeypointEstimator for LandmarkModel {
    fn estimate(
        &self,
        img: &RgbImage,
        region: &HandRegion,
        _hint: Option<HandSide>,
    ) -> Result<HandKeypoints> {
        MediaPipeKeypoints {
            model: self.clone(),
            mirrored_input: false,
            refine_passes: 0,
        }
        .estimate(img, region, None)
    }
}

/// MediaPipe's landmark model with the pipeline's handedness convention and optional
/// re-cropping from its own landmarks.
#[derive(Debug, Clone)]
pub struct MediaPipeKeypoints {
    /// The network.
    pub model: LandmarkModel,
    /// Whether images are selfie-mirrored (MediaPipe's own convention).
    pub mirrored_input: bool,
    /// Extra passes that re-crop around the previous pass's landmarks (MediaPipe's tracking
    /// ROI: scale 2.0, shift −0.1) before the final estimate.
    pub refine_passes: usize,
}

impl MediaPipeKeypoints {
    /// Landmarks of the final pass (with the crop they were read from).
    pub fn landmarks(&self, img: &RgbImage, roi: &RotatedRect) -> Result<HandLandmarks> {
        let mut lm = self.model.estimate(img, roi)?;
        for _ in 0..self.refine_passes {
            lm = self.model.estimate(img, &roi_from_landmarks(&lm.image))?;
        }
        Ok(lm)
    }
}

impl MediaPipeKeypoints {
    fn keypoints(&self, lm: HandLandmarks) -> HandKeypoints {
        let mut points = [[0.0; 3]; NUM_LANDMARKS];
        for (p, (q, c)) in points.iter_mut().zip(lm.image.iter().zip(&lm.confidence)) {
            *p = [q[0], q[1], *c];
        }
        // P(MediaPipe label "Left") = P(physical right hand) in an unmirrored image.
        let p_label_left = lm.handedness_raw.clamp(0.0, 1.0);
        let (p_right, p_left) = if self.mirrored_input {
            (1.0 - p_label_left, p_label_left)
        } else {
            (p_label_left, 1.0 - p_label_left)
        };
        let side = if p_right >= p_left {
            (HandSide::Right, p_right)
        } else {
            (HandSide::Left, p_left)
        };
        HandKeypoints {
            points,
            presence: lm.presence,
            side: Some(side),
            cues: Some(NetworkCues {
                world_mm: Some(lm.world.map(|w| w.map(|v| v * 1000.0))),
                depth_px: Some(lm.image.map(|p| p[2])),
            }),
        }
    }
}

impl KeypointEstimator for MediaPipeKeypoints {
    fn estimate(
        &self,
        img: &RgbImage,
        region: &HandRegion,
        _hint: Option<HandSide>,
    ) -> Result<HandKeypoints> {
        Ok(self.keypoints(self.landmarks(img, &region.roi)?))
    }

    fn estimate_tracked(
        &self,
        img: &RgbImage,
        region: &HandRegion,
        _hint: Option<HandSide>,
    ) -> Result<HandKeypoints> {
        Ok(self.keypoints(self.model.estimate(img, &region.roi)?))
    }
}

/// MediaPipe's `HandLandmarksToRectCalculator` + its `RectTransformation` (scale 2, shift
/// −0.1): the region a landmark set suggests for the next crop. As in MediaPipe's graph
/// (`hand_landmark_landmarks_to_roi.pbtxt`) the calculator sees the partial list
/// `[0, 1, 2, 3, 5, 6, 9, 10, 13, 14, 17, 18]`: the rotation runs from the wrist to the
/// mean of the middle MCP and the midpoint of the index and ring MCPs, and the box bounds
/// that list.
pub fn roi_from_landmarks(lm: &[[f64; 3]; NUM_LANDMARKS]) -> RotatedRect {
    const PARTIAL: [usize; 12] = [0, 1, 2, 3, 5, 6, 9, 10, 13, 14, 17, 18];
    let [x0, y0] = [lm[0][0], lm[0][1]];
    let mid = |a: usize, b: usize| [(lm[a][0] + lm[b][0]) / 2.0, (lm[a][1] + lm[b][1]) / 2.0];
    // MediaPipe reads its joints 4, 8 and 6 of the partial list: the index, ring and middle
    // MCP joints (5, 13, 9), whatever the calculator's constants are named.
    let ir = mid(5, 13);
    let (x1, y1) = ((ir[0] + lm[9][0]) / 2.0, (ir[1] + lm[9][1]) / 2.0);
    let rotation = normalize_angle(std::f64::consts::FRAC_PI_2 - (-(y1 - y0)).atan2(x1 - x0));
    let (s, c) = rotation.sin_cos();
    // Bounds in the frame rotated by −rotation.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &j in &PARTIAL {
        let (x, y) = (lm[j][0], lm[j][1]);
        let r = [c * x + s * y, -s * x + c * y];
        for k in 0..2 {
            lo[k] = lo[k].min(r[k]);
            hi[k] = hi[k].max(r[k]);
        }
    }
    let (rc_x, rc_y) = ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0);
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    let mut center = [c * rc_x - s * rc_y, s * rc_x + c * rc_y];
    let shift_y = -0.1;
    center[0] -= h * shift_y * s;
    center[1] += h * shift_y * c;
    let side = w.max(h) * 2.0;
    RotatedRect {
        center,
        width: side,
        height: side,
        rotation,
    }
}

/// Which variant of a MediaPipe network to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ModelVariant {
    /// The larger, more accurate network (default).
    #[default]
    Full,
    /// The smaller, faster network.
    Lite,
}

/// Which weights to load and from where.
#[derive(Clone, Debug, Default)]
pub struct ModelOptions {
    /// Cache directory (default: see [`crate::models`]).
    pub model_dir: Option<PathBuf>,
    /// Palm detector variant.
    pub palm: ModelVariant,
    /// Landmark model variant.
    pub landmark: ModelVariant,
    /// Whether to load the face detector and report head boxes.
    pub detect_heads: bool,
}

impl ModelVariant {
    /// The palm detector's file of this variant.
    pub fn palm_file(self) -> ModelFile {
        match self {
            ModelVariant::Full => ModelFile::PalmDetectionFull,
            ModelVariant::Lite => ModelFile::PalmDetectionLite,
        }
    }

    /// The landmark network's file of this variant.
    pub fn landmark_file(self) -> ModelFile {
        match self {
            ModelVariant::Full => ModelFile::HandLandmarkFull,
            ModelVariant::Lite => ModelFile::HandLandmarkLite,
        }
    }
}

impl ModelOptions {
    /// What these networks are, for a report: MediaPipe's release, the two networks' sizes,
    /// whether each crop's mirror image is averaged in, and the precision (`options`).
    pub fn describe(&self, options: &PipelineOptions) -> String {
        format!(
            "MediaPipe 0.10.14 palm detector ({:?}) + hand landmarks ({:?}{}) in tract, {}",
            self.palm,
            self.landmark,
            if options.landmarks.mirror_pass {
                ", mean of each crop and its mirror image"
            } else {
                ", one pass per crop"
            },
            options.precision
        )
    }
}

/// Thresholds and behaviour of the pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineOptions {
    /// Palm detector thresholds.
    pub palm: PalmOptions,
    /// Landmark stage options.
    pub landmarks: LandmarkOptions,
    /// Hands whose presence score is below this are dropped (MediaPipe: 0.5).
    pub min_presence: f32,
    /// At most this many hands per image, best detection scores first.
    pub max_hands: usize,
    /// Two hands whose keypoint boxes overlap by more than this IoU are one hand.
    pub duplicate_iou: f64,
    /// Re-crop passes of the landmark model around its own landmarks (0 = MediaPipe's single
    /// pass on the palm-derived crop).
    pub refine_passes: usize,
    /// Whether images are selfie-mirrored (affects the reported side only).
    pub mirrored_input: bool,
    /// The arithmetic of the palm and landmark networks' quantizable layers: f32 (the
    /// default), or int8 with monohand's shipped calibration ([`crate::int8`]). The face
    /// detector always runs in f32.
    pub precision: crate::Precision,
}

impl Default for PipelineOptions {
    fn default() -> Self {
        PipelineOptions {
            palm: PalmOptions::default(),
            landmarks: LandmarkOptions::default(),
            min_presence: 0.5,
            max_hands: 16,
            duplicate_iou: 0.5,
            refine_passes: 1,
            mirrored_input: false,
            precision: crate::Precision::F32,
        }
    }
}

impl PipelineOptions {
    /// Checks the thresholds: at least one hand, a presence threshold in `[0, 1]`, a
    /// duplicate IoU in `[0, 1]`.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(crate::VisionError::Options(m));
        if self.max_hands == 0 {
            return bad("at least one hand per image".into());
        }
        if !(0.0..=1.0).contains(&self.min_presence) {
            return bad(format!(
                "min_presence {} must be in [0, 1]",
                self.min_presence
            ));
        }
        if !(0.0..=1.0).contains(&self.duplicate_iou) {
            return bad(format!(
                "duplicate_iou {} must be in [0, 1]",
                self.duplicate_iou
            ));
        }
        Ok(())
    }
}

/// Where a hand already known is looked for: its 21 keypoints `[u, v]` in the image
/// (pixel centres at integers, as [`DetectedHand::keypoints`]), from which the landmark
/// network's crop is made as from a tracked hand's ([`roi_from_landmarks`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CropSeed {
    /// The keypoints, MediaPipe/OpenPose order.
    pub points: [[f64; 2]; NUM_LANDMARKS],
    /// The detector score the hand found there carries.
    pub score: f32,
}

impl CropSeed {
    /// The seed of a hand found in the previous frame: its keypoints and score.
    pub fn from_hand(hand: &DetectedHand) -> CropSeed {
        CropSeed {
            points: hand.keypoints.points.map(|p| [p[0], p[1]]),
            score: hand.detection_score,
        }
    }
}

/// One hand found in an image (pixel-centre coordinates, see the module docs).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DetectedHand {
    /// Oriented box around the keypoints (10 % margin), turned like the hand (its "up" axis
    /// runs from the wrist towards the fingers).
    pub oriented_box: RotatedRect,
    /// The crop the keypoints were read from.
    pub roi: RotatedRect,
    /// Hand detector score.
    pub detection_score: f32,
    /// Keypoint network's hand-presence probability.
    pub presence: f32,
    /// Physical side of the hand.
    pub side: HandSide,
    /// Probability of [`Self::side`].
    pub side_score: f32,
    /// 21 keypoints `[u, v, confidence]`, MediaPipe/OpenPose order.
    pub keypoints: Keypoints2d,
    /// The network's relative 3D when it gives it (MediaPipe: metric landmarks in mm and
    /// relative depth in image pixels, both in the image's axes).
    pub cues: Option<NetworkCues>,
}

impl DetectedHand {
    /// What the 3D fitter of `monohand-core` consumes: side and keypoints.
    pub fn observation(&self) -> HandObservation {
        HandObservation {
            side: self.side,
            keypoints: self.keypoints,
            cues: self.cues,
        }
    }
}

/// One head (pixel-centre coordinates).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DetectedHead {
    /// Face detector score.
    pub score: f32,
    /// Head box.
    pub head_box: BBox,
    /// Face box.
    pub face_box: BBox,
}

/// Everything found in one image.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Detections {
    /// Image width and height in pixels (after EXIF orientation).
    pub image_size: (u32, u32),
    /// Hands, best detection first.
    pub hands: Vec<DetectedHand>,
    /// Heads (empty unless the face detector is loaded).
    pub heads: Vec<DetectedHead>,
    /// The arithmetic the palm and landmark networks ran in
    /// ([`PipelineOptions::precision`]).
    #[serde(serialize_with = "precision_name")]
    pub precision: crate::Precision,
}

fn precision_name<S: serde::Serializer>(p: &crate::Precision, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(p.name())
}

/// Hand (and head) detection with 21 keypoints per hand.
pub struct HandPipeline {
    detector: Box<dyn HandDetector>,
    estimator: Box<dyn KeypointEstimator>,
    /// For custom keypoint estimators: MediaPipe's landmark model, run first on each region
    /// for the hand's side (to mirror one-sided networks) and its presence score.
    side_source: Option<MediaPipeKeypoints>,
    face: Option<FaceDetector>,
    /// Whether independent network passes of one frame run side by side (see
    /// [`HandPipeline::set_parallel`]).
    parallel: bool,
    /// Options.
    pub options: PipelineOptions,
}

impl std::fmt::Debug for HandPipeline {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HandPipeline")
            .field("heads", &self.face.is_some())
            .field("options", &self.options)
            .finish()
    }
}

fn load_net(store: &ModelStore, file: ModelFile, precision: crate::Precision) -> Result<TfliteNet> {
    let bytes = store.load(file)?;
    TfliteNet::from_bytes_in(&bytes, &store.path_of(file), Default::default(), precision)
}

/// The weights of a pipeline's networks as bytes, each with the name it is known by in
/// errors: read from the cache by [`HandPipeline::new`], or handed in by a caller without
/// a file system (the browser, `monohand-web`). The caller checks them against the pinned
/// checksums first ([`ModelFile::check`], or [`ModelFile::sha256`] to tell which file
/// they are).
#[derive(Debug, Clone, Copy)]
pub struct NetworkBytes<'a> {
    /// The palm detector's `.tflite` file.
    pub palm: (&'a [u8], &'a Path),
    /// The landmark network's `.tflite` file.
    pub landmark: (&'a [u8], &'a Path),
    /// The face detector's `.tflite` file, when heads are wanted.
    pub face: Option<(&'a [u8], &'a Path)>,
}

impl HandPipeline {
    /// MediaPipe's palm detector + landmark model (+ BlazeFace when `models.detect_heads`),
    /// fetching the weights on first use.
    pub fn new(models: &ModelOptions, options: PipelineOptions) -> Result<Self> {
        options.validate()?;
        let store = ModelStore::new(models.model_dir.clone())?;
        let load = |file: ModelFile| -> Result<(Vec<u8>, PathBuf)> {
            Ok((store.load(file)?, store.path_of(file)))
        };
        let palm = load(models.palm.palm_file())?;
        let landmark = load(models.landmark.landmark_file())?;
        let face = if models.detect_heads {
            Some(load(ModelFile::FaceDetectionShortRange)?)
        } else {
            None
        };
        HandPipeline::from_bytes(
            NetworkBytes {
                palm: (&palm.0, &palm.1),
                landmark: (&landmark.0, &landmark.1),
                face: face.as_ref().map(|(b, p)| (b.as_slice(), p.as_path())),
            },
            options,
        )
    }

    /// MediaPipe's palm detector + landmark model (+ BlazeFace when `nets.face` is given)
    /// from the networks' bytes: what [`HandPipeline::new`] builds once it has read them.
    pub fn from_bytes(nets: NetworkBytes<'_>, options: PipelineOptions) -> Result<Self> {
        let net = |(bytes, origin): (&[u8], &Path)| {
            TfliteNet::from_bytes_in(bytes, origin, Default::default(), options.precision)
        };
        let face = match nets.face {
            Some((bytes, origin)) => Some(TfliteNet::from_bytes(bytes, origin)?),
            None => None,
        };
        HandPipeline::from_networks(net(nets.palm)?, net(nets.landmark)?, face, options)
    }

    /// MediaPipe's palm detector, landmark model and (when given) BlazeFace from networks
    /// already imported: what [`HandPipeline::from_bytes`] builds once it has them (the
    /// options are checked here).
    pub(crate) fn from_networks(
        palm: TfliteNet,
        landmark: TfliteNet,
        face: Option<TfliteNet>,
        options: PipelineOptions,
    ) -> Result<Self> {
        options.validate()?;
        let detector = PalmDetector::new(palm, options.palm)?;
        let model = LandmarkModel::new(landmark, options.landmarks)?;
        let estimator = MediaPipeKeypoints {
            model,
            mirrored_input: options.mirrored_input,
            refine_passes: options.refine_passes,
        };
        let face = match face {
            Some(net) => Some(FaceDetector::new(net)?),
            None => None,
        };
        Ok(HandPipeline {
            detector: Box::new(detector),
            estimator: Box::new(estimator),
            side_source: None,
            face,
            parallel: true,
            options,
        })
    }

    /// MediaPipe's palm detector (+ BlazeFace) with another keypoint network, e.g.
    /// [`crate::heatmap::OnnxHeatmapEstimator`]. MediaPipe's landmark model still runs once per
    /// region to tell the hand's side (so one-sided networks get mirrored crops) and whether a
    /// hand is present; the keypoints are the custom estimator's.
    pub fn with_keypoint_estimator(
        models: &ModelOptions,
        options: PipelineOptions,
        estimator: Box<dyn KeypointEstimator>,
    ) -> Result<Self> {
        let mut p = HandPipeline::new(models, options)?;
        let store = ModelStore::new(models.model_dir.clone())?;
        let model = LandmarkModel::new(
            load_net(&store, models.landmark.landmark_file(), options.precision)?,
            options.landmarks,
        )?;
        p.side_source = Some(MediaPipeKeypoints {
            model,
            mirrored_input: options.mirrored_input,
            refine_passes: 0,
        });
        p.estimator = estimator;
        Ok(p)
    }

    /// A pipeline from any detector and keypoint estimator (e.g. an ONNX heatmap model).
    pub fn with_components(
        detector: Box<dyn HandDetector>,
        estimator: Box<dyn KeypointEstimator>,
        face: Option<FaceDetector>,
        options: PipelineOptions,
    ) -> Self {
        HandPipeline {
            detector,
            estimator,
            side_source: None,
            face,
            parallel: true,
            options,
        }
    }

    /// Whether it detects heads (it has a face detector).
    pub fn detects_heads(&self) -> bool {
        self.face.is_some()
    }

    /// Whether the network passes of one frame that do not depend on each other (the
    /// landmark passes of tracked hands, the palm and face detectors) run side by side on
    /// rayon's threads (the default) or one after the other. The results are the same. The
    /// two passes of the mirror pass ([`LandmarkOptions::mirror_pass`]) are always given
    /// to rayon together; rayon's pool (`RAYON_NUM_THREADS=1`) limits them.
    pub fn set_parallel(&mut self, parallel: bool) {
        self.parallel = parallel;
    }

    /// See [`HandPipeline::set_parallel`].
    pub fn parallel(&self) -> bool {
        self.parallel
    }

    /// Reads an image file (EXIF orientation applied) and detects in it.
    pub fn detect_file(&self, path: &Path) -> Result<Detections> {
        let img = crate::image_io::load_rgb(path)?;
        self.detect(&img)
    }

    /// Hands and heads in an RGB image.
    pub fn detect(&self, img: &RgbImage) -> Result<Detections> {
        self.detect_through(img, None)
    }

    /// [`Self::detect`] for an image of a known camera: with `lens`, each hand is read in
    /// its rectified view ([`Self::track_through`]).
    pub fn detect_through(&self, img: &RgbImage, lens: Option<&Camera>) -> Result<Detections> {
        Ok(self.track_through(img, lens, &[], true)?.0)
    }

    /// Video tracking, as MediaPipe does it: each hand of the previous frame is looked for
    /// again in the crop its keypoints predict (one landmark inference, no detector), and the
    /// palm detector runs only when `detect_new` is set (on the first frame, when a hand was
    /// lost, or every N frames for new hands), and so does the head detector. Returns the
    /// detections and, per hand, the index
    /// in `previous` it continues (`None` for a new detection). A tracked hand whose presence
    /// falls below [`PipelineOptions::min_presence`] is dropped (lost).
    pub fn track(
        &self,
        img: &RgbImage,
        previous: &[DetectedHand],
        detect_new: bool,
    ) -> Result<(Detections, Vec<Option<usize>>)> {
        self.track_through(img, None, previous, detect_new)
    }

    /// [`Self::track`] for frames of a known camera: with `lens`, each hand's crop is the
    /// view of a virtual pinhole camera aimed at it ([`crate::rectify`]), so that the
    /// landmark network sees an undistorted, perspective-correct hand anywhere in a wide or
    /// fisheye frame; its keypoints map back into the image through the same camera.
    pub fn track_through(
        &self,
        img: &RgbImage,
        lens: Option<&Camera>,
        previous: &[DetectedHand],
        detect_new: bool,
    ) -> Result<(Detections, Vec<Option<usize>>)> {
        let seeds: Vec<CropSeed> = previous.iter().map(CropSeed::from_hand).collect();
        self.track_seeds(img, lens, &seeds, detect_new)
    }

    /// [`Self::track_through`] from seeds: each hand already known is looked for in the crop
    /// its seed's keypoints predict (a previous frame's keypoints, or a hand fitted in 3D and
    /// projected into this view), the palm detector running only when `detect_new` is set.
    /// Returns the detections and, per hand, the index of the seed it continues (`None` for
    /// a new detection). A seed with a non-finite keypoint is skipped.
    pub fn track_seeds(
        &self,
        img: &RgbImage,
        lens: Option<&Camera>,
        seeds: &[CropSeed],
        detect_new: bool,
    ) -> Result<(Detections, Vec<Option<usize>>)> {
        // The crop each seed's keypoints predict.
        let tracked: Vec<(usize, HandRegion)> = seeds
            .iter()
            .enumerate()
            .filter_map(|(i, seed)| {
                let mut lm = [[0.0; 3]; NUM_LANDMARKS];
                for (dst, p) in lm.iter_mut().zip(&seed.points) {
                    let [u, v] = from_pixel_centres(*p);
                    *dst = [u, v, 0.0];
                }
                if lm.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
                    return None;
                }
                let region = HandRegion {
                    score: seed.score,
                    roi: roi_from_landmarks(&lm),
                };
                Some((i, region))
            })
            .collect();
        // The networks that do not depend on each other run side by side: the landmark
        // passes of the tracked hands (as many as may be kept), and the palm and face
        // detectors when they run. What is kept is then decided in order, exactly as one
        // pass after the other would.
        let ahead = tracked.len().min(self.options.max_hands);
        let face = self.face.as_ref().filter(|_| detect_new);
        let (mut tracked_kp, (regions, faces)) = self.side_by_side(
            &tracked[..ahead],
            img,
            lens,
            detect_new.then_some(self.detector.as_ref()),
            face,
        );
        let mut hands: Vec<DetectedHand> = Vec::new();
        let mut origin: Vec<Option<usize>> = Vec::new();
        for (k, (i, region)) in tracked.iter().enumerate() {
            if hands.len() >= self.options.max_hands {
                break;
            }
            let kp = match tracked_kp.get_mut(k).and_then(Option::take) {
                Some(kp) => kp?,
                // Beyond the passes run ahead (earlier hands were dropped): run it now.
                None => self.estimate_keypoints(img, lens, region, true)?,
            };
            if let Some(hand) = self.accept(region, kp, &hands) {
                hands.push(hand);
                origin.push(Some(*i));
            }
        }
        if let Some(regions) = regions {
            let mut regions = regions?;
            regions.sort_by(|a, b| b.score.total_cmp(&a.score));
            for region in regions {
                if hands.len() >= self.options.max_hands {
                    break;
                }
                // A palm inside a hand already found is that hand: skip the landmark
                // inference (MediaPipe drops such detections the same way).
                let centre = to_pixel_centres(region.roi.center);
                if hands.iter().any(|h| h.keypoints.bounds().contains(centre)) {
                    continue;
                }
                if let Some(hand) = self.estimate_region(img, lens, &region, false, &hands)? {
                    hands.push(hand);
                    origin.push(None);
                }
            }
        }
        // A face detection lying mostly on a detected hand is a palm seen as a face. Heads
        // are context for new hands, so they are looked for when the detector runs.
        let heads = match faces {
            Some(found) => found?
                .into_iter()
                .map(to_head)
                .filter(|h| {
                    !hands
                        .iter()
                        .any(|hand| h.face_box.fraction_covered_by(&hand.keypoints.bounds()) > 0.7)
                })
                .collect(),
            _ => Vec::new(),
        };
        let detections = Detections {
            image_size: img.dimensions(),
            hands,
            heads,
            precision: self.options.precision,
        };
        Ok((detections, origin))
    }

    /// The tracked hands' keypoints, and the palm and face detections when `detector` and
    /// `face` are given, computed side by side on rayon's threads when there are two or more
    /// of them (each network call takes its own run state). Results come back in order.
    #[allow(clippy::type_complexity)]
    fn side_by_side(
        &self,
        tracked: &[(usize, HandRegion)],
        img: &RgbImage,
        lens: Option<&Camera>,
        detector: Option<&dyn HandDetector>,
        face: Option<&FaceDetector>,
    ) -> (
        Vec<Option<Result<HandKeypoints>>>,
        (
            Option<Result<Vec<HandRegion>>>,
            Option<Result<Vec<HeadDetection>>>,
        ),
    ) {
        let hand = |(_, region): &(usize, HandRegion)| {
            Some(self.estimate_keypoints(img, lens, region, true))
        };
        let palms = || detector.map(|d| d.detect_hands(img));
        let faces = || face.map(|f| f.detect(img));
        let jobs = tracked.len() + usize::from(detector.is_some()) + usize::from(face.is_some());
        if jobs < 2 || !self.parallel {
            return (tracked.iter().map(hand).collect(), (palms(), faces()));
        }
        use rayon::prelude::*;
        rayon::join(
            || tracked.par_iter().map(hand).collect(),
            || rayon::join(palms, faces),
        )
    }

    /// Keypoints in one region (the network passes only); with `lens`, read in the region's
    /// rectified view and mapped back (the region's view cannot be made: read as it is).
    fn estimate_keypoints(
        &self,
        img: &RgbImage,
        lens: Option<&Camera>,
        region: &HandRegion,
        tracked: bool,
    ) -> Result<HandKeypoints> {
        let Some(camera) = lens else {
            return self.estimate_unrectified(img, region, tracked);
        };
        let roi = shift_rect(region.roi);
        let view = RectifiedView::aimed_at(camera, &roi)
            .and_then(|view| view.roi(camera, &roi).map(|r| (view, r)));
        let Some((view, view_roi)) = view else {
            return self.estimate_unrectified(img, region, tracked);
        };
        let in_view = HandRegion {
            score: region.score,
            roi: RotatedRect {
                center: from_pixel_centres(view_roi.center),
                ..view_roi
            },
        };
        let mut kp = VIEW.with(|buffers| {
            let (patch, map) = &mut *buffers.borrow_mut();
            view.draw(camera, img, patch, map);
            self.estimate_unrectified(patch, &in_view, tracked)
        })?;
        view.map_back(camera, &mut kp);
        Ok(kp)
    }

    /// Keypoints in one region of `img` as it is (the network passes only).
    fn estimate_unrectified(
        &self,
        img: &RgbImage,
        region: &HandRegion,
        tracked: bool,
    ) -> Result<HandKeypoints> {
        let estimate = |e: &dyn KeypointEstimator, hint| {
            if tracked {
                e.estimate_tracked(img, region, hint)
            } else {
                e.estimate(img, region, hint)
            }
        };
        Ok(match &self.side_source {
            None => estimate(self.estimator.as_ref(), None)?,
            Some(mp) => {
                let first = estimate(mp, None)?;
                let mut kp = estimate(self.estimator.as_ref(), first.side.map(|s| s.0))?;
                kp.presence = first.presence;
                kp.side = first.side;
                kp
            }
        })
    }

    /// The hand `kp` describes in `region`; `None` when no hand is present there or it
    /// duplicates one of `found`.
    fn accept(
        &self,
        region: &HandRegion,
        kp: HandKeypoints,
        found: &[DetectedHand],
    ) -> Option<DetectedHand> {
        if kp.presence < self.options.min_presence {
            return None;
        }
        let hand = to_detected(region, kp);
        let b = hand.keypoints.bounds();
        if found
            .iter()
            .any(|h| h.keypoints.bounds().iou(&b) > self.options.duplicate_iou)
        {
            return None;
        }
        Some(hand)
    }

    /// Keypoints in one region; `None` when no hand is present there or it duplicates one of
    /// `found`.
    fn estimate_region(
        &self,
        img: &RgbImage,
        lens: Option<&Camera>,
        region: &HandRegion,
        tracked: bool,
        found: &[DetectedHand],
    ) -> Result<Option<DetectedHand>> {
        let kp = self.estimate_keypoints(img, lens, region, tracked)?;
        Ok(self.accept(region, kp, found))
    }
}

thread_local! {
    /// The rectified view a thread's last hand was read in, and its grid map: reused.
    static VIEW: std::cell::RefCell<(RgbImage, Vec<Option<[f64; 2]>>)> =
        std::cell::RefCell::new((RgbImage::new(1, 1), Vec::new()));
}

fn to_head(h: HeadDetection) -> DetectedHead {
    DetectedHead {
        score: h.score,
        head_box: h.head_box.map_corners(to_pixel_centres),
        face_box: h.face_box.map_corners(to_pixel_centres),
    }
}

fn shift_rect(r: RotatedRect) -> RotatedRect {
    RotatedRect {
        center: to_pixel_centres(r.center),
        ..r
    }
}

fn to_detected(region: &HandRegion, kp: HandKeypoints) -> DetectedHand {
    let mut keypoints = Keypoints2d::default();
    for (dst, src) in keypoints.points.iter_mut().zip(&kp.points) {
        let [u, v] = to_pixel_centres([src[0], src[1]]);
        *dst = [u, v, src[2]];
    }
    let rotation = region.roi.rotation;
    let (s, c) = rotation.sin_cos();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &kp.points {
        let r = [c * p[0] + s * p[1], -s * p[0] + c * p[1]];
        for k in 0..2 {
            lo[k] = lo[k].min(r[k]);
            hi[k] = hi[k].max(r[k]);
        }
    }
    let (w, h) = ((hi[0] - lo[0]) * 1.2, (hi[1] - lo[1]) * 1.2);
    let (rx, ry) = ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0);
    let center = [c * rx - s * ry, s * rx + c * ry];
    let oriented_box = shift_rect(RotatedRect {
        center,
        width: w,
        height: h,
        rotation,
    });
    let (side, side_score) = kp.side.unwrap_or((HandSide::Right, 0.5));
    DetectedHand {
        oriented_box,
        roi: shift_rect(region.roi),
        detection_score: region.score,
        presence: kp.presence,
        side,
        side_score,
        keypoints,
        cues: kp.cues,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roi_from_upright_landmarks_is_unrotated_and_centred_above_the_palm() {
        let mut lm = [[0.0; 3]; NUM_LANDMARKS];
        for (j, p) in lm.iter_mut().enumerate() {
            let finger = (j.max(1) - 1) / 4;
            let along = ((j.max(1) - 1) % 4) as f64;
            *p = if j == 0 {
                [100.0, 200.0, 0.0]
            } else {
                [70.0 + 15.0 * finger as f64, 160.0 - 20.0 * along, 0.0]
            };
        }
        let r = roi_from_landmarks(&lm);
        assert!(r.rotation.abs() < 0.2, "{}", r.rotation);
        assert!(r.center[1] < 200.0);
        assert!(r.width > 100.0);
    }

    #[test]
    fn roi_rotation_follows_the_mcp_joints_not_the_pip_joints() {
        // MCPs straight above the wrist; the index, middle and ring PIPs bent far to the
        // right. MediaPipe's rotation comes from the MCPs: the crop stays upright.
        let mut lm = [[0.0; 3]; NUM_LANDMARKS];
        lm[0] = [100.0, 200.0, 0.0];
        for (mcp, x) in [(1, 80.0), (5, 85.0), (9, 100.0), (13, 115.0), (17, 125.0)] {
            lm[mcp] = [x, 140.0, 0.0];
            for k in 1..4 {
                lm[mcp + k] = [x + if mcp == 1 { 0.0 } else { 40.0 * k as f64 }, 140.0, 0.0];
            }
        }
        let r = roi_from_landmarks(&lm);
        assert!(r.rotation.abs() < 1e-9, "{}", r.rotation);
        // Turning the MCPs turns the crop: MCPs up and to the right by 45 degrees.
        let mut turned = lm;
        for p in turned.iter_mut().skip(1) {
            let (dx, dy) = (p[0] - 100.0, p[1] - 200.0);
            let (s, c) = std::f64::consts::FRAC_PI_4.sin_cos();
            *p = [100.0 + c * dx - s * dy, 200.0 + s * dx + c * dy, 0.0];
        }
        let r = roi_from_landmarks(&turned);
        assert!(
            (r.rotation.abs() - std::f64::consts::FRAC_PI_4).abs() < 1e-9,
            "{}",
            r.rotation
        );
    }

    #[test]
    fn pipeline_can_be_shared_across_threads() {
        fn assert_send_sync<T: Send + Sync>() {}
        assert_send_sync::<HandPipeline>();
    }

    #[test]
    fn detections_serialise_to_json() {
        let d = Detections {
            image_size: (4, 3),
            hands: Vec::new(),
            heads: Vec::new(),
            precision: crate::Precision::Int8,
        };
        let json = serde_json::to_string(&d).expect("json");
        assert!(json.contains("\"image_size\":[4,3]"), "{json}");
        assert!(json.contains("\"precision\":\"int8\""), "{json}");
    }
}
