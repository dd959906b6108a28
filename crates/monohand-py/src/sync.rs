//! `Session.track`'s views of a rig and how they are matched in time (`sync`): the same
//! as `monohand run --view ... --sync` (docs/calibration.md, "Videos that did not start
//! together").

use crate::errors::*;
use monohand::core::sync::{SyncSettings, ViewOffset};
use monohand::engine::sync::{find_offsets, SYNC_FRAMES};
use monohand::engine::{Engine, FrameSource, Input, DEFAULT_STALL_TIMEOUT};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The inputs `path` names when it is a path (one view) or a list of paths (one per
/// camera); `None` when it is neither (the caller's own frames).
pub(crate) fn paths_of(path: &Bound<'_, PyAny>) -> PyResult<Option<Vec<String>>> {
    if let Ok(one) = path.extract::<std::path::PathBuf>() {
        return Ok(Some(vec![one.to_string_lossy().into_owned()]));
    }
    let Ok(many) = path.extract::<Vec<std::path::PathBuf>>() else {
        return Ok(None);
    };
    if many.is_empty() {
        return Err(PyValueError::new_err("path: an empty list of views"));
    }
    Ok(Some(
        many.iter()
            .map(|p| p.to_string_lossy().into_owned())
            .collect(),
    ))
}

/// The caller's own frames come in the order given: refuses any `sync` but `"index"`.
pub(crate) fn no_sync_for_frames(sync: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
    let Some(sync) = sync.filter(|s| !s.is_none()) else {
        return Ok(());
    };
    match sync.extract::<String>().ok().as_deref() {
        Some("index") => Ok(()),
        _ => Err(PyValueError::new_err(
            "sync matches the videos of a rig in time; frames given by the caller hold one \
             image per camera already (each item a list of images)",
        )),
    }
}

/// Opens every view; an error names the view when there are several.
pub(crate) fn open(views: &[String]) -> Result<Vec<Box<dyn FrameSource>>, String> {
    views
        .iter()
        .enumerate()
        .map(|(v, s)| {
            Input::parse(s)
                .and_then(|i| i.open(DEFAULT_STALL_TIMEOUT))
                .map_err(|e| match views.len() {
                    1 => e.to_string(),
                    _ => format!("view {}: {e}", v + 1),
                })
        })
        .collect()
}

/// Each view's offset (seconds, the first view's 0) that `sync` asks for: `None` or
/// `"index"`: none (frames matched by index); `"auto"`: found from the hands (the views
/// read once more); a list: how late each later view started. Without the GIL for `auto`.
pub(crate) fn offsets(
    py: Python<'_>,
    sync: Option<&Bound<'_, PyAny>>,
    engine: &Engine,
    views: &[String],
) -> PyResult<Option<Vec<f64>>> {
    let Some(sync) = sync.filter(|s| !s.is_none()) else {
        return Ok(None);
    };
    let word = sync.extract::<String>().ok();
    if word.as_deref() == Some("index") {
        return Ok(None);
    }
    if views.len() < 2 || engine.cameras().len() != views.len() {
        return Err(PyValueError::new_err(
            "sync matches the views of a calibrated rig in time: it needs a list of two or more \
             paths and a Session with one camera per path",
        ));
    }
    if word.as_deref() == Some("auto") {
        let found = py
            .detach(|| {
                let sources = open(views)?;
                find_offsets(
                    engine.pipeline(),
                    engine.settings(),
                    engine.cameras(),
                    sources,
                    SYNC_FRAMES,
                    &SyncSettings::default(),
                )
                .map_err(|e| e.to_string())
            })
            .map_err(MonohandError::new_err)?;
        let mut out = Vec::with_capacity(found.len());
        for (v, o) in found.iter().enumerate() {
            match o {
                ViewOffset::Found(f) => out.push(f.offset_s),
                ViewOffset::Open(why) => {
                    return Err(MonohandError::new_err(format!(
                        "sync=\"auto\": view {}'s start could not be found ({why}); give the \
                         offsets (sync=[seconds for each view after the first])",
                        v + 1
                    )))
                }
            }
        }
        return Ok(Some(out));
    }
    let later: Vec<f64> = sync.extract().map_err(|_| {
        PyValueError::new_err(
            "sync must be \"index\", \"auto\" or a list of seconds, one per view after the first",
        )
    })?;
    if later.len() + 1 != views.len() || later.iter().any(|x| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "sync gives {} offset(s) for {} later view(s): one finite number of seconds each",
            later.len(),
            views.len() - 1
        )));
    }
    Ok(Some(std::iter::once(0.0).chain(later).collect()))
}
