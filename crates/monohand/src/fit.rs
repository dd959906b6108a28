//! One hand's fit over its views, shared by the video session and the 2D-only lifter.

use crate::notes::{Note, NoteTopic};
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
        let (lo, hi) = HAND_SCALE_RANGE;
        if s.eq_ignore_ascii_case("auto") {
            return Ok(HandScale::Auto);
        }
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() && v > lo && v < hi => Ok(HandScale::Fixed(v)),
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
    if scale.is_finite() && scale > lo && scale < hi {
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
) -> crate::SessionResult<[HandSkeleton; 2]> {
    let (lo, hi) = HAND_SCALE_RANGE;
    if !(scale.is_finite() && scale > lo && scale < hi) {
        return Err(crate::settings::SettingsError::new(
            crate::settings::Field::HandScale,
            format!("{scale} must be between {lo} and {hi} (1: the average adult hand)"),
        )
        .into());
    }
    let side = |side| -> crate::SessionResult<HandSkeleton> {
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
