//! One hand's fit over its views, shared by the video session and the 2D-only lifter.

use crate::base::errors::{Field, SessionResult, SettingsError};
use crate::base::notes::{Note, NoteTopic};
use monohand_core::fitting::{estimate_proportions, ProportionEstimate};
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;

/// How one fit ended.
#[derive(Debug)]
pub enum FitOutcome {
    /// A usable fit (every number finite).
    Fitted(Box<FitResult>),
    /// The solver returned non-finite numbers; the tracker was reset.
    Diverged,
    /// The fit was refused (too few usable joints, ...).
    Failed(CoreError),
}

/// Whether a fit is usable (no NaN or infinity anywhere).
pub fn is_finite(fit: &FitResult) -> bool {
    fit.pose.is_finite()
        && fit.reprojection_error_px.is_finite()
        && fit
            .joints_3d
            .iter()
            .all(|x| x.iter().all(|v| v.is_finite()))
}

/// Fits `views` with `tracker` (warm-started from its last pose); a diverged fit resets it.
pub fn fit_views(tracker: &mut HandTracker, views: &[View]) -> FitOutcome {
    match tracker.update(views) {
        Ok(fit) if is_finite(&fit) => FitOutcome::Fitted(Box::new(fit)),
        Ok(_) => {
            tracker.reset();
            FitOutcome::Diverged
        }
        Err(e) => FitOutcome::Failed(e),
    }
}

/// Each side's proportions, the size kept, from the network's metric 3D `cues` of that
/// side ([`estimate_proportions`]): the skeleton to fit with, and what to tell the user.
/// The one policy of the engine, the session and the lifting job.
pub fn learn_proportions(
    template: &HandSkeleton,
    side: HandSide,
    cues: &[NetworkCues],
) -> (Option<ProportionEstimate>, Note) {
    match estimate_proportions(template, cues) {
        Ok(est) => {
            let note = Note::new(
                NoteTopic::Proportions,
                format!("{side} hand proportions {est}"),
            );
            (Some(est), note)
        }
        Err(e) => (
            None,
            Note::new(
                NoteTopic::Proportions,
                format!("{side} hand proportions not learnt ({e}); keeping the model's"),
            ),
        ),
    }
}

/// The hand sizes a user may ask for, as a factor on the default adult hand (open
/// interval): outside it the 3D would be a child's doll or a giant's.
pub const HAND_SCALE_RANGE: (f64, f64) = (0.3, 3.0);

/// Whether `scale` is a hand size a user may ask for: finite and inside
/// [`HAND_SCALE_RANGE`]. The one check of every form it is given in (a factor, a hand
/// file's scale, a ruler's length, the skeletons' scale).
fn is_hand_scale(scale: f64) -> bool {
    let (lo, hi) = HAND_SCALE_RANGE;
    scale.is_finite() && scale > lo && scale < hi
}

/// The hand's size: a fixed factor on the default adult hand, or measured from the input
/// (with two or more calibrated views, [`FitSettings::auto_scale_frames`]). Parsed from
/// `"auto"` or a factor in [`HAND_SCALE_RANGE`].
///
/// [`FitSettings::auto_scale_frames`]: crate::FitSettings::auto_scale_frames
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HandScale {
    /// Multiply the default hand (hand length ~185 mm) by this.
    Fixed(f64),
    /// Estimate the factor from the first frames.
    Auto,
}

impl HandScale {
    /// The factor to start from (1 for [`HandScale::Auto`] until it is measured).
    pub fn initial(self) -> f64 {
        match self {
            HandScale::Fixed(s) => s,
            HandScale::Auto => 1.0,
        }
    }
}

/// A hand size that is neither `auto` nor a factor in [`HAND_SCALE_RANGE`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{text:?} is neither \"auto\" nor a factor between {} and {}",
    HAND_SCALE_RANGE.0,
    HAND_SCALE_RANGE.1
)]
pub struct HandScaleError {
    /// What was given.
    pub text: String,
}

impl std::str::FromStr for HandScale {
    type Err = HandScaleError;
    fn from_str(s: &str) -> Result<HandScale, HandScaleError> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(HandScale::Auto);
        }
        match s.parse::<f64>() {
            Ok(v) if is_hand_scale(v) => Ok(HandScale::Fixed(v)),
            _ => Err(HandScaleError { text: s.into() }),
        }
    }
}

/// Where the hand size of a fit came from: what the records ([`HandSizeRecord`]) and the
/// summary say.
///
/// [`HandSizeRecord`]: monohand_io::jsonl::HandSizeRecord
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HandSizeSource {
    /// The population average (no size given).
    #[default]
    Default,
    /// A factor given (`--hand-scale S`).
    Scale,
    /// Measured by two or more calibrated views (`--hand-scale auto`, `--save-hand`).
    Measured,
    /// A hand file (`--hand`).
    File,
    /// A ruler's hand length (`--hand-length-mm`).
    Ruler,
}

impl HandSizeSource {
    /// `default`, `scale`, `measured`, `file` or `ruler`, as the records say it.
    pub const fn as_str(self) -> &'static str {
        match self {
            HandSizeSource::Default => "default",
            HandSizeSource::Scale => "scale",
            HandSizeSource::Measured => "measured",
            HandSizeSource::File => "file",
            HandSizeSource::Ruler => "ruler",
        }
    }
}

/// The hand's size as a user may give it, in whichever face (the CLI's `--hand`,
/// `--hand-length-mm` and `--hand-scale`; Python's `hand=` and `hand_scale=`; the
/// browser's `hand` and `handLengthMm`): at most one of them. The faces parse their
/// arguments into this; [`GivenHandSize::choose`] decides, the same for all.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GivenHandSize<'a> {
    /// A hand file (`run --save-hand`), read.
    pub file: Option<&'a monohand_io::hand::HandFile>,
    /// A ruler's hand length, mm ([`scale_from_ruler`]).
    pub ruler_mm: Option<f64>,
    /// A factor on the default hand, or `auto`.
    pub scale: Option<HandScale>,
}

/// Why a hand size as given ([`GivenHandSize`]) cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HandSizeError {
    /// More than one way was given.
    #[error(
        "the hand's size is given {0} ways: give one (a hand file, a ruler's length or a scale)"
    )]
    MoreThanOne(usize),
    /// A ruler's length no size in [`HAND_SCALE_RANGE`] has.
    #[error(transparent)]
    Ruler(#[from] RulerLengthError),
    /// A hand file's numbers are wrong.
    #[error("{0}")]
    File(String),
    /// A factor outside [`HAND_SCALE_RANGE`].
    #[error("the hand scale {0} must be between {lo} and {hi} (1: the average adult hand)", lo = HAND_SCALE_RANGE.0, hi = HAND_SCALE_RANGE.1)]
    Scale(f64),
}

impl GivenHandSize<'_> {
    /// The hand size to fit at and where it comes from: a hand file's size, a ruler's
    /// length through [`scale_from_ruler`], a factor (1, or nothing given: the default hand),
    /// or `auto` (the default hand until two or more views measure it). More than one given
    /// is an error, not a precedence.
    pub fn choose(&self) -> Result<(HandScale, HandSizeSource), HandSizeError> {
        let given = [
            self.file.is_some(),
            self.ruler_mm.is_some(),
            self.scale.is_some(),
        ];
        let n = given.iter().filter(|g| **g).count();
        if n > 1 {
            return Err(HandSizeError::MoreThanOne(n));
        }
        if let Some(file) = self.file {
            file.validate("hand file")
                .map_err(|e| HandSizeError::File(e.to_string()))?;
            if !is_hand_scale(file.scale) {
                return Err(HandSizeError::Scale(file.scale));
            }
            return Ok((HandScale::Fixed(file.scale), HandSizeSource::File));
        }
        if let Some(mm) = self.ruler_mm {
            return Ok((
                HandScale::Fixed(scale_from_ruler(mm)?),
                HandSizeSource::Ruler,
            ));
        }
        match self.scale {
            None => Ok((HandScale::Fixed(1.0), HandSizeSource::Default)),
            Some(HandScale::Auto) => Ok((HandScale::Auto, HandSizeSource::Default)),
            Some(HandScale::Fixed(s)) => {
                if !is_hand_scale(s) {
                    return Err(HandSizeError::Scale(s));
                }
                let source = if s == 1.0 {
                    HandSizeSource::Default
                } else {
                    HandSizeSource::Scale
                };
                Ok((HandScale::Fixed(s), source))
            }
        }
    }
}

/// A ruler's hand length (the hand flat, from the wrist crease to the end of the middle
/// finger) minus the model's (from its wrist joint along the middle finger's bones to its
/// tip keypoint), mm. Measured on the table rig (docs/absolute-depth.md): its reference,
/// triangulated from manual labels that put the wrist on the crease and the tip at the
/// finger's end, gives 178.3 mm (the median over its frames of the chain wrist, middle
/// base, the three joints, tip); `--save-hand` with its 4 shared views gives the model's
/// 176.9 mm. One person: a ruler's own error (1-2 mm) is of the same order.
pub const RULER_OFFSET_MM: f64 = 1.4;

/// A ruler's hand length that no hand size in [`HAND_SCALE_RANGE`] has.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("a hand {length_mm} mm long by ruler is outside the sizes the model takes ({lo:.0} to {hi:.0} mm)")]
pub struct RulerLengthError {
    /// What was given.
    pub length_mm: f64,
    /// The shortest ruler length accepted, mm.
    pub lo: f64,
    /// The longest, mm.
    pub hi: f64,
}

/// The hand scale ([`HandScale::Fixed`]) of a hand whose ruler length is `length_mm`
/// ([`RULER_OFFSET_MM`]); an error outside [`HAND_SCALE_RANGE`].
pub fn scale_from_ruler(length_mm: f64) -> Result<f64, RulerLengthError> {
    let default = HandSkeleton::default_for(HandSide::Right).hand_length();
    let scale = (length_mm - RULER_OFFSET_MM) / default;
    let (lo, hi) = HAND_SCALE_RANGE;
    if is_hand_scale(scale) {
        Ok(scale)
    } else {
        Err(RulerLengthError {
            length_mm,
            lo: lo * default + RULER_OFFSET_MM,
            hi: hi * default + RULER_OFFSET_MM,
        })
    }
}

/// The default (population average) left and right hands scaled by `scale`, with the
/// subject's 20 bone lengths (mm, at scale 1) when given: the hand-size policy of the
/// engine, the CLI and the Python package.
pub fn hand_skeletons(
    scale: f64,
    bone_lengths_mm: Option<&[f64; 20]>,
) -> SessionResult<[HandSkeleton; 2]> {
    if !is_hand_scale(scale) {
        let (lo, hi) = HAND_SCALE_RANGE;
        return Err(SettingsError::new(
            Field::HandScale,
            format!("{scale} must be between {lo} and {hi} (1: the average adult hand)"),
        )
        .into());
    }
    let side = |side| -> SessionResult<HandSkeleton> {
        let mut sk = HandSkeleton::default_for(side).scaled(scale)?;
        if let Some(lengths) = bone_lengths_mm {
            sk = sk.with_bone_lengths(&lengths.map(|l| l * scale))?;
        }
        Ok(sk)
    };
    Ok([side(HandSide::Left)?, side(HandSide::Right)?])
}

#[cfg(test)]
mod tests {

    #[test]
    fn the_hand_scale_range_is_open_and_refuses_what_is_not_finite() {
        use super::{hand_skeletons, is_hand_scale, HandScale, HAND_SCALE_RANGE};
        let (lo, hi) = HAND_SCALE_RANGE;
        for (s, ok) in [
            (1.0, true),
            (0.939, true),
            (lo, false),
            (hi, false),
            (lo + 1e-9, true),
            (f64::NAN, false),
            (f64::INFINITY, false),
        ] {
            assert_eq!(is_hand_scale(s), ok, "{s}");
            // every form of the hand's size checks it the same way
            assert_eq!(
                format!("{s}").parse::<HandScale>().is_ok(),
                ok,
                "parsed {s}"
            );
            assert_eq!(hand_skeletons(s, None).is_ok(), ok, "skeletons of {s}");
        }
    }

    #[test]
    fn one_hand_size_is_chosen_the_same_for_every_face() {
        use monohand_io::hand::{HandFile, HandSource};
        let file = HandFile::new(HandSource::Views, 0.94, 177.7);
        let given = |file, ruler_mm, scale| GivenHandSize {
            file,
            ruler_mm,
            scale,
        };
        assert_eq!(
            given(None, None, None).choose(),
            Ok((HandScale::Fixed(1.0), HandSizeSource::Default))
        );
        assert_eq!(
            given(Some(&file), None, None).choose(),
            Ok((HandScale::Fixed(0.94), HandSizeSource::File))
        );
        let (ruler, source) = given(None, Some(181.0), None).choose().unwrap();
        assert_eq!(source, HandSizeSource::Ruler);
        assert_eq!(ruler, HandScale::Fixed(scale_from_ruler(181.0).unwrap()));
        assert_eq!(
            given(None, None, Some(HandScale::Fixed(1.05))).choose(),
            Ok((HandScale::Fixed(1.05), HandSizeSource::Scale))
        );
        assert_eq!(
            given(None, None, Some(HandScale::Fixed(1.0))).choose(),
            Ok((HandScale::Fixed(1.0), HandSizeSource::Default))
        );
        assert_eq!(
            given(None, None, Some(HandScale::Auto)).choose(),
            Ok((HandScale::Auto, HandSizeSource::Default))
        );
        assert_eq!(
            given(Some(&file), Some(181.0), None).choose(),
            Err(HandSizeError::MoreThanOne(2))
        );
        assert!(matches!(
            given(None, Some(20.0), None).choose(),
            Err(HandSizeError::Ruler(_))
        ));
        assert_eq!(
            given(None, None, Some(HandScale::Fixed(9.0))).choose(),
            Err(HandSizeError::Scale(9.0))
        );
        let bad = HandFile::new(HandSource::Views, -1.0, 177.7);
        assert!(matches!(
            given(Some(&bad), None, None).choose(),
            Err(HandSizeError::File(_))
        ));
    }
    use super::*;

    #[test]
    fn hand_scale_parses_auto_or_a_factor_in_range() {
        assert_eq!("auto".parse::<HandScale>(), Ok(HandScale::Auto));
        assert_eq!("AUTO".parse::<HandScale>(), Ok(HandScale::Auto));
        assert_eq!("0.9".parse::<HandScale>(), Ok(HandScale::Fixed(0.9)));
        for bad in ["0", "0.3", "3", "NaN", "inf", "big", ""] {
            assert!(bad.parse::<HandScale>().is_err(), "{bad:?}");
        }
        assert_eq!(HandScale::Auto.initial(), 1.0);
        assert_eq!(HandScale::Fixed(1.2).initial(), 1.2);
    }
}
