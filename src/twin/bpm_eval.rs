//! Twin of `gpu/shaders/bpm_eval.wgsl`: one invocation per sample, the interpolated UV at a
//! point of a triangle (the evaluation itself is [`eval`] in [`super::bpm_common`]).

use super::bpm_common::{eval, Complex, TriangleMaps};
use super::real::{sum, Real, V3};

/// One evaluation point (WGSL `Sample`): face id and barycentrics of corners j and k.
#[derive(Clone, Copy, Debug)]
pub struct Sample<R> {
    pub face: u32,
    /// (b_j, b_k); b_i = 1 − b_j − b_k.
    pub b: [R; 2],
}

/// The kernel body for one sample: b = (1 − b_j − b_k, b_j, b_k), `eval(maps[face], b,
/// interp)`. `None` for a face beyond `maps` (the GPU reads out of bounds there).
pub fn bpm_eval<R: Real>(
    maps: &[TriangleMaps<R>],
    s: &Sample<R>,
    interp: u32,
) -> Option<Complex<R>> {
    let t = maps.get(s.face as usize)?;
    let b = V3::new(sum(&[R::lit(1.0), -s.b[0], -s.b[1]]), s.b[0], s.b[1]);
    Some(eval(t, b, interp))
}
