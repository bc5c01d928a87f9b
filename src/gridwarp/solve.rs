//! Solving frames (seed §5.3): the unknowns are all interior grid lines, the starting point is
//! the previous frame's solution (warm start), the bounds come from it (seed §5.2), and the
//! box-constrained Levenberg–Marquardt solver of [`crate::lm`] minimises the energy.

use std::time::Instant;

use super::bounds::{frame_bounds, BoundOptions};
use super::energy::{AaEnergy, DeformedFields, RestFields, RestSamples};
use super::energy_naa::{
    naa_frame_bounds, DeformedJacobian, NaaEnergy, NaaModel, NaaRestSamples, VertexGrid,
};
use super::grid::Grid;
use crate::error::{Error, Result};
use crate::lm::{minimize, Bounds, LmOptions, LmReport, Residuals, Speculative};

/// Options of a gridwarp solve. Defaults: 8×8 midpoint samples per cell, the practical LM
/// preset ([`LmOptions::default`]), no smoothness bound, no looping, the Gauss–Newton model for
/// the non-axis-aligned energy.
#[derive(Clone, Debug, Default)]
pub struct SolveOptions {
    /// Midpoint-rule samples per cell (K, L); (0, 0) means the default 8×8.
    pub samples: (usize, usize),
    pub lm: LmOptions,
    /// Smoothness bound o between frames (None: foldover bounds only).
    pub smoothness: Option<f64>,
    /// Treat the sequence as a loop (needs `smoothness`).
    pub looping: bool,
    /// The non-axis-aligned energy's model Hessian ([`NaaModel`]; the AA energy always uses
    /// Gauss–Newton).
    pub naa_model: NaaModel,
}

impl SolveOptions {
    /// Midpoint samples per cell (K, L), the default 8×8 for (0, 0).
    pub fn samples_per_cell(&self) -> (usize, usize) {
        match self.samples {
            (0, 0) => (8, 8),
            (k, l) => (k.max(1), l.max(1)),
        }
    }

    /// The bound options of frame `frame` of `frames`: the smoothness bound, and looping when asked.
    pub fn bound_options(&self, frame: usize, frames: usize) -> BoundOptions {
        BoundOptions {
            smoothness: self.smoothness,
            looping: self.looping.then_some((frame, frames)),
        }
    }
}

/// One frame's result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameSolution {
    pub grid: Grid,
    pub lm: LmReport,
    /// Energy of the unwarped (rest) grid on this frame, for comparison.
    pub rest_energy: f64,
    pub seconds: f64,
}

/// Solve one frame: minimise the energy of `deformed` over the lines, starting from and bounded
/// around `previous` (and `first`, for looping frame `frame` of `frames`).
pub fn solve_frame(
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedFields,
    previous: &Grid,
    first: &Grid,
    (frame, frames): (usize, usize),
    options: &SolveOptions,
) -> Result<FrameSolution> {
    let start = Instant::now();
    let (k, l) = options.samples_per_cell();
    let energy = AaEnergy::new(rest, rest_grid, deformed, k, l);
    minimize_frame(
        energy,
        rest_grid,
        previous,
        first,
        (frame, frames),
        options,
        start,
    )
}

/// [`solve_frame`] on rest samples built beforehand ([`RestSamples::new`], once per sequence:
/// they depend on the rest fields, the rest grid and K×L only, the paper's preprocessing).
/// The samples' K×L is used (`options.samples` is not read); `seconds` is the frame's own
/// cost, without the samples' precomputation.
pub fn solve_frame_with_rest_samples(
    samples: &RestSamples,
    deformed: &DeformedFields,
    previous: &Grid,
    first: &Grid,
    (frame, frames): (usize, usize),
    options: &SolveOptions,
) -> Result<FrameSolution> {
    let start = Instant::now();
    let energy = AaEnergy::from_rest_samples(samples, deformed);
    minimize_frame(
        energy,
        samples.grid(),
        previous,
        first,
        (frame, frames),
        options,
        start,
    )
}

/// The solve of one frame given its energy (CPU or GPU objective alike): bounds around
/// `previous` (seed §5.2), the rest grid's energy for the report, LM from `previous` (seed
/// §5.3); `seconds` counts from `start` (so it includes building the energy).
pub fn minimize_frame(
    mut energy: impl Residuals + Send,
    rest_grid: &Grid,
    previous: &Grid,
    first: &Grid,
    (frame, frames): (usize, usize),
    options: &SolveOptions,
    start: Instant,
) -> Result<FrameSolution> {
    let bounds = frame_bounds(previous, first, &options.bound_options(frame, frames));
    let (report, rest_energy) = minimize_and_rest_energy(
        &mut energy,
        &previous.to_unknowns(),
        &rest_grid.to_unknowns(),
        &bounds,
        &options.lm,
    )?;
    Ok(FrameSolution {
        grid: rest_grid.with_unknowns(&report.x),
        lm: report,
        rest_energy,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// [`minimize`] from `start`, and the energy at `rest` for the report. The problem is handed
/// to the solver through [`Speculative`]: a trial point's normal equations are computed with
/// its energy while trials are being accepted (same iterates and result, fewer passes over
/// the samples; the grid-warp energies give the same F both ways). When the solver starts
/// at the rest point (a first frame, or a frame whose previous solution did not move) its
/// first evaluation already is F(rest), so no evaluation is spent on it.
pub fn minimize_and_rest_energy(
    energy: &mut (impl Residuals + Send),
    start: &[f64],
    rest: &[f64],
    bounds: &Bounds,
    options: &LmOptions,
) -> Result<(LmReport, f64)> {
    let report =
        on_pool_thread(|| minimize(&mut Speculative::new(&mut *energy), start, bounds, options))?;
    let rest_energy = if bounds.clamp(start) == rest {
        report.accepted_energies[0]
    } else {
        energy.energy(rest)
    };
    Ok((report, rest_energy))
}

/// `f()` run on a thread of rayon's pool (the calling thread if it is one): the solver's
/// parallel passes over the cells are then forked from a pool thread, which works on them
/// itself while the other threads steal, instead of a thread outside the pool handing each
/// pass over and sleeping until it is done (one wake-up per pass saved, tens of microseconds
/// on a busy machine). What `f` computes does not change.
fn on_pool_thread<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::scope(|_| f())
}

/// The frame loop of seed §5.3, shared by every sequence solver: frame j is solved by
/// `solve(j, previous, first)` warm-started from frame j − 1's solution (frame 0 from `start`),
/// `first` being frame 0's solution (the centre of the looping bounds; `start` for frame 0).
pub fn solve_frames<G, S>(
    start: &G,
    frames: usize,
    grid_of: impl Fn(&S) -> &G,
    mut solve: impl FnMut(usize, &G, &G) -> Result<S>,
) -> Result<Vec<S>> {
    let mut solutions: Vec<S> = Vec::with_capacity(frames);
    for j in 0..frames {
        let previous = solutions.last().map_or(start, &grid_of);
        let first = solutions.first().map_or(start, &grid_of);
        let solution = solve(j, previous, first)?;
        solutions.push(solution);
    }
    Ok(solutions)
}

/// Solve a whole sequence frame by frame, each frame warm-started from the previous solution
/// (the first from the rest grid). The rest samples are built once, before the first frame
/// (the first frame's `seconds` does not include them).
pub fn solve_sequence(
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedFields],
    options: &SolveOptions,
) -> Result<Vec<FrameSolution>> {
    let (k, l) = options.samples_per_cell();
    let samples = RestSamples::new(rest, rest_grid, k, l);
    solve_frames(
        rest_grid,
        frames.len(),
        |s: &FrameSolution| &s.grid,
        |j, previous, first| {
            let frame = (j, frames.len());
            solve_frame_with_rest_samples(&samples, &frames[j], previous, first, frame, options)
        },
    )
}

/// Solve a whole non-axis-aligned sequence frame by frame (seed §5.3 with §8's vertices), as
/// [`solve_sequence`] does for the lines: frame j starts from frame j − 1's vertices (frame 0
/// from `start`, normally [`VertexGrid::from_grid`] of the rest grid), its bounds are
/// [`naa_frame_bounds`] around them — foldover boxes, the smoothness bound o
/// and, with `looping`, the looping box around frame 0's solution — and every frame is solved by
/// [`solve_naa_frame`], on rest samples built once before the first frame
/// ([`NaaRestSamples`]; the first frame's `seconds` does not include them). The border mode
/// (fixed or sliding) is `start`'s.
///
/// Errors: those of [`solve_naa_frame`] (`start` of the wrong shape or
/// folded).
pub fn solve_naa_sequence(
    rest: &RestFields,
    rest_grid: &Grid,
    start: &VertexGrid,
    frames: &[DeformedJacobian],
    options: &SolveOptions,
) -> Result<Vec<NaaFrameSolution>> {
    let (k, l) = options.samples_per_cell();
    let samples = NaaRestSamples::new(rest, rest_grid, k, l);
    solve_frames(
        start,
        frames.len(),
        |s: &NaaFrameSolution| &s.vertices,
        |j, previous, first| {
            let frame = (j, frames.len());
            solve_naa_frame_with_rest_samples(&samples, &frames[j], previous, first, frame, options)
        },
    )
}

/// One NAA frame's result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NaaFrameSolution {
    pub vertices: VertexGrid,
    pub lm: LmReport,
    /// Energy of the rest vertices on this frame, for comparison.
    pub rest_energy: f64,
    pub seconds: f64,
}

/// Solve one NAA frame: minimise the energy of `deformed` over the interior vertices, starting
/// from and bounded around `previous` (and `first`, for looping frame `frame` of `frames`), as
/// [`solve_frame`] does for the AA lines. The border mode is `previous`'s
/// ([`VertexGrid::sliding_border`]).
///
/// Errors: `previous` or `first` does not match the rest grid's shape, or `previous` folds.
pub fn solve_naa_frame(
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedJacobian,
    previous: &VertexGrid,
    first: &VertexGrid,
    frame: (usize, usize),
    options: &SolveOptions,
) -> Result<NaaFrameSolution> {
    let start = Instant::now();
    let (k, l) = options.samples_per_cell();
    let samples = NaaRestSamples::new(rest, rest_grid, k, l);
    solve_naa_frame_from(start, &samples, deformed, previous, first, frame, options)
}

/// [`solve_naa_frame`] on rest samples built beforehand ([`NaaRestSamples::new`], once per
/// sequence: they depend on the rest fields, the rest grid and K×L only, the paper's
/// preprocessing). The samples' K×L is used (`options.samples` is not read); `seconds` is
/// the frame's own cost, without the samples' precomputation.
pub fn solve_naa_frame_with_rest_samples(
    samples: &NaaRestSamples,
    deformed: &DeformedJacobian,
    previous: &VertexGrid,
    first: &VertexGrid,
    frame: (usize, usize),
    options: &SolveOptions,
) -> Result<NaaFrameSolution> {
    let start = Instant::now();
    solve_naa_frame_from(start, samples, deformed, previous, first, frame, options)
}

/// The solve of [`solve_naa_frame`] given its rest samples; `seconds` counts from `start`.
fn solve_naa_frame_from(
    start: Instant,
    samples: &NaaRestSamples,
    deformed: &DeformedJacobian,
    previous: &VertexGrid,
    first: &VertexGrid,
    frame: (usize, usize),
    options: &SolveOptions,
) -> Result<NaaFrameSolution> {
    let energy = NaaEnergy::from_rest_samples(samples, deformed)
        .with_sliding_border(previous.sliding_border)
        .with_model(options.naa_model);
    let rest_vertices = energy.rest_vertices().clone();
    minimize_naa_frame(
        energy,
        &rest_vertices,
        previous,
        first,
        frame,
        options,
        start,
    )
}

/// The solve of one NAA frame given its energy (the fast [`NaaEnergy`] or the plain
/// [`super::plain::PlainNaaEnergy`] alike), as [`minimize_frame`] for the lines: bounds
/// [`naa_frame_bounds`] around `previous` (seed §5.2), the rest vertices' energy for the
/// report, LM from `previous` (seed §5.3); `seconds` counts from `start`. `rest_vertices`
/// are the energy's (their border mode is `previous`'s).
///
/// Errors: `previous` or `first` does not match the rest vertices' shape or border mode.
pub fn minimize_naa_frame(
    mut energy: impl Residuals + Send,
    rest_vertices: &VertexGrid,
    previous: &VertexGrid,
    first: &VertexGrid,
    (frame, frames): (usize, usize),
    options: &SolveOptions,
    start: Instant,
) -> Result<NaaFrameSolution> {
    let (m, n) = (rest_vertices.m, rest_vertices.n);
    for (name, g) in [("previous", previous), ("first", first)] {
        if (g.m, g.n, g.points.len()) != (m, n, m * n)
            || g.sliding_border != rest_vertices.sliding_border
        {
            return Err(Error::InvalidArgument(format!(
                "gridwarp naa: {name} vertex grid is {}×{} (sliding border {}) for a {m}×{n} \
                 rest grid (sliding border {})",
                g.m, g.n, g.sliding_border, rest_vertices.sliding_border
            )));
        }
    }
    let bound_options = options.bound_options(frame, frames);
    let bounds = naa_frame_bounds(previous, first, &bound_options);
    let (report, rest_energy) = minimize_and_rest_energy(
        &mut energy,
        &previous.to_unknowns(),
        &rest_vertices.to_unknowns(),
        &bounds,
        &options.lm,
    )?;
    Ok(NaaFrameSolution {
        vertices: rest_vertices.with_unknowns(&report.x),
        lm: report,
        rest_energy,
        seconds: start.elapsed().as_secs_f64(),
    })
}
