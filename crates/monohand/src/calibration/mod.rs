//! Calibrating cameras from frames of a printed chessboard: images, a folder, a video or a
//! webcam in (one input a camera), each camera's intrinsics and distortion out, and for a
//! rig the poses between the cameras. `monohand calibrate` and Python's
//! `monohand.calibrate` are this module; the corner finder and the estimate are
//! [`monohand_calib`]'s.
//!
//! Images are all used (the user chose them). From a video or a webcam, frames are
//! examined a few times a second, and a frame is kept only when the board is whole, still
//! (its corners moved under [`MAX_MOTION_PX`] a frame since the frame examined before),
//! about as sharp as the views kept, and in another place or pose than every view kept
//! ([`MIN_VIEW_DISTANCE`]); at most [`CalibrateSettings::max_views`] views, the first
//! that pass. A webcam stops by itself once it has enough views spread over the image. A rig's inputs pair by order (images, sorted by file name)
//! or by time (videos).

mod frames;
mod report;
mod window;

pub use frames::{Coverage, SeenFrame};
pub use monohand_calib::calibrate::{
    CalibWarning, CalibrateOptions, CameraCalibration, DistortionModel, RigCalibration,
};
pub use monohand_calib::{Board, CalibError};
pub use report::{
    camera_info, date_utc, depth_std_mm, draw_seen, markdown_report, picture, summary,
    HAND_DEPTH_MM,
};
pub use window::CalibrationWindow;

use crate::engine::{EngineError, Input};
use monohand_calib::calibrate::{calibrate_camera, calibrate_rig, BoardView};
use std::path::{Path, PathBuf};

/// Mean corner motion between two examined frames, pixels per frame, above which a video
/// frame is taken as moving (motion blur, rolling shutter) and not kept.
pub const MAX_MOTION_PX: f64 = 1.5;

/// How different a new view must be from every view kept: the mean distance between the
/// boards' corners, as a fraction of the image's diagonal (2.5% is 20 px at 640x480; of
/// the 13 poses of OpenCV's sample photos, one is 15 px from another).
pub const MIN_VIEW_DISTANCE: f64 = 0.025;

/// How a calibration runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrateSettings {
    /// The board.
    pub board: Board,
    /// The estimate's options (distortion model, outliers).
    pub options: CalibrateOptions,
    /// From a video or a webcam: views (instants, for a rig) kept at most.
    pub max_views: usize,
    /// A webcam stops by itself once it has this many views and [`Coverage::fraction`]
    /// of at least [`CalibrateSettings::live_coverage`] (and whenever the caller says stop).
    pub live_views: usize,
    /// See [`CalibrateSettings::live_views`].
    pub live_coverage: f64,
    /// Video frames examined per second of video (a webcam: every frame that comes).
    pub examine_fps: f64,
    /// The corners' subpixel window (half width, OpenCV's `winSize`); `None` fits it to
    /// the squares ([`monohand_calib::corners::refine_half_window`]).
    pub half_window: Option<usize>,
}

impl CalibrateSettings {
    /// The defaults for `board`: 40 views at most, a webcam done at 20 views covering 60%
    /// of the image, 5 video frames examined a second.
    pub fn new(board: Board) -> CalibrateSettings {
        CalibrateSettings {
            board,
            options: CalibrateOptions::default(),
            max_views: 40,
            live_views: 20,
            live_coverage: 0.6,
            examine_fps: 5.0,
            half_window: None,
        }
    }
}

/// What can stop a calibration. Nothing is written when one occurs.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// An input could not be opened or read.
    #[error(transparent)]
    Input(#[from] EngineError),
    /// An input stopped on an error while its frames were read.
    #[error("{input}: {source}")]
    Read {
        /// The input.
        input: String,
        /// What stopped it.
        source: crate::engine::SourceError,
    },
    /// The inputs do not fit together (a rig of images and videos, different lengths, ...).
    #[error("{0}")]
    Inputs(String),
    /// An input showed the board in too few frames; `reasons` says what was seen instead.
    #[error("{input}: the {board} board was found in {found} frame(s) of {frames}, too few to calibrate ({reasons})")]
    TooFewBoards {
        /// The input.
        input: String,
        /// The board, as `9x6`.
        board: String,
        /// Frames with the whole board.
        found: usize,
        /// Frames examined.
        frames: usize,
        /// The commonest reasons the others were not used.
        reasons: String,
    },
    /// The estimate itself failed.
    #[error(transparent)]
    Calibration(#[from] CalibError),
    /// A file could not be written (those before it were written whole).
    #[error(transparent)]
    Output(#[from] monohand_io::IoError),
    /// A printable board was asked for in a format that is not made.
    #[error("{}: write .svg, .pdf or .png", path.display())]
    BoardFormat {
        /// The file asked for.
        path: PathBuf,
    },
}

/// One input's frames, as examined: the views kept and why the others were not.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraViews {
    /// The input's name.
    pub input: String,
    /// Frame size.
    pub width: u32,
    /// Frame size.
    pub height: u32,
    /// Frames examined.
    pub frames: usize,
    /// Views kept: the board's corners, named by file or frame.
    pub views: Vec<BoardView>,
    /// Frames not kept, with the reason (`left10.jpg: no chessboard found`).
    pub skipped: Vec<(String, String)>,
    /// Where the kept views' corners fell.
    pub coverage: Coverage,
}

/// A finished calibration: each camera's views and result, and the rig's when there are
/// several cameras.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibrated {
    /// The board.
    pub board: Board,
    /// Per camera, in input order.
    pub views: Vec<CameraViews>,
    /// Per camera, in input order; a rig's cameras have extrinsics from the first camera.
    pub cameras: Vec<CameraCalibration>,
    /// The rig's joint result, with several cameras.
    pub rig: Option<RigCalibration>,
}

/// An input as `monohand calibrate` takes it: `webcam:N`, a folder of images, an image
/// or video file, or a file-name pattern with `*` in a folder (`photos/left*.jpg`, quoted
/// so that the shell leaves it), whose matches are taken in file-name order.
pub fn parse_input(s: &str) -> Result<Input, CalibrateError> {
    let path = Path::new(s);
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    if !name.contains('*') {
        return Ok(Input::parse(s)?);
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let (head, tail) = name.split_once('*').unwrap_or((name, ""));
    if tail.contains('*') {
        return Err(CalibrateError::Inputs(format!(
            "{s}: one * at most in a pattern"
        )));
    }
    let entries = std::fs::read_dir(dir)
        .map_err(|e| CalibrateError::Inputs(format!("{}: {e}", dir.display())))?;
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .filter(|p| {
            p.file_name().and_then(|n| n.to_str()).is_some_and(|n| {
                n.len() >= head.len() + tail.len() && n.starts_with(head) && n.ends_with(tail)
            })
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(CalibrateError::Inputs(format!("{s}: no file matches")));
    }
    Ok(Input::Images(files))
}

/// A board size that is not `COLSxROWS` ([`parse_board_size`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is not COLSxROWS, e.g. 9x6")]
pub struct BoardSizeError(pub String);

/// A board's inner corners from `COLSxROWS` (`9x6`), as every face takes it.
pub fn parse_board_size(s: &str) -> Result<(usize, usize), BoardSizeError> {
    let parse = |v: &str| v.trim().parse::<usize>().ok();
    match s.split_once(['x', 'X']).map(|(c, r)| (parse(c), parse(r))) {
        Some((Some(c), Some(r))) => Ok((c, r)),
        _ => Err(BoardSizeError(s.to_string())),
    }
}

/// The inputs as the faces give them: for one camera (`rig` false) one input or several
/// image files (taken as one camera's photos, in the order given); for a rig one input
/// per camera. Each is read by [`parse_input`].
pub fn camera_inputs(names: &[String], rig: bool) -> Result<Vec<Input>, CalibrateError> {
    if names.is_empty() {
        return Err(CalibrateError::Inputs(
            "no input: give a folder, images, a video or webcam:N (or one input per camera of a rig)"
                .into(),
        ));
    }
    if rig || names.len() == 1 {
        return names.iter().map(|n| parse_input(n)).collect();
    }
    let mut files = Vec::new();
    for n in names {
        match parse_input(n)? {
            Input::Images(f) => files.extend(f),
            Input::Video(_) => {
                return Err(CalibrateError::Inputs(format!(
                    "{n}: several inputs for one camera must all be images (a rig: one input per camera)"
                )))
            }
        }
    }
    Ok(vec![Input::Images(files)])
}

/// Reads every input (one per camera), keeps its views, and calibrates the camera, or the
/// rig when there are several. `seen` is shown every examined frame (a live window) and
/// stops the reading when it returns `false` (the calibration then uses what it has).
pub fn calibrate(
    inputs: &[Input],
    settings: &CalibrateSettings,
    seen: &mut dyn FnMut(&SeenFrame<'_>) -> bool,
) -> Result<Calibrated, CalibrateError> {
    let (views, instants) = frames::collect(inputs, settings, seen)?;
    for v in &views {
        if v.views.len() < 3 {
            return Err(too_few(v, &settings.board));
        }
    }
    let board = settings.board;
    if views.len() == 1 {
        let v = &views[0];
        let cam = calibrate_camera(&board, &v.views, v.width, v.height, &settings.options)?;
        return Ok(Calibrated {
            board,
            views,
            cameras: vec![cam],
            rig: None,
        });
    }
    let sizes: Vec<(u32, u32)> = views.iter().map(|v| (v.width, v.height)).collect();
    let rig = calibrate_rig(&board, &instants, &sizes, &settings.options)?;
    Ok(Calibrated {
        board,
        views,
        cameras: rig.cameras.clone(),
        rig: Some(rig),
    })
}

fn too_few(v: &CameraViews, board: &Board) -> CalibrateError {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for (_, why) in &v.skipped {
        match counts.iter_mut().find(|(w, _)| w == why) {
            Some((_, n)) => *n += 1,
            None => counts.push((why.clone(), 1)),
        }
    }
    counts.sort_by_key(|c| std::cmp::Reverse(c.1));
    let reasons: Vec<String> = counts
        .iter()
        .take(3)
        .map(|(w, n)| format!("{n} x {w}"))
        .collect();
    CalibrateError::TooFewBoards {
        input: v.input.clone(),
        board: format!("{}x{}", board.cols, board.rows),
        found: v.views.len(),
        frames: v.frames,
        reasons: if reasons.is_empty() {
            "no frame".into()
        } else {
            reasons.join("; ")
        },
    }
}

/// Where a calibration's files go.
#[derive(Debug, Clone, PartialEq)]
pub struct Outputs {
    /// One camera: its JSON file. A rig: a folder (made if missing) that gets one
    /// `camN.json` per camera, N from 0 in input order.
    pub path: PathBuf,
    /// Also write each camera as OpenCV FileStorage YAML, beside its JSON (`.yaml`).
    pub opencv_yaml: bool,
    /// Also write the Markdown report here, with one picture per camera beside it
    /// (`NAME-camN.png`).
    pub report: Option<PathBuf>,
}

/// Writes a calibration's files (each whole or not at all); returns their paths.
pub fn write_outputs(c: &Calibrated, out: &Outputs) -> Result<Vec<PathBuf>, CalibrateError> {
    let date = date_utc();
    let jsons: Vec<PathBuf> = if c.cameras.len() == 1 {
        vec![out.path.clone()]
    } else {
        std::fs::create_dir_all(&out.path).map_err(|error| monohand_io::IoError::Write {
            path: out.path.clone(),
            error,
        })?;
        (0..c.cameras.len())
            .map(|k| out.path.join(format!("cam{k}.json")))
            .collect()
    };
    let mut written = Vec::new();
    for (k, path) in jsons.iter().enumerate() {
        let info = camera_info(c, k, &date);
        let camera = &c.cameras[k].camera;
        let json = monohand_io::calibration::calibrated_camera_json(camera, &info);
        monohand_io::calibration::write_atomically(path, format!("{json:#}\n"))?;
        written.push(path.clone());
        if out.opencv_yaml {
            let yaml_path = path.with_extension("yaml");
            let yaml = monohand_io::calibration::opencv_yaml(camera, &info);
            monohand_io::calibration::write_atomically(&yaml_path, &yaml)?;
            written.push(yaml_path);
        }
    }
    if let Some(report) = &out.report {
        written.extend(write_report(c, report)?);
    }
    Ok(written)
}

fn write_report(c: &Calibrated, report: &Path) -> Result<Vec<PathBuf>, CalibrateError> {
    let stem = report
        .file_stem()
        .map_or("report".into(), |s| s.to_string_lossy().to_string());
    let mut written = Vec::new();
    let mut names = Vec::new();
    for k in 0..c.cameras.len() {
        let name = format!("{stem}-cam{k}.png");
        let path = report.with_file_name(&name);
        let tmp = report.with_file_name(format!(".{name}.partial.png"));
        let saved = picture(c, k)
            .save(&tmp)
            .map_err(|e| std::io::Error::other(e.to_string()));
        saved
            .and_then(|()| std::fs::rename(&tmp, &path))
            .map_err(|error| {
                let _ = std::fs::remove_file(&tmp);
                monohand_io::IoError::Write {
                    path: path.clone(),
                    error,
                }
            })?;
        written.push(path);
        names.push(name);
    }
    monohand_io::calibration::write_atomically(report, markdown_report(c, &names))?;
    written.push(report.to_path_buf());
    Ok(written)
}

/// Writes a printable `board` (an A4 or larger page with the board at its size) to `path`,
/// as SVG, PDF or PNG at 300 dpi by its extension; returns the page written.
pub fn write_board(
    board: &Board,
    path: &Path,
) -> Result<monohand_calib::print::BoardPage, CalibrateError> {
    let page = monohand_calib::print::BoardPage::new(board);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let bytes = match ext.as_deref() {
        Some("svg") => page.to_svg().into_bytes(),
        Some("pdf") => page.to_pdf(),
        Some("png") => board_png(&page, 300.0)?,
        _ => {
            return Err(CalibrateError::BoardFormat {
                path: path.to_path_buf(),
            })
        }
    };
    monohand_io::calibration::write_atomically(path, &bytes)?;
    Ok(page)
}

/// A printable board as PNG bytes at `dpi`, with the resolution stated in the file (so
/// that printing at 100% gives squares of the board's size).
pub fn board_png(
    page: &monohand_calib::print::BoardPage,
    dpi: f64,
) -> Result<Vec<u8>, CalibrateError> {
    let (w, h, px) = page.rasterize(dpi / 25.4);
    let err = |e: png::EncodingError| {
        CalibrateError::Inputs(format!("cannot encode the board as PNG: {e}"))
    };
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, w as u32, h as u32);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        let per_metre = (dpi / 0.0254).round() as u32;
        enc.set_pixel_dims(Some(png::PixelDimensions {
            xppu: per_metre,
            yppu: per_metre,
            unit: png::Unit::Meter,
        }));
        let mut writer = enc.write_header().map_err(err)?;
        writer.write_image_data(&px).map_err(err)?;
        writer.finish().map_err(err)?;
    }
    Ok(bytes)
}
