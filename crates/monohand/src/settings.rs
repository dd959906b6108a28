//! The one resolved configuration of a run. Each face (the CLI, Python, the browser, the
//! evaluation) fills in plain [`Settings`]; [`Settings::resolve`] checks them once and
//! derives what depends on other settings, as ripgrep resolves its arguments once:
//!
//! - the landmark network's refine passes: none when tracking (MediaPipe's single pass:
//!   the next frame's crop comes from this one's keypoints), one for independent images
//!   (the crop re-centred on the first pass's keypoints);
//! - what tracking implies: smoothing and the offline smoother need it (frames not tracked
//!   have no frames around them), and the depth filter runs only while tracking, and not
//!   offline (the refit with the frames around each frame steadies the hand itself);
//! - the detection cadence: `detect_every` of at least 1, used only while tracking.
//!
//! The engine ([`crate::engine::Engine`]) and the session ([`crate::Session`]) build their
//! stages from the [`ResolvedSettings`] only, and a shared pipeline is checked against them
//! ([`ResolvedSettings::check_pipeline`]). A refusal is a [`SettingsError`] naming the
//! [`Field`]; each face says it with its own flag or argument name.

pub use crate::base::errors::{Field, SettingsError};
use crate::stages::cameras::in_first_frame;
use crate::stages::crops::CropSettings;
use crate::stages::fitter::options::FitSettings;
use crate::stages::offline::OfflineSettings;
use monohand_vision::{HandPipeline, PipelineOptions, Precision};

/// The plain settings of a run, as a face fills them in; nothing here is derived from
/// anything else ([`Settings::resolve`] does that).
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// The networks' thresholds. `refine_passes` is derived (ignored here).
    pub pipeline: PipelineOptions,
    /// The 3D stage; [`FitSettings::tracking`] is the run's tracking switch.
    pub fit: FitSettings,
    /// While tracking, look for new hands every this many frames (at least 1).
    pub detect_every: usize,
    /// Stop after this many frames.
    pub max_frames: Option<u64>,
    /// Worker threads for independent images (`None`: all cores; 1: one core).
    pub threads: Option<usize>,
    /// Which calibrated cameras' hands are read in rectified views
    /// ([`monohand_vision::rectify`]).
    pub rectify: RectifyCrops,
    /// With two or more calibrated cameras and tracking, each view's crops come from the
    /// hands fitted in 3D in the frame before, projected into it
    /// ([`crate::CropTracker::guide_through`]); on by default.
    pub fitted_crops: bool,
}

/// Which hands are read in rectified views: the view of a virtual pinhole camera aimed at
/// the hand, drawn through the calibrated camera's model, instead of a crop of the image as
/// it is. Without a calibration (the generic camera, a photo's EXIF camera) crops are
/// always of the image as it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RectifyCrops {
    /// Never (the default: on the dev set through a 150 degree fisheye the rectified views
    /// gave the same 2D and PA error and a 1.6 mm larger absolute error, and on the ordinary
    /// dev video `All` was worse on both halves; docs/calibration.md#rectified-crops).
    #[default]
    Off,
    /// Through calibrated cameras whose lens is not an ideal pinhole (distortion, fisheye).
    Lenses,
    /// Through every calibrated camera (a pinhole's rectified view also undoes the
    /// perspective stretch of a hand far off the axis).
    All,
}

impl std::str::FromStr for RectifyCrops {
    type Err = String;

    /// `off`, `lenses` or `all`, as the command line and Python name them.
    fn from_str(s: &str) -> Result<RectifyCrops, String> {
        match s {
            "off" => Ok(RectifyCrops::Off),
            "lenses" => Ok(RectifyCrops::Lenses),
            "all" => Ok(RectifyCrops::All),
            other => Err(format!("{other:?} is not off, lenses or all")),
        }
    }
}

/// The networks' arithmetic as a face asks for it (`--precision`, Python's `precision=`):
/// one of the two, or chosen by how many views the run has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PrecisionChoice {
    /// f32 with fewer than [`INT8_FROM_VIEWS`] views, int8 from there on (the default).
    #[default]
    Auto,
    /// This precision, whatever the views.
    Fixed(Precision),
}

/// With this many views or more, [`PrecisionChoice::Auto`] runs the networks in int8.
///
/// int8's keypoints differ from f32's by about a pixel; what that costs in 3D depends on how
/// many views pin the hand (the dev rig, `eval --stage full --views stereo --track`, each
/// frame by the views that saw the hand, int8 against f32: 2 views 24.5 against 18.9 mm,
/// 3 views 12.2 against 11.2, 4 views 10.2 against 10.3). A rig of 4 views sees the hand in
/// 2 or 3 of them for 36 of its 76 labelled frames and keeps f32 (12.02 mm, int8 13.27);
/// from 5 views on the hand is in 4 or more far more often, and int8 is what makes 8 views
/// run at video rate (the 2-core EPYC: 17.6 against 11.2 fps). docs/performance.md.
pub const INT8_FROM_VIEWS: usize = 5;

impl PrecisionChoice {
    /// The precision for a run of `views` views.
    pub fn for_views(self, views: usize) -> Precision {
        match self {
            PrecisionChoice::Auto if views >= INT8_FROM_VIEWS => Precision::Int8,
            PrecisionChoice::Auto => Precision::F32,
            PrecisionChoice::Fixed(p) => p,
        }
    }

    /// Its name in options: `auto`, `f32` or `int8`.
    pub fn name(self) -> &'static str {
        match self {
            PrecisionChoice::Auto => "auto",
            PrecisionChoice::Fixed(p) => p.name(),
        }
    }
}

impl std::str::FromStr for PrecisionChoice {
    type Err = String;

    /// `auto`, `f32` or `int8`, as the command line and Python name them.
    fn from_str(s: &str) -> Result<PrecisionChoice, String> {
        match s {
            "auto" => Ok(PrecisionChoice::Auto),
            other => other
                .parse()
                .map(PrecisionChoice::Fixed)
                .map_err(|_| format!("{other:?} is not auto, f32 or int8")),
        }
    }
}

impl Default for Settings {
    /// Video tracking of up to 2 hands, looking for new hands every 10 frames.
    fn default() -> Settings {
        Settings {
            pipeline: PipelineOptions {
                max_hands: 2,
                ..PipelineOptions::default()
            },
            fit: FitSettings::default(),
            detect_every: 10,
            max_frames: None,
            threads: None,
            rectify: RectifyCrops::default(),
            fitted_crops: true,
        }
    }
}

/// The landmark network's refine passes: none when tracking, one for independent images.
fn refine_passes(tracking: bool) -> usize {
    if tracking {
        0
    } else {
        1
    }
}

impl Settings {
    /// Checks the settings and derives what depends on others (the module's list).
    pub fn resolve(self) -> Result<ResolvedSettings, SettingsError> {
        self.check()?;
        let mut derived = self.clone();
        let tracking = derived.fit.tracking;
        derived.pipeline.refine_passes = refine_passes(tracking);
        if !tracking || derived.fit.offline.is_some() {
            derived.fit.depth_filter = None;
        }
        Ok(ResolvedSettings {
            plain: self,
            derived,
        })
    }

    fn check(&self) -> Result<(), SettingsError> {
        let err = |field, why: &str| Err(SettingsError::new(field, why));
        if self.detect_every == 0 {
            return err(Field::DetectEvery, "must be at least 1");
        }
        if self.threads == Some(0) {
            return err(Field::Threads, "must be at least 1");
        }
        check_pipeline_options(&self.pipeline)?;
        self.fit
            .options
            .validate()
            .map_err(|e| SettingsError::new(Field::FitOptions, e.to_string()))?;
        let needs_tracking =
            "needs tracking (a video, or an image sequence tracked): images on their own have \
             no frames around them";
        if let Some(p) = &self.fit.smoothing {
            if !(p.min_cutoff.is_finite() && p.min_cutoff > 0.0) {
                return err(Field::SmoothMinCutoff, "must be positive");
            }
            if !(p.beta.is_finite() && p.beta >= 0.0) {
                return err(Field::SmoothBeta, "must not be negative");
            }
            if !self.fit.tracking {
                return err(Field::Smoothing, needs_tracking);
            }
        }
        if let Some(o) = &self.fit.offline {
            o.validate()?;
            if !self.fit.tracking {
                return err(Field::Offline, needs_tracking);
            }
            if self.fit.smoothing.is_some() {
                return err(
                    Field::Offline,
                    "replaces the One Euro filter: not with smoothing",
                );
            }
        }
        Ok(())
    }
}

/// [`PipelineOptions::validate`], with the field it refuses.
fn check_pipeline_options(p: &PipelineOptions) -> Result<(), SettingsError> {
    if p.max_hands == 0 {
        return Err(SettingsError::new(
            Field::MaxHands,
            "must be at least 1 (one hand per image)",
        ));
    }
    if !(0.0..=1.0).contains(&p.min_presence) {
        return Err(SettingsError::new(Field::MinPresence, "must be in [0, 1]"));
    }
    p.validate()
        .map_err(|e| SettingsError::new(Field::Pipeline, e.to_string()))
}

/// Settings checked, with what depends on other settings derived: built only by
/// [`Settings::resolve`]. The engine and the session run from these.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedSettings {
    /// As the face filled them in (resolved again when one is changed).
    plain: Settings,
    /// With what depends on other settings derived.
    derived: Settings,
}

impl ResolvedSettings {
    /// The settings as resolved (`pipeline.refine_passes` derived, the depth filter off
    /// where it does not run).
    pub fn get(&self) -> &Settings {
        &self.derived
    }

    /// The networks' options, refine passes included: what a pipeline for these settings
    /// is loaded with.
    pub fn pipeline(&self) -> PipelineOptions {
        self.derived.pipeline
    }

    /// The 3D stage.
    pub fn fit(&self) -> &FitSettings {
        &self.derived.fit
    }

    /// The 3D stage for lifting 2D keypoints made elsewhere
    /// ([`crate::engine::lift::lift_keypoints`]), which fits each frame from its keypoints
    /// alone: the settings that need the images' views or the frames around (the hand size
    /// measured from two views, smoothing, the offline smoother, the depth filter) are
    /// refused, not ignored.
    pub fn lifting(&self) -> Result<&FitSettings, SettingsError> {
        let fit = &self.derived.fit;
        let not = |field, what: &str| {
            Err(SettingsError::new(
                field,
                format!("is not done when lifting keypoints ({what}); `run` does it"),
            ))
        };
        if fit.auto_scale_frames.is_some() {
            return not(
                Field::HandScale,
                "the size is measured from two views of the images",
            );
        }
        if fit.smoothing.is_some() {
            return not(Field::Smoothing, "each frame is fitted on its own");
        }
        if fit.offline.is_some() {
            return not(Field::Offline, "each frame is fitted on its own");
        }
        if fit.depth_filter.is_some() {
            return not(Field::DepthFilter, "each frame is fitted on its own");
        }
        Ok(fit)
    }

    /// Per view, the camera its hands are read through ([`RectifyCrops`]), from the
    /// calibrated `cameras` (none: no view is rectified).
    pub fn lenses(
        &self,
        cameras: &[monohand_core::camera::Camera],
    ) -> Vec<Option<monohand_core::camera::Camera>> {
        cameras
            .iter()
            .map(|c| match self.derived.rectify {
                RectifyCrops::Off => None,
                RectifyCrops::Lenses => (!c.distortion.is_ideal()).then_some(*c),
                RectifyCrops::All => Some(*c),
            })
            .collect()
    }

    /// The crop stage's settings for views through these calibrated `cameras` (none: the
    /// images as they are, unguided): tracking, the detection cadence, each view's lens
    /// ([`ResolvedSettings::lenses`]) and, with [`ResolvedSettings::fitted_crops`], the
    /// cameras in the first one's frame through which the fitted hands seed the crops.
    pub fn crops(&self, cameras: &[monohand_core::camera::Camera]) -> CropSettings {
        CropSettings {
            tracking: self.tracking(),
            detect_every: self.detect_every(),
            lenses: self.lenses(cameras),
            guide_cameras: match self.fitted_crops() {
                true => in_first_frame(cameras),
                false => Vec::new(),
            },
        }
    }

    /// Whether frames are tracked.
    pub fn tracking(&self) -> bool {
        self.derived.fit.tracking
    }

    /// While tracking, look for new hands every this many frames (at least 1).
    pub fn detect_every(&self) -> usize {
        self.derived.detect_every
    }

    /// Stop after this many frames.
    pub fn max_frames(&self) -> Option<u64> {
        self.derived.max_frames
    }

    /// Worker threads for independent images (`None`: all cores).
    pub fn threads(&self) -> Option<usize> {
        self.derived.threads
    }

    /// Whether the hands fitted in 3D seed the next frame's crops ([`Settings::fitted_crops`];
    /// it takes effect with tracking and two or more calibrated cameras).
    pub fn fitted_crops(&self) -> bool {
        self.derived.fitted_crops && self.tracking()
    }

    /// The same settings for frames not tracked (the images of a corpus whose videos are
    /// tracked): neither smoothed nor refitted offline, one refine pass.
    pub fn untracked(self) -> ResolvedSettings {
        let mut s = self.plain;
        s.fit.tracking = false;
        s.fit.smoothing = None;
        s.fit.offline = None;
        match s.clone().resolve() {
            Ok(r) => r,
            // Unreachable: dropping tracking with what needs it keeps valid settings valid.
            Err(_) => ResolvedSettings {
                plain: s.clone(),
                derived: s,
            },
        }
    }

    /// The same settings, stopping after `max_frames` frames (`None`: at the input's end).
    pub fn with_max_frames(mut self, max_frames: Option<u64>) -> ResolvedSettings {
        self.plain.max_frames = max_frames;
        self.derived.max_frames = max_frames;
        self
    }

    /// The same settings with the offline smoother on (its defaults) or off, resolved
    /// again (refused without tracking).
    pub fn with_offline(self, on: bool) -> Result<ResolvedSettings, SettingsError> {
        let mut s = self.plain;
        s.fit.offline = on.then(OfflineSettings::default);
        s.resolve()
    }

    /// Checks that a pipeline loaded elsewhere (shared between sessions) runs as these
    /// settings ask: its options (refine passes, that is tracking or not, included) and
    /// whether it detects heads when `heads` says which is wanted.
    pub fn check_pipeline(
        &self,
        pipeline: &HandPipeline,
        heads: Option<bool>,
    ) -> Result<(), SettingsError> {
        let (have, want) = (&pipeline.options, self.pipeline());
        let loaded =
            |what: String| format!("differs from the shared pipeline's: it was loaded {what}");
        if have.refine_passes != want.refine_passes {
            let mode = |p: usize| {
                if p == 0 {
                    "tracking"
                } else {
                    "independent images"
                }
            };
            return Err(SettingsError::new(
                Field::Tracking,
                loaded(format!("for {}", mode(have.refine_passes))),
            ));
        }
        if have.max_hands != want.max_hands {
            return Err(SettingsError::new(
                Field::MaxHands,
                loaded(format!("for {} hands", have.max_hands)),
            ));
        }
        if have.landmarks.mirror_pass != want.landmarks.mirror_pass {
            return Err(SettingsError::new(
                Field::MirrorPass,
                loaded(format!("with mirror pass {}", have.landmarks.mirror_pass)),
            ));
        }
        if have.precision != want.precision {
            return Err(SettingsError::new(
                Field::Precision,
                loaded(format!("in {}", have.precision)),
            ));
        }
        if heads.is_some_and(|h| h != pipeline.detects_heads()) {
            return Err(SettingsError::new(
                Field::Heads,
                loaded(format!("with heads {}", pipeline.detects_heads())),
            ));
        }
        if *have != want {
            return Err(SettingsError::new(
                Field::Pipeline,
                loaded(format!("with {have:?}")),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn auto_precision_is_int8_from_five_views() {
        use std::str::FromStr;
        let auto = PrecisionChoice::from_str("auto").unwrap();
        assert_eq!(auto, PrecisionChoice::Auto);
        assert_eq!(auto.for_views(1), Precision::F32);
        assert_eq!(auto.for_views(INT8_FROM_VIEWS - 1), Precision::F32);
        assert_eq!(auto.for_views(INT8_FROM_VIEWS), Precision::Int8);
        assert_eq!(auto.for_views(8), Precision::Int8);
        let f32 = PrecisionChoice::from_str("f32").unwrap();
        assert_eq!(f32.for_views(8), Precision::F32);
        assert_eq!(
            PrecisionChoice::from_str("int8").unwrap().for_views(1),
            Precision::Int8
        );
        for c in [auto, f32, PrecisionChoice::Fixed(Precision::Int8)] {
            assert_eq!(PrecisionChoice::from_str(c.name()).unwrap(), c);
        }
        assert!(PrecisionChoice::from_str("f16")
            .unwrap_err()
            .contains("auto, f32 or int8"));
    }
    use monohand_core::filtering::OneEuroParams;

    /// A change that spoils the default settings.
    type Spoil = fn(&mut Settings);

    fn refused(s: Settings) -> SettingsError {
        s.resolve().unwrap_err()
    }

    fn untracked() -> Settings {
        let mut s = Settings::default();
        s.fit.tracking = false;
        s
    }

    #[test]
    fn refine_passes_follow_tracking() {
        assert_eq!(
            Settings::default()
                .resolve()
                .unwrap()
                .pipeline()
                .refine_passes,
            0
        );
        assert_eq!(untracked().resolve().unwrap().pipeline().refine_passes, 1);
        // Whatever a face put there.
        let mut s = Settings::default();
        s.pipeline.refine_passes = 5;
        assert_eq!(s.resolve().unwrap().pipeline().refine_passes, 0);
    }

    #[test]
    fn the_depth_filter_runs_only_tracking_and_not_offline() {
        let on = Settings::default().resolve().unwrap();
        assert_eq!(on.fit().depth_filter, Some(crate::DEPTH_FILTER));
        assert_eq!(untracked().resolve().unwrap().fit().depth_filter, None);
        let offline = on.clone().with_offline(true).unwrap();
        assert_eq!(offline.fit().depth_filter, None);
        assert!(offline.fit().offline.is_some());
        // Turned off again, the filter is back.
        let back = offline.with_offline(false).unwrap();
        assert_eq!(back, on);
    }

    #[test]
    fn smoothing_and_offline_need_tracking() {
        let mut s = untracked();
        s.fit.smoothing = Some(OneEuroParams::default());
        assert_eq!(refused(s).field, Field::Smoothing);
        let mut s = untracked();
        s.fit.offline = Some(OfflineSettings::default());
        let e = refused(s);
        assert_eq!(e.field, Field::Offline);
        assert!(e.why.starts_with("needs tracking"), "{e}");
        assert!(untracked().resolve().unwrap().with_offline(true).is_err());
    }

    #[test]
    fn offline_replaces_smoothing() {
        let mut s = Settings::default();
        s.fit.smoothing = Some(OneEuroParams::default());
        s.fit.offline = Some(OfflineSettings::default());
        let e = refused(s);
        assert_eq!(e.field, Field::Offline);
        assert!(e.why.contains("One Euro"), "{e}");
    }

    #[test]
    fn untracked_drops_what_needs_tracking() {
        let mut s = Settings::default();
        s.fit.offline = Some(OfflineSettings::default());
        let images = s.resolve().unwrap().untracked();
        assert!(!images.tracking());
        assert_eq!(images.fit().offline, None);
        assert_eq!(images.fit().smoothing, None);
        assert_eq!(images.fit().depth_filter, None);
        assert_eq!(images.pipeline().refine_passes, 1);
    }

    #[test]
    fn each_refused_setting_names_its_field() {
        let cases: Vec<(Field, Spoil)> = vec![
            (Field::DetectEvery, |s: &mut Settings| s.detect_every = 0),
            (Field::Threads, |s: &mut Settings| s.threads = Some(0)),
            (Field::MaxHands, |s: &mut Settings| s.pipeline.max_hands = 0),
            (Field::MinPresence, |s: &mut Settings| {
                s.pipeline.min_presence = 1.5
            }),
            (Field::Pipeline, |s: &mut Settings| {
                s.pipeline.duplicate_iou = -1.0
            }),
            (Field::FitOptions, |s: &mut Settings| {
                s.fit.options.solver.max_iterations = 0
            }),
            (Field::SmoothMinCutoff, |s: &mut Settings| {
                s.fit.smoothing = Some(OneEuroParams {
                    min_cutoff: 0.0,
                    ..Default::default()
                })
            }),
            (Field::SmoothBeta, |s: &mut Settings| {
                s.fit.smoothing = Some(OneEuroParams {
                    beta: f64::NAN,
                    ..Default::default()
                })
            }),
            (Field::Offline, |s: &mut Settings| {
                s.fit.offline = Some(OfflineSettings {
                    lag: 0,
                    ..Default::default()
                })
            }),
        ];
        for (field, spoil) in cases {
            let mut s = Settings::default();
            spoil(&mut s);
            let e = refused(s);
            assert_eq!(e.field, field, "{e}");
            assert!(e.to_string().starts_with(field.name()), "{e}");
        }
        assert_eq!(
            refused(Settings {
                detect_every: 0,
                ..Settings::default()
            })
            .to_string(),
            "detect_every must be at least 1"
        );
    }
}
