//! The `ffmpeg` and `ffprobe` executables: where they are ([`FfmpegTools`]), what they
//! support (asked once per process and executable and cached: the encoders, and the
//! reader's [`FfmpegFeatures`]), and starting them (a process group of their own, the
//! error for a tool that cannot be run, what a tool said on its standard error).

use monohand_io::IoError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Mutex, OnceLock};

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
    ///
    /// [`reader_args`]: super::reader_args
    pub fn features(&self) -> FfmpegFeatures {
        static FEATURES: OnceLock<Mutex<HashMap<PathBuf, FfmpegFeatures>>> = OnceLock::new();
        self.answer(&FEATURES, &["-h", "full"], FfmpegFeatures::from_help)
            .unwrap_or_default()
    }
}

/// What an `ffmpeg` executable supports among the options [`VideoReader`] would like
/// ([`FfmpegTools::features`]): it then uses them, else their older forms.
///
/// [`VideoReader`]: super::VideoReader
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
pub(super) fn spawn_error(tool: &Path, e: std::io::Error) -> IoError {
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

/// What ffmpeg or ffprobe said about `input`, for an [`IoError::Video`] (whose message
/// already starts with the input's name): its lines joined with `; `, each without the
/// `input: ` that ffmpeg puts before them, so that the error names the file once.
pub(super) fn ffmpeg_said(stderr: &str, input: &str) -> String {
    let prefix = format!("{input}: ");
    stderr
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| l.strip_prefix(prefix.as_str()).unwrap_or(l))
        .collect::<Vec<_>>()
        .join("; ")
}

/// Starts a command in its own process group, so that a Ctrl-C in the
/// terminal reaches only this program, which then ends ffmpeg cleanly.
pub(super) fn own_process_group(cmd: &mut Command) -> &mut Command {
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        cmd.process_group(0);
    }
    cmd
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::video::{probe_with, Encoder, VideoInput, VideoWriter};

    #[test]
    fn what_ffmpeg_said_names_the_input_once() {
        let stderr = "[mov,mp4,m4a,3gp,3g2,mj2 @ 0x55c8bd6db4c0] moov atom not found\n\
                      dir/bad.mp4: Invalid data found when processing input\n";
        assert_eq!(
            ffmpeg_said(stderr, "dir/bad.mp4"),
            "[mov,mp4,m4a,3gp,3g2,mj2 @ 0x55c8bd6db4c0] moov atom not found; \
             Invalid data found when processing input"
        );
        assert_eq!(ffmpeg_said(" \n", "x.mp4"), "");
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
