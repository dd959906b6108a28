//! Datasets read natively (without converting them to a manifest first).

pub mod stb;
