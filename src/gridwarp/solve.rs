//! Solving frames (seed §5.3): the unknowns are all interior grid lines, the starting point is
//! the previous frame's solution (warm start), the bounds come from it (seed §5.2), and the
//! box-constrained Levenberg–Marquardt solver of [`crate::lm`] minimises the energy.

use std::time::Instant;

use super::bounds::{frame_bounds, BoundOptions};
use super::energy::{AaEnergy, DeformedFields, RestFields};
use super::grid::Grid;
use crate::error::Result;
use crate::lm::{minimize, LmOptions, LmReport};

/// Options of a gridwarp solve. Defaults: 8×8 midpoint samples per cell, the practical LM
/// preset ([`LmOptions::default`]), no smoothness bound, no looping.
#[derive(Clone, Debug, Default)]
pub struct SolveOptions {
    /// Midpoint-rule samples per cell (K, L); (0, 0) means the default 8×8.
    pub samples: (usize, usize),
    pub lm: LmOptions,
    /// Smoothness bound o between frames (None: foldover bounds only).
    pub smoothness: Option<f64>,
    /// Treat the sequence as a loop (needs `smoothness`).
    pub looping: bool,
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
    let mut energy = AaEnergy::new(rest, rest_grid, deformed, k, l);
    let bounds = frame_bounds(previous, first, &options.bound_options(frame, frames));
    let rest_energy = crate::lm::Residuals::energy(&mut energy, &rest_grid.to_unknowns());
    let report = minimize(&mut energy, &previous.to_unknowns(), &bounds, &options.lm)?;
    Ok(FrameSolution {
        grid: rest_grid.with_unknowns(&report.x),
        lm: report,
        rest_energy,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Solve a whole sequence frame by frame, each frame warm-started from the previous solution
/// (the first from the rest grid).
pub fn solve_sequence(
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedFields],
    options: &SolveOptions,
) -> Result<Vec<FrameSolution>> {
    let mut solutions: Vec<FrameSolution> = Vec::with_capacity(frames.len());
    for (j, deformed) in frames.iter().enumerate() {
        let previous = solutions.last().map_or(rest_grid, |s| &s.grid);
        let first = solutions.first().map_or(rest_grid, |s| &s.grid);
        let solution = solve_frame(
            rest,
            rest_grid,
            deformed,
            previous,
            first,
            (j, frames.len()),
            options,
        )?;
        solutions.push(solution);
    }
    Ok(solutions)
}
