//! `Frame` and `VideoReader`: a video's frames decoded ahead by ffmpeg.

use crate::errors::*;
use monohand_media::video::{VideoInput, VideoReader};
use numpy::ndarray::Array3;
use numpy::PyArray3;
use pyo3::exceptions::{PyStopIteration, PyValueError};
use pyo3::prelude::*;
use std::sync::mpsc::{sync_channel, Receiver};
use std::sync::Mutex;

/// One decoded video frame: `index`, `time_s` and `image`, an `(H, W, 3)` uint8 RGB array
/// (handed over from the decoder without a copy).
#[pyclass(module = "monohand._monohand", name = "Frame", frozen, get_all)]
pub(crate) struct PyFrame {
    /// Frame index, from 0.
    pub(crate) index: u64,
    /// Nominal time, seconds (`index / fps`).
    pub(crate) time_s: f64,
    /// The pixels.
    pub(crate) image: Py<PyArray3<u8>>,
}

/// Frames a [`PyVideoReader`] decodes ahead of its caller: while Python processes one
/// frame, up to this many more are decoded and waiting (about 0.9 MB each at 640x480).
pub(crate) const DECODE_AHEAD: usize = 3;

/// What the decoding thread hands over: a frame, the end (`None`), or the error that ended
/// the video.
pub(crate) type Decoded = monohand_io::IoResult<Option<monohand_media::video::VideoFrame>>;

/// The frames of a video file (anything ffmpeg reads), decoded by an ffmpeg child process.
///
/// A thread of its own reads the frames from ffmpeg, [`DECODE_AHEAD`] ahead of the caller
/// (a bounded channel: it waits when they are not taken), so that decoding runs while
/// Python processes the frame before; taking a frame waits with the GIL released.
#[pyclass(module = "monohand._monohand", name = "VideoReader")]
pub(crate) struct PyVideoReader {
    /// The stream's description; `None` once closed or ended.
    pub(crate) info: Option<monohand_media::video::VideoInfo>,
    /// The decoded frames (in a mutex only to keep the class `Sync`; `&mut self` reaches
    /// it without locking).
    pub(crate) frames: Option<Mutex<Receiver<Decoded>>>,
    /// The decoding thread, which owns the reader (and so ffmpeg).
    pub(crate) decoder: Option<std::thread::JoinHandle<()>>,
}

impl PyVideoReader {
    /// Stops decoding: the thread's next hand-over fails, it ends and drops the reader,
    /// which stops ffmpeg; waits for that (a frame's decoding at most).
    pub(crate) fn stop(&mut self) {
        self.info = None;
        self.frames = None;
        if let Some(t) = self.decoder.take() {
            let _ = t.join();
        }
    }
}

impl Drop for PyVideoReader {
    fn drop(&mut self) {
        self.stop();
    }
}

#[pymethods]
impl PyVideoReader {
    #[new]
    fn new(py: Python<'_>, path: String) -> PyResult<PyVideoReader> {
        let input = VideoInput::parse(&path);
        let mut reader = py.detach(|| VideoReader::open(&input)).map_err(io_err)?;
        let info = reader.info().clone();
        let (tx, rx) = sync_channel::<Decoded>(DECODE_AHEAD);
        let decoder = std::thread::Builder::new()
            .name("monohand-video".into())
            .spawn(move || loop {
                let next = reader.next_frame();
                let more = matches!(next, Ok(Some(_)));
                if tx.send(next).is_err() || !more {
                    return;
                }
            })
            .map_err(|e| {
                MonohandError::new_err(format!("cannot start the decoding thread: {e}"))
            })?;
        Ok(PyVideoReader {
            info: Some(info),
            frames: Some(Mutex::new(rx)),
            decoder: Some(decoder),
        })
    }

    /// Frames per second (30 if the file does not say).
    #[getter]
    fn fps(&self) -> PyResult<f64> {
        self.info
            .as_ref()
            .map(|i| i.fps_or_default())
            .ok_or_else(|| PyValueError::new_err("the reader is closed"))
    }

    /// `(width, height)` of the frames.
    #[getter]
    fn size(&self) -> PyResult<(usize, usize)> {
        self.info
            .as_ref()
            .map(|i| (i.width, i.height))
            .ok_or_else(|| PyValueError::new_err("the reader is closed"))
    }

    fn __iter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<PyFrame> {
        let Some(frames) = self.frames.as_mut() else {
            return Err(PyStopIteration::new_err(()));
        };
        let rx = match frames.get_mut() {
            Ok(rx) => rx,
            Err(poisoned) => poisoned.into_inner(),
        };
        // The thread's last message is the end or an error, after which it is not asked
        // again: a closed channel here means it panicked.
        // `move`: the closure owns the `&mut` (Send), not a shared `&Receiver` (not Sync).
        let Ok(next) = py.detach(move || rx.recv()) else {
            py.detach(|| self.stop());
            return Err(MonohandError::new_err("the video's decoding thread failed"));
        };
        match next {
            Ok(Some(f)) => {
                let (w, h) = f.image.dimensions();
                let arr = Array3::from_shape_vec((h as usize, w as usize, 3), f.image.into_raw())
                    .map_err(|e| MonohandError::new_err(e.to_string()))?;
                Ok(PyFrame {
                    index: f.index,
                    time_s: f.timestamp_s,
                    image: PyArray3::from_owned_array(py, arr).unbind(),
                })
            }
            Ok(None) => {
                py.detach(|| self.stop());
                Err(PyStopIteration::new_err(()))
            }
            Err(e) => {
                py.detach(|| self.stop());
                Err(io_err(e))
            }
        }
    }

    /// Stops ffmpeg.
    fn close(&mut self, py: Python<'_>) {
        py.detach(|| self.stop());
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, py: Python<'_>, _args: &Bound<'_, pyo3::types::PyTuple>) -> bool {
        self.close(py);
        false
    }
}
