//! Axis-aligned boxes in the image plane.

use serde::{Deserialize, Serialize};

/// An axis-aligned box `[x_min, y_min, x_max, y_max]` in pixels.
///
/// Every box monohand hands out publicly (hands, heads, JSON Lines records) is in
/// pixel-centre coordinates, the OpenCV/OpenPose convention the keypoints use: the centre
/// of the first pixel is `(0, 0)`. (The detectors' raw outputs in `monohand-vision`'s
/// `palm`, `face` and `ssd` modules are in the continuous coordinates the networks work
/// in, as their docs say.) In JSON a box is the array `[x_min, y_min, x_max, y_max]`.
///
/// ```
/// use monohand_core::bbox::BBox;
///
/// let a = BBox::new(0.0, 0.0, 10.0, 10.0);
/// let b = BBox::new(5.0, 0.0, 15.0, 10.0);
/// assert_eq!(a.iou(&b), 50.0 / 150.0);
/// assert!(a.contains([10.0, 0.0]) && !a.contains([10.5, 0.0]));
/// assert_eq!(a.fraction_covered_by(&b), 0.5);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
#[serde(from = "[f64; 4]", into = "[f64; 4]")]
pub struct BBox {
    /// Left edge.
    pub x_min: f64,
    /// Top edge.
    pub y_min: f64,
    /// Right edge.
    pub x_max: f64,
    /// Bottom edge.
    pub y_max: f64,
}

impl BBox {
    /// The box with these edges.
    pub const fn new(x_min: f64, y_min: f64, x_max: f64, y_max: f64) -> BBox {
        BBox {
            x_min,
            y_min,
            x_max,
            y_max,
        }
    }

    /// The box of this centre, width and height.
    pub fn from_centre_size(centre: [f64; 2], width: f64, height: f64) -> BBox {
        let (hw, hh) = (width / 2.0, height / 2.0);
        BBox::new(
            centre[0] - hw,
            centre[1] - hh,
            centre[0] + hw,
            centre[1] + hh,
        )
    }

    /// The smallest box holding every point (an empty iterator gives an inverted box of
    /// infinite edges, whose area is 0 and which contains nothing).
    pub fn around(points: impl IntoIterator<Item = [f64; 2]>) -> BBox {
        let mut b = BBox::new(
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for [x, y] in points {
            b.x_min = b.x_min.min(x);
            b.y_min = b.y_min.min(y);
            b.x_max = b.x_max.max(x);
            b.y_max = b.y_max.max(y);
        }
        b
    }

    /// Width (0 for an inverted box).
    pub fn width(&self) -> f64 {
        (self.x_max - self.x_min).max(0.0)
    }

    /// Height (0 for an inverted box).
    pub fn height(&self) -> f64 {
        (self.y_max - self.y_min).max(0.0)
    }

    /// Area (0 for an inverted box).
    pub fn area(&self) -> f64 {
        self.width() * self.height()
    }

    /// The centre `[x, y]`.
    pub fn centre(&self) -> [f64; 2] {
        [
            (self.x_min + self.x_max) / 2.0,
            (self.y_min + self.y_max) / 2.0,
        ]
    }

    /// Whether every edge is finite.
    pub fn is_finite(&self) -> bool {
        self.to_array().iter().all(|v| v.is_finite())
    }

    /// Whether the point lies inside or on the edge.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        (self.x_min..=self.x_max).contains(&p[0]) && (self.y_min..=self.y_max).contains(&p[1])
    }

    /// The area shared with `other`.
    pub fn intersection_area(&self, other: &BBox) -> f64 {
        let iw = (self.x_max.min(other.x_max) - self.x_min.max(other.x_min)).max(0.0);
        let ih = (self.y_max.min(other.y_max) - self.y_min.max(other.y_min)).max(0.0);
        iw * ih
    }

    /// Intersection over union (0 when both are empty).
    pub fn iou(&self, other: &BBox) -> f64 {
        let inter = self.intersection_area(other);
        let union = self.area() + other.area() - inter;
        if union > 0.0 {
            inter / union
        } else {
            0.0
        }
    }

    /// The fraction of this box's area that `other` covers (0 when this box is empty).
    pub fn fraction_covered_by(&self, other: &BBox) -> f64 {
        let area = self.area();
        if area > 0.0 {
            self.intersection_area(other) / area
        } else {
            0.0
        }
    }

    /// The box with both corners mapped by `f` (for a shift or a scale of the plane).
    pub fn map_corners(&self, f: impl Fn([f64; 2]) -> [f64; 2]) -> BBox {
        let [x0, y0] = f([self.x_min, self.y_min]);
        let [x1, y1] = f([self.x_max, self.y_max]);
        BBox::new(x0, y0, x1, y1)
    }

    /// `[x_min, y_min, x_max, y_max]`.
    pub const fn to_array(&self) -> [f64; 4] {
        [self.x_min, self.y_min, self.x_max, self.y_max]
    }
}

impl From<[f64; 4]> for BBox {
    fn from(b: [f64; 4]) -> BBox {
        BBox::new(b[0], b[1], b[2], b[3])
    }
}

impl From<BBox> for [f64; 4] {
    fn from(b: BBox) -> [f64; 4] {
        b.to_array()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iou_of_disjoint_identical_and_nested_boxes() {
        let a = BBox::new(0.0, 0.0, 10.0, 10.0);
        assert_eq!(a.iou(&a), 1.0);
        assert_eq!(a.iou(&BBox::new(20.0, 20.0, 30.0, 30.0)), 0.0);
        // Touching edges share no area.
        assert_eq!(a.iou(&BBox::new(10.0, 0.0, 20.0, 10.0)), 0.0);
        let inner = BBox::new(2.0, 2.0, 7.0, 7.0);
        assert_eq!(a.iou(&inner), 25.0 / 100.0);
        assert_eq!(inner.fraction_covered_by(&a), 1.0);
        assert_eq!(a.fraction_covered_by(&inner), 0.25);
        // Degenerate boxes: no division by zero.
        let empty = BBox::around([]);
        assert_eq!(empty.area(), 0.0);
        assert_eq!(empty.iou(&empty), 0.0);
        assert_eq!(empty.fraction_covered_by(&a), 0.0);
        assert!(!empty.contains([0.0, 0.0]));
    }

    #[test]
    fn around_centre_and_json() {
        let b = BBox::around([[3.0, 4.0], [1.0, 9.0], [2.0, -1.0]]);
        assert_eq!(b, BBox::new(1.0, -1.0, 3.0, 9.0));
        assert_eq!(b.centre(), [2.0, 4.0]);
        assert_eq!(BBox::from_centre_size([2.0, 4.0], 2.0, 10.0), b);
        assert_eq!((b.width(), b.height(), b.area()), (2.0, 10.0, 20.0));
        let shifted = b.map_corners(|[x, y]| [x - 0.5, y - 0.5]);
        assert_eq!(shifted, BBox::new(0.5, -1.5, 2.5, 8.5));
        let json = serde_json::to_string(&b).unwrap();
        assert_eq!(json, "[1.0,-1.0,3.0,9.0]");
        let back: BBox = serde_json::from_str(&json).unwrap();
        assert_eq!(back, b);
        assert!(b.is_finite() && !BBox::new(f64::NAN, 0.0, 1.0, 1.0).is_finite());
    }
}
