//! The hand model: keypoint order, pose parameters, limits and skeleton.

pub mod calibrate;
pub mod joints;
pub mod limits;
pub mod params;
pub mod skeleton;

pub use calibrate::{fit_skeleton, palm_frame, SkeletonFit};
pub use joints::{Finger, HandSide, BONES, JOINT_NAMES, NUM_FINGERS, NUM_JOINTS, PARENT, WRIST};
pub use limits::JointLimits;
pub use params::{
    angle_index, angle_names, FingerAngle, HandPose, NUM_ANGLES, NUM_DOF, NUM_PARAMS,
};
pub use skeleton::{FingerGeometry, HandSkeleton, THUMB_HINGE_ROLL_DEG};
