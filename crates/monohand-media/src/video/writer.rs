//! Encoding: [`VideoWriter`] runs `ffmpeg` and writes packed RGB frames to its standard
//! input, with the best [`Encoder`] the executable has.

use super::reader::drain_stderr;
use super::tools::{own_process_group, spawn_error, FfmpegTools};
use super::RgbImage;
use monohand_io::{IoError, IoResult};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::thread::JoinHandle;

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
        // Dropping the pipe closes it: ffmpeg sees the end of its input.
        self.stdin = None;
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
}
