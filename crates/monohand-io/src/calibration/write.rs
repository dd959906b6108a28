//! Writing a calibration's result: the project JSON with what the calibration says about
//! itself, and OpenCV `cv::FileStorage` YAML.

use super::camera_to_json;
use crate::error::{IoError, IoResult};
use monohand_core::camera::{Camera, LensModel};
use serde_json::{json, Value};
use std::path::Path;

/// What a calibration says about itself, written beside its camera.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationInfo {
    /// RMS reprojection error of the calibration, pixels.
    pub rms_px: f64,
    /// Views of the board used.
    pub views: usize,
    /// Inner corners along a row of the board.
    pub board_cols: usize,
    /// Inner corners along a column of the board.
    pub board_rows: usize,
    /// Side of a square, millimetres.
    pub square_mm: f64,
    /// When it was made, ISO 8601 (UTC).
    pub date: String,
    /// One standard deviation of `fx, fy, cx, cy` (pixels) and of each distortion
    /// coefficient written, when known.
    pub std: Option<CameraStd>,
}

/// One standard deviation of a calibration's numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraStd {
    /// Focal length x, pixels.
    pub fx: f64,
    /// Focal length y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// The distortion coefficients', in the order of the camera's `dist`.
    pub dist: Vec<f64>,
}

/// The project JSON of a calibrated camera: [`camera_to_json`] with `rms_px`, `views`,
/// `board`, `date` and `std`, all of which [`super::parse_calibration`] reads back.
pub fn calibrated_camera_json(camera: &Camera, info: &CalibrationInfo) -> Value {
    let mut v = camera_to_json(camera);
    if let Some(o) = v.as_object_mut() {
        o.insert("rms_px".into(), json!(info.rms_px));
        o.insert("views".into(), json!(info.views));
        o.insert(
            "board".into(),
            json!({
                "cols": info.board_cols,
                "rows": info.board_rows,
                "square_mm": info.square_mm,
            }),
        );
        o.insert("date".into(), json!(info.date));
        if let Some(s) = &info.std {
            o.insert(
                "std".into(),
                json!({"fx": s.fx, "fy": s.fy, "cx": s.cx, "cy": s.cy, "dist": s.dist}),
            );
        }
    }
    v
}

/// A calibrated camera as OpenCV's `cv::FileStorage` writes YAML (the keys of OpenCV's
/// `calibration` sample: `camera_matrix`, `distortion_coefficients`,
/// `avg_reprojection_error`, ...; `fisheye_model: 1` and the 4 coefficients of a fisheye,
/// as that sample writes them; `R` and `T` for a rig's other cameras, as
/// `cv::stereoCalibrate` gives them).
pub fn opencv_yaml(camera: &Camera, info: &CalibrationInfo) -> String {
    let k = &camera.intrinsics;
    let c = camera.distortion.coeffs;
    let fisheye = camera.distortion.model == LensModel::Fisheye;
    let n = if fisheye {
        4
    } else if c[5..].iter().any(|&v| v != 0.0) {
        8
    } else {
        5
    };
    let mut out = format!(
        "%YAML:1.0\n---\ncalibration_time: \"{}\"\nnr_of_frames: {}\nimage_width: {}\n\
         image_height: {}\nboard_width: {}\nboard_height: {}\nsquare_size: {}\n",
        info.date,
        info.views,
        k.width,
        k.height,
        info.board_cols,
        info.board_rows,
        num(info.square_mm)
    );
    if fisheye {
        out.push_str("fisheye_model: 1\n");
    }
    let km = [k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0];
    out.push_str(&matrix("camera_matrix", 3, 3, &km));
    out.push_str(&matrix("distortion_coefficients", 1, n, &c[..n]));
    out.push_str(&format!("avg_reprojection_error: {}\n", num(info.rms_px)));
    if !camera.extrinsics.is_identity() {
        let m = camera.extrinsics.rotation.matrix();
        let r: Vec<f64> = (0..3)
            .flat_map(|i| (0..3).map(move |j| m[(i, j)]))
            .collect();
        out.push_str(&matrix("R", 3, 3, &r));
        let t = camera.extrinsics.translation;
        out.push_str(&matrix("T", 3, 1, &[t.x, t.y, t.z]));
    }
    out
}

/// A number as YAML reads it back exactly (always with a `.` or an exponent).
fn num(v: f64) -> String {
    format!("{v:?}")
}

fn matrix(name: &str, rows: usize, cols: usize, data: &[f64]) -> String {
    let items: Vec<String> = data.iter().map(|&v| num(v)).collect();
    format!(
        "{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
        items.join(", ")
    )
}

/// Writes `bytes` (text or binary) to `path` whole or not at all: into a temporary file
/// beside it, then renamed over it, so a failure leaves any earlier file as it was.
pub fn write_atomically(path: impl AsRef<Path>, bytes: impl AsRef<[u8]>) -> IoResult<()> {
    let path = path.as_ref();
    let err = |error| IoError::Write {
        path: path.to_path_buf(),
        error,
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.partial"));
    std::fs::write(&tmp, bytes).map_err(err)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        err(e)
    })
}

#[cfg(test)]
mod tests {
    use super::super::{parse_calibration, CalibrationFormat};
    use super::*;
    use monohand_core::camera::{Distortion, Extrinsics, Intrinsics};
    use nalgebra::{Rotation3, Vector3};

    fn rig_camera() -> Camera {
        Camera::new(
            Intrinsics {
                fx: 542.4,
                fy: 541.6,
                cx: 328.3,
                cy: 247.0,
                width: 640,
                height: 480,
            },
            Distortion::from_slice(&[-0.28, 0.1, 1e-3, -2e-4, 0.02]).unwrap(),
            Extrinsics {
                rotation: Rotation3::from_euler_angles(0.01, -0.02, 0.005),
                translation: Vector3::new(-83.3, 1.2, 0.4),
            },
        )
        .unwrap()
    }

    fn info() -> CalibrationInfo {
        CalibrationInfo {
            rms_px: 0.46,
            views: 13,
            board_cols: 9,
            board_rows: 6,
            square_mm: 25.0,
            date: "2026-11-27T06:00:00Z".into(),
            std: Some(CameraStd {
                fx: 0.9,
                fy: 0.8,
                cx: 0.6,
                cy: 0.5,
                dist: vec![0.01, 0.05, 1e-4, 1e-4, 0.1],
            }),
        }
    }

    #[test]
    fn the_json_is_read_back_with_its_rms() {
        let cam = rig_camera();
        let text = format!("{:#}", calibrated_camera_json(&cam, &info()));
        let back = parse_calibration(&text, "cam.json").unwrap();
        assert_eq!(back.format, CalibrationFormat::MonohandJson);
        assert_eq!(back.camera.intrinsics, cam.intrinsics);
        assert_eq!(back.camera.distortion, cam.distortion);
        assert_eq!(back.reprojection_error_px, Some(0.46));
        let r = back.camera.extrinsics.rotation.matrix() - cam.extrinsics.rotation.matrix();
        assert!(r.abs().max() < 1e-12);
        assert_eq!(
            back.camera.extrinsics.translation,
            cam.extrinsics.translation
        );
        assert!(text.contains("\"square_mm\": 25.0"), "{text}");
    }

    #[test]
    fn the_opencv_yaml_is_read_back_exactly() {
        let cam = rig_camera();
        let yaml = opencv_yaml(&cam, &info());
        let back = parse_calibration(&yaml, "cam.yaml").unwrap();
        assert_eq!(back.format, CalibrationFormat::OpenCvYaml);
        assert_eq!(back.camera.intrinsics, cam.intrinsics);
        assert_eq!(back.camera.distortion, cam.distortion);
        assert_eq!(back.reprojection_error_px, Some(0.46));
        assert_eq!(
            back.camera.extrinsics.translation,
            cam.extrinsics.translation
        );
        assert!(yaml.contains("board_width: 9\nboard_height: 6\nsquare_size: 25.0\n"));
    }

    #[test]
    fn a_failed_write_leaves_the_old_file() {
        let dir = std::env::temp_dir().join(format!("monohand-io-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("cam.json");
        write_atomically(&path, "old").unwrap();
        write_atomically(&path, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        // A path inside a missing folder fails and writes nothing.
        assert!(write_atomically(dir.join("missing/cam.json"), "x").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
