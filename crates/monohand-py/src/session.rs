//! `Session`, `TrackedFrame` and `FrameStream`: frames in, tracked absolute 3D hands out,
//! frame by frame or a whole video on the engine's threads.

use crate::camera::*;
use crate::convert::*;
use crate::errors::*;
use crate::frames::FramesError;
use crate::hand::*;
use crate::hand_size::*;
use crate::models::*;
use crate::recording::{rerun_sink, SharedSink};
use monohand::engine::{Engine, Observer, Output, RunReport, Sink};
use monohand::records::fitted_record;
use monohand::SessionOptions;
use monohand_core::filtering::OneEuroParams;
use monohand_io::jsonl::FrameRecord;
use pyo3::exceptions::{PyStopIteration, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyList;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::{Arc, Mutex};

/// Frames in, tracked absolute 3D hands out.
///
/// `Session(cameras=None, hands=2, tracking=True, ...)`: `cameras` is a `Camera`, a list
/// of them (a calibrated rig, the first the reference), or `None` (a generic camera for the
/// image size; the 3D is then only as absolute as that guess). `hand_scale` sizes the
/// average adult hand (0.9 for a small hand; the absolute depth scales with it).
/// `precision` is "f32", "int8" or "auto" (int8 with 5 cameras or more, else f32; with
/// `models`, the models' precision). Use it as
/// a context manager,
/// and call `process(image, time_s)` once per frame in order. `rerun="hands.rrd"` writes
/// every frame of the session (`process`'s and `track`'s) into a Rerun recording, as
/// `monohand run --rerun` does (images scaled by `rerun_image_scale`); it is complete once
/// the session is closed.
#[pyclass(module = "monohand._monohand", name = "Session")]
pub(crate) struct PySession {
    pub(crate) inner: Option<monohand::Session>,
    pub(crate) next_time: f64,
    /// The same pipeline, cameras and settings as the engine `track` runs.
    pub(crate) engine: Arc<Engine>,
    /// The Rerun recording every frame also goes to.
    pub(crate) rerun: Option<SharedSink>,
}

impl PySession {
    pub(crate) fn session(&mut self) -> PyResult<&mut monohand::Session> {
        self.inner
            .as_mut()
            .ok_or_else(|| PyValueError::new_err("the session is closed"))
    }
}

#[pymethods]
impl PySession {
    #[new]
    #[pyo3(signature = (cameras=None, hands=2, tracking=true, model_dir=None, smoothing=false, heads=false, detect_every=10, models=None, hand_scale=None, mirror_pass=true, rectify_crops="off", precision="auto", hand=None, rerun=None, rerun_image_scale=1.0, fitted_crops=true))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        cameras: Option<&Bound<'_, PyAny>>,
        hands: usize,
        tracking: bool,
        model_dir: Option<std::path::PathBuf>,
        smoothing: bool,
        heads: bool,
        detect_every: usize,
        models: Option<PyRef<'_, PyModels>>,
        hand_scale: Option<f64>,
        mirror_pass: bool,
        rectify_crops: &str,
        precision: &str,
        hand: Option<&Bound<'_, PyAny>>,
        rerun: Option<std::path::PathBuf>,
        rerun_image_scale: f64,
        fitted_crops: bool,
    ) -> PyResult<PySession> {
        let (skeletons, hand_size) = sized_hands(hand, hand_scale)?;
        let cameras = to_cameras(cameras)?;
        let rerun = rerun
            .map(|p| rerun_sink(&p, cameras.len(), rerun_image_scale))
            .transpose()?;
        let choice: monohand::PrecisionChoice = precision_arg(precision)?;
        // `auto` with shared models takes the models' precision; else it is the views'.
        let precision = match (&models, choice) {
            (Some(m), monohand::PrecisionChoice::Auto) => m.precision,
            _ => choice.for_views(cameras.len().max(1)),
        };
        let rectify = rectify_crops
            .parse()
            .map_err(|e| PyValueError::new_err(format!("rectify_crops: {e}")))?;
        let mut options = SessionOptions::default()
            .hands(hands)
            .tracking(tracking)
            .heads(heads)
            .mirror_pass(mirror_pass)
            .precision(precision)
            .skeletons(skeletons)
            .smoothing(smoothing.then(OneEuroParams::default))
            .detect_every(detect_every);
        options.settings.rectify = rectify;
        options.settings.fitted_crops = fitted_crops;
        options.settings.fit.hand_size = hand_size;
        let resolved = options
            .settings
            .clone()
            .resolve()
            .map_err(|e| settings_err(&e))?;
        if let Some(dir) = model_dir {
            options = options.model_dir(dir);
        }
        let pipeline = match models {
            Some(m) => {
                if (m.hands, m.tracking, m.heads, m.mirror_pass, m.precision)
                    != (hands, tracking, heads, mirror_pass, precision)
                {
                    return Err(PyValueError::new_err(format!(
                        "the session asks for hands={hands}, tracking={}, heads={}, \
                         mirror_pass={}, precision={:?} but the models were loaded with {}",
                        py_bool(tracking),
                        py_bool(heads),
                        py_bool(mirror_pass),
                        precision.name(),
                        m.__repr__()
                    )));
                }
                Arc::clone(&m.pipeline)
            }
            // Loading (and on first use fetching) the networks takes a while: let Python run.
            None => Arc::new(
                py.detach(|| monohand::Session::load_pipeline(&options))
                    .map_err(session_err)?,
            ),
        };
        let engine =
            Engine::new(Arc::clone(&pipeline), cameras.clone(), resolved).map_err(engine_err)?;
        let inner =
            monohand::Session::with_pipeline(cameras, pipeline, options).map_err(session_err)?;
        Ok(PySession {
            inner: Some(inner),
            next_time: 0.0,
            engine: Arc::new(engine),
            rerun,
        })
    }

    /// Tracks a whole input, `monohand run`'s way: `path` is a video file (anything ffmpeg
    /// reads), an image, a folder of images or `webcam:N`. Decoding, the networks and the
    /// fit run on threads of their own, without the GIL, as in `monohand run` (the same
    /// engine). Returns an iterator over the frames, in order, each a `TrackedFrame`; at
    /// most a few frames wait in memory. Each call starts from a fresh state (its own
    /// tracks and ids), apart from `process`'s. An input that ends on an error raises
    /// `MonohandError` after its good frames. `path` may also be the caller's own frames:
    /// any iterable of images (an `(H, W, 3)` uint8 array, or a list of them, one per
    /// camera), `(image, time_s)` pairs or `read_video` frames (without a time: 30 frames a
    /// second), taken on the engine's reader thread, so that a frame loop over them runs
    /// at `run`'s speed where `process` waits for the fit after the networks; an exception
    /// the iterable raises, or a frame that is not an image, is raised after the frames
    /// before it. `offline=True` is `monohand run --offline`:
    /// each frame is refitted with the frames after it too (needs a tracking session).
    /// A calibrated rig's session takes a list of paths, one per camera; `sync` is how
    /// their frames are matched: `"index"` (the default), `"auto"` (each view's start found
    /// from the hands, then frames matched by time; a view whose start cannot be found
    /// raises `MonohandError`) or how many seconds each later view started after the first
    /// (a list), as `monohand run --sync`. Each frame's `cameras` say each view's
    /// `time_offset_s`. `lerobot="DIR"` also writes the input as a LeRobot v3 dataset of one
    /// episode (`monohand run --lerobot`, its task `lerobot_task`; `DIR` must be new), whole
    /// once the stream has ended, also when it is closed early or fails.
    #[pyo3(signature = (path, max_frames=None, offline=false, sync=None, lerobot=None, lerobot_task="human hand"))]
    #[allow(clippy::too_many_arguments)]
    fn track(
        &mut self,
        py: Python<'_>,
        path: &Bound<'_, PyAny>,
        max_frames: Option<u64>,
        offline: bool,
        sync: Option<&Bound<'_, PyAny>>,
        lerobot: Option<std::path::PathBuf>,
        lerobot_task: &str,
    ) -> PyResult<PyFrameStream> {
        self.session()?;
        let mut engine = (*self.engine)
            .clone()
            .with_max_frames(max_frames)
            .with_offline(offline)
            .map_err(engine_err)?;
        let (sources, frames_error) = match crate::sync::paths_of(path)? {
            Some(views) => {
                if let Some(offsets) = crate::sync::offsets(py, sync, &engine, &views)? {
                    engine = engine.with_view_offsets(offsets);
                }
                let sources = py
                    .detach(|| crate::sync::open(&views))
                    .map_err(MonohandError::new_err)?;
                (sources, FramesError::default())
            }
            None => {
                crate::sync::no_sync_for_frames(sync)?;
                crate::frames::sources(path, engine.cameras().len())?
            }
        };
        engine.check_sources(&sources).map_err(engine_err)?;
        let (tx, rx) = sync_channel::<FrameRecord>(8);
        let watch = Arc::new(Watch::default());
        let observer = Arc::clone(&watch);
        let rerun = self.rerun.clone();
        let source = crate::sync::paths_of(path)?.and_then(|v| v.first().cloned());
        let lerobot = lerobot
            .map(|d| {
                crate::lerobot::sink(
                    &d,
                    sources.len(),
                    sources.first().and_then(|s| s.fps()),
                    lerobot_task,
                    source.as_deref().map(std::path::Path::new),
                )
            })
            .transpose()?;
        let worker = std::thread::Builder::new()
            .name("monohand-track".into())
            .spawn(move || {
                let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(ChannelSink(tx))];
                sinks.extend(rerun.map(|r| Box::new(r) as Box<dyn Sink>));
                sinks.extend(lerobot.map(|l| l as Box<dyn Sink>));
                engine.run(sources, &mut sinks, &*observer)
            })
            .map_err(|e| MonohandError::new_err(format!("could not start a thread: {e}")))?;
        Ok(PyFrameStream {
            rx: Some(Mutex::new(rx)),
            worker: Some(worker),
            watch,
            report: None,
            frames_error,
        })
    }

    /// Processes one frame: `image` is an `(H, W, 3)` uint8 RGB array, or a list of them,
    /// one per camera. `time_s` is the frame's time in seconds (default: 30 fps). Returns
    /// the frame's hands.
    #[pyo3(signature = (image, time_s=None))]
    fn process(
        &mut self,
        py: Python<'_>,
        image: &Bound<'_, PyAny>,
        time_s: Option<f64>,
    ) -> PyResult<Vec<PyHand>> {
        Ok(self
            .process_record(py, image, time_s)?
            .hands
            .into_iter()
            .map(|inner| PyHand { inner })
            .collect())
    }

    /// Like `process`, but returns the whole frame record (as `monohand run` writes it) as
    /// a dict, with the heads and any per-frame error.
    #[pyo3(signature = (image, time_s=None))]
    fn process_dict<'py>(
        &mut self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        time_s: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let record = self.process_record(py, image, time_s)?;
        as_python(py, &record)
    }

    /// Messages for the user since the last call (assumptions made, hand size found).
    fn notes(&mut self) -> PyResult<Vec<String>> {
        Ok(self.session()?.take_notes())
    }

    /// The cameras in use (a generic one once the first image told its size, if none
    /// was given).
    #[getter]
    fn cameras(&mut self) -> PyResult<Vec<PyCamera>> {
        Ok(self
            .session()?
            .cameras()
            .iter()
            .map(|&inner| PyCamera { inner })
            .collect())
    }

    /// Frees the networks and completes the Rerun recording; later calls raise.
    fn close(&mut self) -> PyResult<()> {
        self.inner = None;
        if let Some(r) = self.rerun.take() {
            r.lock()
                .and_then(|mut s| s.finish())
                .map_err(|e| MonohandError::new_err(format!("rerun: {e}")))?;
        }
        Ok(())
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, _args: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.close()?;
        Ok(false)
    }
}

impl PySession {
    pub(crate) fn process_record(
        &mut self,
        py: Python<'_>,
        image: &Bound<'_, PyAny>,
        time_s: Option<f64>,
    ) -> PyResult<FrameRecord> {
        let images: Vec<monohand::RgbImage> = if let Ok(list) = image.cast::<PyList>() {
            list.iter().map(|i| to_image(&i)).collect::<PyResult<_>>()?
        } else {
            vec![to_image(image)?]
        };
        let t = time_s.unwrap_or(self.next_time);
        self.next_time = t + 1.0 / 30.0;
        let session = self.session()?;
        let mut done = py
            .detach(|| {
                let refs: Vec<&monohand::RgbImage> = images.iter().collect();
                session.process(&refs, t)
            })
            .map_err(session_err)?;
        // Without the stereo hand-size measurement (not offered here) every frame comes
        // back at once.
        let Some(frame) = done.pop() else {
            return Err(MonohandError::new_err("the session kept the frame back"));
        };
        let mut record = fitted_record(&frame, None);
        record.time_s = Some(t);
        if let Some(e) = record.error.take() {
            return Err(MonohandError::new_err(e));
        }
        if let Some(rerun) = &self.rerun {
            let mut views = images.into_iter().map(Some);
            let first = views.next().flatten();
            let others: Vec<Option<monohand::RgbImage>> = views.collect();
            let output = Output {
                record: &record,
                image: first.as_ref(),
                cameras: &frame.cameras,
                other_images: &others,
                fitted: Some(&frame),
            };
            rerun
                .lock()
                .and_then(|mut s| s.write(&output))
                .map_err(|e| MonohandError::new_err(format!("rerun: {e}")))?;
        }
        Ok(record)
    }
}

/// The engine's side of a `track` call: Python's wish to stop, and the notes for the user.
#[derive(Default)]
pub(crate) struct Watch {
    pub(crate) stop: AtomicBool,
    pub(crate) notes: Mutex<Vec<String>>,
}

impl Observer for Watch {
    fn cancelled(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    fn note(&self, note: &monohand::Note) {
        if let Ok(mut n) = self.notes.lock() {
            n.push(note.message.clone());
        }
    }
}

/// Hands each record to Python's iterator; a full queue makes the engine wait.
pub(crate) struct ChannelSink(pub(crate) SyncSender<FrameRecord>);

impl Sink for ChannelSink {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), monohand::engine::SinkError> {
        self.0
            .send(frame.record.clone())
            .map_err(|_| "the iterator over the frames was closed".into())
    }
}

/// One frame of `Session.track`: `index`, `time_s` (for videos), `hands`, `error` (why
/// the frame could not be read, else `None`), `cameras` (the camera of each view the
/// hands were fitted with, as dicts) and `to_dict()`, the whole record as `monohand run`
/// writes it.
#[pyclass(module = "monohand._monohand", name = "TrackedFrame", frozen)]
pub(crate) struct PyTrackedFrame {
    pub(crate) record: FrameRecord,
}

#[pymethods]
impl PyTrackedFrame {
    /// Frame index, from 0.
    #[getter]
    fn index(&self) -> u64 {
        self.record.frame
    }
    /// Time of the frame in the video, seconds (`None` for independent images).
    #[getter]
    fn time_s(&self) -> Option<f64> {
        self.record.time_s
    }
    /// The frame's hands.
    #[getter]
    fn hands(&self) -> Vec<PyHand> {
        self.record
            .hands
            .iter()
            .map(|h| PyHand { inner: h.clone() })
            .collect()
    }
    /// Why the frame has no result, else `None`.
    #[getter]
    fn error(&self) -> Option<String> {
        self.record.error.clone()
    }
    /// The camera of each view the frame was fitted with (`fx, fy, cx, cy, width, height,
    /// source`), as dicts.
    #[getter]
    fn cameras<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        as_python(py, &self.record.cameras)
    }
    /// The whole record, as `monohand run` writes it (docs/output-format.md).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        as_python(py, &self.record)
    }
    fn __repr__(&self) -> String {
        format!(
            "TrackedFrame(index={}, hands={})",
            self.record.frame,
            self.record.hands.len()
        )
    }
}

/// The frames of a `Session.track` call, in order, as they are done.
#[pyclass(module = "monohand._monohand", name = "FrameStream")]
pub(crate) struct PyFrameStream {
    /// In a mutex only because Python objects must be shareable between threads.
    pub(crate) rx: Option<Mutex<Receiver<FrameRecord>>>,
    pub(crate) worker: Option<std::thread::JoinHandle<monohand::engine::EngineResult<RunReport>>>,
    pub(crate) watch: Arc<Watch>,
    pub(crate) report: Option<RunReport>,
    /// The exception that ended the caller's own frames, raised as it was.
    pub(crate) frames_error: FramesError,
}

impl PyFrameStream {
    /// Waits for the engine to end and keeps its report; its error, if any.
    pub(crate) fn join(&mut self, py: Python<'_>) -> PyResult<()> {
        self.rx = None;
        let Some(worker) = self.worker.take() else {
            return Ok(());
        };
        let result = py
            .detach(|| worker.join())
            .map_err(|_| MonohandError::new_err("the engine's thread failed"))?;
        let report = result.map_err(|e| MonohandError::new_err(monohand::engine::chain(&e)))?;
        let input_error = report.input_error.clone();
        self.report = Some(report);
        if let Some(e) = self.frames_error.take() {
            return Err(e);
        }
        match input_error {
            Some(e) => Err(MonohandError::new_err(e.to_string())),
            None => Ok(()),
        }
    }
}

#[pymethods]
impl PyFrameStream {
    fn __iter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<PyTrackedFrame> {
        let Some(rx) = self.rx.as_ref() else {
            return Err(PyStopIteration::new_err(()));
        };
        let next = py.detach(|| match rx.lock() {
            Ok(rx) => rx.recv().ok(),
            Err(_) => None,
        });
        match next {
            Some(record) => Ok(PyTrackedFrame { record }),
            None => {
                self.join(py)?;
                Err(PyStopIteration::new_err(()))
            }
        }
    }

    /// Messages for the user so far (assumptions made, hand size found).
    fn notes(&self) -> Vec<String> {
        self.watch
            .notes
            .lock()
            .map(|n| n.clone())
            .unwrap_or_default()
    }

    /// Totals once the stream has ended (`frames`, `frames_with_hands`, `hands`,
    /// `hands_3d`, `mean_reprojection_px`, `unreadable`, `seconds`, `fps`), else `None`.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let Some(r) = &self.report else {
            return Ok(None);
        };
        let json = serde_json::json!({
            "frames": r.frames,
            "frames_with_hands": r.frames_with_hands,
            "hands": r.hands,
            "hands_3d": r.hands_3d,
            "mean_reprojection_px": r.mean_reprojection_px(),
            "unreadable": r.unreadable,
            "seconds": r.seconds,
            "fps": r.frames as f64 / r.seconds.max(1e-9),
        });
        as_python(py, &json).map(Some)
    }

    /// Stops the engine (the frame in flight is finished) and waits for it.
    fn close(&mut self, py: Python<'_>) {
        self.watch.stop.store(true, Ordering::Relaxed);
        self.rx = None;
        let _ = self.join(py);
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

impl Drop for PyFrameStream {
    fn drop(&mut self) {
        // The engine stops at its next frame: its sink fails once the queue is gone.
        self.watch.stop.store(true, Ordering::Relaxed);
    }
}
