//! Reading a calibration's frames: grey pixels, the board found in each, the frames of a
//! rig paired, and the views kept from a video.

use super::{CalibrateError, CalibrateSettings, CameraViews, MAX_MOTION_PX, MIN_VIEW_DISTANCE};
use crate::engine::{FrameSource, Input, SourceError, SourceFrame};
use monohand_calib::calibrate::BoardView;
use monohand_calib::corners::{find_chessboard_with, FoundBoard};
use monohand_calib::GrayImage;
use monohand_vision::RgbImage;
use nalgebra::Point2;
use std::time::Duration;

/// A video or webcam that delivers no frame for this long has stalled.
const STALL: Duration = Duration::from_secs(10);

/// Where a camera's kept views' corners fell: a grid of cells over the image, each
/// counting the corners seen in it.
#[derive(Debug, Clone, PartialEq)]
pub struct Coverage {
    /// Cells across.
    pub cols: usize,
    /// Cells down.
    pub rows: usize,
    /// Frame size.
    pub width: u32,
    /// Frame size.
    pub height: u32,
    /// Corners per cell, row by row.
    pub hits: Vec<u32>,
}

impl Coverage {
    /// An empty grid of 8 cells across the longer side (and as many square-ish cells
    /// along the other as fit).
    pub fn new(width: u32, height: u32) -> Coverage {
        let (w, h) = (width.max(1) as f64, height.max(1) as f64);
        let (cols, rows) = if w >= h {
            (8, ((8.0 * h / w).round() as usize).max(1))
        } else {
            (((8.0 * w / h).round() as usize).max(1), 8)
        };
        Coverage {
            cols,
            rows,
            width,
            height,
            hits: vec![0; cols * rows],
        }
    }

    /// The cell of a pixel, if it is inside the image.
    pub fn cell(&self, p: &Point2<f64>) -> Option<usize> {
        let (w, h) = (self.width as f64, self.height as f64);
        if !(p.x >= 0.0 && p.y >= 0.0 && p.x < w && p.y < h) {
            return None;
        }
        let c = ((p.x / w * self.cols as f64) as usize).min(self.cols - 1);
        let r = ((p.y / h * self.rows as f64) as usize).min(self.rows - 1);
        Some(r * self.cols + c)
    }

    /// Counts a view's corners.
    pub fn add(&mut self, corners: &[Point2<f64>]) {
        for p in corners {
            if let Some(i) = self.cell(p) {
                self.hits[i] += 1;
            }
        }
    }

    /// The fraction of cells that saw a corner.
    pub fn fraction(&self) -> f64 {
        let seen = self.hits.iter().filter(|&&n| n > 0).count();
        seen as f64 / self.hits.len().max(1) as f64
    }
}

/// One examined frame, for a live view.
#[derive(Debug)]
pub struct SeenFrame<'a> {
    /// The camera (input) it came from, from 0.
    pub camera: usize,
    /// The frame.
    pub image: &'a RgbImage,
    /// The board's corners, when the whole board was found.
    pub corners: Option<&'a [Point2<f64>]>,
    /// Why the board was not used, when it was not.
    pub why_not: Option<&'a str>,
    /// Whether this frame was kept as a view.
    pub kept: bool,
    /// Views (instants) kept so far.
    pub views: usize,
    /// The views wanted before a webcam stops by itself.
    pub views_wanted: usize,
    /// This camera's coverage so far.
    pub coverage: &'a Coverage,
}

/// Per camera, per kept instant, its view (`None` where it did not see the whole board).
pub(super) type Instants = Vec<Vec<Option<BoardView>>>;

/// What one camera saw at one instant.
struct Seen {
    name: String,
    found: Result<FoundBoard, String>,
}

/// Reads the inputs, pairs a rig's frames, and keeps the views: per camera its views, and
/// per camera per kept instant its view (for the rig's estimate).
pub(super) fn collect(
    inputs: &[Input],
    settings: &CalibrateSettings,
    seen: &mut dyn FnMut(&SeenFrame<'_>) -> bool,
) -> Result<(Vec<CameraViews>, Instants), CalibrateError> {
    if inputs.is_empty() {
        return Err(CalibrateError::Inputs("no input given".into()));
    }
    let videos = inputs.iter().filter(|i| i.is_video()).count();
    if videos != 0 && videos != inputs.len() {
        return Err(CalibrateError::Inputs(
            "a rig's inputs must be all images (paired by order) or all videos (paired by time)"
                .into(),
        ));
    }
    check_lengths(inputs)?;
    let mut sources = inputs
        .iter()
        .map(|i| i.open(STALL))
        .collect::<Result<Vec<_>, _>>()?;
    let live = inputs
        .iter()
        .any(|i| matches!(i, Input::Video(v) if v.is_live()));
    let mut state = Collector::new(inputs, settings, videos > 0, live);
    let stride = stride(&sources, settings, live);
    let mut instant = 0usize;
    let mut go_on = true;
    while go_on {
        let Some(frames) = next_instant(&mut sources, inputs)? else {
            break;
        };
        instant += 1;
        if !(instant - 1).is_multiple_of(stride) {
            continue;
        }
        go_on = state.examine(frames, stride, seen);
    }
    Ok(state.finish())
}

/// Image inputs of a rig must have as many files each; videos as many frames (±1).
fn check_lengths(inputs: &[Input]) -> Result<(), CalibrateError> {
    if inputs.len() < 2 {
        return Ok(());
    }
    let counts: Vec<Option<usize>> = inputs
        .iter()
        .map(|i| match i {
            Input::Images(f) => Some(f.len()),
            Input::Video(_) => None,
        })
        .collect();
    if counts.iter().all(Option::is_some) && counts.windows(2).any(|w| w[0] != w[1]) {
        let each: Vec<String> = counts
            .iter()
            .zip(inputs)
            .map(|(n, i)| format!("{} has {}", input_name(i), n.unwrap_or(0)))
            .collect();
        return Err(CalibrateError::Inputs(format!(
            "the rig's inputs have different numbers of images ({}): images pair by sorted order, so each camera needs one per instant",
            each.join(", ")
        )));
    }
    Ok(())
}

/// Every how many frames a video is examined.
fn stride(sources: &[Box<dyn FrameSource>], settings: &CalibrateSettings, live: bool) -> usize {
    if live || !sources.iter().all(|s| s.is_video()) {
        return 1;
    }
    let fps = sources[0].fps().unwrap_or(30.0);
    ((fps / settings.examine_fps.max(0.1)).round() as usize).max(1)
}

/// The next frame of every input, paired: by order for images, by time for videos (a
/// frame more than half a frame interval behind the others is dropped). `None` at the end
/// of the first input to end; an error when the others go on for more than a frame.
fn next_instant(
    sources: &mut [Box<dyn FrameSource>],
    inputs: &[Input],
) -> Result<Option<Vec<SourceFrame>>, CalibrateError> {
    let mut frames = Vec::with_capacity(sources.len());
    for (s, input) in sources.iter_mut().zip(inputs) {
        match s.next_frame().map_err(|e| read_error(input, e))? {
            Some(f) => frames.push(Some(f)),
            None => frames.push(None),
        }
    }
    if frames.iter().all(Option::is_none) {
        return Ok(None);
    }
    if frames.iter().any(Option::is_none) {
        return ended_early(sources, inputs, &frames);
    }
    let mut frames: Vec<SourceFrame> = frames.into_iter().flatten().collect();
    if sources.len() > 1 && sources[0].is_video() {
        align_by_time(sources, inputs, &mut frames)?;
    }
    Ok(Some(frames))
}

/// Drops the frames behind until the rig's frames are within half a frame of each other.
fn align_by_time(
    sources: &mut [Box<dyn FrameSource>],
    inputs: &[Input],
    frames: &mut [SourceFrame],
) -> Result<(), CalibrateError> {
    let half = 0.5 / sources[0].fps().unwrap_or(30.0);
    for _ in 0..1000 {
        let latest = frames
            .iter()
            .map(|f| f.timestamp_s)
            .fold(f64::NEG_INFINITY, f64::max);
        let Some(k) = frames.iter().position(|f| f.timestamp_s < latest - half) else {
            return Ok(());
        };
        match sources[k]
            .next_frame()
            .map_err(|e| read_error(&inputs[k], e))?
        {
            Some(f) => frames[k] = f,
            None => {
                return Err(CalibrateError::Inputs(format!(
                    "{} ended before the other cameras' videos: a rig's videos must cover the same time",
                    input_name(&inputs[k])
                )))
            }
        }
    }
    Err(CalibrateError::Inputs(
        "the rig's videos could not be paired by time (their clocks differ by over 1000 frames)"
            .into(),
    ))
}

/// One input ended: fine if every other one ends within a frame, else an error.
fn ended_early(
    sources: &mut [Box<dyn FrameSource>],
    inputs: &[Input],
    frames: &[Option<SourceFrame>],
) -> Result<Option<Vec<SourceFrame>>, CalibrateError> {
    for (k, f) in frames.iter().enumerate() {
        if f.is_some() && sources[k].next_frame().ok().flatten().is_some() {
            let ended: Vec<String> = frames
                .iter()
                .zip(inputs)
                .filter(|(f, _)| f.is_none())
                .map(|(_, i)| input_name(i))
                .collect();
            return Err(CalibrateError::Inputs(format!(
                "the rig's inputs have different lengths: {} ended while {} went on",
                ended.join(", "),
                input_name(&inputs[k])
            )));
        }
    }
    Ok(None)
}

fn read_error(input: &Input, source: SourceError) -> CalibrateError {
    CalibrateError::Read {
        input: input_name(input),
        source,
    }
}

/// An input's name in messages.
pub(super) fn input_name(input: &Input) -> String {
    match input {
        Input::Images(files) if files.len() == 1 => files[0].display().to_string(),
        Input::Images(files) => match files.first().and_then(|f| f.parent()) {
            Some(dir) if files.iter().all(|f| f.parent() == Some(dir)) => {
                format!("{} ({} images)", dir.display(), files.len())
            }
            _ => format!("{} images", files.len()),
        },
        Input::Video(v) => v.name(),
    }
}

/// The 8-bit grey of an RGB frame (ITU-R BT.601 luma, as OpenCV's `COLOR_RGB2GRAY`), into
/// `out`.
fn to_grey(image: &RgbImage, out: &mut Vec<u8>) {
    out.clear();
    out.extend(image.pixels().map(|p| {
        let [r, g, b] = p.0;
        ((299 * r as u32 + 587 * g as u32 + 114 * b as u32 + 500) / 1000) as u8
    }));
}

/// The state of the reading: per camera what was kept, and the kept instants.
struct Collector<'s> {
    settings: &'s CalibrateSettings,
    /// Frames of a video: select views (images are all kept).
    select: bool,
    live: bool,
    cameras: Vec<CameraViews>,
    /// Kept instants: per camera the frame's name and the board seen, if any.
    kept: Vec<Vec<Option<(String, FoundBoard)>>>,
    /// The boards of the instant examined before (for the motion test).
    previous: Vec<Option<Vec<Point2<f64>>>>,
    grey: Vec<u8>,
}

impl<'s> Collector<'s> {
    fn new(inputs: &[Input], settings: &'s CalibrateSettings, select: bool, live: bool) -> Self {
        Collector {
            settings,
            select,
            live,
            cameras: inputs
                .iter()
                .map(|i| CameraViews {
                    input: input_name(i),
                    width: 0,
                    height: 0,
                    frames: 0,
                    views: Vec::new(),
                    skipped: Vec::new(),
                    coverage: Coverage::new(1, 1),
                })
                .collect(),
            kept: Vec::new(),
            previous: vec![None; inputs.len()],
            grey: Vec::new(),
        }
    }

    /// Finds the board in one instant's frames, decides whether to keep the instant, and
    /// shows each frame. Returns whether to go on reading.
    fn examine(
        &mut self,
        frames: Vec<SourceFrame>,
        stride: usize,
        seen: &mut dyn FnMut(&SeenFrame<'_>) -> bool,
    ) -> bool {
        let mut boards = Vec::with_capacity(frames.len());
        for (k, f) in frames.iter().enumerate() {
            boards.push(self.find(k, f));
        }
        let keep = self.decide(&mut boards, stride);
        if keep {
            for (k, b) in boards.iter().enumerate() {
                if let Ok(found) = &b.found {
                    self.cameras[k].coverage.add(&found.corners);
                }
            }
            let instant = boards
                .iter()
                .map(|b| b.found.clone().ok().map(|f| (b.name.clone(), f)))
                .collect();
            self.kept.push(instant);
        }
        let mut go_on = true;
        for (k, (f, b)) in frames.iter().zip(&boards).enumerate() {
            let Ok(image) = &f.image else { continue };
            let frame = SeenFrame {
                camera: k,
                image,
                corners: b.found.as_ref().ok().map(|x| x.corners.as_slice()),
                why_not: if keep {
                    None
                } else {
                    b.found.as_ref().err().map(|s| s.as_str())
                },
                kept: keep,
                views: self.kept.len(),
                views_wanted: self.settings.live_views,
                coverage: &self.cameras[k].coverage,
            };
            go_on &= seen(&frame);
        }
        for (k, b) in boards.into_iter().enumerate() {
            if !keep {
                let why = match b.found {
                    Err(why) => why,
                    Ok(_) => "not kept".into(),
                };
                self.cameras[k].skipped.push((b.name, why));
            }
        }
        go_on && !(self.live && self.enough())
    }

    /// A webcam has enough views to stop.
    fn enough(&self) -> bool {
        self.kept.len() >= self.settings.live_views
            && self
                .cameras
                .iter()
                .all(|c| c.coverage.fraction() >= self.settings.live_coverage)
    }

    fn find(&mut self, k: usize, f: &SourceFrame) -> Seen {
        let cam = &mut self.cameras[k];
        cam.frames += 1;
        let name = match &f.source {
            Some(file) => file.clone(),
            None => format!("frame {}", f.index),
        };
        let image = match &f.image {
            Ok(image) => image,
            Err(e) => {
                return Seen {
                    name,
                    found: Err(format!("unreadable: {e}")),
                }
            }
        };
        let (w, h) = image.dimensions();
        if cam.width == 0 {
            (cam.width, cam.height) = (w, h);
            cam.coverage = Coverage::new(w, h);
        } else if (cam.width, cam.height) != (w, h) {
            let why = format!(
                "{w}x{h}, not the {}x{} of the camera's first frame",
                cam.width, cam.height
            );
            return Seen {
                name,
                found: Err(why),
            };
        }
        to_grey(image, &mut self.grey);
        let found = match GrayImage::new(w as usize, h as usize, &self.grey) {
            Ok(grey) => {
                find_chessboard_with(&grey, &self.settings.board, self.settings.half_window)
                    .map_err(|e| e.to_string())
            }
            Err(e) => Err(e.to_string()),
        };
        Seen { name, found }
    }

    /// Whether to keep an instant; marks why not in `boards` when it is not.
    fn decide(&mut self, boards: &mut [Seen], stride: usize) -> bool {
        if boards.iter().all(|b| b.found.is_err()) {
            self.previous.iter_mut().for_each(|p| *p = None);
            return false;
        }
        if !self.select {
            return true;
        }
        let mut why: Option<String> = None;
        for (k, b) in boards.iter().enumerate() {
            let Ok(found) = &b.found else {
                self.previous[k] = None;
                continue;
            };
            if let Some(prev) = &self.previous[k] {
                let motion = mean_distance(prev, &found.corners) / stride as f64;
                if motion > MAX_MOTION_PX {
                    why.get_or_insert(format!("moving ({motion:.1} px a frame)"));
                }
            }
            self.previous[k] = Some(found.corners.clone());
            let sharp = self.kept_sharpness(k);
            if sharp > 0.0 && found.sharpness < 0.6 * sharp {
                why.get_or_insert(format!(
                    "blurred (sharpness {:.2}, the views kept have {sharp:.2})",
                    found.sharpness
                ));
            }
        }
        if why.is_none() && !self.differs(boards) {
            why = Some("too like a view already kept".into());
        }
        if self.kept.len() >= self.settings.max_views && why.is_none() {
            why = Some(format!("{} views kept already", self.settings.max_views));
        }
        match why {
            None => true,
            Some(why) => {
                for b in boards.iter_mut() {
                    if b.found.is_ok() {
                        b.found = Err(why.clone());
                    }
                }
                false
            }
        }
    }

    /// Median sharpness of the boards kept for camera `k` (0 before three are kept).
    fn kept_sharpness(&self, k: usize) -> f64 {
        let mut s: Vec<f64> = self
            .kept
            .iter()
            .filter_map(|i| i[k].as_ref().map(|(_, b)| b.sharpness))
            .collect();
        if s.len() < 3 {
            return 0.0;
        }
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    }

    /// Whether an instant differs from every kept one in some camera's view.
    fn differs(&self, boards: &[Seen]) -> bool {
        self.kept.iter().all(|kept| {
            boards
                .iter()
                .zip(kept)
                .enumerate()
                .any(|(k, (b, old))| match (&b.found, old) {
                    (Ok(new), Some((_, old))) => {
                        mean_distance(&new.corners, &old.corners)
                            > MIN_VIEW_DISTANCE * self.diagonal(k)
                    }
                    (Ok(_), None) => true,
                    _ => false,
                })
        })
    }

    fn diagonal(&self, k: usize) -> f64 {
        let c = &self.cameras[k];
        (c.width as f64).hypot(c.height as f64)
    }

    /// Per camera its views, and per camera per kept instant its view.
    fn finish(mut self) -> (Vec<CameraViews>, Instants) {
        let mut instants: Instants = vec![Vec::new(); self.cameras.len()];
        for kept in std::mem::take(&mut self.kept) {
            for (k, b) in kept.into_iter().enumerate() {
                let view = b.map(|(name, b)| BoardView {
                    name,
                    corners: b.corners,
                });
                if let Some(v) = &view {
                    self.cameras[k].views.push(v.clone());
                }
                instants[k].push(view);
            }
        }
        (self.cameras, instants)
    }
}

/// Mean distance between corresponding corners, pixels.
fn mean_distance(a: &[Point2<f64>], b: &[Point2<f64>]) -> f64 {
    let n = a.len().min(b.len()).max(1);
    a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / n as f64
}
