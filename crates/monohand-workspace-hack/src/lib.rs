//! No code: see Cargo.toml (the features this crate enables, and why).
