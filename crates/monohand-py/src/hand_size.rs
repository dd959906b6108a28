//! `HandSize`: the person's hand, measured once and reused; the hand models a size gives.

use crate::convert::*;
use crate::errors::*;
use monohand_core::prelude::*;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The default (population average) hands, left then right, scaled by `hand_scale`
/// ([`monohand::hand_skeletons`]).
pub(crate) fn skeletons(hand_scale: f64) -> PyResult<[HandSkeleton; 2]> {
    monohand::hand_skeletons(hand_scale, None).map_err(session_err)
}

/// The hands of a `hand=` (a `HandSize` or a hand file's path) or a `hand_scale=` (not
/// both; neither: the default size), and where their size came from.
pub(crate) fn sized_hands(
    hand: Option<&Bound<'_, PyAny>>,
    hand_scale: Option<f64>,
) -> PyResult<([HandSkeleton; 2], monohand::HandSizeSource)> {
    let hand = hand.map(PyHandSize::from_arg).transpose()?;
    // A `HandSize.from_length` is a ruler's length; one loaded, a hand file.
    let (file, ruler_mm) = match &hand {
        Some(h) if h.source == monohand::HandSizeSource::Ruler => (None, h.file.ruler_mm),
        Some(h) => (Some(&h.file), None),
        None => (None, None),
    };
    let given = monohand::GivenHandSize {
        file,
        ruler_mm,
        scale: hand_scale.map(monohand::HandScale::Fixed),
    };
    let (scale, source) = given.choose().map_err(|e| match e {
        monohand::HandSizeError::MoreThanOne(_) => {
            PyValueError::new_err("give hand= or hand_scale=, not both")
        }
        e @ monohand::HandSizeError::Scale(_) if given.file.is_none() => {
            PyValueError::new_err(format!("hand_scale: {e}"))
        }
        e => PyValueError::new_err(format!("hand: {e}")),
    })?;
    Ok((skeletons(scale.initial())?, source))
}

/// A person's hand, measured once and reused: the hand file of `monohand run --save-hand`
/// (docs/absolute-depth.md).
///
/// `HandSize.load(path)` reads one, `HandSize.from_length(mm)` makes one from a ruler's
/// hand length (the hand flat, wrist crease to the end of the middle finger), `save(path)`
/// writes it. `Session(hand=...)` and `Lifter(hand=...)` fit both hands at its size. (The
/// name `Hand` is the fitted hand a session returns.)
#[pyclass(module = "monohand._monohand", name = "HandSize", frozen)]
#[derive(Clone)]
pub(crate) struct PyHandSize {
    pub(crate) file: monohand_io::hand::HandFile,
    /// What the records say of it: `file` when loaded, `ruler` from a length.
    pub(crate) source: monohand::HandSizeSource,
}

impl PyHandSize {
    /// The hand size of `hand`: a `HandSize`, or a path to a hand file.
    pub(crate) fn from_arg(hand: &Bound<'_, PyAny>) -> PyResult<PyHandSize> {
        if let Ok(h) = hand.cast::<PyHandSize>() {
            return Ok(h.get().clone());
        }
        let path: std::path::PathBuf = hand.extract().map_err(|_| {
            PyValueError::new_err("hand must be a HandSize or the path of a hand file")
        })?;
        PyHandSize::load(path)
    }
}

#[pymethods]
impl PyHandSize {
    /// Reads a hand file.
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<PyHandSize> {
        let file = monohand_io::hand::read_hand(&path).map_err(io_err)?;
        Ok(PyHandSize {
            file,
            source: monohand::HandSizeSource::File,
        })
    }

    /// The hand of a ruler's length in mm (the hand flat, from the wrist crease to the end
    /// of the middle finger).
    #[staticmethod]
    fn from_length(length_mm: f64) -> PyResult<PyHandSize> {
        let scale = monohand::scale_from_ruler(length_mm)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let model = HandSkeleton::default_for(HandSide::Right).hand_length() * scale;
        Ok(PyHandSize {
            file: monohand_io::hand::HandFile {
                ruler_mm: Some(length_mm),
                ..monohand_io::hand::HandFile::new(
                    monohand_io::hand::HandSource::Ruler,
                    scale,
                    model,
                )
            },
            source: monohand::HandSizeSource::Ruler,
        })
    }

    /// Writes the hand file (whole or not at all).
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        monohand_io::hand::write_hand(&path, &self.file).map_err(io_err)
    }

    /// The size as a factor on the default adult hand.
    #[getter]
    fn scale(&self) -> f64 {
        self.file.scale
    }

    /// The standard uncertainty of `scale` (None where unknown).
    #[getter]
    fn scale_sigma(&self) -> Option<f64> {
        self.file.scale_sigma
    }

    /// The model's wrist-to-middle-fingertip length at this size, mm.
    #[getter]
    fn hand_length_mm(&self) -> f64 {
        self.file.hand_length_mm
    }

    /// `"views"` (measured by a calibrated rig) or `"ruler"`.
    #[getter]
    fn source(&self) -> &'static str {
        self.file.source.as_str()
    }

    /// The side it was measured on (None for a ruler's).
    #[getter]
    fn side(&self) -> Option<&'static str> {
        self.file.side.map(side_name)
    }

    /// The frames it was measured on.
    #[getter]
    fn frames(&self) -> Vec<u64> {
        self.file.frames.clone()
    }

    /// Each bone's length where the views support it (None elsewhere), mm.
    #[getter]
    fn bone_lengths_mm(&self) -> Option<Vec<Option<f64>>> {
        self.file.bone_lengths_mm.map(|b| b.to_vec())
    }

    fn __repr__(&self) -> String {
        format!(
            "HandSize(scale={:.4}, hand_length_mm={:.1}, source={:?})",
            self.file.scale,
            self.file.hand_length_mm,
            self.file.source.as_str()
        )
    }
}
