//! unwarp vectors: one pass of the `unwarp_pass` kernel (phase 0) from a state after two
//! reference sweeps, against the f64 per-texel descent [`descend_texel`] (seed 001), with the
//! per-texel bound [`step_bound`].

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::unwarp::{rounded_state, step_bound, TEXTURE_SIZE};
use crate::error::Result;
use crate::unwarp::gpu::grid_for;
use crate::unwarp::pass::descend_texel;
use crate::unwarp::{HeightMap, UnwarpOptions};

/// The pass's vectors and, with a GPU, reparam's own kernel's output as the candidate.
pub fn vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    heights: &HeightMap,
    options: &UnwarpOptions,
) -> Result<VectorsAndCandidates> {
    let (problem, start) = rounded_state(heights, options, 2)?;
    let grid = grid_for(&problem);
    let mesh = &problem.mesh;
    let (w, h) = (mesh.width, mesh.height);
    let phase = 0;
    let texels = mesh.active_texels(phase);
    let res = mesh.resolution();
    let to_4096 = TEXTURE_SIZE / res[0].max(res[1]);
    let expected: Vec<f64> = texels
        .iter()
        .flat_map(|&(x, y)| descend_texel(&problem, &start, x, y))
        .collect();
    let bounds: Vec<f64> = texels
        .iter()
        .map(|&(x, y)| step_bound(&problem, &start, x, y) * to_4096)
        .collect();
    let n = texels.len();
    let inputs: Vec<(String, String, Array)> = vec![
        (
            "z".into(),
            "f32, rows × columns: node height z = s·h (texture widths)".into(),
            Array::f32(&[h, w], grid.z.clone()),
        ),
        (
            "pins".into(),
            "f32, rows × columns: pin weight w ∈ [0, 1]".into(),
            Array::f32(&[h, w], grid.pins.clone()),
        ),
        (
            "offsets".into(),
            "f32, rows × columns × 2: the start offsets (UV units) of every node".into(),
            Array::f32(
                &[h, w, 2],
                start
                    .iter()
                    .flat_map(|o| [o[0] as f32, o[1] as f32])
                    .collect(),
            ),
        ),
        (
            "active".into(),
            "u32: the row-major node indices updated by this pass (phase 0), in order".into(),
            Array::u32(&[n], grid.phases[phase].clone()),
        ),
        (
            "params".into(),
            "f32: θ, pin resolution R_x, R_y, periodic (1) or fixed (0) border".into(),
            Array::f32(
                &[4],
                vec![
                    grid.theta,
                    grid.pin_resolution[0],
                    grid.pin_resolution[1],
                    if grid.periodic { 1.0 } else { 0.0 },
                ],
            ),
        ),
    ];
    let kernel = KernelData {
        name: "unwarp_pass".into(),
        description: "one Jacobi pass: each active texel descends its node energy along −∇E \
            (flip-free bracket, ternary search, guard), seed 001 §3"
            .into(),
        inputs,
        expected: (
            "per active texel (the order of `active`), f64: the new offset (UV units)".into(),
            Array::f64(&[n, 2], expected),
        ),
        bound: (
            "per texel, texels of a 4096² texture".into(),
            Array::f64(&[n], bounds),
        ),
        metric: Metric::NormOfLastAxis {
            scale: TEXTURE_SIZE,
            unit: "texels of a 4096² texture".into(),
        },
        bound_formula: "2√(ηF/F'')|g| + 2φs + guard s + 1e-6 hi|g|, η = 30 ε".into(),
        derivation: "crosscheck::unwarp::step_bound: the f32 search's resolution, the f32 \
            gradient's direction, the guard's decision"
            .into(),
        per_element: vec!["active".into()],
    };
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let mut backend = crate::unwarp::gpu::GpuPass::new(gpu.clone());
        let mut offsets = start.clone();
        let results = backend.run(&problem, &mut offsets, phase)?.to_vec();
        candidates.push((
            "unwarp_pass".to_string(),
            Array::f32(&[n, 2], results.iter().flat_map(|r| r.offset).collect()),
        ));
    }
    Ok((vec![kernel], candidates))
}
