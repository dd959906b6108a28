//! Kalibr's camera chain YAML (`camchain.yaml`, `camchain-imucam.yaml`): one map per
//! camera, `cam0`, `cam1`, ..., each with `camera_model`, `intrinsics` (`[fu, fv, pu,
//! pv]`), `distortion_model`, `distortion_coeffs`, `resolution` (`[width, height]`) and,
//! from `cam1` on, `T_cn_cnm1`: the 4x4 transform taking the previous camera's
//! coordinates to this camera's, in metres (Kalibr's wiki, "Yaml formats").
//!
//! Read: the `pinhole` camera model with `radtan` (`k1 k2 r1 r2`, OpenCV's `k1 k2 p1
//! p2`), `equidistant` (OpenCV's fisheye `k1 k2 k3 k4`) or `none`. Each camera's
//! extrinsics are relative to `cam0` (the project's reference), chained through the
//! `T_cn_cnm1`s and converted to millimetres: `X_cn = R X_cam0 + t`. The IMU's
//! (`T_cam_imu`, `timeshift_cam_imu`), `rostopic` and `cam_overlaps` are not used; a
//! `T_cn_cnm1` of `cam0` (relative to something outside the chain) is not either.

use super::filestorage::Node;
use super::model::{scalar, KALIBR};
use super::{fs_matrix, image_dim, Calibration, CalibrationFormat};
use crate::error::{IoError, IoResult};
use monohand_core::camera::{Camera, Extrinsics, Intrinsics};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// The keys of one camera of a chain.
const KEYS: [&str; 10] = [
    "camera_model",
    "intrinsics",
    "distortion_model",
    "distortion_coeffs",
    "resolution",
    "T_cn_cnm1",
    "T_cam_imu",
    "timeshift_cam_imu",
    "rostopic",
    "cam_overlaps",
];

/// True if a YAML file's root looks like a camera chain: a `cam0` map with `intrinsics`
/// or `camera_model`.
pub(super) fn looks_like(root: &Node) -> bool {
    root.get("cam0")
        .is_some_and(|c| c.get("intrinsics").is_some() || c.get("camera_model").is_some())
}

/// The cameras of a chain, `cam0` first.
pub(super) fn from_camchain(root: &Node, file: &str) -> IoResult<Vec<Calibration>> {
    let Node::Map { entries, .. } = root else {
        return Err(IoError::format(
            file,
            "a Kalibr camera chain is a map of cameras",
        ));
    };
    // The cameras are cam0 .. cam{n-1}, each once.
    let n = entries.len();
    for (k, _) in entries {
        let known = k
            .strip_prefix("cam")
            .and_then(|i| i.parse::<usize>().ok())
            .is_some_and(|i| i < n && format!("cam{i}") == *k);
        if !known {
            return Err(IoError::field(
                file,
                k.as_str(),
                format!(
                    "not a camera of a Kalibr chain of {n} (expected cam0 to cam{})",
                    n - 1
                ),
            ));
        }
    }
    let mut to_cam0 = Extrinsics::default();
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let name = format!("cam{i}");
        let cam = root
            .get(&name)
            .ok_or_else(|| IoError::field(file, name.as_str(), "missing (each camera once)"))?;
        known_keys(cam, file, &name)?;
        if i > 0 {
            let step = transform(cam, file, &format!("{name}.T_cn_cnm1"))?;
            // X_cn = T_cn_cnm1 X_cnm1 and X_cnm1 = T_cnm1_c0 X_c0.
            to_cam0 = Extrinsics {
                rotation: step.rotation * to_cam0.rotation,
                translation: step.rotation * to_cam0.translation + step.translation,
            };
        }
        out.push(camera(cam, file, &name, to_cam0)?);
    }
    Ok(out)
}

/// Refuses a camera that is no map, or has a key a Kalibr camera does not.
fn known_keys(cam: &Node, file: &str, name: &str) -> IoResult<()> {
    let Node::Map { entries, .. } = cam else {
        return Err(IoError::field(file, name, "expected a map"));
    };
    match entries.iter().find(|(k, _)| !KEYS.contains(&k.as_str())) {
        Some((k, _)) => Err(IoError::field(
            file,
            format!("{name}.{k}"),
            format!(
                "not a key of a Kalibr camera (expected {})",
                KEYS.join(", ")
            ),
        )),
        None => Ok(()),
    }
}

/// One camera of the chain at `extrinsics`.
fn camera(cam: &Node, file: &str, name: &str, extrinsics: Extrinsics) -> IoResult<Calibration> {
    let field = |k: &str| format!("{name}.{k}");
    let need = |k: &str| {
        cam.get(k)
            .ok_or_else(|| IoError::field(file, field(k), "missing"))
    };
    let model = scalar(need("camera_model")?, file, &field("camera_model"))?;
    if model != "pinhole" {
        return Err(IoError::unsupported(
            file,
            field("camera_model"),
            model,
            "pinhole, with distortion_model radtan, equidistant or none",
        ));
    }
    let stated = scalar(need("distortion_model")?, file, &field("distortion_model"))?;
    let lens = KALIBR.find(&stated, file, &field("distortion_model"))?;
    let d = numbers(
        need("distortion_coeffs")?,
        file,
        &field("distortion_coeffs"),
    )?;
    let distortion = lens.lens(&d, file, &field("distortion_coeffs"), "distortion_model")?;
    let k = numbers(need("intrinsics")?, file, &field("intrinsics"))?;
    let [fx, fy, cx, cy] = k[..] else {
        return Err(IoError::field(
            file,
            field("intrinsics"),
            format!("a pinhole has [fu, fv, pu, pv], got {} values", k.len()),
        ));
    };
    let size = numbers(need("resolution")?, file, &field("resolution"))?;
    let [w, h] = size[..] else {
        return Err(IoError::field(
            file,
            field("resolution"),
            format!("expected [width, height], got {} values", size.len()),
        ));
    };
    let (width, height) = (
        image_dim(w, file, &field("resolution"))?,
        image_dim(h, file, &field("resolution"))?,
    );
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
        extrinsics,
    )
    .map_err(|e| IoError::core(file, e))?;
    Ok(Calibration {
        camera,
        format: CalibrationFormat::KalibrCamchain,
        target_pose: None,
        reprojection_error_px: None,
    })
}

/// A list of finite numbers.
fn numbers(node: &Node, file: &str, field: &str) -> IoResult<Vec<f64>> {
    let (_, _, v) = fs_matrix(node, file, field)?;
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(IoError::field(
            file,
            field,
            format!("value {x} is not finite"),
        ));
    }
    Ok(v)
}

/// A camera's `T_cn_cnm1` as extrinsics in millimetres.
fn transform(cam: &Node, file: &str, field: &str) -> IoResult<Extrinsics> {
    let node = cam
        .get("T_cn_cnm1")
        .ok_or_else(|| IoError::field(file, field, "missing (each camera after cam0 has one)"))?;
    let (r, c, t) = fs_matrix(node, file, field)?;
    if (r, c) != (4, 4) {
        return Err(IoError::field(
            file,
            field,
            format!("expected a 4x4 transform, got {r}x{c}"),
        ));
    }
    if let Some(x) = t.iter().find(|x| !x.is_finite()) {
        return Err(IoError::field(
            file,
            field,
            format!("value {x} is not finite"),
        ));
    }
    if t[12..] != [0.0, 0.0, 0.0, 1.0] {
        return Err(IoError::field(
            file,
            field,
            format!(
                "the last row of a rigid transform is [0, 0, 0, 1], got {:?}",
                &t[12..]
            ),
        ));
    }
    let m = Matrix3::new(t[0], t[1], t[2], t[4], t[5], t[6], t[8], t[9], t[10]);
    let ortho = (m.transpose() * m - Matrix3::identity()).norm();
    if ortho > 1e-3 || m.determinant() <= 0.0 {
        return Err(IoError::field(
            file,
            field,
            format!(
                "its rotation is not one (|R^T R - I| = {ortho:.2e}, det = {:.4})",
                m.determinant()
            ),
        ));
    }
    Ok(Extrinsics {
        // Remove the rounding of the file's digits.
        rotation: Rotation3::from_matrix(&m),
        // Kalibr's metres to millimetres.
        translation: Vector3::new(t[3], t[7], t[11]) * 1000.0,
    })
}

#[cfg(test)]
mod tests {
    use super::super::{parse_calibration, parse_calibrations};

    const CHAIN: &str = include_str!("../../tests/data/kalibr_camchain_imucam.yaml");

    fn err(text: &str) -> String {
        parse_calibrations(text, "chain.yaml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn other_camera_models_are_refused_by_name() {
        for model in ["omni", "ds", "eucm"] {
            let e = err(&CHAIN.replacen(
                "camera_model: pinhole",
                &format!("camera_model: {model}"),
                1,
            ));
            assert_eq!(
                e,
                format!(
                    "chain.yaml: cam0.camera_model \"{model}\" is not supported (pinhole, with \
                     distortion_model radtan, equidistant or none)"
                )
            );
        }
        let e = err(&CHAIN.replace("distortion_model: equidistant", "distortion_model: fov"));
        assert_eq!(
            e,
            "chain.yaml: cam1.distortion_model \"fov\" is not supported (pinhole: radtan, none; \
             fisheye: equidistant)"
        );
    }

    #[test]
    fn a_chain_must_be_whole_and_its_keys_known() {
        let e = err(&CHAIN.replace("cam1:", "cam2:"));
        assert!(
            e.contains("field cam2") && e.contains("cam0 to cam1"),
            "{e}"
        );
        let e = err(&CHAIN.replacen("  T_cn_cnm1:", "  T_cn_cnm2:", 1));
        assert!(
            e.contains("field cam1.T_cn_cnm2") && e.contains("not a key"),
            "{e}"
        );
        let no_t = CHAIN.replacen("T_cn_cnm1", "T_imu_cam", 1);
        assert!(err(&no_t).contains("cam1.T_imu_cam"));
        let e = err(&CHAIN.replace(
            "  - [0.0, 0.0, 0.0, 1.0]\n  cam_overlaps: [0]",
            "  - [0.0, 0.0, 1.0, 1.0]\n  cam_overlaps: [0]",
        ));
        assert!(
            e.contains("cam1.T_cn_cnm1") && e.contains("last row"),
            "{e}"
        );
        let e = err(&CHAIN.replace("resolution: [752, 480]", "resolution: [752]"));
        assert!(
            e.contains("cam0.resolution") && e.contains("[width, height]"),
            "{e}"
        );
        let e = err(&CHAIN.replace(
            "intrinsics: [458.654, 457.296, 367.215, 248.375]",
            "intrinsics: [0.8, 458.654, 457.296, 367.215, 248.375]",
        ));
        assert!(
            e.contains("cam0.intrinsics") && e.contains("got 5 values"),
            "{e}"
        );
        // The first camera alone is one camera.
        let cam0 = &CHAIN[..CHAIN.find("cam1:").unwrap()];
        assert!(parse_calibration(cam0, "cam0.yaml")
            .unwrap()
            .camera
            .extrinsics
            .is_identity());
    }
}
