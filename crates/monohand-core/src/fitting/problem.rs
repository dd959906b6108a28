//! What a solve works on: which joints and degrees of freedom it uses, and the
//! views prepared for it (weighted keypoints, as observed for the fit and mapped to the
//! ideal pinhole image for its starts, and the network's bone directions). Both the solver ([`super::lm`]) and its starts ([`super::init`])
//! read these; this module depends on neither.

use super::options::{CostSettings, FitOptions, View};
use crate::camera::{Camera, LensModel};
use crate::error::{CoreError, CoreResult};
use crate::hand_model::params::ANGLES_PER_FINGER;
use crate::hand_model::{BONES, NUM_DOF, NUM_JOINTS};
use crate::observation::NetworkCues;
use nalgebra::{Matrix2x3, Rotation3, Vector2, Vector3};

/// Which joints a solve uses.
pub(crate) type JointMask = [bool; NUM_JOINTS];
/// Which degrees of freedom a solve may change.
pub(crate) type DofMask = [bool; NUM_DOF];

/// The degrees of freedom constrained by the observed joints: the root always,
/// an angle only if some joint it moves is observed.
pub(crate) fn free_dofs(observed: &JointMask) -> DofMask {
    let mut free = [false; NUM_DOF];
    free[..6].iter_mut().for_each(|f| *f = true);
    for f in crate::hand_model::Finger::ALL {
        let j = f.joints();
        let seen = |from: usize| j[from..].iter().any(|&k| observed[k]);
        let b = 6 + f.index() * ANGLES_PER_FINGER;
        free[b] = seen(1);
        free[b + 1] = seen(1);
        free[b + 2] = seen(2);
        free[b + 3] = seen(3);
    }
    free
}

/// One view prepared for the solver: its keypoints as observed, which the fit
/// reprojects the joints through the camera's lens onto, the same keypoints in the ideal
/// pinhole image for the starts, and weights.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PreparedView {
    pub camera: Camera,
    /// Observed pixels as given (distorted): the fit's targets.
    pub raw: [[f64; 2]; NUM_JOINTS],
    /// Observed pixels mapped to the ideal pinhole image (the camera's intrinsics without
    /// its lens's distortion), for the starts and the cues' directions; meaningful where
    /// `start_weights` is above 0.
    pub ideal: [[f64; 2]; NUM_JOINTS],
    /// `p^k`, or 0 for dropped joints.
    pub weights: [f64; NUM_JOINTS],
    /// `weights`, except 0 for a keypoint with no ideal pinhole pixel (a fisheye's, 90
    /// degrees or more off its axis): the starts' weights. Equal to `weights` for every
    /// pinhole camera.
    pub start_weights: [f64; NUM_JOINTS],
    /// Milliradians per pixel along x and y (`1000 / fx`, `1000 / fy`). The solver
    /// measures reprojection residuals as angles: the same keypoint error in the
    /// image is the same angle at any resolution, so the balance of the keypoints
    /// against the millimetre terms (the network's bone directions, the tracking
    /// pull) does not change when the video is scaled. Without those terms the
    /// minimiser is the paper's pixel cost's.
    pub mrad_per_px: [f64; 2],
    /// Target unit direction of each bone in this camera's frame, from the
    /// network's cues: `[0]` metric 3D, `[1]` relative depth.
    pub bone_targets: [[Vector3<f64>; NUM_BONES]; NUM_CUES],
    /// Weight of each bone residual per cue (0 where the cue is absent).
    pub bone_weights: [[f64; NUM_BONES]; NUM_CUES],
    /// Target unit direction of each finger bone in the hand's own frame, from each cue:
    /// its camera-frame direction turned by the rotation that best places the skeleton's
    /// palm on the cue's ([`CostSettings::hand_frame_weight`]).
    pub hand_targets: [[Vector3<f64>; NUM_BONES]; NUM_CUES],
    /// Weight of each of those residuals (0 where absent, and for the palm's own bones,
    /// which no angle moves).
    pub hand_weights: [[f64; NUM_BONES]; NUM_CUES],
}

/// The skeleton's palm in its own frame: the wrist (the origin) and the joints at the
/// palm's end of the five fingers' first bones, which no joint angle moves.
pub(crate) type Palm = [Vector3<f64>; NUM_PALM_BONES];

/// Bones from the wrist to a finger's base (one per finger).
pub(crate) const NUM_PALM_BONES: usize = 5;

/// Number of bones (one per non-wrist joint).
pub(crate) const NUM_BONES: usize = BONES.len();
/// Cues that give bone directions: the network's metric 3D and its relative depth.
pub(crate) const NUM_CUES: usize = 2;

impl PreparedView {
    /// Validates view `vi` (camera, keypoints, cues), weights its keypoints, maps them to
    /// the ideal pinhole image and sets its bone-direction targets. Returns the view and
    /// its number of usable observations.
    pub(crate) fn prepare(
        v: &View,
        vi: usize,
        o: &FitOptions,
        palm: &Palm,
    ) -> CoreResult<(PreparedView, usize)> {
        let mut used = 0;
        v.camera.validate()?;
        v.keypoints
            .validate()
            .map_err(|e| CoreError::InvalidKeypoints(format!("view {vi}: {e}")))?;
        let mut pv = PreparedView {
            camera: *v.camera,
            raw: [[0.0; 2]; NUM_JOINTS],
            ideal: [[0.0; 2]; NUM_JOINTS],
            weights: [0.0; NUM_JOINTS],
            start_weights: [0.0; NUM_JOINTS],
            mrad_per_px: [
                1000.0 / v.camera.intrinsics.fx,
                1000.0 / v.camera.intrinsics.fy,
            ],
            bone_targets: [[Vector3::zeros(); NUM_BONES]; NUM_CUES],
            bone_weights: [[0.0; NUM_BONES]; NUM_CUES],
            hand_targets: [[Vector3::zeros(); NUM_BONES]; NUM_CUES],
            hand_weights: [[0.0; NUM_BONES]; NUM_CUES],
        };
        for (j, p) in v.keypoints.points.iter().enumerate() {
            pv.raw[j] = [p[0], p[1]];
            if p[2] > 0.0 && p[2] >= o.cost.min_confidence {
                pv.weights[j] = p[2].powf(o.cost.confidence_power);
                if let Some(u) = v.camera.undistort_pixel(nalgebra::Point2::new(p[0], p[1])) {
                    pv.ideal[j] = [u.x, u.y];
                    pv.start_weights[j] = pv.weights[j];
                }
                used += 1;
            }
        }
        if let Some(cues) = v.cues {
            cues.validate()
                .map_err(|e| CoreError::InvalidKeypoints(format!("view {vi}: {e}")))?;
            let found = set_bone_targets(&mut pv, cues, &o.cost);
            if o.cost.hand_frame_weight > 0.0 {
                set_hand_targets(&mut pv, &found, palm, &o.cost);
            }
        }
        Ok((pv, used))
    }

    /// Whether the fit may place camera-frame point `x` where it is: more than 1 mm in
    /// front of a pinhole camera; more than 1 mm from a fisheye's centre, in its field.
    #[inline]
    pub(crate) fn sees(&self, x: &Vector3<f64>) -> bool {
        match self.camera.distortion.model {
            LensModel::Pinhole => x.z > 1.0,
            LensModel::Fisheye => x.norm() > 1.0 && self.camera.project_cam(x).is_some(),
        }
    }

    /// The pixel of camera-frame point `x` through the camera's lens, `None` where the fit
    /// may not place it ([`Self::sees`]).
    #[inline]
    pub(crate) fn lens_pixel(&self, x: &Vector3<f64>) -> Option<Vector2<f64>> {
        if !self.sees(x) {
            return None;
        }
        self.camera.project_cam(x).map(|p| p.coords)
    }

    /// The pixel of camera-frame point `x` through the camera's lens and its 2x3
    /// Jacobian, `None` where the fit may not place it ([`Self::sees`]).
    #[inline]
    pub(crate) fn lens_pixel_with_jacobian(
        &self,
        x: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        let in_front = match self.camera.distortion.model {
            LensModel::Pinhole => x.z > 1.0,
            LensModel::Fisheye => x.norm() > 1.0,
        };
        if !in_front {
            return None;
        }
        self.camera.project_with_jacobian(x)
    }
}

/// Sets a prepared view's bone-direction targets from the network's cues.
///
/// The network saw a crop centred on the hand as if it looked straight at
/// it, so its directions are turned by the rotation that takes the optical
/// axis to the viewing ray through the observed joints' mean. A bone's weight
/// is the cue's weight times its segment's reliability
/// ([`CostSettings::cue_segment_weights`]) times the smaller confidence weight of
/// its two joints.
/// Returns, per cue, the camera-frame unit direction of each bone it gives (whatever the
/// cue's weight), for [`set_hand_targets`].
fn set_bone_targets(
    pv: &mut PreparedView,
    cues: &NetworkCues,
    o: &CostSettings,
) -> [[Option<Vector3<f64>>; NUM_BONES]; NUM_CUES] {
    let mut found = [[None; NUM_BONES]; NUM_CUES];
    let (su, sv, n) = (0..NUM_JOINTS)
        .filter(|&j| pv.start_weights[j] > 0.0)
        .fold((0.0, 0.0, 0.0), |(u, v, n), j| {
            (u + pv.ideal[j][0], v + pv.ideal[j][1], n + 1.0)
        });
    if n == 0.0 {
        return found;
    }
    let k = &pv.camera.intrinsics;
    let ray = Vector3::new((su / n - k.cx) / k.fx, (sv / n - k.cy) / k.fy, 1.0);
    let turn = Rotation3::rotation_between(&Vector3::z(), &ray).unwrap_or_else(Rotation3::identity);
    for (b, &(p, c)) in BONES.iter().enumerate() {
        let w = pv.weights[p].min(pv.weights[c]);
        if w <= 0.0 {
            continue;
        }
        let world = cues
            .world_mm
            .map(|m| Vector3::from(m[c]) - Vector3::from(m[p]));
        // The depth cue's bone is in the ideal image, where both joints must have a pixel.
        let pinhole = pv.start_weights[p] > 0.0 && pv.start_weights[c] > 0.0;
        let depth = cues.depth_px.filter(|_| pinhole).map(|z| {
            Vector3::new(
                (pv.ideal[c][0] - pv.ideal[p][0]) / k.fx,
                (pv.ideal[c][1] - pv.ideal[p][1]) / k.fy,
                (z[c] - z[p]) / k.fx,
            )
        });
        for (cue, (d, weight)) in [(world, o.world_weight), (depth, o.depth_weight)]
            .into_iter()
            .enumerate()
        {
            let Some(unit) = d.and_then(|d| (turn * d).try_normalize(1e-12)) else {
                continue;
            };
            found[cue][b] = Some(unit);
            if weight > 0.0 {
                pv.bone_targets[cue][b] = unit;
                pv.bone_weights[cue][b] = weight * w * o.cue_segment_weights[cue][bone_segment(b)];
            }
        }
    }
    found
}

/// Sets a prepared view's hand-frame targets from each cue's camera-frame bone directions
/// (`found`): the rotation that best places the skeleton's `palm` on the cue's palm (its
/// five wrist-to-base bones at the skeleton's lengths, at least three of them given) is
/// the network's tilt of the hand; undone, the finger bones' directions are the
/// network's articulation alone. A finger bone's weight is
/// [`CostSettings::hand_frame_weight`] times its segment's reliability times the smaller
/// confidence weight of its two joints.
fn set_hand_targets(
    pv: &mut PreparedView,
    found: &[[Option<Vector3<f64>>; NUM_BONES]; NUM_CUES],
    palm: &Palm,
    o: &CostSettings,
) {
    for (cue, dirs) in found.iter().enumerate() {
        // The wrist at the origin of both, then each palm bone the cue gives.
        let mut from = [Vector3::zeros(); NUM_PALM_BONES + 1];
        let mut to = from;
        let mut n = 1;
        for (b, dir) in dirs.iter().enumerate() {
            if let (0, Some(d)) = (bone_segment(b), dir) {
                let local = palm[b / 4];
                (from[n], to[n]) = (local, d * local.norm());
                n += 1;
            }
        }
        if n < 4 {
            continue;
        }
        let Some(tilt) = crate::alignment::align(&from[..n], &to[..n], false) else {
            continue;
        };
        let undo = tilt.rotation.inverse();
        for (b, &(p, c)) in BONES.iter().enumerate() {
            let w = pv.weights[p].min(pv.weights[c]);
            if let (1.., Some(d), true) = (bone_segment(b), dirs[b], w > 0.0) {
                pv.hand_targets[cue][b] = undo * d;
                pv.hand_weights[cue][b] =
                    o.hand_frame_weight * w * o.cue_segment_weights[cue][bone_segment(b)];
            }
        }
    }
}

/// The skeleton's [`Palm`]: the local ends of its five wrist-to-base bones.
pub(crate) fn palm_of(skeleton: &crate::hand_model::HandSkeleton) -> Palm {
    let rest = crate::kinematics::forward_kinematics_local(
        skeleton,
        &[0.0; crate::hand_model::NUM_ANGLES],
    );
    std::array::from_fn(|f| rest[BONES[4 * f].1])
}

/// The place of bone `b` in its finger: 0 wrist to base, 1 proximal, 2 middle,
/// 3 distal ([`BONES`] runs finger by finger, base to tip, four bones each).
#[inline]
const fn bone_segment(b: usize) -> usize {
    b % 4
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::finger_of;

    #[test]
    fn bone_segments_follow_the_bone_order() {
        for (b, &(p, c)) in BONES.iter().enumerate() {
            // Segment 0 starts at the wrist; every other bone continues the previous one.
            assert_eq!(bone_segment(b) == 0, p == 0, "bone {b}");
            if bone_segment(b) > 0 {
                assert_eq!(BONES[b - 1].1, p, "bone {b}");
            }
            assert_eq!(finger_of(c), finger_of(BONES[b - bone_segment(b)].1));
        }
    }
}
