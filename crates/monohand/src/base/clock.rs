//! The clock the session times its stages with: std's, except in the browser
//! (wasm32-unknown-unknown), where std's panics and the page's (`performance.now`, through
//! `web-time`) is read instead.

#[cfg(not(target_family = "wasm"))]
pub(crate) use std::time::Instant;
#[cfg(target_family = "wasm")]
pub(crate) use web_time::Instant;
