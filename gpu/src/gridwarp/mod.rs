//! Content-aware grid warp (seed 000) in f32: the axis-aligned energy's per-cell kernel.
//!
//! | kernel | host | WGSL | what it computes |
//! |---|---|---|---|
//! | `gridwarp_aa_cell` | [`aa_cells`] / [`AaKernel::run`] | `shaders/gridwarp_aa.wgsl` | per cell: energy, 4×4 JᵀJ block, 4-vector Jᵀr |
//! | `gridwarp_aa_residuals` | [`aa_residuals`] | `shaders/gridwarp_aa_residuals.wgsl` (after `gridwarp_aa.wgsl`) | per sample: r^s, r^t (conformance vectors) |
//! | `gridwarp_lookup` | [`lookup::lookup`] / [`LookupKernel::run`] | `shaders/gridwarp_lookup.wgsl` | per query UV: the warped texture lookup of an atlas of ROIs (AA, NAA, blending) |
//!
//! This is the GPU half of the paper's hybrid solver (seed §7): the objective and its normal
//! equations are evaluated on the GPU, one cell per invocation, and read back; Levenberg–Marquardt
//! stays on the CPU. The reference's twin, name for name, is the plain path `PlainAaEnergy`
//! (`src/gridwarp/plain/aa.rs`) with `Field::bilinear` (`src/gridwarp/field.rs`); its residuals
//! are the fast `AaEnergy`'s (`src/gridwarp/energy.rs`) bit for bit.

pub mod aa;
pub mod lookup;

pub use aa::{
    aa_cells, aa_residuals, AaBinding, AaInput, AaKernel, CellContribution, FieldF32, RestSample,
    NO_UNKNOWN,
};
pub use lookup::{LookupKernel, LookupTables, RoiGrid, RoiRect};
