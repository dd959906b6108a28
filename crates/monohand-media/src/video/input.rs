//! What a video is read from ([`VideoInput`]): a file, URL or image-sequence pattern, or a
//! webcam, and the ffmpeg/ffprobe arguments that open it. Below both the prober and the
//! reader, which each take one.

use std::path::PathBuf;

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
    }
}
