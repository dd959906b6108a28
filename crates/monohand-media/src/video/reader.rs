//! Decoding: [`VideoReader`] runs `ffmpeg` on a [`VideoInput`] and reads its frames from
//! its standard output (8-bit 4:2:0 streams as decoded, converted to RGB here; others as
//! packed RGB), with each frame's time from the `showinfo` filter and
//! a stall timeout ([`DEFAULT_STALL_TIMEOUT`]); ffmpeg's standard error is drained on a
//! thread (for the writer too).

use super::input::VideoInput;
use super::probe::{probe_with, VideoInfo};
use super::tools::{ffmpeg_said, own_process_group, spawn_error, FfmpegFeatures, FfmpegTools};
use super::yuv::{yuv420_frame_len, yuv420_to_rgb, Yuv420};
use super::RgbImage;
use monohand_io::{IoError, IoResult};
use std::io::Read;
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender};
use std::sync::Mutex;
use std::thread::JoinHandle;
use std::time::Duration;

/// How many bytes of ffmpeg's standard error are kept for error messages (the tail).
const STDERR_KEEP: usize = 4096;

/// Reads a child's standard error on a thread, keeping the last [`STDERR_KEEP`] bytes.
pub(super) fn drain_stderr(pipe: impl Read + Send + 'static) -> JoinHandle<String> {
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
    /// One whole frame of packed RGB (converted from ffmpeg's planes where it sent YUV).
    Frame(Vec<u8>),
    /// ffmpeg's output ended, after this many bytes of an incomplete frame.
    End(usize),
    /// Reading ffmpeg's output failed.
    Failed(std::io::Error),
}

/// Reads whole frames from ffmpeg's standard output on a thread, so that the reader can
/// wait for them with a timeout. At most two frames are held (one in the channel, one
/// being read); frame buffers are handed back for reuse.
/// Bytes of the pipe from ffmpeg asked for: Linux's default 64 KiB moves a 4K RGB
/// frame (25 MB) in about 380 reads, each a wake-up of both processes.
#[cfg(target_os = "linux")]
const PIPE_BYTES: libc::c_int = 1 << 20;

/// Asks for a pipe of [`PIPE_BYTES`] (Linux; capped by `/proc/sys/fs/pipe-max-size`
/// for unprivileged users). A refusal leaves the default, which works, slower.
#[cfg(target_os = "linux")]
fn widen_pipe(stdout: &ChildStdout) {
    use std::os::fd::AsRawFd;
    // SAFETY: fcntl on a file descriptor this process owns (the child's stdout pipe),
    // with an integer argument; it changes nothing else and failure is harmless.
    let _ = unsafe { libc::fcntl(stdout.as_raw_fd(), libc::F_SETPIPE_SZ, PIPE_BYTES) };
}

#[cfg(not(target_os = "linux"))]
fn widen_pipe(_stdout: &ChildStdout) {}

fn pump_frames(
    mut stdout: ChildStdout,
    (width, height): (usize, usize),
    yuv: Option<Yuv420>,
) -> (Receiver<Pumped>, SyncSender<Vec<u8>>) {
    let (tx, rx) = sync_channel::<Pumped>(1);
    let (back_tx, back_rx) = sync_channel::<Vec<u8>>(2);
    let frame_len = width * height * 3;
    let wire_len = wire_frame_len((width, height), yuv);
    std::thread::spawn(move || {
        // What ffmpeg writes, when it is not the RGB itself: one frame's planes, reused.
        let mut planes = match yuv {
            Some(_) => vec![0u8; wire_len],
            None => Vec::new(),
        };
        loop {
            let mut buf = back_rx
                .try_recv()
                .ok()
                .filter(|b| b.len() == frame_len)
                .unwrap_or_else(|| vec![0u8; frame_len]);
            let wire = match yuv {
                Some(_) => &mut planes[..],
                None => &mut buf[..],
            };
            let mut filled = 0;
            while filled < wire_len {
                match stdout.read(&mut wire[filled..]) {
                    Ok(0) => break,
                    Ok(n) => filled += n,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(e) => {
                        let _ = tx.send(Pumped::Failed(e));
                        return;
                    }
                }
            }
            if filled < wire_len {
                let _ = tx.send(Pumped::End(filled));
                return;
            }
            if let Some(layout) = yuv {
                // Both lengths are the ones the conversion checks, so it always converts.
                let _ = yuv420_to_rgb(&planes, (width, height), layout, &mut buf);
            }
            if tx.send(Pumped::Frame(buf)).is_err() {
                return;
            }
        }
    });
    (rx, back_tx)
}

/// The bytes of one frame on ffmpeg's output: 4:2:0 planes or packed RGB.
fn wire_frame_len((width, height): (usize, usize), yuv: Option<Yuv420>) -> usize {
    match yuv {
        Some(_) => yuv420_frame_len(width, height),
        None => width * height * 3,
    }
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
    /// The bytes of one frame on ffmpeg's output (for the message about a frame cut short).
    wire_len: usize,
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

/// Hands frames a [`VideoReader`] returned back to it for reuse, from any thread: the
/// reader then decodes into those buffers instead of allocating (and zeroing) a new one
/// per frame, which at 3840x2160 is 25 MB per frame (docs/performance.md, issue 34).
#[derive(Clone, Debug)]
pub struct FrameRecycler(SyncSender<Vec<u8>>);

impl FrameRecycler {
    /// Gives `image`'s buffer back to the reader (dropped if the reader already holds two
    /// spare buffers, or has ended, or the size is not the video's).
    pub fn recycle(&self, image: RgbImage) {
        let _ = self.0.try_send(image.into_raw());
    }
}

impl VideoReader {
    /// A handle that gives frames back to this reader for reuse ([`FrameRecycler`]).
    pub fn recycler(&self) -> FrameRecycler {
        FrameRecycler(self.spare.clone())
    }

    /// Probes the input and starts decoding it.
    pub fn open(input: &VideoInput) -> IoResult<VideoReader> {
        VideoReader::open_with(&FfmpegTools::default(), input)
    }

    /// [`VideoReader::open`] with explicit tool paths.
    pub fn open_with(tools: &FfmpegTools, input: &VideoInput) -> IoResult<VideoReader> {
        let info = probe_with(tools, input)?;
        // 8-bit 4:2:0 streams come as they are decoded and are converted on the reading
        // thread (half the bytes through the pipe, no conversion in ffmpeg; `yuv.rs`).
        let yuv = Yuv420::of_stream(&info);
        let pix_fmt = yuv.map_or("rgb24", |l| l.pix_fmt());
        let args = reader_args(input, tools.features(), pix_fmt);
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
        widen_pipe(&stdout);
        // parse_probe_json caps the size at MAX_FRAME_PIXELS.
        let (frames, spare) = pump_frames(stdout, (info.width, info.height), yuv);
        let wire_len = wire_frame_len((info.width, info.height), yuv);
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
            wire_len,
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
        let len = self.wire_len;
        let len_rgb = self.info.width * self.info.height * 3;
        let received = match self.frames.get_mut() {
            Ok(rx) => rx.recv_timeout(self.stall_timeout),
            Err(poisoned) => poisoned.into_inner().recv_timeout(self.stall_timeout),
        };
        let filled = match received {
            Ok(Pumped::Frame(buf)) => match RgbImage::from_raw(w, h, buf) {
                Some(image) => {
                    let old = std::mem::replace(frame, image).into_raw();
                    // Only a frame's worth of bytes is worth keeping: `next_frame` swaps
                    // in an empty image, which would take a spare's place for nothing.
                    if old.len() == len_rgb {
                        let _ = self.spare.try_send(old);
                    }
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
        let said = ffmpeg_said(stderr, &self.name);
        if !said.is_empty() {
            message.push_str(": ");
            message.push_str(&said);
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

/// The ffmpeg arguments that decode `input` to raw frames of `pix_fmt` (`rgb24`, or the
/// stream's own 4:2:0 format, see [`Yuv420`]) on standard output: every
/// decoded frame once (`-fps_mode passthrough`, or `-vsync passthrough` for an ffmpeg
/// before 5.1: no frame duplicated or dropped to make a variable frame rate constant),
/// each frame's presentation time logged by the `showinfo` filter (`-v level+info`;
/// [`VideoReader`] reads it and keeps only the error lines for messages), without the
/// filter's per-frame checksums where `features` allows.
pub fn reader_args(input: &VideoInput, features: FfmpegFeatures, pix_fmt: &str) -> Vec<String> {
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
            pix_fmt,
            "-",
        ]
        .map(String::from),
    );
    args
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reader_arguments_follow_the_features() {
        let old = FfmpegFeatures::default();
        let args = reader_args(&VideoInput::parse("a b.mp4"), old, "rgb24");
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
        let args = reader_args(&VideoInput::parse("a b.mp4"), new, "yuv420p");
        assert!(args.contains(&"showinfo=checksum=0".to_string()));
        let mode = args.iter().position(|a| a == "-fps_mode").unwrap();
        assert_eq!(args[mode + 1], "passthrough");
        assert!(!args.contains(&"-vsync".to_string()));
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
}
