//! unwarp vectors: one pass of the `unwarp_pass` kernel (phase 0) from a state after two
//! reference sweeps, against the f64 per-texel descent [`descend_texel`] (seed 001), with the
//! per-texel bound [`step_bound`]; and a whole run: the total energy after each sweep, with
//! the relative bound [`run_energy_bound`].

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::unwarp::{
    rounded_state, run_energy_bound, step_bound, sweep_ends, TEXTURE_SIZE,
};
use crate::error::Result;
use crate::unwarp::gpu::grid_for;
use crate::unwarp::pass::descend_texel;
use crate::unwarp::{HeightMap, UnwarpOptions};

/// The whole run's vectors: the height map and options as the run receives them, and the total
/// energy E = E_triangles + E_pins (seed 001 §2) after each sweep of the finest level, each
/// with the relative bound [`run_energy_bound`]. With a GPU, the candidate is the run with
/// reparam's own `unwarp_pass` kernel (energies in f64 from its f32 offsets).
pub fn run_vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    heights: &HeightMap,
    options: &UnwarpOptions,
) -> Result<VectorsAndCandidates> {
    let cpu = crate::unwarp::solve(heights, options, |_| {})?;
    let phases = crate::unwarp::pass::sweep_phases(&cpu.problem.mesh).len();
    let totals: Vec<f64> = cpu
        .fine()
        .energy_per_pass
        .iter()
        .map(|e| e.total())
        .collect();
    let ends: Vec<usize> = sweep_ends(totals.len(), phases).collect();
    let expected: Vec<f64> = ends.iter().map(|&p| totals[p]).collect();
    let bounds: Vec<f64> = ends.iter().map(|&p| run_energy_bound(&totals, p)).collect();
    let n = ends.len();
    let periodic = matches!(options.border, crate::unwarp::Border::Periodic);
    let mut inputs = vec![
        (
            "heights".into(),
            "f64, rows × columns: the height map h ∈ [0, 1] (row 0 = the top row of the image)"
                .into(),
            Array::f64(&[heights.height, heights.width], heights.values.clone()),
        ),
        (
            "params".into(),
            "f64: s (node z = s·h, texture widths), θ, periodic (1) or fixed (0) border, sweeps \
             on the finest level, h_fix, Δ (pinning band), levels, sweeps per coarser level, \
             coarse-move scales (0 = the paper's texel passes only); no stopping tolerance"
                .into(),
            Array::f64(
                &[9],
                vec![
                    options.scale,
                    options.theta,
                    if periodic { 1.0 } else { 0.0 },
                    options.sweeps as f64,
                    options.fixation.h_fix,
                    options.fixation.delta,
                    options.levels as f64,
                    options.coarse_sweeps as f64,
                    options.coarse_moves as f64,
                ],
            ),
        ),
    ];
    if let Some(mask) = &options.fixation.mask {
        inputs.push((
            "pin_mask".into(),
            "f32, rows × columns: the painted pin mask (1 = pinned)".into(),
            Array::f32(&[mask.height, mask.width], mask.pixels.clone()),
        ));
    }
    let kernel = KernelData {
        name: "unwarp_run".into(),
        description: format!(
            "a whole run: E = Σ_T E_T + Σ pins after each of the {n} sweeps ({phases} Jacobi \
             passes each, from offset 0) on the finest level (seed 001 §2–3)"
        ),
        inputs,
        expected: (
            "per sweep (1-based sweep k at row k − 1), f64: the total energy after it".into(),
            Array::f64(&[n], expected),
        ),
        bound: ("per sweep, relative".into(), Array::f64(&[n], bounds)),
        metric: Metric::Relative {
            unit: "relative to the f64 energy".into(),
        },
        bound_formula: "2η Σ_{q<p} E_q / E_p, η = 30 ε, over the passes q before the sweep's \
            end p (crosscheck::unwarp::run_energy_bound)"
            .into(),
        derivation: "each f32 pass can leave each texel at most 2ηF above or below where the \
            f64 pass from the same state leaves it (the search's resolution), so pass q adds \
            ≤ 2η E_q; later passes descend from both states alike and do not amplify it (first \
            order): |ΔE_p| ≤ 2η Σ_{q<p} E_q"
            .into(),
        per_element: vec![],
        covers: Vec::new(),
    };
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let mut backend = crate::unwarp::gpu::GpuPass::new(gpu.clone());
        let run = crate::unwarp::solve_with(&mut backend, heights, options, |_| {})?;
        let e = &run.fine().energy_per_pass;
        let got: Vec<f64> = ends
            .iter()
            .map(|&p| e.get(p).map_or(f64::NAN, |e| e.total()))
            .collect();
        candidates.push(("unwarp_run".to_string(), Array::f64(&[n], got)));
    }
    Ok((vec![kernel], candidates))
}

/// The pass's vectors ([`run_vectors`] after them) and, with a GPU, reparam's own kernel's output as the candidate.
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
        bound_formula: crate::crosscheck::unwarp::STEP_BOUND_FORMULA.into(),
        derivation: "crosscheck::unwarp::step_bound: the f32 search's resolution, the f32 \
            gradient's direction, the guard's decision"
            .into(),
        per_element: vec!["active".into()],
        covers: Vec::new(),
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
    let (run, run_candidates) = run_vectors(gpu, heights, options)?;
    candidates.extend(run_candidates);
    Ok((std::iter::once(kernel).chain(run).collect(), candidates))
}
