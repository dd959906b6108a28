//! Video in and out through the `ffmpeg` and `ffprobe` command-line tools.
//!
//! No codec library is linked: [`VideoReader`] runs
//! `ffmpeg -i INPUT -f rawvideo -pix_fmt rgb24 -` and reads packed RGB frames
//! from its standard output; [`VideoWriter`] runs
//! `ffmpeg -f rawvideo -pix_fmt rgb24 -s WxH -r FPS -i - ... OUT` and writes
//! frames to its standard input; [`probe`] asks `ffprobe` for the size, frame
//! rate, frame count and codec of the first video stream. Anything ffmpeg can
//! decode is accepted (MP4/MOV, MKV/WebM, AVI, MPEG-TS, image files and image
//! sequences such as `img_%04d.png`), and a Linux webcam is read with the input
//! string `webcam:N` (`-f v4l2 -i /dev/videoN`, see [`VideoInput`]).
//!
//! The tools must be on `PATH` (Debian/Ubuntu: `apt-get install ffmpeg`, which
//! provides both), or named by the environment variables `MONOHAND_FFMPEG` and
//! `MONOHAND_FFPROBE`; when they are missing every function returns
//! [`IoError::ToolMissing`], which says what to install.
//!
//! Errors never hang or panic: ffmpeg's standard error is drained on a thread
//! (so a chatty ffmpeg cannot block on a full pipe) and its last lines are put
//! into [`IoError::Video`]. A corrupt or truncated video yields its decodable
//! frames first and then an error; an unreadable file fails in [`probe`] /
//! [`VideoReader::open`].
//!
//! ```no_run
//! use monohand_media::video::{VideoInput, VideoReader, VideoWriter};
//! let mut reader = VideoReader::open(&VideoInput::parse("clip.mp4")).unwrap();
//! let info = reader.info().clone();
//! let mut writer = VideoWriter::create("out.mp4", info.width, info.height, info.fps_or_default()).unwrap();
//! for frame in &mut reader {
//!     let frame = frame.unwrap();
//!     // ... draw on frame.image ...
//!     writer.write(&frame.image).unwrap();
//! }
//! writer.finish().unwrap();
//! ```

use monohand_io::{IoError, IoResult};
use serde_json::Value;
use std::collections::HashMap;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::Duration;

/// The frame rate assumed when a video does not state one (frames per second).
pub const DEFAULT_FPS: f64 = 30.0;

/// Largest frame accepted from a video, in pixels (2^26, 67 megapixels: an RGB frame of
/// 201 MB; 8K UHD is 33 megapixels). The reader allocates one frame of this size, so a
/// forged stream header cannot make it allocate more.
pub const MAX_FRAME_PIXELS: usize = 1 << 26;

/// How many bytes of ffmpeg's standard error are kept for error messages (the tail).
const STDERR_KEEP: usize = 4096;

/// The one image type of the project: packed 8-bit RGB, rows top to bottom (the `image`
/// crate's buffer, which the vision front end takes too).
pub use image::RgbImage;

/// Where the `ffmpeg` and `ffprobe` executables are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FfmpegTools {
    /// The `ffmpeg` executable (a name looked up on `PATH`, or a path).
    pub ffmpeg: PathBuf,
    /// The `ffprobe` executable.
    pub ffprobe: PathBuf,
}

impl Default for FfmpegTools {
    /// `$MONOHAND_FFMPEG` / `$MONOHAND_FFPROBE` if set, else `ffmpeg` / `ffprobe` on `PATH`.
    fn default() -> FfmpegTools {
        let var = |k: &str, d: &str| {
            std::env::var_os(k)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
                .unwrap_or_else(|| PathBuf::from(d))
        };
        FfmpegTools {
            ffmpeg: var("MONOHAND_FFMPEG", "ffmpeg"),
            ffprobe: var("MONOHAND_FFPROBE", "ffprobe"),
        }
    }
}

impl FfmpegTools {
    /// Whether `ffmpeg` can be run (`ffmpeg -version` succeeds).
    pub fn available(&self) -> bool {
        Command::new(&self.ffmpeg)
            .arg("-version")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    }

    /// What `read` makes of `ffmpeg`'s standard output for `args` (`-encoders`, `-h full`),
    /// asked once per process and executable and remembered in `cache` (the caller's, one
    /// per question; only `read`'s result is kept); `None` if ffmpeg cannot be run.
    fn answer<T: Clone>(
        &self,
        cache: &OnceLock<Mutex<HashMap<PathBuf, T>>>,
        args: &[&str],
        read: impl FnOnce(&str) -> T,
    ) -> Option<T> {
        let cache = cache.get_or_init(|| Mutex::new(HashMap::new()));
        if let Some(a) = cache.lock().ok().and_then(|m| m.get(&self.ffmpeg).cloned()) {
            return Some(a);
        }
        let out = Command::new(&self.ffmpeg)
            .arg("-hide_banner")
            .args(args)
            .stdin(Stdio::null())
            .stderr(Stdio::null())
            .output()
            .ok()?;
        let answer = read(&String::from_utf8_lossy(&out.stdout));
        if let Ok(mut m) = cache.lock() {
            m.insert(self.ffmpeg.clone(), answer.clone());
        }
        Some(answer)
    }

    /// Whether `ffmpeg` has this encoder, as listed by `ffmpeg -encoders`.
    pub fn has_encoder(&self, name: &str) -> bool {
        static ENCODERS: OnceLock<Mutex<HashMap<PathBuf, Vec<String>>>> = OnceLock::new();
        self.answer(&ENCODERS, &["-encoders"], |list| {
            list.lines()
                .filter_map(|l| l.split_whitespace().nth(1).map(str::to_string))
                .collect()
        })
        .is_some_and(|names| names.iter().any(|n| n == name))
    }

    /// What this `ffmpeg` supports among the options [`reader_args`] would like to use, from
    /// one `ffmpeg -h full` (asked once per process and executable; an ffmpeg that cannot
    /// be run supports nothing).
    pub fn features(&self) -> FfmpegFeatures {
        static FEATURES: OnceLock<Mutex<HashMap<PathBuf, FfmpegFeatures>>> = OnceLock::new();
        self.answer(&FEATURES, &["-h", "full"], FfmpegFeatures::from_help)
            .unwrap_or_default()
    }
}

/// What an `ffmpeg` executable supports among the options [`VideoReader`] would like
/// ([`FfmpegTools::features`]): it then uses them, else their older forms.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FfmpegFeatures {
    /// The `showinfo` filter can leave out its per-frame checksums (`showinfo=checksum=0`,
    /// FFmpeg 5.0 on). They cost about 1 ms of ffmpeg's time per 640x480 frame, and the
    /// reader only wants the timestamps.
    pub showinfo_checksum_option: bool,
    /// `-fps_mode` (FFmpeg 5.1 on). It replaces `-vsync`, which FFmpeg 7.0 removed.
    pub fps_mode: bool,
}

impl FfmpegFeatures {
    /// The option that sets how frames are timed on output: `-fps_mode`, or its older name
    /// `-vsync` where there is no `-fps_mode` (the reader passes it `passthrough`).
    pub fn fps_mode_option(&self) -> &'static str {
        if self.fps_mode {
            "-fps_mode"
        } else {
            "-vsync"
        }
    }

    /// Reads the text of `ffmpeg -h full`: `-fps_mode` among the options (listed as
    /// `-fps_mode` or `-fps_mode[:<stream_spec>]`), `checksum` among the options under
    /// `showinfo AVOptions:`.
    pub fn from_help(help: &str) -> FfmpegFeatures {
        let mut features = FfmpegFeatures::default();
        let mut in_showinfo = false;
        for line in help.lines() {
            let first = line.split_whitespace().next().unwrap_or("");
            if !line.starts_with(char::is_whitespace) {
                in_showinfo = line.starts_with("showinfo AVOptions:");
            }
            features.fps_mode |= first.split('[').next() == Some("-fps_mode");
            features.showinfo_checksum_option |= in_showinfo && first == "checksum";
        }
        features
    }
}

/// The error for a tool that could not be started.
fn spawn_error(tool: &Path, e: std::io::Error) -> IoError {
    if e.kind() == std::io::ErrorKind::NotFound {
        IoError::ToolMissing {
            tool: tool.display().to_string(),
        }
    } else {
        IoError::Video {
            input: tool.display().to_string(),
            message: format!("cannot run: {e}"),
        }
    }
}

/// A video source: a file (or anything else ffmpeg opens) or a webcam.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum VideoInput {
    /// A file, URL or image-sequence pattern, given to ffmpeg's `-i` as is.
    File(PathBuf),
    /// A Video4Linux device `/dev/videoN` (Linux webcams), read with `-f v4l2`.
    Webcam(u32),
}

impl VideoInput {
    /// `webcam:N` (N a number) is [`VideoInput::Webcam`]; anything else is a file.
    pub fn parse(s: &str) -> VideoInput {
        if let Some(n) = s.strip_prefix("webcam:").and_then(|n| n.parse().ok()) {
            return VideoInput::Webcam(n);
        }
        VideoInput::File(PathBuf::from(s))
    }

    /// The ffmpeg/ffprobe arguments that open this input: `["-i", path]`, or
    /// `["-f", "v4l2", "-i", "/dev/videoN"]` for a webcam.
    pub fn input_args(&self) -> Vec<String> {
        match self {
            VideoInput::File(p) => vec!["-i".into(), p.display().to_string()],
            VideoInput::Webcam(n) => vec![
                "-f".into(),
                "v4l2".into(),
                "-i".into(),
                format!("/dev/video{n}"),
            ],
        }
    }

    /// The name used in messages.
    pub fn name(&self) -> String {
        match self {
            VideoInput::File(p) => p.display().to_string(),
            VideoInput::Webcam(n) => format!("webcam:{n} (/dev/video{n})"),
        }
    }

    /// Whether this is a live source (no end, no frame count).
    pub fn is_live(&self) -> bool {
        matches!(self, VideoInput::Webcam(_))
    }
}

/// What [`probe`] found out about the first video stream.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoInfo {
    /// Width of the decoded frames, pixels (after the rotation, which ffmpeg applies).
    pub width: usize,
    /// Height of the decoded frames, pixels (after the rotation).
    pub height: usize,
    /// Frame rate, frames per second, if the container states one.
    pub fps: Option<f64>,
    /// Number of frames, if the container states it (often absent, e.g. in MKV/WebM).
    pub frame_count: Option<u64>,
    /// The codec name, e.g. `h264`.
    pub codec: Option<String>,
    /// Display rotation in degrees from the stream's metadata (phone videos);
    /// the reader's frames are already rotated, so this is informational.
    pub rotation_deg: i32,
}

impl VideoInfo {
    /// The frame rate, or [`DEFAULT_FPS`] if unknown.
    pub fn fps_or_default(&self) -> f64 {
        self.fps
            .filter(|f| f.is_finite() && *f > 0.0)
            .unwrap_or(DEFAULT_FPS)
    }
}

/// Parses a rational such as `30000/1001` (or a plain number); `None` for `0/0` or junk.
fn parse_rate(s: &str) -> Option<f64> {
    let v = match s.split_once('/') {
        Some((n, d)) => n.trim().parse::<f64>().ok()? / d.trim().parse::<f64>().ok()?,
        None => s.trim().parse().ok()?,
    };
    (v.is_finite() && v > 0.0).then_some(v)
}

/// Parses `ffprobe -of json` output (see [`probe`]); `name` is used in errors.
pub fn parse_probe_json(text: &str, name: &str) -> IoResult<VideoInfo> {
    let v: Value = serde_json::from_str(text).map_err(|e| IoError::json(name, &e))?;
    let Some(s) = v
        .get("streams")
        .and_then(Value::as_array)
        .and_then(|a| a.first())
    else {
        return Err(IoError::Video {
            input: name.into(),
            message: "no video stream found".into(),
        });
    };
    let dim = |k: &str| {
        s.get(k)
            .and_then(Value::as_u64)
            .filter(|&d| d > 0 && d < 1 << 16)
            .map(|d| d as usize)
            .ok_or_else(|| IoError::field(name, format!("streams[0].{k}"), "missing or invalid"))
    };
    let (w, h) = (dim("width")?, dim("height")?);
    if w * h > MAX_FRAME_PIXELS {
        return Err(IoError::field(
            name,
            "streams[0]",
            format!(
                "{w}x{h} frames exceed the limit of {MAX_FRAME_PIXELS} pixels (MAX_FRAME_PIXELS)"
            ),
        ));
    }
    let str_field = |k: &str| s.get(k).and_then(Value::as_str);
    let fps = str_field("r_frame_rate").and_then(parse_rate);
    let frame_count = str_field("nb_frames")
        .and_then(|n| n.parse::<u64>().ok())
        .filter(|&n| n > 0);
    let codec = str_field("codec_name").map(str::to_string);
    if codec.as_deref() == Some("ansi") {
        // ffmpeg's tty demuxer takes any .txt (.ans, .nfo, ...) file and draws its text.
        return Err(IoError::Video {
            input: name.into(),
            message: "a text file, not a video or image (ffmpeg would draw its characters as \
                      frames, codec ansi)"
                .into(),
        });
    }
    // Rotation: newer ffprobe puts it in the display-matrix side data, older in tags.rotate.
    let side = s
        .get("side_data_list")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .find_map(|d| d.get("rotation").and_then(Value::as_f64));
    let tag = s
        .get("tags")
        .and_then(|t| t.get("rotate"))
        .and_then(Value::as_str)
        .and_then(|r| r.parse::<f64>().ok());
    let rotation_deg = side.or(tag).unwrap_or(0.0).round() as i32;
    let quarter = rotation_deg.rem_euclid(180) == 90;
    let (width, height) = if quarter { (h, w) } else { (w, h) };
    Ok(VideoInfo {
        width,
        height,
        fps,
        frame_count,
        codec,
        rotation_deg,
    })
}

/// Describes the first video stream of an input with
/// `ffprobe -v error -select_streams v:0 -show_entries stream=... -of json`.
pub fn probe(input: &VideoInput) -> IoResult<VideoInfo> {
    probe_with(&FfmpegTools::default(), input)
}

/// [`probe`] with explicit tool paths.
pub fn probe_with(tools: &FfmpegTools, input: &VideoInput) -> IoResult<VideoInfo> {
    let name = input.name();
    if let VideoInput::File(p) = input {
        // A clearer message than ffprobe's for the commonest mistake (unless it is
        // a pattern or URL, which ffprobe resolves itself).
        let s = p.to_string_lossy();
        if !p.exists() && !s.contains('%') && !s.contains("://") {
            return Err(IoError::Read {
                path: p.clone(),
                error: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
    }
    let mut args: Vec<String> = ["-v", "error", "-select_streams", "v:0", "-show_entries"]
        .map(String::from)
        .to_vec();
    args.push(
        "stream=width,height,r_frame_rate,nb_frames,codec_name:stream_tags=rotate:stream_side_data=rotation"
            .into(),
    );
    args.extend(["-of".into(), "json".into()]);
    let mut input_args = input.input_args();
    // ffprobe takes the input without -i.
    if let Some(pos) = input_args.iter().position(|a| a == "-i") {
        input_args.remove(pos);
    }
    args.extend(input_args);
    let out = Command::new(&tools.ffprobe)
        .args(&args)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| spawn_error(&tools.ffprobe, e))?;
    let stderr = String::from_utf8_lossy(&out.stderr).trim().to_string();
    if !out.status.success() {
        return Err(IoError::Video {
            input: name,
            message: format!("ffprobe cannot read it ({}): {stderr}", out.status),
        });
    }
    parse_probe_json(&String::from_utf8_lossy(&out.stdout), &name).map_err(|e| match e {
        IoError::Video { input, message } if !stderr.is_empty() => IoError::Video {
            input,
            message: format!("{message}; ffprobe said: {stderr}"),
        },
        e => e,
    })
}

/// Reads a child's standard error on a thread, keeping the last [`STDERR_KEEP`] bytes.
fn drain_stderr(pipe: impl Read + Send + 'static) -> JoinHandle<String> {
    drain_stderr_with(pipe, None)
}

/// [`drain_stderr`] for a decoder run with `-v level+info` and the `showinfo` filter
/// ([`reader_args`]): each frame's `pts_time` goes to `times` (NaN when the frame has
/// none), and only the lines of level error and worse are kept for messages.
fn drain_stderr_with(
    pipe: impl Read + Send + 'static,
    times: Option<std::sync::mpsc::Sender<f64>>,
) -> JoinHandle<String> {
    std::thread::spawn(move || {
        let mut kept: Vec<u8> = Vec::new();
        let mut keep = |line: &[u8]| {
            kept.extend_from_slice(line);
            kept.push(b'\n');
            if kept.len() > 2 * STDERR_KEEP {
                kept.drain(..kept.len() - STDERR_KEEP);
            }
        };
        let mut reader = std::io::BufReader::new(pipe);
        let mut line = Vec::new();
        loop {
            line.clear();
            match std::io::BufRead::read_until(&mut reader, b'\n', &mut line) {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
            let text = String::from_utf8_lossy(&line);
            let text = text.trim_end();
            match &times {
                None => keep(text.as_bytes()),
                Some(tx) => {
                    if let Some(t) = showinfo_pts_time(text) {
                        let _ = tx.send(t);
                    } else if let Some(msg) = ["[error] ", "[fatal] ", "[panic] "]
                        .iter()
                        .find_map(|tag| text.split_once(tag).map(|(_, m)| m))
                    {
                        keep(msg.as_bytes());
                    }
                }
            }
        }
        if kept.len() > STDERR_KEEP {
            kept.drain(..kept.len() - STDERR_KEEP);
        }
        String::from_utf8_lossy(&kept).trim().to_string()
    })
}

/// The `pts_time` of a `showinfo` frame line (`[Parsed_showinfo_0 @ 0x..] [info] n:   3
/// pts:   100 pts_time:0.1 ...`); NaN for `NOPTS`; `None` for any other line.
fn showinfo_pts_time(line: &str) -> Option<f64> {
    if !line.contains("Parsed_showinfo") || !line.contains("] n:") {
        return None;
    }
    let v = line.split_once("pts_time:")?.1.split_whitespace().next()?;
    Some(
        v.parse::<f64>()
            .ok()
            .filter(|t| t.is_finite())
            .unwrap_or(f64::NAN),
    )
}

/// Starts a command in its own process group, so that a Ctrl-C in the
/// terminal reaches only this program, which then ends ffmpeg cleanly.
fn own_process_group(cmd: &mut Command) -> &mut Command {
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        cmd.process_group(0);
    }
    cmd
}

/// One decoded frame with its position in the video.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoFrame {
    /// Frame index, from 0.
    pub index: u64,
    /// Time of the frame, seconds: its presentation time in the stream, from 0 at the first
    /// frame (so variable-frame-rate video keeps its real clock), or `index / fps` (see
    /// [`VideoInfo::fps_or_default`]) for a frame without one.
    pub timestamp_s: f64,
    /// The pixels.
    pub image: RgbImage,
}

/// How long [`VideoReader`] waits for the next frame before it gives up on a source
/// that stopped delivering (a frozen webcam, a pipe whose writer stalls): 30 seconds.
pub const DEFAULT_STALL_TIMEOUT: Duration = Duration::from_secs(30);

/// What the thread that reads ffmpeg's output hands over.
enum Pumped {
    /// One whole frame of packed RGB.
    Frame(Vec<u8>),
    /// ffmpeg's output ended, after this many bytes of an incomplete frame.
    End(usize),
    /// Reading ffmpeg's output failed.
    Failed(std::io::Error),
}

/// Reads whole frames from ffmpeg's standard output on a thread, so that the reader can
/// wait for them with a timeout. At most two frames are held (one in the channel, one
/// being read); frame buffers are handed back for reuse.
fn pump_frames(
    mut stdout: ChildStdout,
    frame_len: usize,
) -> (Receiver<Pumped>, SyncSender<Vec<u8>>) {
    let (tx, rx) = sync_channel::<Pumped>(1);
    let (back_tx, back_rx) = sync_channel::<Vec<u8>>(2);
    std::thread::spawn(move || loop {
        let mut buf = back_rx
            .try_recv()
            .ok()
            .filter(|b| b.len() == frame_len)
            .unwrap_or_else(|| vec![0u8; frame_len]);
        let mut filled = 0;
        while filled < frame_len {
            match stdout.read(&mut buf[filled..]) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    let _ = tx.send(Pumped::Failed(e));
                    return;
                }
            }
        }
        if filled < frame_len {
            let _ = tx.send(Pumped::End(filled));
            return;
        }
        if tx.send(Pumped::Frame(buf)).is_err() {
            return;
        }
    });
    (rx, back_tx)
}

/// Decodes a video to RGB frames with an `ffmpeg` child process.
///
/// Frames come in decoding-output order with consecutive indices. After the
/// last frame, [`VideoReader::read_into`] returns `Ok(None)` if ffmpeg ended
/// cleanly, or an [`IoError::Video`] carrying ffmpeg's message if it failed
/// (corrupt or truncated input, ffmpeg killed); later calls return `Ok(None)`.
/// A source that delivers no frame for the stall timeout
/// ([`DEFAULT_STALL_TIMEOUT`], see [`VideoReader::set_stall_timeout`]) ends the same
/// way, with an error saying so: a frozen webcam or a stalled pipe never hangs the
/// reader. Dropping the reader stops ffmpeg.
pub struct VideoReader {
    child: Child,
    // The receivers sit in mutexes only to keep the reader `Sync` (the Python binding
    // shares it); `&mut self` reaches them with `get_mut`, without locking.
    frames: Mutex<Receiver<Pumped>>,
    spare: SyncSender<Vec<u8>>,
    stall_timeout: Duration,
    stderr: Option<JoinHandle<String>>,
    /// Each frame's presentation time, from the decoder's `showinfo` lines.
    times: Mutex<Receiver<f64>>,
    /// The first frame's presentation time (the clock starts there).
    first_pts: Option<f64>,
    info: VideoInfo,
    name: String,
    next_index: u64,
    done: bool,
}

impl std::fmt::Debug for VideoReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoReader")
            .field("input", &self.name)
            .field("info", &self.info)
            .field("next_index", &self.next_index)
            .field("stall_timeout", &self.stall_timeout)
            .finish()
    }
}

impl VideoReader {
    /// Probes the input and starts decoding it.
    pub fn open(input: &VideoInput) -> IoResult<VideoReader> {
        VideoReader::open_with(&FfmpegTools::default(), input)
    }

    /// [`VideoReader::open`] with explicit tool paths.
    pub fn open_with(tools: &FfmpegTools, input: &VideoInput) -> IoResult<VideoReader> {
        let info = probe_with(tools, input)?;
        let args = reader_args(input, tools.features());
        let mut child = own_process_group(Command::new(&tools.ffmpeg).args(&args))
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| spawn_error(&tools.ffmpeg, e))?;
        let (Some(stdout), Some(stderr)) = (child.stdout.take(), child.stderr.take()) else {
            let _ = child.kill();
            let _ = child.wait();
            return Err(IoError::Video {
                input: input.name(),
                message: "cannot connect to ffmpeg's output".into(),
            });
        };
        // parse_probe_json caps the size at MAX_FRAME_PIXELS.
        let (frames, spare) = pump_frames(stdout, info.width * info.height * 3);
        let (times_tx, times) = std::sync::mpsc::channel();
        Ok(VideoReader {
            child,
            frames: Mutex::new(frames),
            spare,
            stall_timeout: DEFAULT_STALL_TIMEOUT,
            stderr: Some(drain_stderr_with(stderr, Some(times_tx))),
            times: Mutex::new(times),
            first_pts: None,
            info,
            name: input.name(),
            next_index: 0,
            done: false,
        })
    }

    /// How long to wait for a frame before the source counts as stalled
    /// (default [`DEFAULT_STALL_TIMEOUT`]).
    pub fn set_stall_timeout(&mut self, timeout: Duration) {
        self.stall_timeout = timeout;
    }

    /// The probed stream description; frames have `info().width x info().height` pixels.
    pub fn info(&self) -> &VideoInfo {
        &self.info
    }

    /// Number of frames returned so far.
    pub fn frames_read(&self) -> u64 {
        self.next_index
    }

    /// Reads the next frame into `frame` (the decoded buffer is swapped in and the old
    /// one reused for a later frame, so a loop over one buffer allocates nothing) and
    /// returns `(index, timestamp_s)`, or `None` at the end. Waits at most the stall
    /// timeout for the frame.
    pub fn read_into(&mut self, frame: &mut RgbImage) -> IoResult<Option<(u64, f64)>> {
        if self.done {
            return Ok(None);
        }
        let size = (
            u32::try_from(self.info.width),
            u32::try_from(self.info.height),
        );
        let (Ok(w), Ok(h)) = size else {
            self.done = true;
            let why = format!("{}x{} is too large", self.info.width, self.info.height);
            return Err(self.end_error(why));
        };
        let len = self.info.width * self.info.height * 3;
        let received = match self.frames.get_mut() {
            Ok(rx) => rx.recv_timeout(self.stall_timeout),
            Err(poisoned) => poisoned.into_inner().recv_timeout(self.stall_timeout),
        };
        let filled = match received {
            Ok(Pumped::Frame(buf)) => match RgbImage::from_raw(w, h, buf) {
                Some(image) => {
                    let old = std::mem::replace(frame, image).into_raw();
                    let _ = self.spare.try_send(old);
                    let index = self.next_index;
                    self.next_index += 1;
                    // showinfo logs a frame before ffmpeg writes it, so its time is there.
                    let stall = self.stall_timeout;
                    let pts = match self.times.get_mut() {
                        Ok(rx) => rx.recv_timeout(stall),
                        Err(poisoned) => poisoned.into_inner().recv_timeout(stall),
                    }
                    .ok()
                    .filter(|t| t.is_finite());
                    let t = match pts {
                        Some(pts) => pts - *self.first_pts.get_or_insert(pts),
                        None => index as f64 / self.info.fps_or_default(),
                    };
                    return Ok(Some((index, t)));
                }
                None => {
                    self.done = true;
                    return Err(self.end_error("a frame of the wrong size".into()));
                }
            },
            Ok(Pumped::End(filled)) => filled,
            Err(RecvTimeoutError::Disconnected) => 0,
            Ok(Pumped::Failed(e)) => {
                self.done = true;
                return Err(self.end_error(format!("cannot read from ffmpeg: {e}")));
            }
            Err(RecvTimeoutError::Timeout) => {
                self.done = true;
                let why = format!(
                    "no frame for {:.1} s: the source stopped delivering, so it was closed",
                    self.stall_timeout.as_secs_f64()
                );
                return Err(self.end_error(why));
            }
        };
        // End of output: clean end, or a failure after the good frames.
        self.done = true;
        let status = self.child.wait();
        let stderr = self
            .stderr
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default();
        let ok = status.as_ref().is_ok_and(|s| s.success());
        if ok && filled == 0 && stderr.is_empty() {
            return Ok(None);
        }
        let mut why = match &status {
            Ok(s) if !s.success() => format!("ffmpeg failed ({s})"),
            Err(e) => format!("ffmpeg could not be waited for: {e}"),
            Ok(_) => "ffmpeg reported decoding errors".to_string(),
        };
        if filled > 0 {
            why.push_str(&format!(
                "; the last frame is incomplete ({filled} of {len} bytes)"
            ));
        }
        Err(self.error_with(why, &stderr))
    }

    /// Reads the next frame into a new buffer, or `None` at the end.
    pub fn next_frame(&mut self) -> IoResult<Option<VideoFrame>> {
        let mut image = RgbImage::new(0, 0);
        Ok(self
            .read_into(&mut image)?
            .map(|(index, timestamp_s)| VideoFrame {
                index,
                timestamp_s,
                image,
            }))
    }

    /// An error after a failed read: stops ffmpeg and collects its message.
    fn end_error(&mut self, why: String) -> IoError {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let stderr = self
            .stderr
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default();
        self.error_with(why, &stderr)
    }

    fn error_with(&self, why: String, stderr: &str) -> IoError {
        let mut message = format!("{why} after {} good frame(s)", self.next_index);
        if !stderr.is_empty() {
            message.push_str(": ");
            message.push_str(stderr);
        }
        IoError::Video {
            input: self.name.clone(),
            message,
        }
    }
}

impl Iterator for VideoReader {
    type Item = IoResult<VideoFrame>;

    /// The next frame; after an error, `None`.
    fn next(&mut self) -> Option<IoResult<VideoFrame>> {
        self.next_frame().transpose()
    }
}

impl Drop for VideoReader {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
        if let Some(t) = self.stderr.take() {
            let _ = t.join();
        }
    }
}

/// The ffmpeg arguments that decode `input` to packed RGB on standard output: every
/// decoded frame once (`-fps_mode passthrough`, or `-vsync passthrough` for an ffmpeg
/// before 5.1: no frame duplicated or dropped to make a variable frame rate constant),
/// each frame's presentation time logged by the `showinfo` filter (`-v level+info`;
/// [`VideoReader`] reads it and keeps only the error lines for messages), without the
/// filter's per-frame checksums where `features` allows.
pub fn reader_args(input: &VideoInput, features: FfmpegFeatures) -> Vec<String> {
    let mut args: Vec<String> = ["-hide_banner", "-nostdin", "-nostats", "-v", "level+info"]
        .map(String::from)
        .to_vec();
    args.extend(input.input_args());
    args.extend(
        [
            "-map",
            "0:v:0",
            "-an",
            "-sn",
            "-vf",
            if features.showinfo_checksum_option {
                "showinfo=checksum=0"
            } else {
                "showinfo"
            },
            features.fps_mode_option(),
            "passthrough",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
            "-",
        ]
        .map(String::from),
    );
    args
}

/// The video encoder a [`VideoWriter`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoder {
    /// H.264 with `libx264` (`-preset veryfast`, `-pix_fmt yuv420p`): small, plays everywhere.
    Libx264,
    /// MPEG-4 part 2 (`mpeg4`, built into every ffmpeg), the fallback.
    Mpeg4,
}

impl Encoder {
    /// `libx264` if this ffmpeg has it, else `mpeg4`.
    pub fn best_available(tools: &FfmpegTools) -> Encoder {
        if tools.has_encoder("libx264") {
            Encoder::Libx264
        } else {
            Encoder::Mpeg4
        }
    }

    fn args(self) -> &'static [&'static str] {
        match self {
            Encoder::Libx264 => &["-c:v", "libx264", "-preset", "veryfast", "-crf", "20"],
            Encoder::Mpeg4 => &["-c:v", "mpeg4", "-q:v", "3"],
        }
    }
}

/// The ffmpeg arguments that encode `width x height` RGB frames from standard input to `out`.
pub fn writer_args(
    width: usize,
    height: usize,
    fps: f64,
    encoder: Encoder,
    out: &Path,
) -> Vec<String> {
    let mut args: Vec<String> = ["-hide_banner", "-v", "error", "-y"]
        .map(String::from)
        .to_vec();
    args.extend(["-f", "rawvideo", "-pix_fmt", "rgb24"].map(String::from));
    args.extend([
        "-s".into(),
        format!("{width}x{height}"),
        "-r".into(),
        format!("{fps}"),
    ]);
    args.extend(["-i", "-", "-an"].map(String::from));
    if width % 2 == 1 || height % 2 == 1 {
        // yuv420p needs even sizes: pad one black row/column.
        args.extend(["-vf".into(), "pad=ceil(iw/2)*2:ceil(ih/2)*2".into()]);
    }
    args.extend(encoder.args().iter().map(|s| s.to_string()));
    args.extend(["-pix_fmt".into(), "yuv420p".into()]);
    args.push(out.display().to_string());
    args
}

/// Encodes RGB frames to a video file with an `ffmpeg` child process.
///
/// The container follows the file extension (`.mp4`, `.mkv`, `.mov`, `.avi`).
/// [`VideoWriter::finish`] closes ffmpeg's input and waits for it to write the
/// file; dropping an unfinished writer does the same (errors ignored), so an
/// interrupted program still leaves a playable file. ffmpeg runs in its own
/// process group: a Ctrl-C in the terminal does not kill it mid-file, and if
/// this program dies, ffmpeg sees its input end and finalises the file.
pub struct VideoWriter {
    child: Option<Child>,
    stdin: Option<ChildStdin>,
    stderr: Option<JoinHandle<String>>,
    width: usize,
    height: usize,
    frames: u64,
    path: PathBuf,
}

impl std::fmt::Debug for VideoWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoWriter")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("frames", &self.frames)
            .finish()
    }
}

impl VideoWriter {
    /// Starts encoding `width x height` frames at `fps` to `path` (overwritten)
    /// with the best available encoder.
    pub fn create(
        path: impl AsRef<Path>,
        width: usize,
        height: usize,
        fps: f64,
    ) -> IoResult<VideoWriter> {
        let tools = FfmpegTools::default();
        let encoder = Encoder::best_available(&tools);
        VideoWriter::create_with(&tools, encoder, path, width, height, fps)
    }

    /// [`VideoWriter::create`] with explicit tools and encoder.
    pub fn create_with(
        tools: &FfmpegTools,
        encoder: Encoder,
        path: impl AsRef<Path>,
        width: usize,
        height: usize,
        fps: f64,
    ) -> IoResult<VideoWriter> {
        let path = path.as_ref().to_path_buf();
        let bad = |message: String| IoError::Video {
            input: path.display().to_string(),
            message,
        };
        if width == 0 || height == 0 || width >= 1 << 15 || height >= 1 << 15 {
            return Err(bad(format!("invalid frame size {width}x{height}")));
        }
        if !(fps.is_finite() && fps > 0.0 && fps <= 1000.0) {
            return Err(bad(format!("invalid frame rate {fps}")));
        }
        let args = writer_args(width, height, fps, encoder, &path);
        let mut child = own_process_group(Command::new(&tools.ffmpeg).args(&args))
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| spawn_error(&tools.ffmpeg, e))?;
        let stdin = child.stdin.take();
        let stderr = child.stderr.take().map(drain_stderr);
        Ok(VideoWriter {
            child: Some(child),
            stdin,
            stderr,
            width,
            height,
            frames: 0,
            path,
        })
    }

    /// Frames written so far.
    pub fn frames_written(&self) -> u64 {
        self.frames
    }

    /// The output file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Encodes one frame, which must have the writer's size.
    pub fn write(&mut self, frame: &RgbImage) -> IoResult<()> {
        let name = self.path.display().to_string();
        let (w, h) = frame.dimensions();
        if (w as usize, h as usize) != (self.width, self.height) {
            return Err(IoError::Video {
                input: name,
                message: format!(
                    "frame {} is {w}x{h}, the video is {}x{}",
                    self.frames, self.width, self.height
                ),
            });
        }
        let Some(stdin) = self.stdin.as_mut() else {
            return Err(IoError::Video {
                input: name,
                message: "the writer is already finished".into(),
            });
        };
        if let Err(e) = stdin.write_all(frame.as_raw()) {
            // ffmpeg has gone (bad path, unsupported container, ...): report what it said.
            let why = format!("cannot send frame {} to ffmpeg: {e}", self.frames);
            return Err(match self.close() {
                Err(IoError::Video { input, message }) => IoError::Video {
                    input,
                    message: format!("{why}; {message}"),
                },
                _ => IoError::Video {
                    input: name,
                    message: why,
                },
            });
        }
        self.frames += 1;
        Ok(())
    }

    /// Closes ffmpeg's input, waits for it to finish the file and reports its errors.
    pub fn finish(mut self) -> IoResult<()> {
        self.close()
    }

    fn close(&mut self) -> IoResult<()> {
        drop(self.stdin.take());
        let Some(mut child) = self.child.take() else {
            return Ok(());
        };
        let status = child.wait();
        let stderr = self
            .stderr
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default();
        match status {
            Ok(s) if s.success() => Ok(()),
            Ok(s) => Err(IoError::Video {
                input: self.path.display().to_string(),
                message: format!(
                    "ffmpeg failed ({s}) after {} frame(s): {stderr}",
                    self.frames
                ),
            }),
            Err(e) => Err(IoError::Video {
                input: self.path.display().to_string(),
                message: format!("ffmpeg could not be waited for: {e}"),
            }),
        }
    }
}

impl Drop for VideoWriter {
    fn drop(&mut self) {
        let _ = self.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_strings_map_to_ffmpeg_arguments() {
        assert_eq!(VideoInput::parse("webcam:2"), VideoInput::Webcam(2));
        assert_eq!(
            VideoInput::parse("webcam:2").input_args(),
            vec!["-f", "v4l2", "-i", "/dev/video2"]
        );
        assert!(VideoInput::parse("webcam:0").is_live());
        // Not a number: a file that happens to start with "webcam:".
        assert_eq!(
            VideoInput::parse("webcam:x.mp4"),
            VideoInput::File(PathBuf::from("webcam:x.mp4"))
        );
        let old = FfmpegFeatures::default();
        let args = reader_args(&VideoInput::parse("a b.mp4"), old);
        let i = args.iter().position(|a| a == "-i").unwrap();
        assert_eq!(args[i + 1], "a b.mp4");
        assert!(args.ends_with(&["rgb24".to_string(), "-".to_string()]));
        assert!(args.contains(&"-nostdin".to_string()));
        assert!(args.contains(&"showinfo".to_string()));
        assert!(args.contains(&"-vsync".to_string()));
        let new = FfmpegFeatures {
            showinfo_checksum_option: true,
            fps_mode: true,
        };
        let args = reader_args(&VideoInput::parse("a b.mp4"), new);
        assert!(args.contains(&"showinfo=checksum=0".to_string()));
        let mode = args.iter().position(|a| a == "-fps_mode").unwrap();
        assert_eq!(args[mode + 1], "passthrough");
        assert!(!args.contains(&"-vsync".to_string()));
    }

    #[test]
    fn features_come_from_the_help_text() {
        // Excerpts of `ffmpeg -h full`: FFmpeg 5.1 (Debian 12), 9.0, and 4.4 (neither).
        let v5 = "-vsync              set video sync method globally; deprecated, use -fps_mode\n\
                  -fps_mode           set framerate mode for matching video streams; overrides vsync\n\
                  \n\
                  showinfo AVOptions:\n\
                  \x20  checksum          <boolean>    ..FV....... calculate checksums (default true)\n\
                  \n\
                  showpalette AVOptions:\n\
                  \x20  s                 <int>        ..FV....... set pixel box size\n";
        let both = FfmpegFeatures {
            showinfo_checksum_option: true,
            fps_mode: true,
        };
        assert_eq!(FfmpegFeatures::from_help(v5), both);
        let v9 = "-fps_mode[:<stream_spec>]  set framerate mode for matching video streams\n\
                  showinfo AVOptions:\n\
                  \x20  checksum          <boolean>    ..FV....... calculate checksums (default true)\n\
                  \x20  udu_sei_as_ascii  <boolean>    ..FV....... try to print user data\n";
        assert_eq!(FfmpegFeatures::from_help(v9), both);
        // A `checksum` of another filter or codec does not count, nor `-fps_mode` in prose.
        let v4 = "-vsync              video sync method\n\
                  framemd5 AVOptions:\n\
                  \x20  checksum          <boolean>    ..FV....... calculate checksums\n\
                  showinfo AVOptions:\n\
                  \n\
                  -vf filter_graph    set video filters (see -fps_mode)\n";
        assert_eq!(FfmpegFeatures::from_help(v4), FfmpegFeatures::default());
    }

    #[test]
    fn showinfo_lines_give_the_frame_times() {
        let l = "[Parsed_showinfo_0 @ 0x561d13559700] [info] n:   5 pts:    500 pts_time:0.5     pos: 1 fmt:yuv420p";
        assert_eq!(showinfo_pts_time(l), Some(0.5));
        let l = "[Parsed_showinfo_0 @ 0x5] [info] n:   0 pts:NOPTS pts_time:NOPTS pos: -1";
        assert!(showinfo_pts_time(l).is_some_and(f64::is_nan));
        let l = "[Parsed_showinfo_0 @ 0x5] [info] config in time_base: 1/1000, frame_rate: 30/1";
        assert_eq!(showinfo_pts_time(l), None);
        assert_eq!(showinfo_pts_time("[info] Stream mapping:"), None);
    }

    #[test]
    fn writer_arguments_pad_odd_sizes() {
        let a = writer_args(640, 480, 30.0, Encoder::Libx264, Path::new("o.mp4"));
        assert!(a.windows(2).any(|w| w == ["-s", "640x480"]));
        assert!(a.windows(2).any(|w| w == ["-c:v", "libx264"]));
        assert!(!a.contains(&"-vf".to_string()));
        assert_eq!(a.last().map(String::as_str), Some("o.mp4"));
        let a = writer_args(641, 480, 29.97, Encoder::Mpeg4, Path::new("o.mp4"));
        assert!(a.contains(&"-vf".to_string()));
        assert!(a.windows(2).any(|w| w == ["-r", "29.97"]));
        assert!(a.windows(2).any(|w| w == ["-c:v", "mpeg4"]));
    }

    /// Found while writing the fuzz harness: each dimension was capped at 65 535 but not
    /// their product, so a stream header claiming 65535x65535 made the reader allocate a
    /// 12.9 GB frame.
    #[test]
    fn forged_frame_size_is_an_error() {
        let j = r#"{"streams": [{"width": 65535, "height": 65535}]}"#;
        let e = parse_probe_json(j, "big.mp4").unwrap_err().to_string();
        assert!(e.contains("exceed the limit of 67108864 pixels"), "{e}");
        let j = r#"{"streams": [{"width": 8192, "height": 8192}]}"#;
        assert!(parse_probe_json(j, "8k.mp4").is_ok());
    }

    #[test]
    fn probe_json_is_parsed() {
        let j = r#"{"programs": [], "streams": [{"codec_name": "h264", "width": 1920,
            "height": 1080, "r_frame_rate": "30000/1001", "nb_frames": "300",
            "side_data_list": [{"rotation": -90}]}]}"#;
        let info = parse_probe_json(j, "p.mp4").unwrap();
        assert_eq!((info.width, info.height), (1080, 1920));
        assert_eq!(info.rotation_deg, -90);
        assert!((info.fps.unwrap() - 29.97).abs() < 0.01);
        assert_eq!(info.frame_count, Some(300));
        assert_eq!(info.codec.as_deref(), Some("h264"));
        let j = r#"{"streams": [{"width": 640, "height": 480, "r_frame_rate": "0/0",
            "tags": {"rotate": "180"}}]}"#;
        let info = parse_probe_json(j, "p.mkv").unwrap();
        assert_eq!(
            (info.width, info.height, info.rotation_deg),
            (640, 480, 180)
        );
        assert_eq!(info.fps, None);
        assert_eq!(info.fps_or_default(), DEFAULT_FPS);
        assert_eq!(info.frame_count, None);
        let e = parse_probe_json(r#"{"streams": []}"#, "a.wav")
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.wav") && e.contains("no video stream"), "{e}");
        let e = parse_probe_json(r#"{"streams": [{"width": 0}]}"#, "z.mp4")
            .unwrap_err()
            .to_string();
        assert!(e.contains("width"), "{e}");
    }

    #[test]
    fn missing_tools_say_what_to_install() {
        let tools = FfmpegTools {
            ffmpeg: PathBuf::from("/nonexistent/ffmpeg"),
            ffprobe: PathBuf::from("/nonexistent/ffprobe"),
        };
        assert!(!tools.available());
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("x.mp4");
        std::fs::write(&f, b"data").unwrap();
        let e = probe_with(&tools, &VideoInput::File(f.clone()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("apt-get install ffmpeg"), "{e}");
        let e = VideoWriter::create_with(&tools, Encoder::Mpeg4, &f, 4, 4, 25.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("/nonexistent/ffmpeg") && e.contains("ffmpeg"),
            "{e}"
        );
    }
}
