//! # monohand-core
//!
//! The geometry core of monohand: a 26-DoF kinematic hand model, pinhole
//! cameras with OpenCV distortion, and a Levenberg-Marquardt fitter that
//! lifts 2D hand keypoints from one or more calibrated views to absolute 3D
//! joint positions in millimetres (Panteleris, Oikonomidis, Argyros, WACV 2018).
//!
//! This crate has no machine-learning or image dependencies: anyone with 2D
//! keypoints (OpenPose, MediaPipe, MMPose, ...) and a camera can use it alone.
//!
//! ```
//! use monohand_core::prelude::*;
//!
//! let camera = Camera::pinhole(800.0, 800.0, 320.0, 240.0, 640, 480).unwrap();
//! let skeleton = HandSkeleton::default_for(HandSide::Right);
//! // Make 2D keypoints by projecting a known pose, then lift them back.
//! let mut truth = HandPose::default();
//! truth.translation = nalgebra::Vector3::new(20.0, -10.0, 450.0);
//! truth.rotation = nalgebra::UnitQuaternion::from_euler_angles(3.0, 0.1, 0.2);
//! let joints = forward_kinematics(&skeleton, &truth);
//! let mut kp = Keypoints2d::default();
//! for (j, x) in joints.iter().enumerate() {
//!     let px = camera.project(x).unwrap();
//!     kp.points[j] = [px.x, px.y, 1.0];
//! }
//! let mut fitter = HandFitter::new(skeleton, FitOptions::default()).unwrap();
//! let fit = fitter.fit(&[View::new(&camera, &kp)]).unwrap();
//! assert!((fit.joints_3d[8] - joints[8]).norm() < 1.0);
//! ```

#![deny(missing_docs)]

pub mod alignment;
pub mod bbox;
pub mod camera;
pub mod error;
pub mod filtering;
pub mod fitting;
pub mod hand_model;
pub mod kinematics;
pub mod observation;
pub mod sync;
pub mod triangulation;
pub mod wrist;
pub mod xr;

pub use error::{CoreError, CoreResult};

/// The types most users need.
pub mod prelude {
    pub use crate::bbox::BBox;
    pub use crate::camera::{Camera, Distortion, Extrinsics, Intrinsics, LensModel};
    pub use crate::error::{CoreError, CoreResult};
    pub use crate::fitting::{
        CostSettings, FitOptions, FitResult, FusionSettings, HandFitter, HandTracker,
        SolverSettings, TrackingSettings, View,
    };
    pub use crate::hand_model::{
        Finger, HandPose, HandSide, HandSkeleton, JointLimits, NUM_JOINTS,
    };
    pub use crate::kinematics::forward_kinematics;
    pub use crate::observation::{HandObservation, Keypoints2d};
}
