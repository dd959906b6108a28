//! Temporal smoothing of joint trajectories (pure math, no I/O).
//!
//! - [`one_euro`]: the One Euro filter (Casiez, Roussel, Vogel, CHI 2012), an
//!   adaptive low-pass filter that smooths a still hand strongly and a moving
//!   hand lightly, so jitter is removed without much lag.

pub mod one_euro;

pub use one_euro::{JointFilter, OneEuroFilter, OneEuroParams};
