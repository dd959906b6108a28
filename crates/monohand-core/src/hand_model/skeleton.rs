//! The hand skeleton: palm layout, bone lengths, joint axes and limits.
//!
//! The hand frame has its origin at the wrist, `+y` pointing distally (wrist to
//! middle knuckle) and `+z` out of the palm (palmar side). For a right hand `+x`
//! points to the thumb side; a left hand is the mirror image (`x -> -x`) in the
//! same frame. The palm is rigid: the four finger MCP joints and the thumb CMC
//! joint are fixed points of the hand frame.
//!
//! Each finger is a chain of three bones. Its base joint has two degrees of
//! freedom, applied as `R(abduction_axis, abduction) * R(flexion_axis, flexion)`,
//! so the flexion hinge turns with the abduction; the two distal joints are
//! hinges about the same (turned) flexion axis. Positive flexion bends towards
//! the palm, positive abduction spreads towards the thumb (for the thumb:
//! away from the palm plane).

use crate::error::{CoreError, CoreResult};
use crate::hand_model::joints::{Finger, HandSide, BONES, NUM_FINGERS};
use crate::hand_model::limits::JointLimits;
use nalgebra::{Rotation3, Unit, Vector3};

/// The geometry of one finger in the hand frame at rest (all angles zero).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FingerGeometry {
    /// Position of the base joint (MCP; thumb CMC) in the hand frame, mm.
    pub base: Vector3<f64>,
    /// Direction of the first bone at rest.
    pub rest_direction: Unit<Vector3<f64>>,
    /// Flexion hinge axis at rest (perpendicular to `rest_direction`).
    pub flexion_axis: Unit<Vector3<f64>>,
    /// Abduction axis of the base joint (fixed in the hand frame).
    pub abduction_axis: Unit<Vector3<f64>>,
    /// Lengths of the three bones, base to tip, mm.
    pub lengths: [f64; 3],
}

impl FingerGeometry {
    /// Builds a finger from its base, rest bone direction and the direction the
    /// tip moves to when the finger flexes; axes follow the sign conventions of
    /// the module docs (`abduction_towards` is where positive abduction moves the bone).
    pub fn new(
        base: Vector3<f64>,
        rest_direction: Vector3<f64>,
        flex_towards: Vector3<f64>,
        abduction_towards: Vector3<f64>,
        lengths: [f64; 3],
    ) -> FingerGeometry {
        let d = Unit::new_normalize(rest_direction);
        let f = Unit::new_normalize(flex_towards.into_inner_or(d));
        let h = Unit::new_normalize(d.cross(&f));
        let ab = abduction_towards - d.into_inner() * d.dot(&abduction_towards);
        let a = Unit::new_normalize(d.cross(&ab));
        FingerGeometry {
            base,
            rest_direction: d,
            flexion_axis: h,
            abduction_axis: a,
            lengths,
        }
    }
}

trait OrthoTo {
    fn into_inner_or(self, d: Unit<Vector3<f64>>) -> Vector3<f64>;
}
impl OrthoTo for Vector3<f64> {
    fn into_inner_or(self, d: Unit<Vector3<f64>>) -> Vector3<f64> {
        self - d.into_inner() * d.dot(&self)
    }
}

/// A complete hand skeleton (one side, one size).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandSkeleton {
    /// Which hand this skeleton describes.
    pub side: HandSide,
    /// The five fingers, thumb to little.
    pub fingers: [FingerGeometry; NUM_FINGERS],
    /// Joint angle limits.
    pub limits: JointLimits,
    /// How far the thumb's hinge is rolled about its metacarpal from the planar
    /// thumb of the paper's model, degrees in the right hand's sense:
    /// [`THUMB_HINGE_ROLL_DEG`] for the default skeleton, 0 for a thumb whose hinge
    /// was fitted to 3D labels. [`HandSkeleton::planar_thumb`] undoes it.
    pub thumb_hinge_roll_deg: f64,
}

/// Default adult right hand, mm: (base position, rest direction, bone lengths).
///
/// Wrist-to-MCP distances and phalanx lengths are the means of the generic hand
/// models in `shared/data/hand_models/bone_length_stats.json` (UmeTrack, WebXR)
/// and published anthropometry (external finger lengths index 64, middle 71,
/// ring 66, little 53 mm; Chatzioglou et al. 2024). Fingers fan out from a
/// point 40 mm proximal to the wrist.
const DEFAULT_RIGHT: [([f64; 3], [f64; 3]); NUM_FINGERS] = [
    ([24.0, 26.0, 6.0], [44.0, 32.0, 26.0]), // thumb: CMC, metacarpal, proximal, distal
    ([24.0, 94.0, 0.0], [40.0, 24.0, 21.0]), // index
    ([3.0, 95.0, 0.0], [44.0, 27.0, 23.0]),  // middle
    ([-16.0, 89.0, -2.0], [41.0, 26.0, 22.0]), // ring
    ([-33.0, 80.0, -4.0], [32.0, 20.0, 20.0]), // little
];

/// Roll of the default thumb's hinge axis about its metacarpal, degrees (right hand).
///
/// The thumb's three flexion joints share one hinge axis in this model. Its roll
/// about the metacarpal is taken from UmeTrack's generic hand model
/// (`shared/data/hand_models/umetrack`): posed so that its metacarpal points where
/// UmeTrack's does, the model's hinge lies 39.1 degrees from UmeTrack's MCP axis
/// and 48.2 degrees from its IP axis; this is their mean. Without it the thumb bent
/// in a plane turned away from real thumbs (docs/accuracy.md, "The thumb's hinge").
pub const THUMB_HINGE_ROLL_DEG: f64 = -43.6;

impl HandSkeleton {
    /// A default adult hand of the given side (hand length ~ 185 mm).
    ///
    /// ```
    /// use monohand_core::hand_model::{HandSide, HandSkeleton};
    /// let sk = HandSkeleton::default_for(HandSide::Left).scaled(1.1).unwrap();
    /// assert!(sk.bone_lengths()[9] > 40.0);
    /// ```
    pub fn default_for(side: HandSide) -> HandSkeleton {
        let right = Self::default_right(THUMB_HINGE_ROLL_DEG);
        match side {
            HandSide::Right => right,
            HandSide::Left => right.mirrored(),
        }
    }

    fn default_right(thumb_roll_deg: f64) -> HandSkeleton {
        let fingers = std::array::from_fn(|i| {
            let (b, len) = DEFAULT_RIGHT[i];
            let base = Vector3::new(b[0], b[1], b[2]);
            if i == 0 {
                // Thumb: metacarpal points radially, distally and a little palmar;
                // it flexes across the palm and abducts away from the palm plane.
                // Its hinge is rolled about the metacarpal by THUMB_HINGE_ROLL_DEG.
                let d = Vector3::new(0.62, 0.72, 0.30);
                let roll = Rotation3::from_axis_angle(
                    &Unit::new_normalize(d),
                    thumb_roll_deg.to_radians(),
                );
                FingerGeometry::new(
                    base,
                    d,
                    roll * Vector3::new(-0.55, 0.15, 0.82),
                    Vector3::new(0.0, 0.0, 1.0),
                    len,
                )
            } else {
                let dir = base + Vector3::new(0.0, 40.0, 0.0);
                FingerGeometry::new(
                    base,
                    Vector3::new(dir.x, dir.y, 0.0),
                    Vector3::new(0.0, 0.0, 1.0),
                    Vector3::new(1.0, 0.0, 0.0),
                    len,
                )
            }
        });
        HandSkeleton {
            side: HandSide::Right,
            fingers,
            limits: JointLimits::default(),
            thumb_hinge_roll_deg: thumb_roll_deg,
        }
    }

    /// The same hand with the thumb's hinge rolled back to the planar thumb
    /// ([`Self::thumb_hinge_roll_deg`] 0). The fitter uses it for fits that see
    /// only 2D keypoints: there the roll lets the hand trade the thumb's bending
    /// plane for a tilt in depth that no pixel can tell apart (docs/accuracy.md).
    pub fn planar_thumb(&self) -> HandSkeleton {
        let mut out = *self;
        let roll = -self.thumb_hinge_roll_deg.to_radians();
        let g = &mut out.fingers[0];
        let angle = match self.side {
            HandSide::Right => roll,
            // A mirrored skeleton's rotations turn the other way.
            HandSide::Left => -roll,
        };
        g.flexion_axis = Unit::new_normalize(
            Rotation3::from_axis_angle(&g.rest_direction, angle) * g.flexion_axis.into_inner(),
        );
        out.thumb_hinge_roll_deg = 0.0;
        out
    }

    /// The mirror image (`x -> -x` in the hand frame), with the side swapped.
    ///
    /// Axes are mirrored and negated so that the same angles give the mirrored
    /// pose: positive flexion still bends towards the palm.
    pub fn mirrored(&self) -> HandSkeleton {
        let m = |v: Vector3<f64>| Vector3::new(-v.x, v.y, v.z);
        let fingers = self.fingers.map(|f| FingerGeometry {
            base: m(f.base),
            rest_direction: Unit::new_unchecked(m(f.rest_direction.into_inner())),
            flexion_axis: Unit::new_unchecked(-m(f.flexion_axis.into_inner())),
            abduction_axis: Unit::new_unchecked(-m(f.abduction_axis.into_inner())),
            lengths: f.lengths,
        });
        HandSkeleton {
            side: self.side.opposite(),
            fingers,
            limits: self.limits,
            thumb_hinge_roll_deg: self.thumb_hinge_roll_deg,
        }
    }

    /// The same hand uniformly scaled (bone lengths and palm) by `s`.
    pub fn scaled(&self, s: f64) -> CoreResult<HandSkeleton> {
        if !(s.is_finite() && s > 0.05 && s < 20.0) {
            return Err(CoreError::InvalidSkeleton(format!(
                "hand scale {s} must be in (0.05, 20)"
            )));
        }
        let mut out = *self;
        for f in &mut out.fingers {
            f.base *= s;
            f.lengths = f.lengths.map(|l| l * s);
        }
        Ok(out)
    }

    /// The 20 bone lengths in [`BONES`] order (wrist-to-base distance first for each finger).
    pub fn bone_lengths(&self) -> [f64; 20] {
        std::array::from_fn(|i| {
            let f = &self.fingers[i / 4];
            match i % 4 {
                0 => f.base.norm(),
                k => f.lengths[k - 1],
            }
        })
    }

    /// Replaces the bone lengths (in [`BONES`] order, mm). Wrist-to-base bones
    /// move the base joint along its direction from the wrist.
    pub fn with_bone_lengths(&self, lengths: &[f64; 20]) -> CoreResult<HandSkeleton> {
        for (i, &l) in lengths.iter().enumerate() {
            if !(l.is_finite() && l > 1.0 && l < 500.0) {
                let (a, b) = BONES[i];
                return Err(CoreError::InvalidSkeleton(format!(
                    "bone {a}-{b} length {l} mm is outside (1, 500)"
                )));
            }
        }
        let mut out = *self;
        for (fi, f) in out.fingers.iter_mut().enumerate() {
            let n = f.base.norm();
            if n > 1e-9 {
                f.base *= lengths[4 * fi] / n;
            }
            for k in 0..3 {
                f.lengths[k] = lengths[4 * fi + k + 1];
            }
        }
        Ok(out)
    }

    /// Total length of the middle finger chain from the wrist, a size measure (mm).
    pub fn hand_length(&self) -> f64 {
        let m = &self.fingers[Finger::Middle.index()];
        m.base.norm() + m.lengths.iter().sum::<f64>()
    }

    /// Checks geometry and limits.
    pub fn validate(&self) -> CoreResult<()> {
        for (i, f) in self.fingers.iter().enumerate() {
            let nums = [f.base.as_slice(), &f.lengths].concat();
            if nums.iter().any(|v| !v.is_finite()) || f.lengths.iter().any(|&l| l <= 0.0) {
                return Err(CoreError::InvalidSkeleton(format!(
                    "finger {i} has bad geometry"
                )));
            }
        }
        self.limits.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hand_model::joints::NUM_JOINTS;

    #[test]
    fn planar_thumb_undoes_the_default_roll_on_both_sides() {
        let planar_right = HandSkeleton::default_right(0.0);
        for (side, planar) in [
            (HandSide::Right, planar_right),
            (HandSide::Left, planar_right.mirrored()),
        ] {
            let rolled = HandSkeleton::default_for(side);
            let unrolled = rolled.planar_thumb();
            assert_eq!(unrolled.thumb_hinge_roll_deg, 0.0);
            let (a, b) = (unrolled.fingers[0], planar.fingers[0]);
            assert!((a.flexion_axis.into_inner() - b.flexion_axis.into_inner()).norm() < 1e-12);
            assert_eq!(a.rest_direction, b.rest_direction);
            assert_eq!(a.abduction_axis, b.abduction_axis);
            // The roll is real (44 degrees), and nothing else moves.
            let turned = rolled.fingers[0].flexion_axis.angle(&a.flexion_axis);
            assert!((turned.to_degrees() - THUMB_HINGE_ROLL_DEG.abs()).abs() < 1e-9);
            assert_eq!(unrolled.fingers[1..], rolled.fingers[1..]);
            assert_eq!(unrolled.bone_lengths(), rolled.bone_lengths());
            // Planar already: nothing to undo.
            assert_eq!(unrolled.planar_thumb(), unrolled);
        }
    }

    #[test]
    fn axes_are_orthonormal_where_expected() {
        for side in [HandSide::Left, HandSide::Right] {
            let sk = HandSkeleton::default_for(side);
            for f in &sk.fingers {
                assert!(f.flexion_axis.dot(&f.rest_direction).abs() < 1e-12);
                assert!(f.abduction_axis.dot(&f.rest_direction).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn default_bone_lengths_are_anatomical() {
        let sk = HandSkeleton::default_for(HandSide::Right);
        let l = sk.bone_lengths();
        assert!((l[8] - 95.05).abs() < 0.1, "wrist-middle MCP {}", l[8]);
        assert!((170.0..200.0).contains(&sk.hand_length()));
        let l2 = sk.with_bone_lengths(&l).unwrap().bone_lengths();
        for i in 0..20 {
            assert!((l[i] - l2[i]).abs() < 1e-9);
        }
        assert!(sk.scaled(f64::NAN).is_err());
        let mut bad = l;
        bad[3] = -1.0;
        assert!(sk.with_bone_lengths(&bad).is_err());
    }

    #[test]
    fn left_is_mirror_of_right() {
        let r = HandSkeleton::default_for(HandSide::Right);
        let l = HandSkeleton::default_for(HandSide::Left);
        let mut angles = [0.0; 20];
        for (i, a) in angles.iter_mut().enumerate() {
            *a = 0.05 * i as f64 - 0.3;
        }
        let pr = crate::kinematics::forward_kinematics_local(&r, &angles);
        let pl = crate::kinematics::forward_kinematics_local(&l, &angles);
        for j in 0..NUM_JOINTS {
            assert!((pl[j] - Vector3::new(-pr[j].x, pr[j].y, pr[j].z)).norm() < 1e-9);
        }
        // Right thumb on +x, left thumb on -x.
        assert!(pr[4].x > 0.0 && pl[4].x < 0.0);
    }

    #[test]
    fn flexion_bends_towards_palm() {
        let sk = HandSkeleton::default_for(HandSide::Right);
        let mut a = [0.0; 20];
        a[4] = 1.0; // index MCP flexion
        let p = crate::kinematics::forward_kinematics_local(&sk, &a);
        assert!(p[8].z > 20.0, "index tip z {}", p[8].z);
        let mut b = [0.0; 20];
        b[5] = 0.3; // index abduction towards the thumb
        let q = crate::kinematics::forward_kinematics_local(&sk, &b);
        assert!(q[8].x > sk.rest_joints()[8].x + 5.0);
    }
}
