//! `Session.track`'s frames when the caller's Python code makes them: any iterable of
//! images, `(image, time_s)` pairs or `read_video` frames, read on the engine's reader
//! thread, so that the caller's frames take `monohand run`'s path (the networks of one
//! frame beside the fit of the one before) instead of `process`'s one after the other.

use crate::convert::to_image;
use monohand::engine::{FrameSource, SourceError, SourceFrame};
use monohand::RgbImage;
use pyo3::exceptions::{PyStopIteration, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};
use std::sync::{Arc, Mutex};

/// Frame time when an item does not give one: 30 frames a second, as `process`.
const DEFAULT_FPS: f64 = 30.0;

/// What the views' sources share: the caller's iterator, and the later views' images of
/// the frame the first view read last.
struct Shared {
    iter: Py<PyAny>,
    views: usize,
    next: u64,
    /// The last time an item gave, and its frame's index: a frame without a time is
    /// 1/30 s per frame after it (`index / 30` when none gave one).
    clock: (f64, u64),
    /// Later views' images (view 2 first) of the current frame, taken as they are read.
    later: Vec<Option<RgbImage>>,
}

/// Where the exception that ended a caller's frames is kept for the stream to raise.
#[derive(Clone, Default)]
pub(crate) struct FramesError(Arc<Mutex<Option<PyErr>>>);

impl FramesError {
    /// The exception, once (`None` when the frames ended well or were not the caller's).
    pub(crate) fn take(&self) -> Option<PyErr> {
        self.0.lock().ok().and_then(|mut e| e.take())
    }
}

/// One view of the caller's frames.
pub(crate) struct PythonFrames {
    shared: Arc<Mutex<Shared>>,
    view: usize,
    error: FramesError,
}

/// One source per view over `iterable` (each item holds one image per view, as
/// `process` takes them), and where the exception that ends it will be.
pub(crate) fn sources(
    iterable: &Bound<'_, PyAny>,
    views: usize,
) -> PyResult<(Vec<Box<dyn FrameSource>>, FramesError)> {
    let iter = iterable.try_iter().map_err(|_| {
        PyValueError::new_err(
            "track takes a path, a list of paths (one per camera), or an iterable of frames \
             (images, (image, time_s) pairs or read_video frames)",
        )
    })?;
    let shared = Arc::new(Mutex::new(Shared {
        iter: iter.into_any().unbind(),
        views: views.max(1),
        next: 0,
        clock: (0.0, 0),
        later: Vec::new(),
    }));
    let error = FramesError::default();
    let sources = (0..views.max(1))
        .map(|view| {
            Box::new(PythonFrames {
                shared: Arc::clone(&shared),
                view,
                error: error.clone(),
            }) as Box<dyn FrameSource>
        })
        .collect();
    Ok((sources, error))
}

/// An item's images (one per view) and time, if it gives one.
fn parse_item(item: &Bound<'_, PyAny>, views: usize) -> PyResult<(Vec<RgbImage>, Option<f64>)> {
    let (images, time_s) = if let Ok(pair) = item.cast::<PyTuple>() {
        if pair.len() != 2 {
            return Err(PyValueError::new_err(format!(
                "a frame given as a tuple is (image, time_s), not {} items",
                pair.len()
            )));
        }
        let t: f64 = pair
            .get_item(1)?
            .extract()
            .map_err(|_| PyValueError::new_err("a frame's time_s must be a number of seconds"))?;
        (pair.get_item(0)?, Some(t))
    } else if item.hasattr("image")? && item.hasattr("time_s")? {
        (
            item.getattr("image")?,
            Some(item.getattr("time_s")?.extract()?),
        )
    } else {
        (item.clone(), None)
    };
    let images: Vec<RgbImage> = match images.cast::<PyList>() {
        Ok(list) => list.iter().map(|i| to_image(&i)).collect::<PyResult<_>>()?,
        Err(_) => vec![to_image(&images)?],
    };
    if images.len() != views {
        return Err(PyValueError::new_err(format!(
            "a frame with {} image(s) for a session of {views} camera(s): give one per camera",
            images.len()
        )));
    }
    if let Some(t) = time_s.filter(|t| !t.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "a frame's time_s must be finite, not {t}"
        )));
    }
    Ok((images, time_s))
}

impl Shared {
    /// The first view's next frame, the later views' kept for them.
    fn next_first(&mut self, py: Python<'_>) -> PyResult<Option<(u64, f64, RgbImage)>> {
        let item = match self.iter.bind(py).call_method0("__next__") {
            Ok(item) => item,
            Err(e) if e.is_instance_of::<PyStopIteration>(py) => return Ok(None),
            Err(e) => return Err(e),
        };
        let (images, time_s) = parse_item(&item, self.views)?;
        let index = self.next;
        let t = match time_s {
            Some(t) => {
                self.clock = (t, index);
                t
            }
            None => self.clock.0 + (index - self.clock.1) as f64 / DEFAULT_FPS,
        };
        self.next += 1;
        let mut images = images.into_iter();
        let first = images
            .next()
            .ok_or_else(|| PyValueError::new_err("no image"))?;
        self.later = images.map(Some).collect();
        Ok(Some((index, t, first)))
    }
}

impl PythonFrames {
    fn shared(&self) -> Result<std::sync::MutexGuard<'_, Shared>, SourceError> {
        self.shared
            .lock()
            .map_err(|_| SourceError::Other("the frames failed in another thread".into()))
    }
}

impl FrameSource for PythonFrames {
    fn next_frame(&mut self) -> Result<Option<SourceFrame>, SourceError> {
        if self.view > 0 {
            // Only the first view reads; the later ones take their image of its frame.
            return Err(SourceError::Other(
                "the caller's frames are matched by index".into(),
            ));
        }
        let mut shared = self.shared()?;
        match Python::attach(|py| shared.next_first(py)) {
            Ok(f) => Ok(f.map(|(index, t, image)| SourceFrame::given(index, t, image))),
            Err(e) => {
                let message = e.to_string();
                if let Ok(mut slot) = self.error.0.lock() {
                    *slot = Some(e);
                }
                Err(SourceError::Other(message))
            }
        }
    }

    fn frame_at(&mut self, index: u64, time_s: f64) -> Result<Option<SourceFrame>, SourceError> {
        if self.view == 0 {
            return self.next_frame();
        }
        let view = self.view;
        let image = self
            .shared()?
            .later
            .get_mut(view - 1)
            .and_then(Option::take);
        Ok(image.map(|i| SourceFrame::given(index, time_s, i)))
    }

    fn is_video(&self) -> bool {
        true
    }
}
