#![doc = include_str!("README.md")]

pub mod conformality;
pub mod eval;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod moebius;
pub mod precompute;
pub mod quality;
pub mod render;
pub mod vertex_rule;

pub use eval::{
    edge_weights, edge_weights_distance, eval_bpm, eval_linear, face_samples, Interp, Sample,
    INTERIOR_POINTS,
};
pub use moebius::{ExpLog, Mobius, Sl2};
pub use precompute::{
    precompute, Bpm, BpmOptions, Fit, Order, PrecomputeReport, TriangleMaps, Unfold,
};
pub use quality::{qc_protocol, qc_protocol_faces, FaceQc, QcStats};
pub use vertex_rule::{authors_vertex_owners, VertexOwners, VertexRule};
