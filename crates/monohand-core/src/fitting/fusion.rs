//! The network's depth and pixels fused into the fitted joints.
//!
//! With one camera the fit's joints are a posed skeleton: its 2D agreement is
//! what the pixels say, its depths what the skeleton and the network's bone
//! directions allow together. The network's own 3D is a second estimate of the
//! same depths whose errors are partly independent of the fit's (the skeleton's
//! proportions and joint conventions are not the network's). [`fuse_network_depth`]
//! moves each joint along its viewing ray to a weighted mean of the depths: the
//! fit's, the metric 3D's (MediaPipe's world landmarks, placed rigidly on the
//! fit) and the relative depth's (the landmark `z`, in pixels, scaled to mm at
//! the fit's mean depth). The reprojection stays the fit's; only depth changes.
//! [`fuse_keypoints`] then does the same across the rays: the 2D keypoints are a
//! second estimate of where each joint is seen, which the skeleton cannot always
//! reach. The weights were chosen on the development set (docs/accuracy.md).

use nalgebra::{Point2, Vector3};

use crate::alignment::align;
use crate::camera::Camera;
use crate::hand_model::NUM_JOINTS;
use crate::observation::{Keypoints2d, NetworkCues};

/// Moves each of `joints` (reference frame, mm) along its viewing ray from
/// `camera` to the depth `(1 − a − b) z_fit + a z_world + b z_rel`, with
/// `[a, b] = weights`:
/// - `z_world`: the joint's depth in [`NetworkCues::world_mm`] after the rigid
///   transform that best places those points on `joints`;
/// - `z_rel`: the fit's mean depth `z̄` plus the joint's [`NetworkCues::depth_px`]
///   relative to their mean, times `z̄ / f_x` (pixels to mm at that depth).
///
/// A cue that is absent or has weight 0 is left out. Returns `None` if the
/// weights are not in `[0, 1]` with a sum of at most 1, the alignment is
/// undefined, or a joint or its fused depth is not in front of the camera.
///
/// ```
/// use monohand_core::{camera::Camera, fitting::fuse_network_depth, observation::NetworkCues};
/// use nalgebra::Vector3;
///
/// let camera = Camera::centred(500.0, 640, 480).expect("valid");
/// let fit: [Vector3<f64>; 21] =
///     std::array::from_fn(|j| Vector3::new(j as f64 * 3.0, (j % 4) as f64 * 5.0, 400.0));
/// // The network sees the same hand with its last tip 20 mm nearer the camera.
/// let mut world = fit.map(|p| [p.x, p.y, 0.0]);
/// world[20][2] = -20.0;
/// let cues = NetworkCues { world_mm: Some(world), depth_px: None };
/// let fused = fuse_network_depth(&fit, &camera, &cues, [0.5, 0.0]).expect("in front");
/// assert!(fused[20].z < 400.0); // the tip moves nearer
/// let px = |p: &Vector3<f64>| camera.project(p).expect("in front");
/// assert!((px(&fused[20]) - px(&fit[20])).norm() < 1e-9); // along its ray
/// ```
pub fn fuse_network_depth(
    joints: &[Vector3<f64>; NUM_JOINTS],
    camera: &Camera,
    cues: &NetworkCues,
    weights: [f64; 2],
) -> Option<[Vector3<f64>; NUM_JOINTS]> {
    let [a, b] = weights;
    if !((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b) && a + b <= 1.0) {
        return None;
    }
    let depth = |x: &Vector3<f64>| camera.extrinsics.transform(x).z;
    let z_fit = joints.map(|x| depth(&x));
    let mut z = z_fit.map(|z| (1.0 - a - b) * z);
    match cues.world_mm.filter(|_| a > 0.0) {
        Some(world) => {
            let world = world.map(Vector3::from);
            let placed = align(&world, joints, false)?;
            for (z, w) in z.iter_mut().zip(&world) {
                *z += a * depth(&placed.apply(w));
            }
        }
        None => z.iter_mut().zip(&z_fit).for_each(|(z, f)| *z += a * f),
    }
    let mean = |v: &[f64; NUM_JOINTS]| v.iter().sum::<f64>() / NUM_JOINTS as f64;
    match cues.depth_px.filter(|_| b > 0.0) {
        Some(rel) => {
            let (z_mean, rel_mean) = (mean(&z_fit), mean(&rel));
            let mm_per_px = z_mean / camera.intrinsics.fx;
            for (z, r) in z.iter_mut().zip(&rel) {
                *z += b * (z_mean + (r - rel_mean) * mm_per_px);
            }
        }
        None => z.iter_mut().zip(&z_fit).for_each(|(z, f)| *z += b * f),
    }
    let centre = camera.centre();
    let mut out = *joints;
    for ((x, &zf), &zn) in out.iter_mut().zip(&z_fit).zip(&z) {
        if !(zf > 0.0 && zn > 0.0 && zn.is_finite()) {
            return None;
        }
        *x = centre + (*x - centre) * (zn / zf);
    }
    Some(out)
}

/// Moves each of `joints` (reference frame, mm) a share `weight` of the way to the
/// point at the same depth from `camera` on the viewing ray of its keypoint, for the
/// keypoints with a confidence above 0 and at least `min_confidence`; the others stay.
/// With a weight of 1 the joints reproject onto their keypoints.
///
/// Returns `None` for a weight outside `[0, 1]` or a used joint not in front of the
/// camera.
///
/// ```
/// use monohand_core::{camera::Camera, fitting::fuse_keypoints, observation::Keypoints2d};
/// use nalgebra::Vector3;
///
/// let camera = Camera::centred(500.0, 640, 480).expect("valid");
/// let fit = [Vector3::new(0.0, 0.0, 400.0); 21];
/// let seen = camera.project(&fit[5]).expect("in front");
/// let mut kp = Keypoints2d::default();
/// kp.points[5] = [seen.x + 10.0, seen.y, 0.9]; // 10 px right of where joint 5 projects
/// let fused = fuse_keypoints(&fit, &camera, &kp, 0.1, 0.5).expect("in front");
/// assert!((fused[5] - Vector3::new(4.0, 0.0, 400.0)).norm() < 1e-9); // 5 px = 4 mm
/// assert_eq!(fused[6], fit[6]); // no keypoint
/// ```
pub fn fuse_keypoints(
    joints: &[Vector3<f64>; NUM_JOINTS],
    camera: &Camera,
    keypoints: &Keypoints2d,
    min_confidence: f64,
    weight: f64,
) -> Option<[Vector3<f64>; NUM_JOINTS]> {
    if !(0.0..=1.0).contains(&weight) {
        return None;
    }
    let ext = &camera.extrinsics;
    let mut out = *joints;
    for (x, &[u, v, p]) in out.iter_mut().zip(&keypoints.points) {
        if weight == 0.0 || p <= 0.0 || p < min_confidence {
            continue;
        }
        let z = ext.transform(x).z;
        let ray = camera.ray(Point2::new(u, v))?;
        if !(z > 0.0 && ray.z > 0.0) {
            return None;
        }
        let on_ray = ext.rotation.inverse() * (ray * (z / ray.z) - ext.translation);
        *x += (on_ray - *x) * weight;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Extrinsics;
    use crate::hand_model::{HandPose, HandSkeleton};
    use crate::kinematics::forward_kinematics;
    use nalgebra::{Rotation3, UnitQuaternion};

    fn hand() -> [Vector3<f64>; NUM_JOINTS] {
        let pose = HandPose {
            translation: Vector3::new(20.0, -10.0, 450.0),
            rotation: UnitQuaternion::from_euler_angles(0.3, -0.5, 0.2),
            ..HandPose::default()
        };
        forward_kinematics(
            &HandSkeleton::default_for(crate::hand_model::HandSide::Right),
            &pose,
        )
    }

    fn cues(world: [[f64; 3]; NUM_JOINTS]) -> NetworkCues {
        NetworkCues {
            world_mm: Some(world),
            depth_px: None,
        }
    }

    /// A camera 100 mm to the side of the reference frame's origin, turned.
    fn side_camera() -> Camera {
        Camera::centred(600.0, 640, 480)
            .expect("valid")
            .with_extrinsics(Extrinsics {
                rotation: Rotation3::from_euler_angles(0.0, -0.2, 0.0),
                translation: Vector3::new(-100.0, 0.0, 20.0),
            })
    }

    #[test]
    fn agreeing_depths_change_nothing_and_rays_are_kept() {
        let fit = hand();
        let camera = side_camera();
        // The network's 3D: the same hand, turned and moved anywhere.
        let turn = Rotation3::from_euler_angles(1.0, 0.2, -0.7);
        let world = fit.map(|p| {
            let q = turn * p - Vector3::new(0.0, 0.0, 450.0);
            [q.x, q.y, q.z]
        });
        let fused = fuse_network_depth(&fit, &camera, &cues(world), [0.6, 0.0]).expect("fused");
        for (a, b) in fused.iter().zip(&fit) {
            assert!((a - b).norm() < 1e-6, "{a} vs {b}");
        }
    }

    #[test]
    fn a_disagreeing_depth_moves_the_joint_by_the_weight_along_its_ray() {
        let fit = hand();
        let camera = side_camera();
        // Every joint of the network's hand agrees but the index tip, 30 mm
        // further along the camera's axis.
        let axis = camera.extrinsics.rotation.inverse() * Vector3::z();
        let mut world = fit.map(|p| [p.x, p.y, p.z]);
        let tip = fit[8] + axis * 30.0;
        world[8] = [tip.x, tip.y, tip.z];
        let depth = |p: &Vector3<f64>| camera.extrinsics.transform(p).z;
        for w in [0.0, 0.5, 1.0] {
            let fused = fuse_network_depth(&fit, &camera, &cues(world), [w, 0.0]).expect("fused");
            let placed = align(&world.map(Vector3::from), &fit, false).expect("aligned");
            let expected = (1.0 - w) * depth(&fit[8]) + w * depth(&placed.apply(&tip));
            assert!((depth(&fused[8]) - expected).abs() < 1e-9);
            let (a, b) = (camera.project(&fused[8]), camera.project(&fit[8]));
            let (a, b) = (a.expect("in front"), b.expect("in front"));
            assert!((a - b).norm() < 1e-9, "the pixel moved: {a} vs {b}");
        }
        // The tip moves away by about half the disagreement at weight 0.5.
        let half = fuse_network_depth(&fit, &camera, &cues(world), [0.5, 0.0]).expect("fused");
        let moved = depth(&half[8]) - depth(&fit[8]);
        assert!(moved > 10.0 && moved < 15.0, "moved {moved} mm");
    }

    #[test]
    fn the_relative_depth_moves_joints_by_its_pixels_at_the_fits_depth() {
        // A flat hand facing a camera at the origin, 400 mm away.
        let camera = Camera::centred(500.0, 640, 480).expect("valid");
        let fit: [Vector3<f64>; NUM_JOINTS] =
            std::array::from_fn(|j| Vector3::new(j as f64 * 3.0, (j % 4) as f64 * 5.0, 400.0));
        // The network says joint 8 is 10 px (8 mm at f = 500, 400 mm) nearer than
        // the others; their mean is then 10/21 px nearer than theirs.
        let mut rel = [0.0; NUM_JOINTS];
        rel[8] = -10.0;
        let cues = NetworkCues {
            world_mm: None,
            depth_px: Some(rel),
        };
        let fused = fuse_network_depth(&fit, &camera, &cues, [0.3, 0.5]).expect("fused");
        let mm = 400.0 / 500.0;
        let offset = 10.0 / 21.0 * mm;
        assert!((fused[8].z - (400.0 - 0.5 * (10.0 * mm - offset))).abs() < 1e-9);
        assert!((fused[0].z - (400.0 + 0.5 * offset)).abs() < 1e-9);
        // The absent world cue leaves its share with the fit.
        let world_only = fuse_network_depth(&fit, &camera, &cues, [0.3, 0.0]).expect("fused");
        assert_eq!(world_only, fit);
    }

    #[test]
    fn keypoint_fusion_moves_used_joints_towards_their_rays_at_their_depth() {
        let fit = hand();
        let camera = side_camera();
        // Keypoints 6 px right and 4 px down of where the joints project; joint 3 unused,
        // joint 4 below the confidence threshold.
        let mut kp = Keypoints2d::default();
        for (j, x) in fit.iter().enumerate() {
            let px = camera.project(x).expect("in front");
            kp.points[j] = [px.x + 6.0, px.y + 4.0, if j == 4 { 0.05 } else { 0.9 }];
        }
        kp.points[3][2] = 0.0;
        let depth = |p: &Vector3<f64>| camera.extrinsics.transform(p).z;
        let full = fuse_keypoints(&fit, &camera, &kp, 0.1, 1.0).expect("fused");
        let half = fuse_keypoints(&fit, &camera, &kp, 0.1, 0.5).expect("fused");
        for j in 0..NUM_JOINTS {
            if j == 3 || j == 4 {
                assert_eq!(full[j], fit[j]);
                continue;
            }
            // Weight 1: on the keypoint's ray, at the joint's depth.
            let px = camera.project(&full[j]).expect("in front");
            assert!((px.x - kp.points[j][0]).abs() < 1e-6 && (px.y - kp.points[j][1]).abs() < 1e-6);
            assert!((depth(&full[j]) - depth(&fit[j])).abs() < 1e-9);
            // Weight 0.5: halfway.
            assert!((half[j] - (fit[j] + full[j]) * 0.5).norm() < 1e-9);
        }
        assert_eq!(fuse_keypoints(&fit, &camera, &kp, 0.1, 0.0), Some(fit));
        assert!(fuse_keypoints(&fit, &camera, &kp, 0.1, 1.5).is_none());
    }

    #[test]
    fn degenerate_network_3d_gives_none() {
        let world = [[1.0, 2.0, 3.0]; NUM_JOINTS];
        assert!(fuse_network_depth(&hand(), &side_camera(), &cues(world), [0.5, 0.0]).is_none());
        // Weights outside [0, 1] or summing over 1.
        let fine = cues(hand().map(|p| [p.x, p.y, p.z]));
        for w in [[-0.1, 0.0], [0.0, 1.1], [0.6, 0.5]] {
            assert!(fuse_network_depth(&hand(), &side_camera(), &fine, w).is_none());
        }
    }
}
