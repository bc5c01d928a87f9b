//! Cross-check harness: run a kernel on the CPU in f64 and on the GPU in f32 from identical
//! inputs, and summarise the differences in the kernel's natural unit.
//!
//! "Identical inputs" means the inputs are first rounded to f32 (what the GPU sees) and the f64
//! reference then runs on those rounded values, so the summary measures the kernel's f32
//! arithmetic and nothing else. Summaries are rounded to significant digits (never to decimal
//! places, which would turn 3.7e-7 into 0) before they are snapshotted or printed.
#![doc = include_str!("README.md")]
// `!(e <= tolerance)` is meant throughout: a NaN error counts as over any tolerance.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

/// The relative error of one f32 `+ − ×` in WGSL, 2⁻²³: WGSL's "correctly rounded" means
/// rounded up *or* down (WGSL §15.7), one ULP, not round-to-nearest's half ULP. Every bound
/// derived by counting roundings counts them at this size, so that it holds for any
/// conforming GPU, not only for one that rounds to nearest (issue #34).
pub const WGSL_U: f64 = f32::EPSILON as f64;

/// The smallest normal f32, 2⁻¹²⁶: a product, square or sum below it may be flushed to zero
/// (GPUs flush subnormals), losing up to this much absolutely. Bounds that are relative to
/// their terms' sizes add this per operation, so that inputs with subnormal entries (found by
/// the command fuzzer: a joint matrix entry of 4e-44) are held to what f32 can do there.
pub const F32_FLUSH: f64 = f32::MIN_POSITIVE as f64;

/// The largest vertex coordinate a cross-checked mesh may have: 2⁴⁸ ≈ 2.8e14. The f32 kernels
/// multiply coordinate differences (|Δ| ≤ 2|x| ≤ 2⁴⁹) and sum such products (a ring's areas
/// and dot products, a quadric's entries): each is ≤ 2⁹⁸, so a sum of up to 2²⁹ of them (more
/// terms than any ring or mesh here has) stays ≤ 2¹²⁷ < f32::MAX ≈ 2¹²⁸, and no bound derived
/// from them is infinite. Past it the comparison would measure overflow, not arithmetic: such a
/// mesh is refused ([`check_f32_range`]).
pub const F32_COORDINATE_MAX: f64 = 281_474_976_710_656.0; // 2^48

/// Refuse a mesh with a coordinate beyond ±[`F32_COORDINATE_MAX`]
/// ([`crate::Error::OutOfF32Range`], naming the first such vertex).
pub fn check_f32_range(mesh: &str, positions: &[nalgebra::Point3<f64>]) -> crate::Result<()> {
    check_range(positions, F32_COORDINATE_MAX, |vertex| {
        (mesh.to_string(), vertex)
    })
}

/// Refuse points with a coordinate beyond ±`limit` (or not a number):
/// [`crate::Error::OutOfF32Range`] for the first, named by `name_of(index)` = (what holds it,
/// its vertex number there).
pub fn check_range(
    points: &[nalgebra::Point3<f64>],
    limit: f64,
    name_of: impl Fn(usize) -> (String, usize),
) -> crate::Result<()> {
    match crate::mesh::first_beyond(points, limit) {
        Some((index, value)) => {
            let (mesh, vertex) = name_of(index);
            Err(crate::Error::OutOfF32Range {
                mesh,
                vertex,
                value,
                limit,
            })
        }
        None => Ok(()),
    }
}

pub mod summary;
pub use summary::{round_significant, to_f32_precision, ErrorSummary};

#[cfg(feature = "gpu")]
pub mod bpm;
#[cfg(feature = "gpu")]
pub mod bpm_bound;
#[cfg(feature = "gpu")]
pub mod bpm_models;

pub mod row;
pub use row::{Bounds, Row, Timing, Verdict};

#[cfg(feature = "gpu")]
pub mod gridwarp;
/// The per-query bound of `gridwarp_lookup`'s UVs, from its twin over `Lin`, and its rows.
#[cfg(feature = "gpu")]
pub mod gridwarp_lookup;
#[cfg(feature = "gpu")]
pub mod gridwarp_naa;
#[cfg(feature = "gpu")]
pub mod gridwarp_naa_twin;
#[cfg(feature = "gpu")]
pub mod maps;
#[cfg(feature = "gpu")]
pub mod maps_bound;
/// The per-query bound of `maps_inverse`'s positions, from its twin over `Lin`.
#[cfg(feature = "gpu")]
pub mod maps_inverse_bound;
// The per-pixel bound of `bpm_render` (its module docs; an outer doc here would make rustdoc
// resolve their links in this module).
#[cfg(feature = "gpu")]
pub mod render_bound;
#[cfg(feature = "gpu")]
pub mod run;
#[cfg(feature = "gpu")]
pub mod skinsimp;
#[cfg(feature = "gpu")]
pub mod sweep;
#[cfg(feature = "gpu")]
pub mod timing;
#[cfg(feature = "gpu")]
pub mod unwarp;
/// The `unwarp_pass` step bound, derived from the f32 search's reachable outcomes.
pub mod unwarp_bound;
/// The `unwarp_lookup` rows: the GPU's lookup coordinates against the reference.
#[cfg(feature = "gpu")]
pub mod unwarp_lookup;
/// The `unwarp_lookup` per-query bound and its undecided queries (nearest level at a boundary).
pub mod unwarp_lookup_bound;
