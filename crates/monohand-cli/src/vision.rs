//! Options shared by the commands that run the networks (`detect`, `run`, `models`), and
//! the conversion of the front end's detections to the output records.

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use monohand_core::hand_model::HandSide;
use monohand_vision::heatmap::{parse_input_size, HeatmapModelConfig};
use monohand_vision::{HandPipeline, ModelOptions, ModelStore, ModelVariant, PipelineOptions};
use std::path::PathBuf;

/// Size of a MediaPipe network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum Variant {
    /// The larger, more accurate network.
    Full,
    /// The smaller, faster network.
    Lite,
}

impl From<Variant> for ModelVariant {
    fn from(v: Variant) -> Self {
        match v {
            Variant::Full => ModelVariant::Full,
            Variant::Lite => ModelVariant::Lite,
        }
    }
}

/// The arithmetic of the networks' quantizable layers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum PrecisionArg {
    /// int8 for a `run` of 5 views or more (where the views pin the hand and int8 makes 8
    /// views run at video rate: docs/performance.md), else f32.
    Auto,
    /// f32 throughout, MediaPipe's own arithmetic.
    F32,
    /// The 1x1 and first convolutions of the palm and landmark networks in int8, with the
    /// calibration monohand ships (docs/performance.md, docs/accuracy.md).
    Int8,
}

impl From<PrecisionArg> for monohand::PrecisionChoice {
    fn from(p: PrecisionArg) -> Self {
        use monohand::PrecisionChoice::{Auto, Fixed};
        match p {
            PrecisionArg::Auto => Auto,
            PrecisionArg::F32 => Fixed(monohand_vision::Precision::F32),
            PrecisionArg::Int8 => Fixed(monohand_vision::Precision::Int8),
        }
    }
}

/// How a custom keypoint network's output is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum KeypointFormat {
    /// 21 heatmaps (OpenPose-hand / RTMPose-style); peak with sub-pixel refinement,
    /// confidence = peak value.
    Heatmap,
}

/// Where the networks come from and how they run.
#[derive(Debug, Clone, Args)]
pub(crate) struct ModelArgs {
    /// Folder of the cached MediaPipe weights (default: $MONOHAND_MODEL_DIR, else
    /// ~/.cache/monohand/models), fetched with pip on first use.
    #[arg(long, value_name = "DIR", global = true)]
    pub model_dir: Option<PathBuf>,
    /// Palm detector size.
    #[arg(long, value_enum, default_value = "full", value_name = "SIZE")]
    pub palm_model: Variant,
    /// Hand landmark model size.
    #[arg(long, value_enum, default_value = "full", value_name = "SIZE")]
    pub landmark_model: Variant,
    /// The arithmetic of the palm and landmark networks: f32, or int8 (faster, with the
    /// shipped calibration; as accurate on tracked video, about 0.6 mm less on photos and
    /// untracked frames: docs/accuracy.md; the records say which ran); auto: int8 for a
    /// `run` of 5 views or more, else f32.
    #[arg(long, value_enum, default_value = "auto", value_name = "PRECISION")]
    pub precision: PrecisionArg,
    /// Do not detect heads (the paper's context for left/right; they cost ~3 ms per image).
    #[arg(long)]
    pub no_heads: bool,
    /// The most hands per image.
    #[arg(long = "hands", value_name = "N", default_value_t = 4)]
    pub max_hands: usize,
    /// Hands whose presence score (landmark network) is below this are dropped.
    #[arg(long, value_name = "P", default_value_t = 0.5)]
    pub min_presence: f32,
    /// Images are selfie-mirrored (front cameras): swap left and right.
    #[arg(long)]
    pub mirrored: bool,
    /// Read each crop once, without the mirror-image pass (faster, higher 3D error:
    /// docs/accuracy.md).
    #[arg(long)]
    pub no_mirror_pass: bool,
    /// An ONNX keypoint network instead of MediaPipe's landmark model (which still gives
    /// the side and presence).
    #[arg(long, value_name = "MODEL.onnx", requires = "keypoint_format")]
    pub keypoint_model: Option<PathBuf>,
    /// Output format of --keypoint-model.
    #[arg(long, value_enum, value_name = "FORMAT")]
    pub keypoint_format: Option<KeypointFormat>,
    /// Input size of --keypoint-model, WxH (OpenPose hand: 368x368).
    #[arg(long, value_name = "WxH", default_value = "368x368")]
    pub keypoint_input: String,
    /// The only side --keypoint-model was trained on, left or right (the other side is
    /// mirrored).
    #[arg(long, value_name = "SIDE")]
    pub keypoint_trained_side: Option<HandSide>,
}

impl ModelArgs {
    /// The model store these options point at.
    pub fn store(&self) -> Result<ModelStore> {
        Ok(ModelStore::new(self.model_dir.clone())?)
    }

    /// Which networks, and their options as given for one view (the refine passes are
    /// derived: [`crate::resolve`]).
    pub fn options(&self) -> (ModelOptions, PipelineOptions) {
        self.options_for(1)
    }

    /// The same for a run of `views` views (they choose the precision `auto` means).
    pub fn options_for(&self, views: usize) -> (ModelOptions, PipelineOptions) {
        let models = ModelOptions {
            model_dir: self.model_dir.clone(),
            palm: self.palm_model.into(),
            landmark: self.landmark_model.into(),
            detect_heads: !self.no_heads,
        };
        let options = PipelineOptions {
            max_hands: self.max_hands,
            min_presence: self.min_presence,
            mirrored_input: self.mirrored,
            precision: monohand::PrecisionChoice::from(self.precision).for_views(views),
            landmarks: monohand_vision::landmarks::LandmarkOptions {
                mirror_pass: !self.no_mirror_pass,
                ..Default::default()
            },
            ..PipelineOptions::default()
        };
        (models, options)
    }

    /// The front end for frames tracked or not, its options resolved by the library.
    pub fn pipeline_for(&self, tracking: bool) -> Result<HandPipeline> {
        let mut settings = monohand::Settings {
            pipeline: self.options().1,
            ..Default::default()
        };
        settings.fit.tracking = tracking;
        self.pipeline(crate::resolve(settings)?.pipeline())
    }

    /// Builds the front end with `options` (resolved; fetching the weights if needed).
    pub fn pipeline(&self, options: PipelineOptions) -> Result<HandPipeline> {
        let models = self.options().0;
        let pipeline = match (&self.keypoint_model, self.keypoint_format) {
            (Some(path), Some(KeypointFormat::Heatmap)) => {
                let config = HeatmapModelConfig {
                    input_size: parse_input_size(&self.keypoint_input).with_context(|| {
                        format!(
                            "size {:?} is not WxH with positive integers",
                            self.keypoint_input
                        )
                    })?,
                    trained_side: self.keypoint_trained_side,
                    ..HeatmapModelConfig::default()
                };
                let estimator = monohand_vision::heatmap::OnnxHeatmapEstimator::load(path, config)?;
                HandPipeline::with_keypoint_estimator(&models, options, Box::new(estimator))
            }
            (Some(_), None) => bail!("--keypoint-model needs --keypoint-format"),
            _ => HandPipeline::new(&models, options),
        };
        pipeline
            .context("could not set up the hand networks (--hands, --min-presence, --model-dir)")
    }
}
