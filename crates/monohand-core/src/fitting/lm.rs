//! The Levenberg-Marquardt solver over the 26 degrees of freedom of the hand.
//!
//! Normal equations are accumulated joint by joint from the sparse 2x10
//! Jacobian blocks (6 root columns + the 4 angles of the joint's finger) into
//! fixed-size 26x26 matrices on the stack, so an iteration allocates nothing.
//! Joint limits are box constraints handled by an active set: a degree of
//! freedom sitting on a bound whose step would leave the box is frozen for
//! that step, and the step is projected onto the box.

use super::fusion::{fuse_keypoints, fuse_network_depth};
use super::init::{self, StartSolver};
use super::options::{FitOptions, View};
use super::problem::{
    free_dofs, palm_of, DofMask, JointMask, Palm, PreparedView, NUM_BONES, NUM_CUES,
};
use crate::error::{CoreError, CoreResult};
use crate::hand_model::params::ANGLES_PER_FINGER;
use crate::hand_model::{HandPose, HandSkeleton, BONES, NUM_DOF, NUM_JOINTS};
use crate::kinematics::{
    finger_of, forward_kinematics, forward_kinematics_with_jacobian, LOCAL_DOF,
};
use crate::observation::{Keypoints2d, NetworkCues};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, SMatrix, SVector, UnitQuaternion, Vector2, Vector3};

pub(crate) type Mat26 = SMatrix<f64, NUM_DOF, NUM_DOF>;
pub(crate) type Vec26 = SVector<f64, NUM_DOF>;

/// The outcome of one fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitResult {
    /// The fitted pose (wrist translation in mm, rotation, angles).
    pub pose: HandPose,
    /// The 21 joints in the reference (first) camera frame, millimetres: the
    /// posed skeleton's, with one view moved towards the network's depth
    /// ([`FusionSettings::fuse_world`], [`FusionSettings::fuse_depth`]) and pixels
    /// ([`FusionSettings::fuse_pixels`]).
    ///
    /// [`FusionSettings::fuse_world`]: crate::fitting::FusionSettings::fuse_world
    /// [`FusionSettings::fuse_depth`]: crate::fitting::FusionSettings::fuse_depth
    /// [`FusionSettings::fuse_pixels`]: crate::fitting::FusionSettings::fuse_pixels
    pub joints_3d: [Vector3<f64>; NUM_JOINTS],
    /// The posed skeleton's joints (`pose` through forward kinematics), the
    /// same as `joints_3d` without fusion ([`crate::fitting::fuse_network_depth`],
    /// [`crate::fitting::fuse_keypoints`]).
    pub model_joints_3d: [Vector3<f64>; NUM_JOINTS],
    /// Mean distance in pixels between observed and reprojected joints, over
    /// the joints used in all views (distortion applied, unweighted).
    pub reprojection_error_px: f64,
    /// Levenberg-Marquardt iterations of the winning start.
    pub iterations: usize,
    /// True if a stopping tolerance was met before the iteration cap.
    pub converged: bool,
    /// Final value of the weighted cost.
    pub cost: f64,
    /// Number of (view, joint) observations used.
    pub used_observations: usize,
}

impl FitResult {
    /// The same fit in another frame: its joints and pose mapped by `by` (a rigid
    /// transform from the fit's reference frame into the other).
    pub fn transformed(&self, by: &crate::camera::Extrinsics) -> FitResult {
        let q = UnitQuaternion::from_rotation_matrix(&by.rotation);
        FitResult {
            pose: HandPose {
                translation: by.transform(&self.pose.translation),
                rotation: q * self.pose.rotation,
                ..self.pose
            },
            joints_3d: self.joints_3d.map(|x| by.transform(&x)),
            model_joints_3d: self.model_joints_3d.map(|x| by.transform(&x)),
            ..*self
        }
    }
}

/// A solver run's result before it is turned into a [`FitResult`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Solution {
    pub pose: HandPose,
    pub cost: f64,
    pub iterations: usize,
    pub converged: bool,
}

/// A step [`HandFitter::solve`] tried: the step asked for, the pose it led to (clamped to
/// the limits), the step actually taken and that pose's cost (`None`: not finite).
struct Tried {
    step: Vec26,
    candidate: HandPose,
    taken: Vec26,
    cost: Option<f64>,
}

/// What a warm-started fit's temporal term pulls towards.
// Passed by value once per fit; boxing the joints would allocate per fit.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
enum Towards {
    /// The joints of the starting pose, posed with the skeleton the fit uses.
    Start,
    /// Given joints (reference frame), e.g. a constant-velocity prediction.
    Joints([Vector3<f64>; NUM_JOINTS]),
    /// No temporal term.
    Nothing,
}

/// Fits a [`HandSkeleton`] to 2D keypoints. Reuse one fitter for many fits:
/// its buffers are kept between calls.
#[derive(Debug, Clone)]
pub struct HandFitter {
    /// The skeleton of the fit in progress: `given`, or `planar` for a fit without
    /// the network's 3D cues (see [`HandFitter::skeleton`]).
    posed: HandSkeleton,
    given: HandSkeleton,
    planar: HandSkeleton,
    options: FitOptions,
    pub(crate) views: Vec<PreparedView>,
    /// Bone lengths of the skeleton, in [`BONES`] order.
    bone_lengths: [f64; NUM_BONES],
    /// Joints the temporal term pulls towards (reference frame), in tracking.
    prior: Option<[Vector3<f64>; NUM_JOINTS]>,
    /// The weight of that pull in the fit in progress.
    prior_weight: f64,
    /// The network's 3D of a fit with one view, for [`FitOptions::fusion`].
    fusion_cues: Option<NetworkCues>,
    /// The skeleton's palm in its own frame, for the hand-frame cues.
    palm: Palm,
    /// The pull of the palm's distance from the first camera towards a target, in the
    /// fit in progress ([`HandFitter::fit_from_at_distance`]).
    distance: Option<DistancePull>,
}

/// A pull of the palm's centroid's depth in the first view's camera towards `target`
/// (mm): the residual `weight (d - target)`, `d = a . (t + R centroid) + b`.
#[derive(Debug, Clone, Copy)]
struct DistancePull {
    /// The camera's optical axis in the reference frame (`R_cᵀ e_z`).
    axis: Vector3<f64>,
    /// The camera's translation along its axis (`t_c.z`).
    offset: f64,
    /// The palm's centroid in the hand's frame.
    centroid: Vector3<f64>,
    target: f64,
    weight: f64,
}

impl DistancePull {
    /// The pull for `camera` and the palm of `skeleton`.
    fn new(
        camera: &crate::camera::Camera,
        skeleton: &HandSkeleton,
        target: f64,
        weight: f64,
    ) -> DistancePull {
        DistancePull {
            axis: camera.extrinsics.rotation.matrix().row(2).transpose(),
            offset: camera.extrinsics.translation.z,
            centroid: palm_centroid(skeleton),
            target,
            weight,
        }
    }

    /// The palm's depth of `pose`.
    #[inline]
    fn depth(&self, pose: &HandPose) -> f64 {
        self.axis
            .dot(&(pose.translation + pose.rotation * self.centroid))
            + self.offset
    }

    /// The weighted residual at `pose`.
    #[inline]
    fn residual(&self, pose: &HandPose) -> f64 {
        self.weight * (self.depth(pose) - self.target)
    }

    /// The residual's Jacobian over the root's 6 degrees of freedom (translation, then
    /// the rotation increment applied on the left: `d/dω a.(ω x v) = v x a`).
    #[inline]
    fn jacobian(&self, pose: &HandPose) -> SVector<f64, 6> {
        let v = pose.rotation * self.centroid;
        let dr = v.cross(&self.axis);
        SVector::<f64, 6>::from_column_slice(&[
            self.axis.x,
            self.axis.y,
            self.axis.z,
            dr.x,
            dr.y,
            dr.z,
        ]) * self.weight
    }
}

/// The centroid of the rigid palm (the wrist and the five fingers' bases) in the hand's
/// frame: the point whose depth is the hand's distance ([`HandFitter::palm_depth`]).
fn palm_centroid(skeleton: &HandSkeleton) -> Vector3<f64> {
    let rest = crate::kinematics::forward_kinematics_local(
        skeleton,
        &[0.0; crate::hand_model::NUM_ANGLES],
    );
    // The wrist and each finger's base (thumb CMC, MCPs), which no angle moves.
    let bases = crate::hand_model::Finger::ALL.map(|f| rest[f.joints()[0]]);
    (rest[0] + bases.iter().sum::<Vector3<f64>>()) / (1 + bases.len()) as f64
}

impl HandFitter {
    /// A fitter for one hand skeleton.
    pub fn new(skeleton: HandSkeleton, options: FitOptions) -> CoreResult<HandFitter> {
        skeleton.validate()?;
        options.validate()?;
        Ok(HandFitter {
            bone_lengths: skeleton.bone_lengths(),
            posed: skeleton,
            given: skeleton,
            planar: skeleton.planar_thumb(),
            options,
            views: Vec::with_capacity(2),
            prior: None,
            prior_weight: 0.0,
            fusion_cues: None,
            palm: palm_of(&skeleton),
            distance: None,
        })
    }

    /// The skeleton being fitted.
    ///
    /// A fit that sees only 2D keypoints (no view with the network's 3D cues at a
    /// weight above 0) poses its [`HandSkeleton::planar_thumb`] instead: with the
    /// pixels alone the rolled thumb hinge lets the hand trade the thumb's bending
    /// plane for a tilt in depth (docs/accuracy.md, "The thumb's hinge"). The two
    /// differ only in the thumb's hinge; bone lengths and limits are the same.
    pub fn skeleton(&self) -> &HandSkeleton {
        &self.given
    }

    /// The skeleton the last fit posed ([`HandFitter::skeleton`], or its planar thumb
    /// for a 2D-only fit): the one its [`FitResult::joints_3d`] come from.
    pub fn fitted_skeleton(&self) -> &HandSkeleton {
        &self.posed
    }

    /// Replaces the skeleton (e.g. after estimating the hand's size).
    pub fn set_skeleton(&mut self, skeleton: HandSkeleton) -> CoreResult<()> {
        skeleton.validate()?;
        self.bone_lengths = skeleton.bone_lengths();
        self.posed = skeleton;
        self.given = skeleton;
        self.planar = skeleton.planar_thumb();
        self.palm = palm_of(&skeleton);
        Ok(())
    }

    /// The options in use.
    pub fn options(&self) -> &FitOptions {
        &self.options
    }

    /// Fits from scratch: no previous pose needed.
    ///
    /// The rigid palm (wrist, thumb CMC, four MCPs) is placed first from a
    /// closed-form weak-perspective estimate (both mirror solutions are tried),
    /// then each start is refined over all 26 degrees of freedom and the
    /// lowest-cost result wins.
    pub fn fit(&mut self, views: &[View]) -> CoreResult<FitResult> {
        let used = self.prepare(views)?;
        let observed = self.observed_joints();
        let free = free_dofs(&observed);
        let starts = init::root_candidates(self, &observed);
        let mut best: Option<Solution> = None;
        let view_index = init::best_view(&self.views);
        for start in starts.iter().flatten() {
            let mut sol = self.solve(*start, &observed, &free, self.options.solver.max_iterations);
            // Second pass: re-seat the fingers on the root refined by all joints.
            if sol.cost > 1e-12 * used as f64 {
                let mut again = sol.pose;
                init::init_fingers(&self.posed, &mut again, &self.views[view_index]);
                let second =
                    self.solve(again, &observed, &free, self.options.solver.max_iterations);
                if second.cost < sol.cost {
                    sol = second;
                }
            }
            if best.is_none_or(|b| sol.cost < b.cost) {
                best = Some(sol);
            }
        }
        let sol = best.ok_or_else(|| {
            CoreError::InvalidKeypoints("no starting pose in front of the camera".into())
        })?;
        Ok(self.finish(sol, used))
    }

    /// The poses [`HandFitter::fit`] starts its full Levenberg-Marquardt runs
    /// from, in the order it tries them (at most 8): the closed-form
    /// weak-perspective palm estimates (both mirror solutions) refined on the
    /// palm joints, or the orientation sweep when fewer than three palm joints
    /// are seen, each with its fingers set from the keypoint rays.
    ///
    /// `fit` runs the solver from each of these (with
    /// [`SolverSettings::max_iterations`]), re-seats the fingers on each result and
    /// solves once more (the second pass), and keeps the lowest cost. The
    /// first part alone is [`HandFitter::fit_from`] on each start with
    /// `max_iterations_tracking` set to `max_iterations`; benchmarks use this
    /// to give another solver exactly the starts ours iterates from.
    ///
    /// Errors as [`HandFitter::fit`] for bad views or too few joints; the list
    /// is empty if no start could be placed in front of the cameras.
    ///
    /// [`SolverSettings::max_iterations`]: crate::fitting::SolverSettings::max_iterations
    pub fn starting_poses(&mut self, views: &[View]) -> CoreResult<Vec<HandPose>> {
        self.prepare(views)?;
        let observed = self.observed_joints();
        Ok(init::root_candidates(self, &observed)
            .into_iter()
            .flatten()
            .collect())
    }

    /// Fits starting from a previous pose (tracking). Angles of joints that are
    /// not observed in any view keep their previous values, so those joints keep
    /// their last position relative to the hand and move with its root (the
    /// paper's rule for vanishing joints). With
    /// [`TrackingSettings::temporal_weight`] above 0, every joint is also pulled
    /// towards its position in `start`.
    ///
    /// [`TrackingSettings::temporal_weight`]: crate::fitting::TrackingSettings::temporal_weight
    pub fn fit_from(&mut self, views: &[View], start: &HandPose) -> CoreResult<FitResult> {
        let w = self.options.tracking.temporal_weight;
        self.fit_from_with(views, start, Towards::Start, w, None)
    }

    /// Fits from `start` with every joint pulled towards `target` (reference frame, mm) at
    /// `weight` instead of [`TrackingSettings::temporal_weight`]: a smoother's refit of a
    /// frame towards where its neighbours, before and after, put the hand.
    ///
    /// [`TrackingSettings::temporal_weight`]: crate::fitting::TrackingSettings::temporal_weight
    pub fn refit_towards(
        &mut self,
        views: &[View],
        start: &HandPose,
        target: &[Vector3<f64>; NUM_JOINTS],
        weight: f64,
    ) -> CoreResult<FitResult> {
        if !(weight.is_finite() && weight >= 0.0) {
            return Err(CoreError::InvalidOptions(format!(
                "the pull's weight {weight} must be a finite number >= 0"
            )));
        }
        self.fit_from_with(views, start, Towards::Joints(*target), weight, None)
    }

    /// [`HandFitter::fit_from`] with the temporal term pulling towards `towards`
    /// (the joints predicted for this frame, reference frame), or without it
    /// (`None`).
    pub(crate) fn fit_from_towards(
        &mut self,
        views: &[View],
        start: &HandPose,
        towards: Option<[Vector3<f64>; NUM_JOINTS]>,
    ) -> CoreResult<FitResult> {
        self.fit_from_at_distance(views, start, towards, None)
    }

    /// [`Self::fit_from_towards`] with the palm's depth in the first view's camera
    /// ([`Self::palm_depth`]) pulled towards `distance = (target_mm, weight)`: the
    /// residual `weight (d - target_mm)`, beside the keypoints' milliradians.
    pub(crate) fn fit_from_at_distance(
        &mut self,
        views: &[View],
        start: &HandPose,
        towards: Option<[Vector3<f64>; NUM_JOINTS]>,
        distance: Option<(f64, f64)>,
    ) -> CoreResult<FitResult> {
        let towards = match towards {
            Some(joints) => Towards::Joints(joints),
            None => Towards::Nothing,
        };
        let w = self.options.tracking.temporal_weight;
        self.fit_from_with(views, start, towards, w, distance)
    }

    fn fit_from_with(
        &mut self,
        views: &[View],
        start: &HandPose,
        towards: Towards,
        weight: f64,
        distance: Option<(f64, f64)>,
    ) -> CoreResult<FitResult> {
        if !start.is_finite() {
            return Err(CoreError::InvalidOptions(
                "starting pose is not finite".into(),
            ));
        }
        let used = self.prepare(views)?;
        let observed = self.observed_joints();
        let free = free_dofs(&observed);
        let mut start = *start;
        self.posed.limits.clamp(&mut start.angles);
        if !self.in_front(&start) {
            return self.fit(views);
        }
        // The start's joints are computed only now: `prepare` chose the skeleton this
        // fit poses (planar thumb or not), and the pull must use the same one.
        let towards = match towards {
            Towards::Start => Some(forward_kinematics(&self.posed, &start)),
            Towards::Joints(joints) => Some(joints),
            Towards::Nothing => None,
        };
        self.prior_weight = weight;
        self.prior = towards.filter(|_| weight > 0.0);
        self.distance = distance
            .filter(|&(target, w)| target.is_finite() && w.is_finite() && w > 0.0)
            .map(|(target, w)| DistancePull::new(&self.views[0].camera, &self.posed, target, w));
        let sol = self.solve(
            start,
            &observed,
            &free,
            self.options.solver.max_iterations_tracking,
        );
        Ok(self.finish(sol, used))
    }

    /// Validates the views, weights the keypoints and maps them to the ideal pinhole image
    /// for the starts. Returns the number of usable observations.
    fn prepare(&mut self, views: &[View]) -> CoreResult<usize> {
        if views.is_empty() {
            return Err(CoreError::ViewMismatch("no views given".into()));
        }
        self.views.clear();
        // Only a tracking fit sets a temporal target or a distance, after preparing.
        self.prior = None;
        self.distance = None;
        self.fusion_cues = None;
        let o = &self.options;
        let mut used = 0;
        for (vi, v) in views.iter().enumerate() {
            let (pv, n) = PreparedView::prepare(v, vi, o, &self.palm)?;
            used += n;
            self.views.push(pv);
        }
        // Several views' network 3D are estimates of one shape: together they weigh as
        // much as one view's (the pixel terms, which add geometry, are summed as they are).
        let has_cues = self.views.iter().any(|v| {
            v.bone_weights
                .iter()
                .chain(&v.hand_weights)
                .flatten()
                .any(|&w| w > 0.0)
        });
        self.posed = if has_cues { self.given } else { self.planar };
        if let [v] = views {
            // Each cue is fused only if the fit itself uses it.
            self.fusion_cues = v.cues.map(|c| NetworkCues {
                world_mm: c.world_mm.filter(|_| o.cost.world_weight > 0.0),
                depth_px: c.depth_px.filter(|_| o.cost.depth_weight > 0.0),
            });
        }
        let with_cues = views.iter().filter(|v| v.cues.is_some()).count();
        if with_cues > 1 {
            let share = (1.0 / with_cues as f64).sqrt();
            for pv in &mut self.views {
                pv.bone_weights
                    .iter_mut()
                    .chain(&mut pv.hand_weights)
                    .flatten()
                    .for_each(|w| *w *= share);
            }
        }
        let joints = self.observed_joints().iter().filter(|&&b| b).count();
        if joints < o.cost.min_joints {
            return Err(CoreError::TooFewJoints {
                usable: joints,
                threshold: o.cost.min_confidence,
                needed: o.cost.min_joints,
            });
        }
        Ok(used)
    }

    fn observed_joints(&self) -> JointMask {
        std::array::from_fn(|j| self.views.iter().any(|v| v.weights[j] > 0.0))
    }

    /// The hand's distance from the first view's camera in the last fit's views: the depth
    /// of the palm's centroid (the wrist and the five fingers' bases, rigid), mm.
    /// `None` before any fit.
    pub fn palm_depth(&self, pose: &HandPose) -> Option<f64> {
        let camera = &self.views.first()?.camera;
        Some(DistancePull::new(camera, &self.posed, 0.0, 1.0).depth(pose))
    }

    /// How firmly the last fit's keypoints pin [`Self::palm_depth`] at `pose` (a fit of
    /// those views): its standard deviation in mm, from the Gauss-Newton matrix `H` of the
    /// fit's cost without its temporal and distance pulls, for keypoints whose noise is
    /// `sigma_px` per coordinate (at confidence weight 1), `sqrt(aᵀ (H / σ² + P⁻¹)⁻¹ a)`
    /// with `a` the depth's gradient. `P` is the spread the joint limits allow each angle
    /// (uniform: range² / 12), so that an angle no keypoint pins is not infinitely
    /// uncertain. The articulation enters through `H`: a family of hands along the rays,
    /// nearer and more flexed or farther and flatter, that the keypoints cannot tell
    /// apart, is a large deviation. `None` before a fit or if `H` is singular.
    pub fn palm_depth_sigma(&self, pose: &HandPose, sigma_px: f64) -> Option<f64> {
        let camera = self.views.first()?.camera;
        let sigma_mrad = sigma_px * 1000.0 / camera.intrinsics.fx.max(1e-9);
        if !(sigma_mrad.is_finite() && sigma_mrad > 0.0) {
            return None;
        }
        let mask = self.observed_joints();
        let free = free_dofs(&mask);
        let (mut h, mut g) = (Mat26::zeros(), Vec26::zeros());
        self.linearise_data(pose, &mask, &mut h, &mut g, false)?;
        let mut info = h / (sigma_mrad * sigma_mrad);
        let limits = &self.posed.limits;
        for i in 0..NUM_DOF {
            if !free[i] {
                for k in 0..NUM_DOF {
                    info[(i, k)] = 0.0;
                    info[(k, i)] = 0.0;
                }
                info[(i, i)] = 1.0;
            } else if i >= 6 {
                let range = (limits.upper[i - 6] - limits.lower[i - 6]).max(1e-3);
                info[(i, i)] += 12.0 / (range * range);
            }
        }
        let pull = DistancePull::new(&camera, &self.posed, 0.0, 1.0);
        let mut a = Vec26::zeros();
        a.fixed_rows_mut::<6>(0).copy_from(&pull.jacobian(pose));
        let var = a.dot(&info.cholesky()?.solve(&a));
        (var.is_finite() && var >= 0.0).then(|| var.sqrt())
    }

    pub(crate) fn in_front(&self, pose: &HandPose) -> bool {
        let pts = forward_kinematics(&self.posed, pose);
        self.views.iter().all(|v| {
            pts.iter()
                .all(|p| v.sees(&v.camera.extrinsics.transform(p)))
        })
    }

    fn finish(&self, sol: Solution, used: usize) -> FitResult {
        let joints_3d = forward_kinematics(&self.posed, &sol.pose);
        // The temporal and distance pulls are left out of the reported cost, so that a
        // warm-started and a from-scratch fit of one frame compare fairly.
        let cost = match (self.prior, self.distance) {
            (None, None) => sol.cost,
            _ => self
                .data_cost(&joints_3d, &sol.pose, &self.observed_joints())
                .unwrap_or(sol.cost),
        };
        let mut sum = 0.0;
        let mut n = 0usize;
        for v in &self.views {
            for (j, x) in joints_3d.iter().enumerate() {
                if v.weights[j] > 0.0 {
                    if let Some(px) = v.camera.project(x) {
                        sum += (Vector2::new(px.x - v.raw[j][0], px.y - v.raw[j][1])).norm();
                        n += 1;
                    }
                }
            }
        }
        let fused = self.fuse(&joints_3d);
        FitResult {
            pose: sol.pose,
            joints_3d: fused.unwrap_or(joints_3d),
            model_joints_3d: joints_3d,
            reprojection_error_px: if n > 0 { sum / n as f64 } else { f64::NAN },
            iterations: sol.iterations,
            converged: sol.converged,
            cost,
            used_observations: used,
        }
    }

    /// With one view, the output joints: `joints` with the network's depth fused in
    /// ([`fuse_network_depth`], if the view has cues the fit uses), then moved towards
    /// their keypoints' rays ([`fuse_keypoints`]). `None` with several views, or if a
    /// step is undefined (the fitted joints are kept then).
    fn fuse(&self, joints: &[Vector3<f64>; NUM_JOINTS]) -> Option<[Vector3<f64>; NUM_JOINTS]> {
        let [v] = self.views.as_slice() else {
            return None;
        };
        let o = &self.options;
        let deep = match self.fusion_cues {
            Some(cues) => fuse_network_depth(
                joints,
                &v.camera,
                &cues,
                [o.fusion.fuse_world, o.fusion.fuse_depth],
            )?,
            None => *joints,
        };
        // The keypoints the fit used (weight above 0), as given (distorted).
        let used = Keypoints2d {
            points: std::array::from_fn(|j| {
                let [u, w] = v.raw[j];
                [u, w, if v.weights[j] > 0.0 { 1.0 } else { 0.0 }]
            }),
        };
        fuse_keypoints(&deep, &v.camera, &used, 1.0, o.fusion.fuse_pixels)
    }

    /// Cost of a pose over the masked joints; `None` if a joint is behind a camera.
    pub(crate) fn cost(&self, pose: &HandPose, mask: &JointMask) -> Option<f64> {
        let pts = forward_kinematics(&self.posed, pose);
        let temporal: f64 = (0..NUM_JOINTS)
            .filter_map(|j| self.temporal_residual(j, &pts, mask))
            .map(|r| r.norm_squared())
            .sum();
        let distance = self.distance.map_or(0.0, |d| d.residual(pose).powi(2));
        Some(self.data_cost(&pts, pose, mask)? + temporal + distance)
    }

    /// The pixel and cue terms of the cost for given joints; `None` if a joint
    /// is where a camera does not see it. The pixels are the observed ones, the joints
    /// projected through each camera's lens.
    fn data_cost(
        &self,
        pts: &[Vector3<f64>; NUM_JOINTS],
        pose: &HandPose,
        mask: &JointMask,
    ) -> Option<f64> {
        let to_hand = pose.rotation.inverse().to_rotation_matrix().into_inner();
        let mut cost = 0.0;
        for v in &self.views {
            let ext = &v.camera.extrinsics;
            let k = &v.camera.intrinsics;
            let ideal = v.camera.distortion.is_ideal();
            for j in 0..NUM_JOINTS {
                let w = v.weights[j];
                if w <= 0.0 || !mask[j] {
                    continue;
                }
                let x = ext.transform(&pts[j]);
                let [pu, pv] = v.raw[j];
                let (du, dv) = if ideal {
                    if x.z <= 1.0 {
                        return None;
                    }
                    (
                        (k.fx * x.x / x.z + k.cx - pu) * v.mrad_per_px[0],
                        (k.fy * x.y / x.z + k.cy - pv) * v.mrad_per_px[1],
                    )
                } else {
                    let px = v.lens_pixel(&x)?;
                    (
                        (px.x - pu) * v.mrad_per_px[0],
                        (px.y - pv) * v.mrad_per_px[1],
                    )
                };
                cost += w * w * (du * du + dv * dv);
            }
            for cue in 0..NUM_CUES {
                for b in 0..NUM_BONES {
                    if let Some(res) = self.bone_residual(v, cue, b, pts, mask) {
                        cost += res.norm_squared();
                    }
                    if let Some(res) = self.hand_residual(v, cue, b, pts, &to_hand, mask) {
                        cost += res.norm_squared();
                    }
                }
            }
        }
        Some(cost)
    }

    /// Cost, gradient `J^T r` and Gauss-Newton matrix `J^T J` at a pose.
    fn linearise(
        &self,
        pose: &HandPose,
        mask: &JointMask,
        h: &mut Mat26,
        g: &mut Vec26,
    ) -> Option<f64> {
        let mut cost = self.linearise_data(pose, mask, h, g, true)?;
        if let Some(d) = &self.distance {
            let r = d.residual(pose);
            let jac = d.jacobian(pose);
            cost += r * r;
            h.fixed_view_mut::<6, 6>(0, 0).ger(1.0, &jac, &jac, 1.0);
            g.fixed_rows_mut::<6>(0).axpy(r, &jac, 1.0);
        }
        Some(cost)
    }

    /// [`Self::linearise`] of the pixel and cue terms, with the temporal pull if
    /// `temporal` (the distance pull is [`Self::linearise`]'s).
    fn linearise_data(
        &self,
        pose: &HandPose,
        mask: &JointMask,
        h: &mut Mat26,
        g: &mut Vec26,
        temporal: bool,
    ) -> Option<f64> {
        let mut pts = [Vector3::zeros(); NUM_JOINTS];
        let mut jac = [SMatrix::<f64, 3, LOCAL_DOF>::zeros(); NUM_JOINTS];
        forward_kinematics_with_jacobian(&self.posed, pose, &mut pts, &mut jac);
        h.fill(0.0);
        g.fill(0.0);
        let to_hand = pose.rotation.inverse().to_rotation_matrix().into_inner();
        let mut blocks = Blocks::new();
        let mut forms = [JointForm::default(); NUM_JOINTS];
        let mut cost = 0.0;
        for v in &self.views {
            let r = v.camera.extrinsics.rotation.matrix();
            let ideal = v.camera.distortion.is_ideal();
            for j in 0..NUM_JOINTS {
                let w = v.weights[j];
                if w <= 0.0 || !mask[j] {
                    continue;
                }
                let x = v.camera.extrinsics.transform(&pts[j]);
                // Through the lens: the ideal pinhole's own, or the lens model's.
                let (uv, pj): (Vector2<f64>, Matrix2x3<f64>) = if ideal {
                    if x.z <= 1.0 {
                        return None;
                    }
                    v.camera.pinhole_project_with_jacobian(&x)
                } else {
                    v.lens_pixel_with_jacobian(&x)?
                };
                // Milliradians: `S = diag(1000 / fx, 1000 / fy)`.
                let s = Matrix2::from_diagonal(&Vector2::from(v.mrad_per_px));
                let res = s * (uv - Vector2::new(v.raw[j][0], v.raw[j][1])) * w;
                cost += res.norm_squared();
                // The block is `M jac_j` with `M = w S P R` (2x3): it adds `MᵀM` and
                // `Mᵀ res` to joint j's 3x3 form, applied to `jac_j` once below.
                let m: Matrix2x3<f64> = s * pj * r * w;
                forms[j].add(&m.tr_mul(&m), &m.tr_mul(&res));
            }
            // Bone directions from the network's cues: the child's 10 local
            // degrees of freedom cover its parent's (same finger, or the wrist).
            // Each cue's block is `w_k D` with one `D` per bone, so the cues of a
            // bone add up to `(Σ w_k²) DᵀD` and `Dᵀ Σ w_k r_k`: one product per bone.
            // The hand-frame cues likewise with `D = Rᵀ (jac_c - jac_p)` over the finger's
            // angles alone: the bone in the hand's frame does not move with the root.
            for (b, &(p, c)) in BONES.iter().enumerate() {
                let (mut w2, mut wr) = (0.0, Vector3::zeros());
                let (mut h2, mut hr) = (0.0, Vector3::zeros());
                for cue in 0..NUM_CUES {
                    if let Some(res) = self.bone_residual(v, cue, b, &pts, mask) {
                        cost += res.norm_squared();
                        let w = v.bone_weights[cue][b];
                        w2 += w * w;
                        wr += w * res;
                    }
                    if let Some(res) = self.hand_residual(v, cue, b, &pts, &to_hand, mask) {
                        cost += res.norm_squared();
                        let w = v.hand_weights[cue][b];
                        h2 += w * w;
                        hr += w * res;
                    }
                }
                if w2 > 0.0 {
                    let d: SMatrix<f64, 3, LOCAL_DOF> = r * (jac[c] - jac[p]);
                    blocks.add_scaled(&d, w2, &wr, c);
                }
                if h2 > 0.0 {
                    let mut d: SMatrix<f64, 3, LOCAL_DOF> = to_hand * (jac[c] - jac[p]);
                    d.fixed_columns_mut::<6>(0).fill(0.0);
                    blocks.add_scaled(&d, h2, &hr, c);
                }
            }
        }
        let wt = self.prior_weight;
        if temporal {
            for (j, form) in forms.iter_mut().enumerate() {
                if let Some(res) = self.temporal_residual(j, &pts, mask) {
                    cost += res.norm_squared();
                    form.add(&(Matrix3::identity() * (wt * wt)), &(res * wt));
                }
            }
        }
        for (j, (form, jac_j)) in forms.iter().zip(&jac).enumerate() {
            if form.used {
                blocks.add_form(jac_j, form, j);
            }
        }
        blocks.scatter(h, g);
        Some(cost)
    }

    /// The weighted residual of bone `b` against cue `cue` in view `v` (mm), `None`
    /// where the cue is absent or a joint of the bone is masked out.
    #[inline]
    fn bone_residual(
        &self,
        v: &PreparedView,
        cue: usize,
        b: usize,
        pts: &[Vector3<f64>; NUM_JOINTS],
        mask: &JointMask,
    ) -> Option<Vector3<f64>> {
        let w = v.bone_weights[cue][b];
        let (p, c) = BONES[b];
        (w > 0.0 && mask[p] && mask[c]).then(|| {
            let bone = v.camera.extrinsics.rotation * (pts[c] - pts[p]);
            w * (bone - self.bone_lengths[b] * v.bone_targets[cue][b])
        })
    }

    /// The weighted residual of finger bone `b` against cue `cue` in the hand's own frame
    /// (`to_hand`: the fitted rotation's inverse), mm; `None` where the cue is absent or
    /// a joint of the bone is masked out.
    #[inline]
    fn hand_residual(
        &self,
        v: &PreparedView,
        cue: usize,
        b: usize,
        pts: &[Vector3<f64>; NUM_JOINTS],
        to_hand: &Matrix3<f64>,
        mask: &JointMask,
    ) -> Option<Vector3<f64>> {
        let w = v.hand_weights[cue][b];
        let (p, c) = BONES[b];
        (w > 0.0 && mask[p] && mask[c]).then(|| {
            w * (to_hand * (pts[c] - pts[p]) - self.bone_lengths[b] * v.hand_targets[cue][b])
        })
    }

    /// The weighted pull of joint `j` towards its temporal target (mm), `None`
    /// outside tracking or for a masked-out joint.
    #[inline]
    fn temporal_residual(
        &self,
        j: usize,
        pts: &[Vector3<f64>; NUM_JOINTS],
        mask: &JointMask,
    ) -> Option<Vector3<f64>> {
        let prior = self.prior.as_ref().filter(|_| mask[j])?;
        Some(self.prior_weight * (pts[j] - prior[j]))
    }

    /// A failed step of [`Self::solve`] from `pose` (whose cost is `cost` and gradient
    /// `g`), shortened once when it was not already tiny: the step to the minimiser of
    /// the quadratic through the cost at 0 and 1 and the slope at 0 (clamped to 0.1-0.5 of
    /// it; a quarter when that is unknown), kept if it lowers the cost. A step that
    /// lowered the cost, or whose shortening does not, is returned as tried.
    fn shorten_failed_step(
        &self,
        pose: &HandPose,
        tried: Tried,
        cost: f64,
        g: &Vec26,
        mask: &JointMask,
    ) -> (HandPose, Vec26, Option<f64>) {
        let limits = &self.posed.limits;
        let Tried {
            step,
            candidate,
            taken,
            cost: new_cost,
        } = tried;
        match new_cost {
            Some(nc) if nc < cost => (candidate, taken, new_cost),
            _ if taken.amax() > self.options.solver.step_tolerance => {
                let slope = 2.0 * g.dot(&taken);
                let alpha = match new_cost {
                    Some(nc) if slope < 0.0 => {
                        (-slope / (2.0 * (nc - cost - slope))).clamp(0.1, 0.5)
                    }
                    _ => 0.25,
                };
                let short_step = step * alpha;
                let short = apply_step(pose, &short_step, limits);
                match self.cost(&short, mask) {
                    Some(c) if c < cost => {
                        (short, step_between(pose, &short, &short_step), Some(c))
                    }
                    _ => (candidate, taken, new_cost),
                }
            }
            _ => (candidate, taken, new_cost),
        }
    }

    /// Levenberg-Marquardt from `start` over the free degrees of freedom.
    pub(crate) fn solve(
        &self,
        start: HandPose,
        mask: &JointMask,
        free: &DofMask,
        max_iter: usize,
    ) -> Solution {
        let limits = &self.posed.limits;
        let mut pose = start;
        limits.clamp(&mut pose.angles);
        let mut h = Mat26::zeros();
        let mut g = Vec26::zeros();
        let Some(mut cost) = self.linearise(&pose, mask, &mut h, &mut g) else {
            return Solution {
                pose,
                cost: f64::INFINITY,
                iterations: 0,
                converged: false,
            };
        };
        let mut lambda = self.options.solver.initial_damping;
        let mut nu = 2.0;
        let mut converged = false;
        let mut iterations = 0;
        while iterations < max_iter {
            iterations += 1;
            if cost < 1e-18 {
                converged = true;
                break;
            }
            let Some(step) = damped_step(&h, &g, lambda, free, &pose, limits) else {
                lambda *= nu;
                nu *= 2.0;
                continue;
            };
            let candidate = apply_step(&pose, &step, limits);
            // Actual step after projection onto the box.
            let taken = step_between(&pose, &candidate, &step);
            let predicted = -(2.0 * g.dot(&taken) + taken.dot(&(h * taken)));
            let new_cost = self.cost(&candidate, mask);
            // A failed step is first shortened once (to the minimiser of the
            // quadratic through the cost at 0 and 1 and the slope at 0) before
            // the damping is raised: in the curved valleys of the monocular
            // cost the Gauss-Newton direction is often good but too long.
            let (candidate, taken, new_cost) = self.shorten_failed_step(
                &pose,
                Tried {
                    step,
                    candidate,
                    taken,
                    cost: new_cost,
                },
                cost,
                &g,
                mask,
            );
            match new_cost {
                Some(nc) if nc < cost => {
                    let rho = if predicted > 0.0 {
                        (cost - nc) / predicted
                    } else {
                        1.0
                    };
                    let small_decrease = cost - nc <= self.options.solver.cost_tolerance * cost;
                    let small_step = taken.amax() <= self.options.solver.step_tolerance;
                    pose = candidate;
                    lambda *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                    lambda = lambda.max(1e-15);
                    nu = 2.0;
                    match self.linearise(&pose, mask, &mut h, &mut g) {
                        Some(c) => cost = c,
                        None => break,
                    }
                    if small_decrease || small_step {
                        converged = true;
                        break;
                    }
                }
                _ => {
                    if taken.amax() <= self.options.solver.step_tolerance {
                        converged = true;
                        break;
                    }
                    lambda *= nu;
                    nu *= 2.0;
                    if lambda > 1e16 {
                        converged = true;
                        break;
                    }
                }
            }
        }
        Solution {
            pose,
            cost,
            iterations,
            converged,
        }
    }
}

impl StartSolver for HandFitter {
    fn fitted_skeleton(&self) -> &HandSkeleton {
        &self.posed
    }

    fn views(&self) -> &[PreparedView] {
        &self.views
    }

    fn in_front(&self, pose: &HandPose) -> bool {
        HandFitter::in_front(self, pose)
    }

    fn solve_pose(
        &self,
        start: HandPose,
        mask: &JointMask,
        free: &DofMask,
        max_iter: usize,
    ) -> HandPose {
        self.solve(start, mask, free, max_iter).pose
    }
}

/// The residual blocks of one joint that are linear maps of its own Jacobian
/// (`A_k jac_j`: its pixels in every view, its temporal pull), summed as
/// `S = Σ A_kᵀ A_k` and `q = Σ A_kᵀ r_k`, so that `jac_j` enters `J^T J` once.
#[derive(Clone, Copy, Default)]
struct JointForm {
    s: Matrix3<f64>,
    q: Vector3<f64>,
    used: bool,
}

impl JointForm {
    #[inline]
    fn add(&mut self, s: &Matrix3<f64>, q: &Vector3<f64>) {
        self.s += s;
        self.q += q;
        self.used = true;
    }
}

/// `J^T J` and `J^T r` gathered per group of joints that share their local
/// degrees of freedom (the wrist, then each finger: the root's 6 and the
/// finger's 4), in the 10 local columns, and added into the full 26x26 system
/// once per group by [`Blocks::scatter`]. Gathering per group first saves
/// scattering every residual block on its own.
struct Blocks {
    h: [SMatrix<f64, LOCAL_DOF, LOCAL_DOF>; 6],
    g: [SVector<f64, LOCAL_DOF>; 6],
}

impl Blocks {
    fn new() -> Blocks {
        Blocks {
            h: [SMatrix::zeros(); 6],
            g: [SVector::zeros(); 6],
        }
    }

    /// The group of `joint`: 0 the wrist, 1-5 its finger.
    #[inline]
    fn group(joint: usize) -> usize {
        finger_of(joint).map_or(0, |f| f.index() + 1)
    }

    /// Adds `jacᵀ S jac` and `jacᵀ q` of joint `joint`'s [`JointForm`].
    #[inline]
    fn add_form(&mut self, jac: &SMatrix<f64, 3, LOCAL_DOF>, form: &JointForm, joint: usize) {
        let group = Blocks::group(joint);
        self.h[group] += jac.tr_mul(&(form.s * jac));
        self.g[group] += jac.tr_mul(&form.q);
    }

    /// Adds `w2 DᵀD` and `Dᵀ wr`: residual blocks `w_k D` with residuals `r_k`,
    /// `w2 = Σ w_k²`, `wr = Σ w_k r_k`.
    #[inline]
    fn add_scaled<const R: usize>(
        &mut self,
        d: &SMatrix<f64, R, LOCAL_DOF>,
        w2: f64,
        wr: &SVector<f64, R>,
        joint: usize,
    ) {
        let group = Blocks::group(joint);
        self.h[group] += d.tr_mul(d) * w2;
        self.g[group] += d.tr_mul(wr);
    }

    /// Adds every group into `h` and `g` (the wrist's group over the root's 6
    /// degrees of freedom only: its last 4 columns are zero).
    fn scatter(&self, h: &mut Mat26, g: &mut Vec26) {
        for (group, (hl, gl)) in self.h.iter().zip(&self.g).enumerate() {
            let joint = if group == 0 { 0 } else { 4 * group };
            let idx = dof_index_map(joint);
            let n = if group == 0 { 6 } else { LOCAL_DOF };
            for a in 0..n {
                g[idx[a]] += gl[a];
                for b in 0..n {
                    h[(idx[a], idx[b])] += hl[(a, b)];
                }
            }
        }
    }
}

/// Degrees of freedom that a joint's 10 Jacobian columns map to.
#[inline]
fn dof_index_map(joint: usize) -> [usize; LOCAL_DOF] {
    let base = match finger_of(joint) {
        Some(f) => 6 + f.index() * ANGLES_PER_FINGER,
        None => 6,
    };
    [0, 1, 2, 3, 4, 5, base, base + 1, base + 2, base + 3]
}

/// Solves `(H + lambda D) step = -g` over the free, non-blocked degrees of freedom.
fn damped_step(
    h: &Mat26,
    g: &Vec26,
    lambda: f64,
    free: &DofMask,
    pose: &HandPose,
    limits: &crate::hand_model::JointLimits,
) -> Option<Vec26> {
    let mut active = *free;
    let max_diag = (0..NUM_DOF)
        .map(|i| h[(i, i)])
        .fold(0.0f64, f64::max)
        .max(1e-12);
    for _pass in 0..4 {
        let mut a = *h;
        let mut rhs = -*g;
        for i in 0..NUM_DOF {
            if active[i] {
                let d = h[(i, i)].max(1e-9 * max_diag);
                a[(i, i)] += lambda * d;
            } else {
                for k in 0..NUM_DOF {
                    a[(i, k)] = 0.0;
                    a[(k, i)] = 0.0;
                }
                a[(i, i)] = 1.0;
                rhs[i] = 0.0;
            }
        }
        let step = a.cholesky()?.solve(&rhs);
        if step.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mut changed = false;
        for k in 0..crate::hand_model::NUM_ANGLES {
            let i = 6 + k;
            if !active[i] {
                continue;
            }
            let a = pose.angles[k];
            let at_lo = a <= limits.lower[k] + 1e-12 && step[i] < 0.0;
            let at_hi = a >= limits.upper[k] - 1e-12 && step[i] > 0.0;
            if at_lo || at_hi {
                active[i] = false;
                changed = true;
            }
        }
        if !changed {
            return Some(step);
        }
    }
    None
}

/// Applies a 26-vector step to a pose (rotation on the manifold, angles clamped).
pub(crate) fn apply_step(
    pose: &HandPose,
    step: &Vec26,
    limits: &crate::hand_model::JointLimits,
) -> HandPose {
    let mut out = *pose;
    out.translation += Vector3::new(step[0], step[1], step[2]);
    let dq = UnitQuaternion::from_scaled_axis(Vector3::new(step[3], step[4], step[5]));
    out.rotation = UnitQuaternion::new_normalize((dq * pose.rotation).into_inner());
    for k in 0..crate::hand_model::NUM_ANGLES {
        out.angles[k] = (pose.angles[k] + step[6 + k]).clamp(limits.lower[k], limits.upper[k]);
    }
    out
}

/// The step actually taken (angles after clamping; root as requested).
fn step_between(from: &HandPose, to: &HandPose, requested: &Vec26) -> Vec26 {
    let mut s = *requested;
    for k in 0..crate::hand_model::NUM_ANGLES {
        s[6 + k] = to.angles[k] - from.angles[k];
    }
    s
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::field_reassign_with_default)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::fitting::{CostSettings, TrackingSettings};
    use crate::hand_model::HandSide;
    use nalgebra::Rotation3;

    /// A pose, a second camera, keypoints near (not at) the pose's projection, network
    /// cues that disagree with the pose, and a temporal prior elsewhere: every term of the
    /// cost is non-zero.
    fn problem() -> (HandFitter, HandPose, [bool; NUM_JOINTS]) {
        let left = Camera::pinhole(800.0, 790.0, 320.0, 240.0, 640, 480).unwrap();
        problem_seen_by(left, Vector3::new(25.0, -15.0, 420.0))
    }

    /// [`problem`] with the hand's wrist at `at`, seen by `left` and by a second camera of
    /// the same lens 100 mm to its right, turned 11 degrees.
    fn problem_seen_by(
        left: Camera,
        at: Vector3<f64>,
    ) -> (HandFitter, HandPose, [bool; NUM_JOINTS]) {
        let sk = HandSkeleton::default_for(HandSide::Left);
        let mut pose = HandPose::default();
        pose.translation = at;
        pose.rotation = UnitQuaternion::from_euler_angles(0.5, -0.4, 2.2);
        for (i, a) in pose.angles.iter_mut().enumerate() {
            *a = 0.02 * i as f64;
        }
        let right = left.with_extrinsics(crate::camera::Extrinsics {
            rotation: Rotation3::from_euler_angles(0.02, -0.2, 0.01),
            translation: Vector3::new(-100.0, 2.0, 10.0),
        });
        let joints = forward_kinematics(&sk, &pose);
        let mut other = pose;
        other.angles.iter_mut().for_each(|a| *a += 0.15);
        other.rotation = UnitQuaternion::from_euler_angles(0.6, -0.3, 2.1);
        let cue_joints = forward_kinematics(&sk, &other);
        let mut kps = [crate::observation::Keypoints2d::default(); 2];
        for (cam, kp) in [left, right].iter().zip(kps.iter_mut()) {
            for (j, x) in joints.iter().enumerate() {
                let p = cam.project(x).unwrap();
                kp.points[j] = [
                    p.x + (j as f64).sin() * 3.0,
                    p.y - 2.0,
                    0.5 + 0.02 * j as f64,
                ];
            }
        }
        let cues = NetworkCues {
            world_mm: Some(cue_joints.map(|x| [x.x, x.y, x.z])),
            depth_px: Some(std::array::from_fn(|j| cue_joints[j].z - cue_joints[0].z)),
        };
        let options = FitOptions {
            cost: CostSettings {
                world_weight: 0.7,
                depth_weight: 0.4,
                hand_frame_weight: 0.5,
                ..CostSettings::default()
            },
            tracking: TrackingSettings {
                temporal_weight: 0.3,
                ..TrackingSettings::default()
            },
            ..FitOptions::default()
        };
        let mut fitter = HandFitter::new(sk, options).unwrap();
        let views = [
            View::new(&left, &kps[0]).with_cues(Some(&cues)),
            View::new(&right, &kps[1]).with_cues(Some(&cues)),
        ];
        fitter.prepare(&views).unwrap();
        let mut prior = joints;
        prior
            .iter_mut()
            .for_each(|x| *x += Vector3::new(3.0, -2.0, 5.0));
        fitter.prior = Some(prior);
        fitter.prior_weight = fitter.options.tracking.temporal_weight;
        fitter.distance = Some(DistancePull::new(
            &fitter.views[0].camera,
            &fitter.posed,
            at.z - 30.0,
            0.8,
        ));
        let mask = [true; NUM_JOINTS];
        (fitter, pose, mask)
    }

    #[test]
    fn gradient_and_gauss_newton_matrix_match_the_cost() {
        check_gradient(problem());
    }

    /// The fit in the real image: through a lens with distortion, and through a fisheye
    /// with the hand 60 degrees off its axis.
    #[test]
    fn gradient_and_gauss_newton_matrix_match_the_cost_through_every_lens() {
        let mut radtan = Camera::pinhole(800.0, 790.0, 320.0, 240.0, 640, 480).unwrap();
        radtan.distortion =
            crate::camera::Distortion::from_slice(&[-0.28, 0.07, 1e-3, -5e-4, 0.02]).unwrap();
        check_gradient(problem_seen_by(radtan, Vector3::new(25.0, -15.0, 420.0)));
        let fisheye = Camera::fisheye(
            420.0,
            420.0,
            639.5,
            359.5,
            1280,
            720,
            [0.02, -0.005, 1e-3, -2e-4],
        )
        .unwrap();
        check_gradient(problem_seen_by(fisheye, Vector3::new(300.0, -60.0, 170.0)));
    }

    fn check_gradient((fitter, pose, mask): (HandFitter, HandPose, [bool; NUM_JOINTS])) {
        let (mut h, mut g) = (Mat26::zeros(), Vec26::zeros());
        let cost = fitter.linearise(&pose, &mask, &mut h, &mut g).unwrap();
        assert!((cost - fitter.cost(&pose, &mask).unwrap()).abs() < 1e-9 * cost);
        let limits = crate::hand_model::JointLimits {
            lower: [-10.0; crate::hand_model::NUM_ANGLES],
            upper: [10.0; crate::hand_model::NUM_ANGLES],
        };
        // d cost / d step = 2 J^T r, by central differences on the manifold.
        let eps = 1e-6;
        for i in 0..NUM_DOF {
            let mut step = Vec26::zeros();
            step[i] = eps;
            let up = fitter
                .cost(&apply_step(&pose, &step, &limits), &mask)
                .unwrap();
            let down = fitter
                .cost(&apply_step(&pose, &(-step), &limits), &mask)
                .unwrap();
            let numeric = (up - down) / (2.0 * eps);
            assert!(
                (numeric - 2.0 * g[i]).abs() < 1e-4 * (1.0 + numeric.abs()),
                "dof {i}: numeric {numeric}, analytic {}",
                2.0 * g[i]
            );
        }
        // J^T J is symmetric positive semi-definite, and a Gauss-Newton step lowers the cost.
        assert!((h - h.transpose()).amax() < 1e-9 * h.amax());
        let step = -(h + Mat26::identity() * 1e-6 * h.amax())
            .cholesky()
            .unwrap()
            .solve(&g);
        let after = fitter
            .cost(&apply_step(&pose, &(step * 0.5), &limits), &mask)
            .unwrap();
        assert!(after < cost, "{after} >= {cost}");
    }

    #[test]
    fn a_warm_start_pulls_towards_the_start_posed_with_the_skeleton_it_fits() {
        // The last fit had 3D cues (rolled thumb); the next has pixels only, so it poses
        // the planar thumb. Keypoints exactly at the start's planar projection: the fit
        // must stay there. A pull towards the rolled thumb's joints would drag the thumb.
        let sk = HandSkeleton::default_for(HandSide::Left);
        let cam = Camera::pinhole(800.0, 800.0, 320.0, 240.0, 640, 480).unwrap();
        let mut pose = HandPose::default();
        pose.translation = Vector3::new(10.0, -5.0, 450.0);
        pose.rotation = UnitQuaternion::from_euler_angles(0.3, -0.2, 2.0);
        for (i, a) in pose.angles.iter_mut().enumerate() {
            *a = 0.03 * (i % 4) as f64;
        }
        let project = |skeleton: &HandSkeleton| {
            let mut kp = crate::observation::Keypoints2d::default();
            for (j, x) in forward_kinematics(skeleton, &pose).iter().enumerate() {
                let p = cam.project(x).unwrap();
                kp.points[j] = [p.x, p.y, 1.0];
            }
            kp
        };
        let options = FitOptions {
            tracking: TrackingSettings {
                temporal_weight: 1.0,
                ..TrackingSettings::default()
            },
            ..FitOptions::default()
        };
        let mut fitter = HandFitter::new(sk, options).unwrap();
        let rolled = forward_kinematics(&sk, &pose);
        let cues = NetworkCues {
            world_mm: Some(rolled.map(|x| [x.x, x.y, x.z])),
            depth_px: None,
        };
        let with_cues = project(&sk);
        fitter
            .fit_from(&[View::new(&cam, &with_cues).with_cues(Some(&cues))], &pose)
            .unwrap();
        let planar = sk.planar_thumb();
        let pixels = project(&planar);
        let fit = fitter.fit_from(&[View::new(&cam, &pixels)], &pose).unwrap();
        let expected = forward_kinematics(&planar, &pose);
        let worst = (0..NUM_JOINTS)
            .map(|j| (fit.joints_3d[j] - expected[j]).norm())
            .fold(0.0, f64::max);
        let thumb_moved = (1..5)
            .map(|j| (rolled[j] - expected[j]).norm())
            .fold(0.0, f64::max);
        assert!(thumb_moved > 3.0, "the two thumbs differ: {thumb_moved} mm");
        assert!(worst < 1e-3, "the fit left its exact start by {worst} mm");
    }
}
