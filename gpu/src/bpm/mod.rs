//! BPM (Blended Piecewise Möbius Maps) in f32: the data layouts shared by the three kernels and
//! the kernels themselves.
//!
//! | kernel | host | WGSL | what it computes |
//! |---|---|---|---|
//! | [`bpm_precompute`] | `run(gpu, stars, fit)` | `shaders/bpm_precompute.wgsl` | per triangle: layout, M_t, log ratios |
//! | [`bpm_eval`] | `run(gpu, maps, samples, interp)` | `shaders/bpm_eval.wgsl` | UV at (face, barycentrics) |
//! | [`bpm_render`] | `run(gpu, &RenderInput)` | `shaders/bpm_render.wgsl` | textured picture, `eval` per pixel |
//!
//! `shaders/bpm_common.wgsl` holds what they share (complex arithmetic, SL(2,C), fits, exp/log,
//! `eval`); the host concatenates it before each kernel. Each WGSL function has the name of its
//! f64 twin in the reference (`src/bpm/moebius.rs`, `precompute.rs`, `eval.rs`).
//!
//! The `Gpu*` names and the [`precompute`], [`eval`], [`render`] functions re-export the same
//! items under names that do not clash with the reference's types.

pub mod bpm_eval;
pub mod bpm_precompute;
pub mod bpm_render;

use bytemuck::{Pod, Zeroable};

pub use self::bpm_eval::run as eval;
pub use self::bpm_precompute::run as precompute;
pub use self::bpm_render::{run as render, RenderInput};
pub use self::{
    Fit as GpuFit, Interp as GpuInterp, Sample as GpuSample, TriangleMaps as GpuTriangleMaps,
};

/// WGSL shared by the BPM kernels (`bpm_common.wgsl`).
pub const BPM_COMMON_WGSL: &str = include_str!("../../shaders/bpm_common.wgsl");

/// `StarInput::mask` bit of a neighbour across edge `e` (0 = ij, 1 = jk, 2 = ki).
pub const fn neighbour_bit(e: usize) -> u32 {
    1 << e
}
/// `StarInput::mask` bit: t is degenerate, evaluate it linearly.
pub const MASK_DEGENERATE: u32 = 1 << 3;
/// `TriangleMaps::flags` bit: linear fallback (degenerate face or non-finite M_t).
pub const FLAG_LINEAR_FALLBACK: u32 = 1;
/// `TriangleMaps::flags` bit: the star's layout was mirrored (t's UV triangle is clockwise).
pub const FLAG_MIRRORED: u32 = 2;

/// One triangle's star as the precompute kernel reads it (160 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct StarInput {
    /// xyz positions (w unused): corners i, j, k, then the apex across edge ij, jk, ki.
    pub p: [[f32; 4]; 6],
    /// UVs at the same six points.
    pub w: [[f32; 2]; 6],
    /// Bit e ([`neighbour_bit`]): the neighbour across edge e exists; [`MASK_DEGENERATE`]: t is
    /// degenerate (linear fallback).
    pub mask: u32,
    pub _pad: [u32; 3],
}

/// Per-triangle BPM data (192 bytes): output of `bpm_precompute`, input of `bpm_eval` and
/// `bpm_render`. The interpolant is f(z) = w_origin + M_t(exp(½ Σ_e γ_e l_e)(z)).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TriangleMaps {
    /// Layout of corners j, k in t's frame: (z_j.re, z_j.im, z_k.re, z_k.im); z_i = 0.
    pub z: [f32; 4],
    /// (uv_i.x, uv_i.y, uv_j.x, uv_j.y).
    pub uv_ij: [f32; 4],
    /// (uv_k.x, uv_k.y, w_origin.re, w_origin.im).
    pub uv_k_origin: [f32; 4],
    /// M_t: (a.re, a.im, b.re, b.im), (c.re, c.im, d.re, d.im).
    pub m: [[f32; 4]; 2],
    /// Log ratio of edge e, `[[a, b], [c, −a]]`: `logs[2e]` = (a.re, a.im, b.re, b.im),
    /// `logs[2e + 1]` = (c.re, c.im, 0, 0).
    pub logs: [[f32; 4]; 6],
    /// [`FLAG_LINEAR_FALLBACK`] | [`FLAG_MIRRORED`].
    pub flags: u32,
    pub _pad: [u32; 3],
}

impl TriangleMaps {
    /// Whether the face is evaluated linearly whatever the interpolation asked for.
    pub fn is_linear_fallback(&self) -> bool {
        self.flags & FLAG_LINEAR_FALLBACK != 0
    }

    /// Whether the star's layout was mirrored.
    pub fn is_mirrored(&self) -> bool {
        self.flags & FLAG_MIRRORED != 0
    }

    /// The largest |entry| of the three log ratios (0 when all neighbours agree with M_t).
    pub fn max_abs_log(&self) -> f32 {
        self.logs
            .iter()
            .flat_map(|v| [v[0].hypot(v[1]), v[2].hypot(v[3])])
            .fold(0.0, f32::max)
    }
}

/// One evaluation point (16 bytes): face id and barycentrics of corners j and k
/// (b_i = 1 − b_j − b_k).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Sample {
    pub face: u32,
    pub _pad: u32,
    pub b: [f32; 2],
}

impl Sample {
    /// The point of face `face` with barycentrics (1 − b_j − b_k, b_j, b_k).
    pub fn new(face: u32, b_j: f32, b_k: f32) -> Sample {
        Sample {
            face,
            _pad: 0,
            b: [b_j, b_k],
        }
    }
}

/// How the Möbius map through three points is fitted (WGSL `fit_mobius_local` /
/// `fit_mobius_det`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Fit {
    /// Relative to t's first corner, in UV and in the layout (w_origin = uv_i). Default.
    #[default]
    Local,
    /// The seed's 3×3 determinants on absolute UVs (w_origin = 0).
    Determinant,
}

impl Fit {
    /// The WGSL constant: FIT_LOCAL = 0, FIT_DETERMINANT = 1.
    fn code(self) -> u32 {
        match self {
            Fit::Local => 0,
            Fit::Determinant => 1,
        }
    }
}

/// Which interpolant to evaluate (WGSL `eval`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Interp {
    /// Blended piecewise Möbius maps. Default.
    #[default]
    Bpm,
    /// Piecewise-linear interpolation of the corner UVs.
    Linear,
}

impl Interp {
    /// The WGSL constant: INTERP_BPM = 0, INTERP_LINEAR = 1.
    fn code(self) -> u32 {
        match self {
            Interp::Bpm => 0,
            Interp::Linear => 1,
        }
    }
}

/// Uniform of the BPM compute kernels (16 bytes): item count and mode (fit or interp); WGSL
/// `PrecomputeParams` / `EvalParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct KernelParams {
    count: u32,
    mode: u32,
    _pad: [u32; 2],
}

impl KernelParams {
    fn new(count: u32, mode: u32) -> KernelParams {
        KernelParams {
            count,
            mode,
            _pad: [0; 2],
        }
    }
}

/// The source of a BPM kernel: the given parts (dispatch.wgsl, bpm_common.wgsl, the kernel)
/// concatenated, WGSL having no includes.
fn shader_source(parts: &[&str]) -> String {
    parts.join("\n")
}
