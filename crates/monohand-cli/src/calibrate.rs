//! `monohand calibrate`: a camera's or a rig's calibration from frames of a chessboard
//! (docs/calibration.md#calibrate-your-camera-in-a-minute), and `--print-board`. The work
//! is `monohand::calibration`'s.

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use monohand::calibration::{self, Board, CalibrateSettings, DistortionModel, Outputs, SeenFrame};
use monohand_calib::print::BoardPage;
use std::path::PathBuf;

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
    #[arg(long, value_name = "COLSxROWS", value_parser = board_size)]
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
    /// The lens distortion estimated: OpenCV's k1 k2 p1 p2 k3, or its rational model (8).
    #[arg(long, value_enum, default_value_t = Model::Standard)]
    model: Model,
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

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Model {
    /// k1 k2 p1 p2 k3.
    Standard,
    /// k1 k2 p1 p2 k3 k4 k5 k6.
    Rational,
}

fn board_size(s: &str) -> Result<(usize, usize), String> {
    calibration::parse_board_size(s)
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
    settings.options.model = match args.model {
        Model::Standard => DistortionModel::Standard,
        Model::Rational => DistortionModel::Rational,
    };
    let mut window = if args.show {
        Some(show::Window::new()?)
    } else {
        None
    };
    let mut seen = |f: &SeenFrame<'_>| -> bool {
        if crate::interrupted() {
            return false;
        }
        match window.as_mut() {
            Some(w) => w.frame(f),
            None => true,
        }
    };
    let result = calibration::calibrate(&inputs, &settings, &mut seen);
    let calibrated = match result {
        Ok(c) => c,
        Err(e) => {
            if let Some(w) = window.as_mut() {
                w.hold_text(&format!("NOT CALIBRATED: {e}"));
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
        w.hold_picture(&calibration::picture(&calibrated, 0));
    }
    Ok(())
}

fn print_board(board: &Board, path: &PathBuf) -> Result<()> {
    let page = BoardPage::new(board);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let bytes = match ext.as_deref() {
        Some("svg") => page.to_svg().into_bytes(),
        Some("pdf") => page.to_pdf(),
        Some("png") => calibration::board_png(&page, 300.0)?,
        _ => bail!("--print-board {}: write .svg, .pdf or .png", path.display()),
    };
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))?;
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

#[cfg(feature = "show")]
mod show {
    //! The live window of `calibrate --show` (minifb, X11 loaded at run time).
    use anyhow::{anyhow, Result};
    use minifb::{Key, KeyRepeat, WindowOptions};
    use monohand::calibration::{draw_seen, SeenFrame};
    use monohand_media::live::{draw_status, to_0rgb};
    use monohand_vision::RgbImage;

    pub(crate) struct Window {
        window: Option<minifb::Window>,
        buffer: Vec<u32>,
        last: Option<RgbImage>,
    }

    impl Window {
        pub fn new() -> Result<Window> {
            if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
                anyhow::bail!("--show needs an X display (DISPLAY is not set)");
            }
            Ok(Window {
                window: None,
                buffer: Vec::new(),
                last: None,
            })
        }

        /// Shows a frame as the calibration sees it; false once the window is closed or Q.
        pub fn frame(&mut self, seen: &SeenFrame<'_>) -> bool {
            let mut frame = seen.image.clone();
            draw_seen(&mut frame, seen);
            let open = self.show(&frame);
            self.last = Some(frame);
            open
        }

        fn show(&mut self, frame: &RgbImage) -> bool {
            let (w, h) = (frame.width() as usize, frame.height() as usize);
            to_0rgb(frame, &mut self.buffer);
            if self.window.is_none() {
                match minifb::Window::new("monohand calibrate", w, h, WindowOptions::default()) {
                    Ok(mut win) => {
                        win.set_target_fps(0);
                        self.window = Some(win);
                    }
                    Err(e) => {
                        crate::say(&format!("--show: cannot open a window ({e})"));
                        return false;
                    }
                }
            }
            let Some(win) = self.window.as_mut() else {
                return false;
            };
            if win
                .update_with_buffer(&self.buffer, w, h)
                .map_err(|e| anyhow!("{e}"))
                .is_err()
                || !win.is_open()
            {
                return false;
            }
            !win.get_keys_pressed(KeyRepeat::No)
                .iter()
                .any(|k| matches!(k, Key::Q | Key::Escape))
        }

        /// Keeps a picture on screen until the window is closed or Q.
        pub fn hold_picture(&mut self, picture: &RgbImage) {
            while self.show(picture) {
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
        }

        /// Keeps the last frame on screen with a message until closed.
        pub fn hold_text(&mut self, text: &str) {
            if let Some(mut frame) = self.last.take() {
                draw_status(&mut frame, &text.to_uppercase());
                self.hold_picture(&frame);
            }
        }
    }
}

#[cfg(not(feature = "show"))]
mod show {
    //! `calibrate --show` in a build without the `show` feature: refused.
    use anyhow::{bail, Result};
    use monohand::calibration::SeenFrame;
    use monohand_vision::RgbImage;

    /// Never built.
    pub(crate) enum Window {}

    impl Window {
        pub fn new() -> Result<Window> {
            bail!("--show: this monohand was built without the `show` feature")
        }
        pub fn frame(&mut self, _: &SeenFrame<'_>) -> bool {
            match *self {}
        }
        pub fn hold_picture(&mut self, _: &RgbImage) {
            match *self {}
        }
        pub fn hold_text(&mut self, _: &str) {
            match *self {}
        }
    }
}
