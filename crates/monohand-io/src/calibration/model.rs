//! Lens models as calibration files name them: each format's names, the model and
//! coefficient counts each name means, and the refusal of every other name. A file is
//! read as the model it states, or refused; never as another.

use super::distortion;
use super::filestorage::Node;
use crate::error::{IoError, IoResult};
use monohand_core::camera::{Distortion, LensModel};

/// One name a format gives a lens model.
#[derive(Debug)]
pub(super) struct Name {
    /// As the file writes it.
    pub name: &'static str,
    /// What it means.
    pub model: LensModel,
    /// The coefficient counts it takes; empty for OpenCV's pinhole rules (0, 4, 5 or 8,
    /// or 12 or 14 with the thin-prism and tilt terms zero).
    pub counts: &'static [usize],
}

/// The names one format gives lens models.
#[derive(Debug)]
pub(super) struct Names(pub &'static [Name]);

const fn name(name: &'static str, model: LensModel, counts: &'static [usize]) -> Name {
    Name {
        name,
        model,
        counts,
    }
}

/// The project JSON's `model`.
pub(super) const PROJECT: Names = Names(&[
    name("pinhole", LensModel::Pinhole, &[]),
    name("fisheye", LensModel::Fisheye, &[0, 4]),
]);

/// ROS `camera_info`'s `distortion_model` (`sensor_msgs/distortion_models.h`; `fisheye` is
/// what releases of `camera_calibration` before `equidistant` wrote for the same model).
pub(super) const ROS: Names = Names(&[
    name("plumb_bob", LensModel::Pinhole, &[0, 4, 5]),
    name("rational_polynomial", LensModel::Pinhole, &[8]),
    name("equidistant", LensModel::Fisheye, &[4]),
    name("fisheye", LensModel::Fisheye, &[4]),
]);

/// Kalibr's `distortion_model` of a `pinhole` camera.
pub(super) const KALIBR: Names = Names(&[
    name("radtan", LensModel::Pinhole, &[4]),
    name("none", LensModel::Pinhole, &[0]),
    name("equidistant", LensModel::Fisheye, &[4]),
]);

/// An OpenCV FileStorage file's `distortion_model`, `model` or `camera_model`.
pub(super) const OPENCV: Names = Names(&[
    name("pinhole", LensModel::Pinhole, &[]),
    name("plumb_bob", LensModel::Pinhole, &[0, 4, 5]),
    name("radtan", LensModel::Pinhole, &[]),
    name("rational_polynomial", LensModel::Pinhole, &[8]),
    name("fisheye", LensModel::Fisheye, &[4]),
    name("equidistant", LensModel::Fisheye, &[4]),
]);

/// The keys of an OpenCV FileStorage file that state its lens model by name.
const OPENCV_MODEL_KEYS: [&str; 3] = ["distortion_model", "model", "camera_model"];

impl Names {
    /// The name `value` that `field` states; refused, with the names understood, if it is
    /// none of them.
    pub fn find(&self, value: &str, file: &str, field: &str) -> IoResult<&'static Name> {
        self.0
            .iter()
            .find(|n| n.name == value)
            .ok_or_else(|| IoError::unsupported(file, field, value, self.listing()))
    }

    /// `pinhole: plumb_bob, rational_polynomial; fisheye: equidistant`.
    pub fn listing(&self) -> String {
        LensModel::ALL
            .iter()
            .filter_map(|&m| {
                let names: Vec<&str> = self
                    .0
                    .iter()
                    .filter(|n| n.model == m)
                    .map(|n| n.name)
                    .collect();
                (!names.is_empty()).then(|| format!("{m}: {}", names.join(", ")))
            })
            .collect::<Vec<_>>()
            .join("; ")
    }
}

impl Name {
    /// The lens of coefficients `d` (read from `field`) under this name, stated by
    /// `stated_by`: refused if their number is not one the name takes.
    pub fn lens(
        &self,
        d: &[f64],
        file: &str,
        field: &str,
        stated_by: &str,
    ) -> IoResult<Distortion> {
        if self.counts.is_empty() {
            return distortion(LensModel::Pinhole, d, file, field);
        }
        if !self.counts.contains(&d.len()) {
            let what = match self.model {
                LensModel::Pinhole => "k1 k2 p1 p2 k3 k4 k5 k6",
                LensModel::Fisheye => "k1 k2 k3 k4",
            };
            return Err(IoError::field(
                file,
                field,
                format!(
                    "{stated_by} {:?} takes {} coefficients ({what}), got {}",
                    self.name,
                    counts(self.counts),
                    d.len()
                ),
            ));
        }
        distortion(self.model, d, file, field)
    }
}

/// `4`, `0 or 4`, `0, 4 or 5`.
fn counts(c: &[usize]) -> String {
    let s: Vec<String> = c.iter().map(usize::to_string).collect();
    match s.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => s.join(""),
    }
}

/// The lens model an OpenCV FileStorage file states, if any, with the key that states it:
/// `distortion_model`, `model` or `camera_model` by name ([`OPENCV`]), or `fisheye_model`
/// (`0` or `1`, as OpenCV's calibration sample writes it). Every key present must be
/// understood and all must agree; a `xi` (`cv::omnidir`'s mirror parameter) is refused.
pub(super) fn filestorage_model(
    root: &Node,
    file: &str,
) -> IoResult<Option<(&'static str, &'static Name)>> {
    if root.get("xi").is_some() {
        return Err(IoError::unsupported(
            file,
            "xi",
            "cv::omnidir",
            "xi is the omnidirectional model's mirror parameter; the models read are \
             pinhole and fisheye",
        ));
    }
    let mut stated: Vec<(&'static str, &'static Name)> = Vec::new();
    for key in OPENCV_MODEL_KEYS {
        if let Some(node) = root.get(key) {
            stated.push((key, OPENCV.find(&scalar(node, file, key)?, file, key)?));
        }
    }
    if let Some(node) = root.get("fisheye_model") {
        let v = scalar(node, file, "fisheye_model")?;
        let n = match v.as_str() {
            "0" | "false" => OPENCV.find("pinhole", file, "fisheye_model")?,
            "1" | "true" => OPENCV.find("fisheye", file, "fisheye_model")?,
            _ => {
                return Err(IoError::unsupported(
                    file,
                    "fisheye_model",
                    v,
                    "0 for the pinhole, 1 for the fisheye",
                ))
            }
        };
        stated.push(("fisheye_model", n));
    }
    let Some(&(key, first)) = stated.first() else {
        return Ok(None);
    };
    if let Some((other, n)) = stated.iter().find(|(_, n)| n.model != first.model) {
        return Err(IoError::field(
            file,
            *other,
            format!(
                "states the {} model, but {key} states the {}",
                n.model, first.model
            ),
        ));
    }
    // The most specific name (one with its own coefficient counts) wins.
    Ok(Some(
        stated
            .iter()
            .copied()
            .find(|(_, n)| !n.counts.is_empty())
            .unwrap_or((key, first)),
    ))
}

/// A scalar's text.
pub(super) fn scalar(node: &Node, file: &str, field: &str) -> IoResult<String> {
    match node {
        Node::Scalar(s) => Ok(s.clone()),
        _ => Err(IoError::field(file, field, "expected a name")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_list_by_model_and_refuse_others() {
        assert_eq!(
            ROS.listing(),
            "pinhole: plumb_bob, rational_polynomial; fisheye: equidistant, fisheye"
        );
        let e = ROS
            .find("double_sphere", "cam.yaml", "distortion_model")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "cam.yaml: distortion_model \"double_sphere\" is not supported (pinhole: plumb_bob, \
             rational_polynomial; fisheye: equidistant, fisheye)"
        );
        let n = ROS.find("equidistant", "f", "distortion_model").unwrap();
        assert_eq!(n.model, LensModel::Fisheye);
        let e = n.lens(&[0.1; 5], "f", "D", "distortion_model").unwrap_err();
        assert!(
            e.to_string()
                .contains("takes 4 coefficients (k1 k2 k3 k4), got 5"),
            "{e}"
        );
        let d = n
            .lens(&[0.1, 0.2, 0.3, 0.4], "f", "D", "distortion_model")
            .unwrap();
        assert_eq!(d.model, LensModel::Fisheye);
        assert_eq!(counts(&[0, 4, 5]), "0, 4 or 5");
        assert_eq!(counts(&[4]), "4");
    }
}
