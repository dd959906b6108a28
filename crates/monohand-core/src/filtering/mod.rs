//! Temporal smoothing of joint trajectories (pure math, no I/O).
//!
//! - [`one_euro`]: the One Euro filter (Casiez, Roussel, Vogel, CHI 2012), an
//!   adaptive low-pass filter that smooths a still hand strongly and a moving
//!   hand lightly, so jitter is removed without much lag.
//! - [`depth`]: a hand's distance from one camera through a One Euro filter, the hand
//!   scaled about the camera's centre (its pixels unchanged).

pub mod depth;
pub mod one_euro;

pub use depth::{mean_depth, scale_to_depth, DepthFilter};
pub use one_euro::{JointFilter, OneEuroFilter, OneEuroParams};
