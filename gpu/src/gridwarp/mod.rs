//! Content-aware grid warp (seed 000) in f32: the per-cell kernels of the axis-aligned and the
//! non-axis-aligned energy.
//!
//! | kernel | host | WGSL | what it computes |
//! |---|---|---|---|
//! | `gridwarp_aa_cell` | [`aa_cells`] / [`AaKernel::run`] | `shaders/gridwarp_aa.wgsl` | per cell: energy, 4×4 JᵀJ block, 4-vector Jᵀr |
//! | `gridwarp_aa_residuals` | [`aa_residuals`] | `shaders/gridwarp_aa_residuals.wgsl` (after `gridwarp_aa.wgsl`) | per sample: r^s, r^t (conformance vectors) |
//! | `gridwarp_naa_cell` | [`naa_cells`] / [`NaaKernel::run`] | `shaders/gridwarp_naa.wgsl` | per cell: energy, 8×8 JᵀJ block, 8-vector Jᵀr (seed §8) |
//! | `gridwarp_naa_residuals` | [`naa_residuals`] | `shaders/gridwarp_naa_residuals.wgsl` (after `gridwarp_naa.wgsl`) | per sample: r^s, r^t (conformance vectors) |
//! | `gridwarp_lookup` | [`lookup::lookup`] / [`LookupKernel::run`] | `shaders/gridwarp_lookup.wgsl` | per query UV: the warped texture lookup of an atlas of ROIs (AA, NAA, blending) |
//!
//! Both read their fields through `shaders/gridwarp_field.wgsl` ([`FIELD_WGSL`], the bilinear
//! lookup with its gradient, prepended by the host).
//!
//! This is the GPU half of the paper's hybrid solver (seed §7): the objective and its normal
//! equations are evaluated on the GPU, one cell per invocation, and read back; Levenberg–Marquardt
//! stays on the CPU. The reference's twins, name for name, are the plain paths `PlainAaEnergy`
//! (`src/gridwarp/plain/aa.rs`) and `PlainNaaEnergy` (`src/gridwarp/plain/naa.rs`) with
//! `Field::bilinear` (`src/gridwarp/field.rs`); their residuals are the fast `AaEnergy`'s and
//! `NaaEnergy`'s bit for bit.

pub mod aa;
pub mod lookup;
pub mod naa;

pub use aa::{
    aa_cells, aa_residuals, AaBinding, AaInput, AaKernel, CellContribution, FieldF32, RestSample,
    NO_UNKNOWN,
};
pub use naa::{
    naa_cells, naa_residuals, NaaBinding, NaaCellContribution, NaaInput, NaaKernel, VectorFieldF32,
};

/// The bilinear field lookup both kernels share (`shaders/gridwarp_field.wgsl`: `axis`,
/// `bilinear_formula`), prepended after `dispatch.wgsl`.
pub const FIELD_WGSL: &str = include_str!("../../shaders/gridwarp_field.wgsl");
pub use lookup::{LookupKernel, LookupTables, RoiGrid, RoiRect};
