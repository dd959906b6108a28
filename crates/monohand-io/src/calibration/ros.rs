//! ROS `camera_info` YAML, as `camera_calibration` and `camera_calibration_parsers` write
//! it: `image_width`, `image_height`, `camera_name`, `camera_matrix`,
//! `distortion_model`, `distortion_coefficients`, `rectification_matrix` and
//! `projection_matrix` (each matrix a map of `rows`, `cols` and `data`).
//!
//! The camera is the raw image's: `camera_matrix` (`K`) and `distortion_coefficients`
//! (`D`) under `distortion_model` (`plumb_bob`, `rational_polynomial`, `equidistant`;
//! absent, ROS's own reader assumes `plumb_bob`, and so does this one).
//! `rectification_matrix` and `projection_matrix` describe the rectified image of a
//! stereo pair and are not used, except that a camera whose `projection_matrix` holds a
//! baseline (the pair's second camera) is refused: its place relative to the first camera
//! needs both cameras' files.

use super::filestorage::Node;
use super::model::{scalar, ROS};
use super::CalibrationFormat;
use super::{fs_matrix, fs_scalar_number, image_dim, intrinsics_from_k, Calibration};
use crate::error::{IoError, IoResult};
use monohand_core::camera::{Camera, Extrinsics, Intrinsics};

/// The keys a `camera_info` file has.
const KEYS: [&str; 8] = [
    "image_width",
    "image_height",
    "camera_name",
    "camera_matrix",
    "distortion_model",
    "distortion_coefficients",
    "rectification_matrix",
    "projection_matrix",
];

/// True if a YAML file's root looks like a `camera_info`: a `camera_matrix` with
/// `distortion_model` or `distortion_coefficients` beside it.
pub(super) fn looks_like(root: &Node) -> bool {
    root.get("camera_matrix").is_some()
        && (root.get("distortion_model").is_some() || root.get("distortion_coefficients").is_some())
}

/// The camera of a `camera_info` file.
pub(super) fn from_camera_info(root: &Node, file: &str) -> IoResult<Calibration> {
    if let Node::Map { entries, .. } = root {
        if let Some((k, _)) = entries.iter().find(|(k, _)| !KEYS.contains(&k.as_str())) {
            return Err(IoError::field(
                file,
                k.as_str(),
                format!(
                    "not a key of ROS camera_info YAML (expected {})",
                    KEYS.join(", ")
                ),
            ));
        }
    }
    let need = |k: &str| {
        root.get(k)
            .ok_or_else(|| IoError::field(file, k, "missing"))
    };
    let width = image_dim(
        fs_scalar_number(need("image_width")?, file, "image_width")?,
        file,
        "image_width",
    )?;
    let height = image_dim(
        fs_scalar_number(need("image_height")?, file, "image_height")?,
        file,
        "image_height",
    )?;
    let k = matrix(need("camera_matrix")?, file, "camera_matrix", (3, 3))?;
    let [fx, fy, cx, cy] = intrinsics_from_k(&k, file, "camera_matrix")?;
    let model = match root.get("distortion_model") {
        Some(n) => scalar(n, file, "distortion_model")?,
        None => "plumb_bob".to_string(),
    };
    let name = ROS.find(&model, file, "distortion_model")?;
    let (r, c, d) = fs_matrix(
        need("distortion_coefficients")?,
        file,
        "distortion_coefficients",
    )?;
    if r > 1 && c > 1 {
        return Err(IoError::field(
            file,
            "distortion_coefficients",
            format!("expected a vector, got a {r}x{c} matrix"),
        ));
    }
    let distortion = name.lens(&d, file, "distortion_coefficients", "distortion_model")?;
    if let Some(n) = root.get("rectification_matrix") {
        matrix(n, file, "rectification_matrix", (3, 3))?;
    }
    if let Some(n) = root.get("projection_matrix") {
        let p = matrix(n, file, "projection_matrix", (3, 4))?;
        if p[3] != 0.0 || p[7] != 0.0 {
            return Err(IoError::field(
                file,
                "projection_matrix",
                format!(
                    "Tx = {}, Ty = {}: the second camera of a rectified stereo pair, whose place \
                     relative to the first needs both cameras' files; give the rig as a Kalibr \
                     camera chain, OpenCV YAML with R and T, or the project's JSON with R and t",
                    p[3], p[7]
                ),
            ));
        }
    }
    let camera = Camera::new(
        Intrinsics {
            fx,
            fy,
            cx,
            cy,
            width,
            height,
        },
        distortion,
        Extrinsics::default(),
    )
    .map_err(|e| IoError::core(file, e))?;
    Ok(Calibration {
        camera,
        format: CalibrationFormat::RosCameraInfo,
        target_pose: None,
        reprojection_error_px: None,
    })
}

/// A matrix of `shape`, its values row by row.
fn matrix(node: &Node, file: &str, field: &str, shape: (usize, usize)) -> IoResult<Vec<f64>> {
    let (r, c, v) = fs_matrix(node, file, field)?;
    if (r, c) != shape {
        return Err(IoError::field(
            file,
            field,
            format!("expected a {}x{} matrix, got {r}x{c}", shape.0, shape.1),
        ));
    }
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(IoError::field(
            file,
            field,
            format!("value {x} is not finite"),
        ));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::super::parse_calibration;
    use monohand_core::camera::LensModel;

    const EQUIDISTANT: &str = include_str!("../../tests/data/ros_equidistant.yaml");
    const PLUMB_BOB: &str = include_str!("../../tests/data/ros_plumb_bob.yaml");

    fn err(text: &str) -> String {
        parse_calibration(text, "cam.yaml").unwrap_err().to_string()
    }

    #[test]
    fn models_other_than_plumb_bob_rational_and_equidistant_are_refused_by_name() {
        let e = err(&EQUIDISTANT.replace("equidistant", "double_sphere"));
        assert_eq!(
            e,
            "cam.yaml: distortion_model \"double_sphere\" is not supported (pinhole: plumb_bob, \
             rational_polynomial; fisheye: equidistant, fisheye)"
        );
        let e = err(&PLUMB_BOB.replace("plumb_bob", "inverse_brown_conrady"));
        assert!(
            e.contains("\"inverse_brown_conrady\" is not supported"),
            "{e}"
        );
        // The older camera_calibration's name for the same model is read as it.
        let old = parse_calibration(&EQUIDISTANT.replace("equidistant", "fisheye"), "c.yaml");
        assert_eq!(old.unwrap().camera.distortion.model, LensModel::Fisheye);
    }

    #[test]
    fn coefficients_must_be_the_models() {
        // equidistant with plumb_bob's 5: never read as either.
        let five = EQUIDISTANT.replace(
            "cols: 4\n  data: [0.020000, -0.005000, 0.000000, 0.000000]",
            "cols: 5\n  data: [0.02, -0.005, 0, 0, 0]",
        );
        let e = err(&five);
        assert!(
            e.contains("field distortion_coefficients")
                && e.contains("\"equidistant\" takes 4 coefficients (k1 k2 k3 k4), got 5"),
            "{e}"
        );
        let e = err(&PLUMB_BOB.replace("plumb_bob", "rational_polynomial"));
        assert!(
            e.contains("\"rational_polynomial\" takes 8 coefficients"),
            "{e}"
        );
        // Without distortion_model, ROS's reader (and this one) assume plumb_bob.
        let plain = parse_calibration(
            &PLUMB_BOB.replace("distortion_model: plumb_bob\n", ""),
            "c.yaml",
        )
        .unwrap();
        assert_eq!(plain.camera.distortion.listed().len(), 5);
    }

    #[test]
    fn a_stereo_pairs_second_camera_and_unknown_keys_are_refused() {
        let right = PLUMB_BOB.replace(
            "data: [612.41,   0.  , 321.7 ,   0.  ,",
            "data: [612.41,   0.  , 321.7 , -73.49,",
        );
        let e = err(&right);
        assert!(
            e.contains("field projection_matrix")
                && e.contains("Tx = -73.49")
                && e.contains("stereo pair"),
            "{e}"
        );
        let e = err(&format!("{PLUMB_BOB}binning_x: 2\n"));
        assert!(
            e.contains("field binning_x") && e.contains("not a key of ROS camera_info"),
            "{e}"
        );
        let e = err(&PLUMB_BOB.replace("image_width: 640\n", ""));
        assert!(e.contains("field image_width: missing"), "{e}");
        let e = err(&PLUMB_BOB.replace(
            "  rows: 3\n  cols: 3\n  data: [612.41",
            "  rows: 2\n  cols: 3\n  data: [612.41",
        ));
        assert!(e.contains("camera_matrix"), "{e}");
    }
}
