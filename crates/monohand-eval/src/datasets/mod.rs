//! Datasets read natively (without converting them to a manifest first).

pub mod hand_graph_cnn;
pub mod stb;
