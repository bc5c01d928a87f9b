//! unwarp vectors: one pass of the `unwarp_pass` kernel (phase 0) from a state after two
//! reference sweeps, against the f64 per-texel descent [`descend_texel`] (seed 001), with the
//! per-texel bound [`step_bound`]; and a whole run: the total energy after each sweep, with
//! the relative bound [`run_energy_bound`].

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::unwarp::{
    rounded_state, run_energy_bound, step_bound, sweep_ends, TEXTURE_SIZE,
};
use crate::error::Result;
use crate::unwarp::fixation::{pin_q, pin_root};
use crate::unwarp::gpu::grid_for;
use crate::unwarp::pass::{descend_texel, descend_texel_traced};
use crate::unwarp::Problem;
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

/// The `unwarp_pass` kernel in the manifest's words: every symbol an outside implementer needs
/// (seed 001 §3; notes `unwarp.md`; the WGSL `gpu/shaders/unwarp_pass.wgsl`).
pub const PASS_DESCRIPTION: &str = "one phase pass of the per-texel descent (seed 001 §3). \
    Grid W × H = z's shape, node c = y·W + x. Stencil steps d_k (k = 0…5, counter-clockwise): \
    (0,−1), (1,−1), (1,0), (0,1), (−1,1), (−1,0); neighbour n_k = node (x + d_k.x, y + d_k.y), \
    wrapped mod W and mod H when periodic. Per active node c, with its own offset o and R = (W, \
    H): 3D edge P_k = (−d_k.x/W, −d_k.y/H, z_c − z_{n_k}), UV edge U_k = o − d_k/R − o_{n_k}; \
    the six triangles T_k = (c, n_{k−1}, n_k), k − 1 mod 6, with P1 = P_{k−1}, P2 = P_k, \
    U1 = U_{k−1}, U2 = U_k: A = |P1 × P2|, a = U1.x U2.y − U2.x U1.y, D = |U1 − U2|² (P1·P2) \
    + |U1|² ((P2 − P1)·P2) + |U2|² (P1·(P1 − P2)), E_T = D/(A a) · (A/a + a/A)^θ (+∞ when \
    a ≤ 0). Pin barrier with w = pins[c]: q = ‖w R_pin ⊙ o‖², E_pin = ½/(1 − q) (+∞ when \
    q ≥ 1). F(o) = Σ_k E_{T_k} + E_pin, g = ∇F(o) (analytic, with respect to o; the \
    neighbours fixed). No move when g is not finite or zero. Bracket of the step t along −g: \
    from [lo, hi] = [0, ∞), each triangle's a(t) = a − t·den, den = U1 × g + g × U2 (u × v = \
    u.x v.y − v.x u.y), t0 = a/den; for t0 > 0: a > 0 → hi = min(hi, t0), else lo = max(lo, \
    t0); the barrier's positive root t of q(o − t g) = 1, when there is one, → hi = min(hi, \
    t); no move unless lo < hi < ∞. Ternary search: at most 31 iterations while hi − lo > \
    1e−6·hi: t1 = lo + (hi − lo)/3, t2 = hi − (hi − lo)/3, F(o − t1 g) > F(o − t2 g) → lo = \
    t1, else hi = t2; t = (lo + hi)/2. Guard: the new offset is o − t g if F(o − t g) < F(o), \
    else o. Active nodes of one phase share no triangle: each reads only start offsets.";

/// What the canonical pass vectors exercise, from the reference's steps (for the manifest's
/// `covers`): the border wrap, the pin barrier (levels, bracket bounded by its root), the
/// bracket and the guard.
fn pass_covers(problem: &Problem, start: &[[f64; 2]], texels: &[(usize, usize)]) -> Vec<String> {
    let mesh = &problem.mesh;
    let (w, h) = (mesh.width, mesh.height);
    let steps: Vec<_> = texels
        .iter()
        .map(|&(x, y)| (x, y, descend_texel_traced(problem, start, x, y)))
        .collect();
    let wrapped = texels
        .iter()
        .filter(|&&(x, y)| x == 0 || y == 0 || x + 1 == w || y + 1 == h)
        .count();
    let level = |x: usize, y: usize| {
        let i = mesh.index(x, y);
        pin_q(problem.pins[i], problem.pin_resolution, start[i]).sqrt()
    };
    let near_barrier = texels.iter().filter(|&&(x, y)| level(x, y) >= 0.5).count();
    let root_bounds = steps
        .iter()
        .filter(|(x, y, s)| {
            let i = mesh.index(*x, *y);
            let root = pin_root(
                problem.pins[i],
                problem.pin_resolution,
                start[i],
                s.gradient,
            );
            matches!((root, s.bracket), (Some(r), Some([_, hi])) if r == hi)
        })
        .count();
    let bracketed = steps.iter().filter(|(_, _, s)| s.bracket.is_some()).count();
    let moved = steps.iter().filter(|(_, _, s)| s.moved).count();
    let n = texels.len();
    vec![
        format!(
            "border (periodic: {}): {wrapped} of {n} active nodes have neighbours across it",
            mesh.border == crate::unwarp::Border::Periodic
        ),
        format!(
            "pin barrier: {near_barrier} of {n} active nodes start at pin level ‖w R_pin⊙o‖ ≥ 0.5"
        ),
        format!(
            "bracket: found at {bracketed} of {n}; its hi is the barrier's root at {root_bounds}"
        ),
        format!(
            "guard: the step is taken at {moved} of {n}, refused at {}",
            n - moved
        ),
    ]
}

/// The direction of [`translated_start`]'s translation, in texels (both components non-zero
/// and unequal, so that both offset components and both R components matter).
pub const START_TRANSLATION: [f64; 2] = [1.2, -1.0];

/// The largest pin level ‖w R⊙o‖ [`translated_start`] brings a node to.
pub const START_PIN_LEVEL: f64 = 0.98;

/// The pass's start: `offsets` (a state after reference sweeps) translated by s·δ texels,
/// δ = [`START_TRANSLATION`], s ≤ 1 the largest (to 2⁻³⁰) that keeps every node's pin level
/// ‖w R⊙o‖ ≤ [`START_PIN_LEVEL`], rounded to f32.
///
/// The triangle energies see only differences of offsets, so the translation leaves them and
/// their gradients unchanged; it moves the pinned nodes towards their barrier (q = ‖w R⊙o‖²
/// up to 0.9604), where the pin terms E_pin = ½/(1 − q) and ∇E_pin shape the step. From the
/// untranslated state (q ≤ 0.03 on the canonical map) a port that ignores the pins passes.
pub fn translated_start(problem: &Problem, offsets: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let r = problem.pin_resolution;
    let shifted = |s: f64| -> Vec<[f64; 2]> {
        offsets
            .iter()
            .map(|o| {
                [
                    (o[0] + s * START_TRANSLATION[0] / r[0]) as f32 as f64,
                    (o[1] + s * START_TRANSLATION[1] / r[1]) as f32 as f64,
                ]
            })
            .collect()
    };
    let within = |s: f64| {
        shifted(s)
            .iter()
            .zip(&problem.pins)
            .all(|(&o, &w)| pin_q(w, r, o).sqrt() <= START_PIN_LEVEL)
    };
    if within(1.0) {
        return shifted(1.0);
    }
    // within(0) holds for any state the descent reached (every pinned node inside its
    // barrier); bisect on s for the last translation that stays within the level.
    let (mut inside, mut outside) = (0.0, 1.0);
    for _ in 0..30 {
        let mid = 0.5 * (inside + outside);
        if within(mid) {
            inside = mid;
        } else {
            outside = mid;
        }
    }
    shifted(inside)
}

/// The pass's vectors ([`run_vectors`] after them) and, with a GPU, reparam's own kernel's output as the candidate.
pub fn vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    heights: &HeightMap,
    options: &UnwarpOptions,
) -> Result<VectorsAndCandidates> {
    let (problem, swept) = rounded_state(heights, options, 2)?;
    let start = translated_start(&problem, &swept);
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
            "f32, [H, W] (row y, column x; node c = y·W + x): node height z = s·h (texture \
             widths); W and H, the grid's size, are this array's shape"
                .into(),
            Array::f32(&[h, w], grid.z.clone()),
        ),
        (
            "pins".into(),
            "f32, [H, W] as `z`: pin weight w ∈ [0, 1] per node".into(),
            Array::f32(&[h, w], grid.pins.clone()),
        ),
        (
            "offsets".into(),
            "f32, [H, W, 2] as `z`, last axis (u, v): the start offset o of every node, UV \
             units (node c's texture coordinate is ((x + ½)/W, (y + ½)/H) + o_c); a state \
             after two reference sweeps, translated so that pinned nodes sit near their \
             barrier (vectors::unwarp::translated_start)"
                .into(),
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
            "u32: the node indices c = y·W + x updated by this pass, in dispatch order: \
             phase 0, the nodes with x and y even, row-major (periodic border: all of them; \
             fixed: not the outer ring). Every other node is inactive: read, never written"
                .into(),
            Array::u32(&[n], grid.phases[phase].clone()),
        ),
        (
            "params".into(),
            "f32: θ; the pin barrier's R_pin = (R_x, R_y) (the finest level's W, H; the \
             grid's own (W, H) may be smaller on a coarse level); the border: 1 periodic \
             (neighbour indices wrap mod W, mod H), 0 fixed"
                .into(),
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
        description: PASS_DESCRIPTION.into(),
        inputs,
        expected: (
            "per active texel (row i ↔ active[i]), f64: the new offset (u, v) of the node, UV \
             units"
                .into(),
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
        derivation:
            "crosscheck::unwarp_bound::step_bound: the f32 search's reachable steps, the f32 \
            gradient's direction, the guard's decision"
                .into(),
        per_element: vec!["active".into()],
        covers: pass_covers(&problem, &start, &texels),
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
