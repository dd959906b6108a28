//! `monohand calibrate`: a camera's or a rig's calibration from frames of a chessboard
//! (docs/calibration.md#calibrate-your-camera-in-a-minute), and `--print-board`. The work
//! is `monohand::calibration`'s.

use anyhow::{Context, Result};
use clap::Args;
use monohand::calibration::{
    self, Board, CalibrateSettings, CalibrationWindow, DistortionModel, Outputs, SeenFrame,
};
use std::path::{Path, PathBuf};

/// Arguments of `monohand calibrate`.
#[derive(Debug, Args)]
pub(crate) struct CalibrateArgs {
    /// The board's frames: a folder of images, image files, a video, `webcam:N`, or a
    /// quoted pattern such as 'photos/left*.jpg'. A rig: --view once per camera instead.
    #[arg(value_name = "INPUT", conflicts_with = "views")]
    inputs: Vec<String>,
    /// One camera of a rig, once per camera, in the order of `run --view`: images pair
    /// by sorted file name, videos by time.
    #[arg(long = "view", value_name = "INPUT")]
    views: Vec<String>,
    /// The board's inner corners (where four squares meet), COLSxROWS: 9x6 for a board
    /// of 10 x 7 squares.
    #[arg(long, value_name = "COLSxROWS", value_parser = calibration::parse_board_size)]
    board: (usize, usize),
    /// The side of a printed square, millimetres: measure it on the print.
    #[arg(long, value_name = "MM")]
    square_mm: f64,
    /// Where to write: one camera's JSON file, or for a rig a folder that gets one
    /// camN.json per --view (N from 0), as `run --view ... --camera ...` reads them.
    #[arg(
        short,
        long,
        value_name = "FILE|DIR",
        required_unless_present = "print_board"
    )]
    output: Option<PathBuf>,
    /// The lens model estimated: `standard` (OpenCV's k1 k2 p1 p2 k3), `rational` (its
    /// k1..k6 p1 p2), or `fisheye` (its Kannala-Brandt k1..k4 of the angle from the axis)
    /// for lenses wider than about 120 degrees.
    #[arg(
        long,
        value_name = "standard|rational|fisheye",
        default_value = "standard"
    )]
    model: DistortionModel,
    /// Also write each camera as OpenCV FileStorage YAML beside its JSON.
    #[arg(long)]
    opencv_yaml: bool,
    /// Also write a Markdown report here, with a picture per camera beside it (where the
    /// corners were seen, and the distortion field).
    #[arg(long, value_name = "REPORT.md")]
    report: Option<PathBuf>,
    /// The corners' subpixel window, half its side in pixels, as OpenCV's `cornerSubPix`
    /// winSize (its tutorials use 11); by default it is fitted to the squares.
    #[arg(long, value_name = "PX")]
    subpix_window: Option<usize>,
    /// Keep every view, as OpenCV does; by default a view whose error is over 3 times the
    /// median view's (and 1 px) is dropped and said.
    #[arg(long)]
    keep_all_views: bool,
    /// From a video or a webcam: views kept at most.
    #[arg(long, value_name = "N", default_value_t = 40)]
    max_views: usize,
    /// A live window: the corners found, the views kept and the parts of the image still
    /// to cover; then the result (Q to close).
    #[arg(long)]
    show: bool,
    /// Write a printable board for --board and --square-mm (.svg, .pdf or .png at 300
    /// dpi) and stop.
    #[arg(long, value_name = "FILE")]
    print_board: Option<PathBuf>,
}

pub(crate) fn run(args: &CalibrateArgs) -> Result<()> {
    let board = Board::new(args.board.0, args.board.1, args.square_mm)
        .context("--board and --square-mm")?;
    if let Some(path) = &args.print_board {
        return print_board(&board, path);
    }
    let rig = !args.views.is_empty();
    let inputs = calibration::camera_inputs(if rig { &args.views } else { &args.inputs }, rig)?;
    let mut settings = CalibrateSettings::new(board);
    settings.max_views = args.max_views.max(3);
    settings.half_window = args.subpix_window;
    if args.keep_all_views {
        settings.options.outlier_factor = f64::INFINITY;
    }
    settings.options.model = args.model;
    let mut window = match args.show {
        true => Some(CalibrationWindow::open("monohand calibrate").context("--show")?),
        false => None,
    };
    let mut seen = |f: &SeenFrame<'_>| -> bool {
        match window.as_mut() {
            _ if crate::interrupted() => false,
            None => true,
            Some(w) => w.frame(f).unwrap_or_else(|e| {
                crate::say(&format!("--show: {e}"));
                false
            }),
        }
    };
    let result = calibration::calibrate(&inputs, &settings, &mut seen);
    let calibrated = match result {
        Ok(c) => c,
        Err(e) => {
            if let Some(w) = window.as_mut() {
                let _ = w.hold_text(&format!("NOT CALIBRATED: {e}"));
            }
            return Err(e.into());
        }
    };
    crate::say(calibration::summary(&calibrated).trim_end());
    let outputs = Outputs {
        path: args.output.clone().context("--output is required")?,
        opencv_yaml: args.opencv_yaml,
        report: args.report.clone(),
    };
    let written = calibration::write_outputs(&calibrated, &outputs)?;
    for p in &written {
        crate::say(&format!("wrote {}", p.display()));
    }
    if let Some(w) = window.as_mut() {
        let _ = w.hold_result(&calibrated);
    }
    Ok(())
}

fn print_board(board: &Board, path: &Path) -> Result<()> {
    let page = calibration::write_board(board, path).context("--print-board")?;
    crate::say(&format!(
        "wrote {} ({:.0} x {:.0} mm page): print it at 100% scale, measure a printed square \
         and pass that with --square-mm (it was drawn at {} mm)",
        path.display(),
        page.page_width_mm,
        page.page_height_mm,
        board.square_mm
    ));
    Ok(())
}
