//! Quadric simplification of skinned meshes (Landreneau & Schaefer 2009; seed 003, notes
//! `skinsimp.md` "GPU f32 kernels worth cross-checking") in f32: the data-parallel steps.
//!
//! | kernel | host | WGSL | what it computes |
//! |---|---|---|---|
//! | `skinsimp_lbs` | [`lbs::LbsKernel`] | `shaders/skinsimp_lbs.wgsl` | linear blend skinning `p_i^j = Σ_k w_ik M_k^j v̂_i` of V vertices × P poses |
//! | `skinsimp_plane_quadrics`, `skinsimp_vertex_quadrics` | [`quadrics::QuadricKernel`] | `shaders/skinsimp_quadrics.wgsl` | per-pose face quadrics `K_f^j` and boundary / seam constraint planes; per-vertex sums `Q_i^j` by a CSR gather |
//! | `skinsimp_collapse_cost` | [`collapse_cost::CollapseCostKernel`] | `shaders/skinsimp_collapse_cost.wgsl` | per candidate edge and fixed weights α: `Q̃`, the position step, `E(v̂, α)` |
//!
//! Every per-pose array is indexed `element · P + pose` (the reference's layout of vertex
//! quadrics and check positions). The reference's twins are `skin` (`src/skinsimp/mod.rs`),
//! `src/skinsimp/quadric.rs` with `vertex_quadrics` of `src/skinsimp/collapse.rs`, and
//! `position_quadric`, `position_step`, `energy` of `src/skinsimp/cost.rs`. The weight QP and
//! the alternation stay on the CPU.

pub mod collapse_cost;
pub mod lbs;
pub mod quadrics;

pub use collapse_cost::{CollapseCostKernel, CostInput, EdgeCost, EdgeItem, CHOICE_SOLUTION};
pub use lbs::{Influences, LbsInput, LbsKernel};
pub use quadrics::{PlaneSource, QuadricInput, QuadricKernel, SOURCE_FACE};

/// Most candidate bones of one [`EdgeItem`] (two endpoints of at most four influences each).
pub const MAX_CANDIDATES: usize = 8;

/// A joint matrix: the top three rows of the affine 4×4 `M` (its last row is `(0, 0, 0, 1)`),
/// row-major.
pub type JointMatrix = [f32; 12];

/// A symmetric 4×4 quadric: upper triangle `(xx, xy, xz, xw, yy, yz, yw, zz, zw, ww)`.
pub type QuadricF32 = [f32; 10];
