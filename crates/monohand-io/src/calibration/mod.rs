//! Reading cameras from calibration files, and writing the project's own
//! camera JSON.
//!
//! Six formats are read, told apart by their content ([`detect_format`]):
//!
//! | format | looks like |
//! |---|---|
//! | [`CalibrationFormat::MonohandJson`] | `{"fx": .., "fy": .., "cx": .., "cy": .., "width": .., "height": .., "model"?: "pinhole" or "fisheye", "dist"?: [..], "R"?: 3x3 or rotation vector, "t"?: [3] (mm)}` |
//! | [`CalibrationFormat::Wacv18Json`] | the FORTH / WACV'18 tool's JSON: `CameraMatrix`, `Distortion`, `Dims`, `Rotation`, `Translation` |
//! | [`CalibrationFormat::OpenCvYaml`] | `cv::FileStorage` YAML (`%YAML:1.0`, `!!opencv-matrix`) |
//! | [`CalibrationFormat::OpenCvXml`] | `cv::FileStorage` XML (`<opencv_storage>`, `type_id="opencv-matrix"`) |
//! | [`CalibrationFormat::RosCameraInfo`] | ROS `camera_info` YAML: `camera_matrix`, `distortion_model`, `distortion_coefficients`, ... (`ros` module) |
//! | [`CalibrationFormat::KalibrCamchain`] | Kalibr's camera chain: `cam0: {camera_model, intrinsics, distortion_model, ...}`, `cam1: {..., T_cn_cnm1}` (`kalibr` module) |
//!
//! Every file is read as the lens model it states ([`LensModel`]: the pinhole with
//! OpenCV's radial-tangential distortion, or OpenCV's fisheye), or refused with the model's
//! name ([`IoError::Unsupported`]); never as another. In OpenCV FileStorage the model is
//! stated by `distortion_model`, `model` or `camera_model` (`pinhole`, `plumb_bob`,
//! `radtan`, `rational_polynomial`; `fisheye`, `equidistant`) or `fisheye_model` (`0`,
//! `1`, as OpenCV's calibration sample writes it); a file stating none is a pinhole, as
//! OpenCV's `calibrateCamera` writes it.
//!
//! A Kalibr chain holds several cameras: [`parse_calibrations`] and [`read_calibrations`]
//! give them all, and [`read_calibration`] one, named `FILE#camN`.
//!
//! In the OpenCV formats the camera matrix is found under `camera_matrix`,
//! `cameraMatrix` or `K`; the distortion under `distortion_coefficients`,
//! `dist_coeffs`, `distCoeffs` or `D`; the image size under
//! `image_width`/`image_height` (or `image_size: [w, h]`). Optional `R` (3x3
//! or a rotation vector) and `T` (mm) are the stereo extrinsics as
//! `cv::stereoCalibrate` gives them: they map the first camera's frame into
//! this one, `X_this = R X_first + T`, which is exactly [`Extrinsics`].
//!
//! The `Rotation`/`Translation` of a WACV'18 file are NOT applied to the
//! camera: they are OpenCV's `rvec`/`tvec` of a calibration-target view (the
//! tool's `PackOpenCVCalib(repErr, mtx, dist, rvec, tvec, ...)`), a
//! world(target)-to-camera transform `X_cam = R X_world + t` in the target's
//! units. They are exposed as [`Calibration::target_pose`].
//!
//! ```
//! use monohand_io::calibration::{parse_calibration, CalibrationFormat};
//! let cal = parse_calibration(
//!     r#"{"fx": 800, "fy": 800, "cx": 319.5, "cy": 239.5, "width": 640, "height": 480}"#,
//!     "cam.json",
//! ).unwrap();
//! assert_eq!(cal.format, CalibrationFormat::MonohandJson);
//! assert_eq!(cal.camera.intrinsics.fx, 800.0);
//!
//! let bad = parse_calibration(r#"{"fy": 800, "cx": 0, "cy": 0, "width": 640, "height": 480}"#, "cam.json");
//! assert_eq!(bad.unwrap_err().to_string(), "cam.json: field fx: missing");
//! ```

mod filestorage;
mod kalibr;
mod model;
mod ros;
mod write;

pub use write::{
    calibrated_camera_json, opencv_yaml, write_atomically, CalibrationInfo, CameraStd,
};

use crate::error::{name_of, read_text, IoError, IoResult};
use filestorage::{parse_number, Node};
use monohand_core::prelude::*;
use nalgebra::{Matrix3, Rotation3, Vector3};
use serde_json::{json, Map, Value};
use std::path::Path;

/// The calibration file formats understood by [`parse_calibration`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibrationFormat {
    /// The project's small JSON (see the module docs and `docs/calibration.md`).
    MonohandJson,
    /// The JSON written by the WACV'18 / FORTH calibration tool.
    Wacv18Json,
    /// OpenCV `cv::FileStorage` YAML.
    OpenCvYaml,
    /// OpenCV `cv::FileStorage` XML.
    OpenCvXml,
    /// ROS `camera_info` YAML (`camera_calibration`, `camera_calibration_parsers`).
    RosCameraInfo,
    /// Kalibr's camera chain YAML (`camchain.yaml`).
    KalibrCamchain,
}

/// A camera read from a calibration file, with what else the file said.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// The camera, validated. Its extrinsics are those of the file for the
    /// project JSON (`R`, `t`) and OpenCV files (`R`, `T`), relative to `cam0` for a Kalibr
    /// chain (its `T_cn_cnm1`s), identity otherwise.
    pub camera: Camera,
    /// The format the file was in.
    pub format: CalibrationFormat,
    /// WACV'18 files only: the calibration target's pose in the camera
    /// (`X_cam = R X_target + t`, target units, not necessarily mm). Not applied
    /// to [`Calibration::camera`].
    pub target_pose: Option<Extrinsics>,
    /// The RMS reprojection error of the calibration, if the file states it (pixels).
    pub reprojection_error_px: Option<f64>,
}

/// Tells the format from the content; `None` if it is none of the six.
pub fn detect_format(text: &str) -> Option<CalibrationFormat> {
    let t = text.trim_start_matches('\u{feff}').trim_start();
    if t.starts_with('{') {
        let v: Value = serde_json::from_str(t).ok()?;
        let o = v.as_object()?;
        if o.contains_key("CameraMatrix") {
            Some(CalibrationFormat::Wacv18Json)
        } else {
            Some(CalibrationFormat::MonohandJson)
        }
    } else if t.starts_with("%YAML") || t.contains("!!opencv-matrix") {
        Some(CalibrationFormat::OpenCvYaml)
    } else if t.starts_with('<') {
        Some(CalibrationFormat::OpenCvXml)
    } else {
        yaml_format(&filestorage::parse_yaml(t).ok()?)
    }
}

/// A plain YAML file's format: a ROS `camera_info` or a Kalibr chain, by their keys.
fn yaml_format(root: &Node) -> Option<CalibrationFormat> {
    if kalibr::looks_like(root) {
        Some(CalibrationFormat::KalibrCamchain)
    } else if ros::looks_like(root) {
        Some(CalibrationFormat::RosCameraInfo)
    } else {
        None
    }
}

/// Reads a calibration file in any of the supported formats: its one camera, or the
/// camera `N` of a Kalibr chain given as `FILE#camN` (when no file of that whole name
/// exists). A chain of several cameras without `#camN` is refused, naming them.
pub fn read_calibration(path: impl AsRef<Path>) -> IoResult<Calibration> {
    let path = path.as_ref();
    let (file, camera) = match split_camera(path) {
        Some((file, camera)) => (file, Some(camera)),
        None => (path.to_path_buf(), None),
    };
    let text = read_text(&file)?;
    one_camera(
        parse_calibrations(&text, &name_of(&file))?,
        camera,
        &name_of(&file),
    )
}

/// Every camera of a calibration file, in its order (`cam0` first in a Kalibr chain; one
/// camera in every other format).
pub fn read_calibrations(path: impl AsRef<Path>) -> IoResult<Vec<Calibration>> {
    let path = path.as_ref();
    let text = read_text(path)?;
    parse_calibrations(&text, &name_of(path))
}

/// Reads just the camera of a calibration file (see [`read_calibration`]).
pub fn read_camera(path: impl AsRef<Path>) -> IoResult<Camera> {
    read_calibration(path).map(|c| c.camera)
}

/// `FILE#camN` as `(FILE, N)` when no file is named `FILE#camN` itself.
fn split_camera(path: &Path) -> Option<(std::path::PathBuf, usize)> {
    if path.exists() {
        return None;
    }
    let s = path.to_str()?;
    let (file, camera) = s.rsplit_once('#')?;
    let n = camera.strip_prefix("cam")?.parse::<usize>().ok()?;
    Some((std::path::PathBuf::from(file), n))
}

/// The one camera of a file, or its camera `N`.
fn one_camera(
    mut cals: Vec<Calibration>,
    camera: Option<usize>,
    file: &str,
) -> IoResult<Calibration> {
    let n = cals.len();
    match camera {
        None if n == 1 => Ok(cals.remove(0)),
        None => Err(IoError::format(
            file,
            format!(
                "a camera chain of {n} cameras: name one, as {file}#cam0 to {file}#cam{}",
                n.saturating_sub(1)
            ),
        )),
        Some(i) if i < n && cals[i].format == CalibrationFormat::KalibrCamchain => {
            Ok(cals.remove(i))
        }
        Some(i)
            if cals
                .iter()
                .all(|c| c.format == CalibrationFormat::KalibrCamchain) =>
        {
            Err(IoError::format(
                file,
                format!(
                    "no cam{i} in a camera chain of {n} (cam0 to cam{})",
                    n.saturating_sub(1)
                ),
            ))
        }
        Some(i) => Err(IoError::format(
            file,
            format!("#cam{i} names a camera of a Kalibr camera chain; this file has one camera"),
        )),
    }
}

/// Parses calibration text of one camera; `file` names it in errors. A Kalibr chain of
/// several cameras is refused, naming them ([`parse_calibrations`] reads them all).
pub fn parse_calibration(text: &str, file: &str) -> IoResult<Calibration> {
    one_camera(parse_calibrations(text, file)?, None, file)
}

/// Parses calibration text: every camera it holds (several only in a Kalibr chain).
pub fn parse_calibrations(text: &str, file: &str) -> IoResult<Vec<Calibration>> {
    let t = text.trim_start_matches('\u{feff}');
    let trimmed = t.trim_start();
    if trimmed.starts_with('{') {
        let v: Value = serde_json::from_str(t).map_err(|e| IoError::json(file, &e))?;
        let o = v
            .as_object()
            .ok_or_else(|| IoError::format(file, "expected a JSON object"))?;
        return if o.contains_key("CameraMatrix") {
            wacv18(o, file).map(|c| vec![c])
        } else {
            monohand_json(o, file).map(|c| vec![c])
        };
    }
    let syntax = |what: &str, e: filestorage::SyntaxError| IoError::Line {
        file: file.to_string(),
        line: e.line,
        message: format!("{what}: {}", e.message),
    };
    if trimmed.starts_with("%YAML") || t.contains("!!opencv-matrix") {
        let root = filestorage::parse_yaml(t).map_err(|e| syntax("OpenCV YAML", e))?;
        return from_filestorage(&root, file, CalibrationFormat::OpenCvYaml).map(|c| vec![c]);
    }
    if trimmed.starts_with('<') {
        let root = filestorage::parse_xml(t).map_err(|e| syntax("OpenCV XML", e))?;
        return from_filestorage(&root, file, CalibrationFormat::OpenCvXml).map(|c| vec![c]);
    }
    let unrecognised = || {
        IoError::format(
            file,
            "unrecognised calibration format (expected JSON, OpenCV YAML starting with %YAML, \
             OpenCV XML, ROS camera_info YAML or a Kalibr camera chain)",
        )
    };
    let root = filestorage::parse_yaml(t).map_err(|_| unrecognised())?;
    match yaml_format(&root) {
        Some(CalibrationFormat::KalibrCamchain) => kalibr::from_camchain(&root, file),
        Some(_) => ros::from_camera_info(&root, file).map(|c| vec![c]),
        None => Err(unrecognised()),
    }
}

// ------------------------------------------------------------ shared checks

/// Checks a camera matrix and returns (fx, fy, cx, cy).
fn intrinsics_from_k(k: &[f64], file: &str, field: &str) -> IoResult<[f64; 4]> {
    if k.len() != 9 {
        return Err(IoError::field(
            file,
            field,
            format!("expected a 3x3 matrix (9 values), got {}", k.len()),
        ));
    }
    if let Some(i) = k.iter().position(|v| !v.is_finite()) {
        return Err(IoError::field(
            file,
            field,
            format!("element ({}, {}) is not finite ({})", i / 3, i % 3, k[i]),
        ));
    }
    let (fx, fy, cx, cy) = (k[0], k[4], k[2], k[5]);
    if fx <= 0.0 || fy <= 0.0 {
        return Err(IoError::field(
            file,
            field,
            format!("focal lengths must be positive (fx = {fx}, fy = {fy})"),
        ));
    }
    if k[1].abs() > 1e-6 * fx {
        return Err(IoError::field(
            file,
            field,
            format!("skew K[0][1] = {} is not supported (must be 0)", k[1]),
        ));
    }
    if k[3].abs() > 1e-9 || k[6].abs() > 1e-9 || k[7].abs() > 1e-9 || (k[8] - 1.0).abs() > 1e-9 {
        return Err(IoError::field(
            file,
            field,
            format!("not a camera matrix: expected rows [fx 0 cx] [0 fy cy] [0 0 1], got {k:?}"),
        ));
    }
    Ok([fx, fy, cx, cy])
}

/// The lens of `model` from coefficients as OpenCV lists them (for the pinhole, 12 or 14
/// are read when the thin-prism and tilt terms are zero).
fn distortion(model: LensModel, d: &[f64], file: &str, field: &str) -> IoResult<Distortion> {
    if let Some(v) = d.iter().find(|v| !v.is_finite()) {
        return Err(IoError::field(
            file,
            field,
            format!("coefficient {v} is not finite"),
        ));
    }
    let used = match d.len() {
        12 | 14 if model == LensModel::Pinhole && d[8..].iter().all(|&v| v == 0.0) => &d[..8],
        12 | 14 if model == LensModel::Pinhole => {
            return Err(IoError::field(
                file,
                field,
                "thin-prism / tilted-sensor coefficients (s1..s4, tx, ty) are not supported",
            ))
        }
        _ => d,
    };
    Distortion::new(model, used).map_err(|e| IoError::field(file, field, strip_core(&e)))
}

fn strip_core(e: &CoreError) -> String {
    match e {
        CoreError::InvalidCamera(m) => m.clone(),
        other => other.to_string(),
    }
}

fn image_dim(v: f64, file: &str, field: &str) -> IoResult<u32> {
    if !((1.0..=1e6).contains(&v) && v.fract() == 0.0) {
        return Err(IoError::field(
            file,
            field,
            format!("image size must be a positive whole number of pixels, got {v}"),
        ));
    }
    Ok(v as u32)
}

/// A rotation from 9 values (row-major matrix) or 3 (rotation vector, radians).
fn rotation(r: &[f64], file: &str, field: &str) -> IoResult<Rotation3<f64>> {
    if let Some(v) = r.iter().find(|v| !v.is_finite()) {
        return Err(IoError::field(
            file,
            field,
            format!("value {v} is not finite"),
        ));
    }
    match r.len() {
        3 => Ok(Rotation3::new(Vector3::new(r[0], r[1], r[2]))),
        9 => {
            let m = Matrix3::from_row_slice(r);
            let ortho = (m.transpose() * m - Matrix3::identity()).norm();
            if ortho > 1e-3 || m.determinant() <= 0.0 {
                return Err(IoError::field(
                    file,
                    field,
                    format!(
                        "not a rotation matrix (|R^T R - I| = {ortho:.2e}, det = {:.4})",
                        m.determinant()
                    ),
                ));
            }
            // Remove the rounding of the file's digits.
            Ok(Rotation3::from_matrix(&m))
        }
        n => Err(IoError::field(
            file,
            field,
            format!("expected a 3x3 matrix or a rotation vector of 3, got {n} values"),
        )),
    }
}

fn translation(t: &[f64], file: &str, field: &str) -> IoResult<Vector3<f64>> {
    if t.len() != 3 {
        return Err(IoError::field(
            file,
            field,
            format!("expected 3 values, got {}", t.len()),
        ));
    }
    if let Some(v) = t.iter().find(|v| !v.is_finite()) {
        return Err(IoError::field(
            file,
            field,
            format!("value {v} is not finite"),
        ));
    }
    Ok(Vector3::new(t[0], t[1], t[2]))
}

// ------------------------------------------------------------ JSON helpers

fn json_f64(v: &Value, file: &str, field: &str) -> IoResult<f64> {
    v.as_f64()
        .ok_or_else(|| IoError::field(file, field, format!("expected a number, got {v}")))
}

/// A flat list of numbers from a number array or an array of number arrays.
fn json_numbers(v: &Value, file: &str, field: &str) -> IoResult<Vec<f64>> {
    let arr = v
        .as_array()
        .ok_or_else(|| IoError::field(file, field, format!("expected an array, got {v}")))?;
    let mut out = Vec::new();
    for (i, x) in arr.iter().enumerate() {
        match x {
            Value::Array(row) => {
                for (j, y) in row.iter().enumerate() {
                    out.push(json_f64(y, file, &format!("{field}[{i}][{j}]"))?);
                }
            }
            _ => out.push(json_f64(x, file, &format!("{field}[{i}]"))?),
        }
    }
    Ok(out)
}

fn required<'a>(o: &'a Map<String, Value>, key: &str, file: &str) -> IoResult<&'a Value> {
    o.get(key)
        .ok_or_else(|| IoError::field(file, key, "missing"))
}

const MONOHAND_KEYS: [&str; 18] = [
    "fx", "fy", "cx", "cy", "width", "height", "model", "dist", "R", "t", "name", "comment",
    "hfov_deg", // Written by `monohand calibrate` (write::calibrated_camera_json).
    "rms_px", "views", "board", "date", "std",
];

fn monohand_json(o: &Map<String, Value>, file: &str) -> IoResult<Calibration> {
    if let Some(k) = o.keys().find(|k| !MONOHAND_KEYS.contains(&k.as_str())) {
        return Err(IoError::field(
            file,
            k.as_str(),
            format!("unknown field (expected {})", MONOHAND_KEYS.join(", ")),
        ));
    }
    let num = |k: &str| -> IoResult<f64> { json_f64(required(o, k, file)?, file, k) };
    let (fx, fy, cx, cy) = (num("fx")?, num("fy")?, num("cx")?, num("cy")?);
    for (k, v) in [("fx", fx), ("fy", fy)] {
        if v <= 0.0 {
            return Err(IoError::field(
                file,
                k,
                format!("focal length must be positive, got {v}"),
            ));
        }
    }
    let width = image_dim(num("width")?, file, "width")?;
    let height = image_dim(num("height")?, file, "height")?;
    let lens = match o.get("model") {
        Some(Value::String(m)) => model::PROJECT.find(m, file, "model")?,
        Some(v) => {
            return Err(IoError::field(
                file,
                "model",
                format!("expected \"pinhole\" or \"fisheye\", got {v}"),
            ))
        }
        None => model::PROJECT.find("pinhole", file, "model")?,
    };
    let dist = match o.get("dist") {
        Some(v) => lens.lens(&json_numbers(v, file, "dist")?, file, "dist", "model")?,
        None => lens.lens(&[], file, "dist", "model")?,
    };
    let rot = match o.get("R") {
        Some(v) => rotation(&json_numbers(v, file, "R")?, file, "R")?,
        None => Rotation3::identity(),
    };
    let t = match o.get("t") {
        Some(v) => translation(&json_numbers(v, file, "t")?, file, "t")?,
        None => Vector3::zeros(),
    };
    let camera = Camera::new(
        Intrinsics {
            fx,
            fy,
            cx,
            cy,
            width,
            height,
        },
        dist,
        Extrinsics {
            rotation: rot,
            translation: t,
        },
    )
    .map_err(|e| IoError::core(file, e))?;
    let reprojection_error_px = match o.get("rms_px") {
        Some(v) => Some(json_f64(v, file, "rms_px")?),
        None => None,
    };
    Ok(Calibration {
        camera,
        format: CalibrationFormat::MonohandJson,
        target_pose: None,
        reprojection_error_px,
    })
}

fn wacv18(o: &Map<String, Value>, file: &str) -> IoResult<Calibration> {
    let k = json_numbers(required(o, "CameraMatrix", file)?, file, "CameraMatrix")?;
    let [fx, fy, cx, cy] = intrinsics_from_k(&k, file, "CameraMatrix")?;
    let dims = json_numbers(required(o, "Dims", file)?, file, "Dims")?;
    if dims.len() != 2 {
        return Err(IoError::field(
            file,
            "Dims",
            format!("expected [width, height], got {} values", dims.len()),
        ));
    }
    let width = image_dim(dims[0], file, "Dims[0]")?;
    let height = image_dim(dims[1], file, "Dims[1]")?;
    let dist = match o.get("Distortion") {
        Some(v) => distortion(
            LensModel::Pinhole,
            &json_numbers(v, file, "Distortion")?,
            file,
            "Distortion",
        )?,
        None => Distortion::default(),
    };
    let target_pose = match (o.get("Rotation"), o.get("Translation")) {
        (Some(r), Some(t)) => Some(Extrinsics {
            rotation: rotation(&json_numbers(r, file, "Rotation")?, file, "Rotation")?,
            translation: translation(&json_numbers(t, file, "Translation")?, file, "Translation")?,
        }),
        _ => None,
    };
    let reprojection_error_px = match o.get("CalibReprError") {
        Some(v) => Some(json_f64(v, file, "CalibReprError")?),
        None => None,
    };
    let camera = Camera::new(
        Intrinsics {
            fx,
            fy,
            cx,
            cy,
            width,
            height,
        },
        dist,
        Extrinsics::default(),
    )
    .map_err(|e| IoError::core(file, e))?;
    Ok(Calibration {
        camera,
        format: CalibrationFormat::Wacv18Json,
        target_pose,
        reprojection_error_px,
    })
}

// ------------------------------------------------------------ FileStorage

const K_KEYS: [&str; 4] = ["camera_matrix", "cameraMatrix", "K", "Camera_Matrix"];
const D_KEYS: [&str; 5] = [
    "distortion_coefficients",
    "dist_coeffs",
    "distCoeffs",
    "D",
    "Distortion_Coefficients",
];
const W_KEYS: [&str; 3] = ["image_width", "imageWidth", "width"];
const H_KEYS: [&str; 3] = ["image_height", "imageHeight", "height"];
const SIZE_KEYS: [&str; 2] = ["image_size", "imageSize"];

fn find<'a>(root: &'a Node, keys: &[&'a str]) -> Option<(&'a str, &'a Node)> {
    keys.iter().find_map(|k| root.get(k).map(|n| (*k, n)))
}

fn fs_scalar_number(node: &Node, file: &str, field: &str) -> IoResult<f64> {
    match node {
        Node::Scalar(s) => parse_number(s)
            .ok_or_else(|| IoError::field(file, field, format!("{s:?} is not a number"))),
        _ => Err(IoError::field(file, field, "expected a number")),
    }
}

/// The values of a matrix node (`opencv-matrix` or a plain sequence) and its shape.
fn fs_matrix(node: &Node, file: &str, field: &str) -> IoResult<(usize, usize, Vec<f64>)> {
    let seq_numbers = |items: &[Node], f: &str| -> IoResult<Vec<f64>> {
        let mut out = Vec::new();
        for (i, it) in items.iter().enumerate() {
            match it {
                Node::Seq(row) => {
                    for (j, x) in row.iter().enumerate() {
                        out.push(fs_scalar_number(x, file, &format!("{f}[{i}][{j}]"))?);
                    }
                }
                x => out.push(fs_scalar_number(x, file, &format!("{f}[{i}]"))?),
            }
        }
        Ok(out)
    };
    match node {
        Node::Map { .. } => {
            let dim = |k: &str| -> IoResult<usize> {
                let n = node
                    .get(k)
                    .ok_or_else(|| IoError::field(file, format!("{field}.{k}"), "missing"))?;
                let v = fs_scalar_number(n, file, &format!("{field}.{k}"))?;
                if !(v >= 0.0 && v.fract() == 0.0 && v < 1e6) {
                    return Err(IoError::field(
                        file,
                        format!("{field}.{k}"),
                        format!("{v} is not a valid size"),
                    ));
                }
                Ok(v as usize)
            };
            let (rows, cols) = (dim("rows")?, dim("cols")?);
            let data_field = format!("{field}.data");
            let data = match node.get("data") {
                Some(Node::Seq(items)) => seq_numbers(items, &data_field)?,
                Some(Node::Scalar(s)) if s.is_empty() => Vec::new(),
                Some(s @ Node::Scalar(_)) => vec![fs_scalar_number(s, file, &data_field)?],
                Some(_) => {
                    return Err(IoError::field(
                        file,
                        data_field,
                        "expected a list of numbers",
                    ))
                }
                None => return Err(IoError::field(file, data_field, "missing")),
            };
            if data.len() != rows * cols {
                return Err(IoError::field(
                    file,
                    data_field,
                    format!(
                        "has {} values but rows x cols = {rows} x {cols} = {}",
                        data.len(),
                        rows * cols
                    ),
                ));
            }
            Ok((rows, cols, data))
        }
        Node::Seq(items) => {
            let v = seq_numbers(items, field)?;
            let nested = items.iter().all(|i| matches!(i, Node::Seq(_)));
            if nested && !items.is_empty() {
                let rows = items.len();
                Ok((rows, v.len() / rows, v))
            } else {
                Ok((v.len(), 1, v))
            }
        }
        Node::Scalar(_) => Err(IoError::field(file, field, "expected a matrix")),
    }
}

/// The lens of a FileStorage file: its coefficients under the model it states, or the
/// pinhole's when it states none.
fn fs_distortion(root: &Node, file: &str) -> IoResult<Distortion> {
    let stated = model::filestorage_model(root, file)?;
    match find(root, &D_KEYS) {
        Some((f, n)) => {
            let (r, c, d) = fs_matrix(n, file, f)?;
            if r != 1 && c != 1 && r * c != 0 {
                return Err(IoError::field(
                    file,
                    f,
                    format!("expected a vector, got a {r}x{c} matrix"),
                ));
            }
            match stated {
                Some((key, name)) => name.lens(&d, file, f, key),
                None => distortion(LensModel::Pinhole, &d, file, f),
            }
        }
        None => match stated {
            Some((key, name)) => name.lens(&[], file, "distortion_coefficients", key),
            None => Ok(Distortion::default()),
        },
    }
}

fn from_filestorage(root: &Node, file: &str, format: CalibrationFormat) -> IoResult<Calibration> {
    let (k_field, k_node) = find(root, &K_KEYS).ok_or_else(|| {
        IoError::field(
            file,
            "camera_matrix",
            format!("missing (looked for {})", K_KEYS.join(", ")),
        )
    })?;
    let (rows, cols, k) = fs_matrix(k_node, file, k_field)?;
    if (rows, cols) != (3, 3) {
        return Err(IoError::field(
            file,
            k_field,
            format!("expected a 3x3 matrix, got {rows}x{cols}"),
        ));
    }
    let [fx, fy, cx, cy] = intrinsics_from_k(&k, file, k_field)?;
    let dist = fs_distortion(root, file)?;
    let (width, height) = match (
        find(root, &W_KEYS),
        find(root, &H_KEYS),
        find(root, &SIZE_KEYS),
    ) {
        (Some((wf, w)), Some((hf, h)), _) => (
            image_dim(fs_scalar_number(w, file, wf)?, file, wf)?,
            image_dim(fs_scalar_number(h, file, hf)?, file, hf)?,
        ),
        (_, _, Some((sf, s))) => {
            let (_, _, v) = fs_matrix(s, file, sf)?;
            if v.len() != 2 {
                return Err(IoError::field(
                    file,
                    sf,
                    format!("expected [width, height], got {} values", v.len()),
                ));
            }
            (image_dim(v[0], file, sf)?, image_dim(v[1], file, sf)?)
        }
        (None, _, None) => {
            return Err(IoError::field(
                file,
                "image_width",
                "missing (add image_width and image_height, in pixels)",
            ))
        }
        (_, None, None) => {
            return Err(IoError::field(
                file,
                "image_height",
                "missing (add image_width and image_height, in pixels)",
            ))
        }
    };
    let mut extrinsics = Extrinsics::default();
    if let Some(n) = root.get("R") {
        let (_, _, r) = fs_matrix(n, file, "R")?;
        extrinsics.rotation = rotation(&r, file, "R")?;
    }
    if let Some(n) = root.get("T") {
        let (_, _, t) = fs_matrix(n, file, "T")?;
        extrinsics.translation = translation(&t, file, "T")?;
    }
    let reprojection_error_px = match root.get("avg_reprojection_error") {
        Some(n) => fs_scalar_number(n, file, "avg_reprojection_error").ok(),
        None => None,
    };
    let camera = Camera::new(
        Intrinsics {
            fx,
            fy,
            cx,
            cy,
            width,
            height,
        },
        dist,
        extrinsics,
    )
    .map_err(|e| IoError::core(file, e))?;
    Ok(Calibration {
        camera,
        format,
        target_pose: None,
        reprojection_error_px,
    })
}

// ------------------------------------------------------------ writer

/// The project JSON for a camera: `fx fy cx cy width height`, plus `model` and `dist`
/// unless the camera is the ideal pinhole (`dist` the shortest OpenCV list; a fisheye's
/// always its 4), `R` (3x3, row-major rows) and `t` (mm) only if the extrinsics are not
/// the identity.
pub fn camera_to_json(camera: &Camera) -> Value {
    let k = &camera.intrinsics;
    let mut o = Map::new();
    o.insert("fx".into(), json!(k.fx));
    o.insert("fy".into(), json!(k.fy));
    o.insert("cx".into(), json!(k.cx));
    o.insert("cy".into(), json!(k.cy));
    o.insert("width".into(), json!(k.width));
    o.insert("height".into(), json!(k.height));
    if !camera.distortion.is_ideal() {
        o.insert("model".into(), json!(camera.distortion.model.name()));
        o.insert("dist".into(), json!(camera.distortion.listed()));
    }
    if !camera.extrinsics.is_identity() {
        let m = camera.extrinsics.rotation.matrix();
        let rows: Vec<[f64; 3]> = (0..3).map(|r| [m[(r, 0)], m[(r, 1)], m[(r, 2)]]).collect();
        o.insert("R".into(), json!(rows));
        let t = camera.extrinsics.translation;
        o.insert("t".into(), json!([t.x, t.y, t.z]));
    }
    Value::Object(o)
}

/// The project JSON of a generic camera made for a field of view (see
/// [`Camera::with_hfov`]): [`camera_to_json`] with the `hfov_deg` it was made for and a
/// comment saying what it assumes.
pub fn generic_camera_json(camera: &Camera, hfov_deg: f64) -> Value {
    let mut json = camera_to_json(camera);
    if let Some(o) = json.as_object_mut() {
        o.insert("hfov_deg".into(), json!(hfov_deg));
        o.insert(
            "comment".into(),
            json!(
                "generic camera: principal point at the image centre, square pixels, no distortion; \
                 depth is only as right as the field of view"
            ),
        );
    }
    json
}

/// Writes a camera as the project JSON (pretty-printed, see [`camera_to_json`]).
pub fn write_camera_json(path: impl AsRef<Path>, camera: &Camera) -> IoResult<()> {
    let path = path.as_ref();
    let text = format!("{:#}\n", camera_to_json(camera));
    std::fs::write(path, text).map_err(|source| IoError::Write {
        path: path.to_path_buf(),
        error: source,
    })
}

#[cfg(test)]
mod tests;
