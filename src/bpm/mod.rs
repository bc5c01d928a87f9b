//! # BPM — Blended Piecewise Möbius Maps
//!
//! Rorberg, Vaxman, Ben-Chen, "BPM: Blended Piecewise Möbius Maps", Computer Graphics Forum
//! 42(5), 2023; implementation report: seed 004 (`../shared/seeds/004_*.txt`), restated in
//! `../shared/notes/bpm.md`.
//!
//! Texture interpolation that replaces the per-triangle affine map by a per-triangle Möbius map
//! M_t (fitted to the triangle's three vertex UVs in its own plane), blended towards the
//! neighbours' maps near each edge:
//!
//! ```text
//!   δ_e = M_t⁻¹ M_e,  l_e = log(±δ_e)          (per edge, precompute.rs)
//!   f(z) = M_t exp(½ Σ_e γ_e(z) l_e) (z)        (per point, eval.rs)
//! ```
//!
//! | stage | seed step | file |
//! |---|---|---|
//! | SL(2,C) maps, fits, exp/log | 3, 4, 8 | [`moebius`] |
//! | star layout (correct or authors' unfolding, [`Unfold`]), orientation fix, log ratios | 2–5 | [`precompute()`] |
//! | edge-barycentric weights, blending, evaluation | 6–9 | [`eval`] |
//! | quality protocol (QC = σmax/σmin), per-face figures | authors' protocol | [`quality`] |
//! | which face evaluates a shared sub-vertex (the authors' rule) | authors' code | [`vertex_rule`] |
//! | the input map's conformality (cross-ratio mismatch s) | BPM's assumption (issue #36) | [`conformality`] |
//!
//! Entry points: [`precompute()`](precompute::precompute) then [`Bpm::eval`] /
//! [`Bpm::eval_many`]; [`quality::qc_protocol`] for the distortion figures.

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
