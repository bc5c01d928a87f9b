//! Sweeps, convergence and coarse-to-fine (notes § One pass step 4; § Defects: "no
//! coarse-to-fine"). Coarse-to-fine is not in the paper or the demo: solve on the 2×2-averaged
//! height map, upsample the offsets bilinearly as the start of the next finer level.

use std::time::Instant;

use super::coarse_move::{
    coarse_pass, coarse_scales, TriangleTable, COARSE_PHASES, COARSE_SEARCH_RELATIVE_WIDTH,
};
use super::energy::{total_energy, triangle_at, uv_area, Energy};
use super::fixation::pin_q;
use super::height::HeightMap;
use super::pass::{pass, sweep_phases};
use super::{Problem, UnwarpOptions};
use crate::error::Result;

/// Coarse levels smaller than this (either side) are not built.
pub const MIN_COARSE_SIZE: usize = 8;

/// On upsampling, a pinned node's start is pulled inside ‖w R⊙o‖ ≤ this (half its barrier).
pub const PIN_START_LIMIT: f64 = 0.5;

/// On upsampling, the corners of folded triangles are halved at most this many times, then the
/// whole start is zeroed.
pub const MAX_START_HALVINGS: usize = 30;

/// Reported to the progress callback after every sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Level being solved: `levels − 1` is the coarsest, 0 the finest.
    pub level: usize,
    pub levels: usize,
    /// Sweeps done on this level, and the most it will do.
    pub sweep: usize,
    pub sweeps: usize,
    /// Energy ratio of [`Energy::ratio`] after this sweep.
    pub energy_ratio: f64,
}

/// One level's run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LevelRun {
    pub width: usize,
    pub height: usize,
    /// Energy before the first pass (index 0) and after every texel pass.
    pub energy_per_pass: Vec<Energy>,
    /// Texel passes.
    pub passes: usize,
    /// Coarse passes ([`coarse_pass`]; 0 unless `coarse_moves` > 0).
    pub coarse_passes: usize,
    /// With coarse moves: the energy at the end of every sweep, after its coarse passes.
    pub energy_after_coarse_moves: Vec<Energy>,
    pub seconds: f64,
}

impl LevelRun {
    /// The energy before the first sweep and at the end of every sweep (after its coarse
    /// moves, if any); `phases` texel passes per sweep.
    pub fn energy_per_sweep(&self, phases: usize) -> Vec<Energy> {
        let mut sweeps: Vec<Energy> = self
            .energy_per_pass
            .iter()
            .step_by(phases.max(1))
            .copied()
            .collect();
        for (sweep, e) in self.energy_after_coarse_moves.iter().enumerate() {
            sweeps[sweep + 1] = *e;
        }
        sweeps
    }
}

/// The result of [`solve`].
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// The finest level's problem (mesh, θ, pin weights).
    pub problem: Problem,
    /// Per-texel offsets of the finest level (UV units), row-major.
    pub offsets: Vec<[f64; 2]>,
    /// Energy of the finest level at offset 0 (no correction).
    pub initial: Energy,
    /// Energy of the finest level at the end.
    pub last: Energy,
    /// Levels in the order solved: coarsest first, the finest last.
    pub levels: Vec<LevelRun>,
}

impl Solution {
    /// The finest level's run.
    pub fn fine(&self) -> &LevelRun {
        self.levels.last().expect("at least one level")
    }
}

/// The height maps of coarse-to-fine, finest first: `heights` and up to `levels − 1`
/// [`HeightMap::downsampled`] maps, stopping early when a map cannot be halved, would be
/// smaller than [`MIN_COARSE_SIZE`], or has no valid mesh.
pub fn height_pyramid(heights: &HeightMap, options: &UnwarpOptions) -> Vec<HeightMap> {
    let mut pyramid = vec![heights.clone()];
    while pyramid.len() < options.levels.max(1) {
        let Some(coarse) = pyramid.last().and_then(HeightMap::downsampled) else {
            break;
        };
        if coarse.width.min(coarse.height) < MIN_COARSE_SIZE
            || Problem::new(
                &coarse,
                &level_options(options, coarse.width, coarse.height),
            )
            .is_err()
        {
            break;
        }
        pyramid.push(coarse);
    }
    pyramid
}

/// Bilinear value of a periodic (wrap) or clamped W×H field of offsets at texel coordinate
/// (ξ, η) (texel centres at integers).
fn bilinear_offset(
    field: &[[f64; 2]],
    w: usize,
    h: usize,
    xi: f64,
    eta: f64,
    wrap: bool,
) -> [f64; 2] {
    let coordinate = |t: f64, n: usize| -> (usize, usize, f64) {
        let f = t.floor();
        let frac = t - f;
        let i = f as i64;
        if wrap {
            let n = n as i64;
            (
                i.rem_euclid(n) as usize,
                (i + 1).rem_euclid(n) as usize,
                frac,
            )
        } else {
            let last = n as i64 - 1;
            let (i0, i1) = (i.clamp(0, last), (i + 1).clamp(0, last));
            (
                i0 as usize,
                i1 as usize,
                if i < 0 || i >= last { 0.0 } else { frac },
            )
        }
    };
    let (x0, x1, fx) = coordinate(xi, w);
    let (y0, y1, fy) = coordinate(eta, h);
    let at = |x: usize, y: usize| field[y * w + x];
    [0, 1].map(|c| {
        let top = at(x0, y0)[c] * (1.0 - fx) + at(x1, y0)[c] * fx;
        let bottom = at(x0, y1)[c] * (1.0 - fx) + at(x1, y1)[c] * fx;
        top * (1.0 - fy) + bottom * fy
    })
}

/// The start of a finer level from the coarser level's offsets (UV units need no rescaling):
///
/// 1. fine texel (x, y) takes the bilinear coarse offset at coarse texel coordinate
///    (x/2 − ¼, y/2 − ¼) — the same point (x + ½)/W of the unit square;
/// 2. fixed border: the outer ring is set to 0;
/// 3. a pinned node with ‖w R⊙o‖ > [`PIN_START_LIMIT`] is scaled back onto that radius (the
///    coarse level's barrier has the same R, but the fine pin weights differ);
/// 4. repair ([`repair_start`]): the corners of folded triangles are pulled halfway to 0.
pub fn upsample_offsets(
    coarse: &Problem,
    coarse_offsets: &[[f64; 2]],
    fine: &Problem,
) -> Vec<[f64; 2]> {
    let (cw, ch) = (coarse.mesh.width, coarse.mesh.height);
    let fm = &fine.mesh;
    let wrap = fm.border == super::Border::Periodic;
    let resolution = fine.pin_resolution;
    let mut offsets: Vec<[f64; 2]> = (0..fm.node_count())
        .map(|i| {
            let (x, y) = (i % fm.width, i / fm.width);
            if !fm.is_free(x, y) {
                return [0.0; 2];
            }
            let o = bilinear_offset(
                coarse_offsets,
                cw,
                ch,
                x as f64 / 2.0 - 0.25,
                y as f64 / 2.0 - 0.25,
                wrap,
            );
            let q = pin_q(fine.pins[i], resolution, o);
            if q > PIN_START_LIMIT * PIN_START_LIMIT {
                let s = PIN_START_LIMIT / q.sqrt();
                [o[0] * s, o[1] * s]
            } else {
                o
            }
        })
        .collect();
    repair_start(fine, &mut offsets);
    offsets
}

/// Make a start fold-free: up to [`MAX_START_HALVINGS`] rounds, each halving the offsets of
/// every corner of a folded (a ≤ 0) triangle; if folds remain, all offsets are set to 0 (a
/// fold-free start). Returns the number of rounds.
pub fn repair_start(problem: &Problem, offsets: &mut [[f64; 2]]) -> usize {
    let mesh = &problem.mesh;
    for round in 0..MAX_START_HALVINGS {
        let mut folded = vec![false; mesh.node_count()];
        let mut any = false;
        for (x, y) in mesh.cell_owners() {
            for k in [1, 2] {
                let (_, u1, u2) = triangle_at(mesh, offsets, x, y, k);
                let a = uv_area(u1, u2);
                if a.is_nan() || a <= 0.0 {
                    any = true;
                    folded[mesh.index(x, y)] = true;
                    for n in [(k + 5) % 6, k] {
                        folded[mesh.neighbour(x, y, n).expect("cell inside the map")] = true;
                    }
                }
            }
        }
        if !any {
            return round;
        }
        for (o, _) in offsets.iter_mut().zip(&folded).filter(|(_, &f)| f) {
            *o = [0.5 * o[0], 0.5 * o[1]];
        }
    }
    offsets.iter_mut().for_each(|o| *o = [0.0; 2]);
    MAX_START_HALVINGS
}

/// Who runs a pass: the f64 reference ([`CpuPass`]) or the f32 GPU kernel (`gpu::GpuPass`).
pub trait PassBackend {
    /// One pass of `phase` on `offsets` (see [`pass`]).
    fn pass(&mut self, problem: &Problem, offsets: &mut [[f64; 2]], phase: usize) -> Result<()>;
}

/// The f64 reference pass, [`pass`].
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuPass;

impl PassBackend for CpuPass {
    fn pass(&mut self, problem: &Problem, offsets: &mut [[f64; 2]], phase: usize) -> Result<()> {
        pass(problem, offsets, phase);
        Ok(())
    }
}

/// Run sweeps on one level from `offsets`: at most `sweeps`, stopping early when a sweep lowers
/// the total energy by less than `tolerance` relatively. Energy recorded after every pass.
/// A sweep is the texel passes of every phase, then, with `coarse_moves` > 0, the coarse
/// passes of [`coarse_scales`] (r = 2, 4, …, each scale's four phases; f64 on the CPU
/// whatever the backend).
pub fn solve_level(
    backend: &mut dyn PassBackend,
    problem: &Problem,
    offsets: &mut [[f64; 2]],
    sweeps: usize,
    tolerance: Option<f64>,
    coarse_moves: usize,
    mut on_sweep: impl FnMut(usize, &Energy),
) -> Result<LevelRun> {
    let start = Instant::now();
    let scales = coarse_scales(&problem.mesh, coarse_moves);
    let table = (!scales.is_empty()).then(|| TriangleTable::new(&problem.mesh));
    let mut energy_per_pass = vec![total_energy(problem, offsets)];
    let mut energy_after_coarse_moves = Vec::new();
    let mut coarse_passes = 0;
    let mut before = energy_per_pass[0];
    for sweep in 0..sweeps {
        for phase in sweep_phases(&problem.mesh) {
            backend.pass(problem, offsets, phase)?;
            energy_per_pass.push(total_energy(problem, offsets));
        }
        let mut after = *energy_per_pass.last().expect("recorded");
        if let Some(table) = &table {
            for &r in &scales {
                for phase in 0..COARSE_PHASES {
                    coarse_pass(
                        problem,
                        table,
                        offsets,
                        r,
                        phase,
                        COARSE_SEARCH_RELATIVE_WIDTH,
                    );
                    coarse_passes += 1;
                }
            }
            after = total_energy(problem, offsets);
            energy_after_coarse_moves.push(after);
        }
        on_sweep(sweep + 1, &after);
        if tolerance.is_some_and(|tol| before.total() - after.total() < tol * before.total().abs())
        {
            break;
        }
        before = after;
    }
    Ok(LevelRun {
        width: problem.mesh.width,
        height: problem.mesh.height,
        passes: energy_per_pass.len() - 1,
        energy_per_pass,
        coarse_passes,
        energy_after_coarse_moves,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Solve: [`height_pyramid`], then from the coarsest level to the finest, each level started
/// from [`upsample_offsets`] of the previous one (the coarsest from 0), with
/// `options.coarse_sweeps` sweeps on coarse levels and `options.sweeps` on the finest
/// (`options.tolerance` on all). `progress` is called after every sweep. Passes run on the f64
/// reference ([`CpuPass`]); [`solve_with`] takes another backend.
pub fn solve(
    heights: &HeightMap,
    options: &UnwarpOptions,
    progress: impl FnMut(&Progress),
) -> Result<Solution> {
    solve_with(&mut CpuPass, heights, options, progress)
}

/// [`solve`] with the passes run by `backend`.
pub fn solve_with(
    backend: &mut dyn PassBackend,
    heights: &HeightMap,
    options: &UnwarpOptions,
    mut progress: impl FnMut(&Progress),
) -> Result<Solution> {
    let fine = Problem::new(heights, options)?;
    let initial = total_energy(&fine, &vec![[0.0; 2]; fine.mesh.node_count()]);
    let pyramid = height_pyramid(heights, options);
    let levels = pyramid.len();
    let mut runs = Vec::with_capacity(levels);
    let mut previous: Option<(Problem, Vec<[f64; 2]>)> = None;
    for (level, map) in pyramid.iter().enumerate().rev() {
        let problem = if level == 0 {
            fine.clone()
        } else {
            Problem {
                pin_resolution: fine.pin_resolution,
                ..Problem::new(map, &level_options(options, map.width, map.height))?
            }
        };
        let mut offsets = match &previous {
            None => vec![[0.0; 2]; problem.mesh.node_count()],
            Some((coarse, coarse_offsets)) => upsample_offsets(coarse, coarse_offsets, &problem),
        };
        let sweeps = if level == 0 {
            options.sweeps
        } else {
            options.coarse_sweeps
        };
        let theta = options.theta;
        let run = solve_level(
            backend,
            &problem,
            &mut offsets,
            sweeps,
            options.tolerance,
            options.coarse_moves,
            |sweep, energy| {
                progress(&Progress {
                    level,
                    levels,
                    sweep,
                    sweeps,
                    energy_ratio: energy.ratio(theta),
                })
            },
        )?;
        runs.push(run);
        previous = Some((problem, offsets));
    }
    let (problem, offsets) = previous.expect("at least one level");
    let last = total_energy(&problem, &offsets);
    Ok(Solution {
        problem,
        offsets,
        initial,
        last,
        levels: runs,
    })
}

/// The pin mask box-averaged down to `width × height` when its size is an integer multiple of
/// it in both directions, else `None` (then the coarse levels run without it).
pub fn downsample_mask(
    mask: &crate::texture::Image<f32>,
    width: usize,
    height: usize,
) -> Option<crate::texture::Image<f32>> {
    if width == 0
        || height == 0
        || !mask.width.is_multiple_of(width)
        || !mask.height.is_multiple_of(height)
    {
        return None;
    }
    let (fx, fy) = (mask.width / width, mask.height / height);
    Some(crate::texture::Image::from_fn(width, height, |x, y| {
        let mut sum = 0.0f64;
        for j in 0..fy {
            for i in 0..fx {
                sum += mask.get(x * fx + i, y * fy + j) as f64;
            }
        }
        (sum / (fx * fy) as f64) as f32
    }))
}

/// The options of a coarser level of `width × height`: the pin mask box-downsampled
/// ([`downsample_mask`]), everything else unchanged.
pub fn level_options(options: &UnwarpOptions, width: usize, height: usize) -> UnwarpOptions {
    let mut level = options.clone();
    level.fixation.mask = options
        .fixation
        .mask
        .as_ref()
        .and_then(|m| downsample_mask(m, width, height));
    level
}
