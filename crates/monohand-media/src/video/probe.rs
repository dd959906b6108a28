//! `ffprobe`: what a video's first stream is ([`VideoInfo`]: size, frame rate, frame
//! count, codec, rotation), and the parsing of ffprobe's JSON.

use super::input::VideoInput;
use super::tools::{ffmpeg_said, spawn_error, FfmpegTools};
use monohand_io::{IoError, IoResult};
use serde_json::Value;
use std::process::{Command, Stdio};

/// The frame rate assumed when a video does not state one (frames per second).
pub const DEFAULT_FPS: f64 = 30.0;

/// Largest frame accepted from a video, in pixels (2^26, 67 megapixels: an RGB frame of
/// 201 MB; 8K UHD is 33 megapixels). The reader allocates one frame of this size, so a
/// forged stream header cannot make it allocate more.
pub const MAX_FRAME_PIXELS: usize = 1 << 26;

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
    /// The decoder's pixel format, e.g. `yuv420p` (8-bit 4:2:0), if ffprobe names one.
    pub pix_fmt: Option<String>,
    /// The stream's YUV matrix as ffprobe names it (`bt709`, `smpte170m`, ...), if stated.
    pub color_space: Option<String>,
    /// The stream's range as ffprobe names it (`tv`: limited, `pc`: full), if stated.
    pub color_range: Option<String>,
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
        pix_fmt: str_field("pix_fmt").map(str::to_string),
        color_space: str_field("color_space").map(str::to_string),
        color_range: str_field("color_range").map(str::to_string),
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
        "stream=width,height,r_frame_rate,nb_frames,codec_name,pix_fmt,color_space,color_range:stream_tags=rotate:stream_side_data=rotation"
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
    let stderr = ffmpeg_said(&String::from_utf8_lossy(&out.stderr), &name);
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

#[cfg(test)]
mod tests {
    use super::*;

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
            "pix_fmt": "yuv420p", "color_space": "bt709", "color_range": "tv",
            "side_data_list": [{"rotation": -90}]}]}"#;
        let info = parse_probe_json(j, "p.mp4").unwrap();
        assert_eq!(info.pix_fmt.as_deref(), Some("yuv420p"));
        assert_eq!(info.color_space.as_deref(), Some("bt709"));
        assert_eq!(info.color_range.as_deref(), Some("tv"));
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
        assert_eq!((info.pix_fmt, info.color_space), (None, None));
        let e = parse_probe_json(r#"{"streams": []}"#, "a.wav")
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.wav") && e.contains("no video stream"), "{e}");
        let e = parse_probe_json(r#"{"streams": [{"width": 0}]}"#, "z.mp4")
            .unwrap_err()
            .to_string();
        assert!(e.contains("width"), "{e}");
    }
}
