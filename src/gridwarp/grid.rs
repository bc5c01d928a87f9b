//! The rectilinear grid: lines 0 = s₀ < s₁ < … < s_{M−1} = 1 and 0 = t₀ < … < t_{N−1} = 1, the
//! starting grid from the rigidity map (seed Algorithm 1), and the packing of the interior lines
//! into the unknown vector x = (s₁ … s_{M−2}, t₁ … t_{N−2}) of the axis-aligned problem.

use super::field::Field;
use crate::error::{Error, Result};

/// Grid lines along s (vertical lines) and t (horizontal lines), each including 0 and 1.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Grid {
    pub s: Vec<f64>,
    pub t: Vec<f64>,
}

impl Grid {
    /// A grid from its lines; checks 0 and 1 at the ends and strictly increasing lines.
    pub fn new(s: Vec<f64>, t: Vec<f64>) -> Result<Grid> {
        for (name, lines) in [("s", &s), ("t", &t)] {
            let ok = lines.len() >= 2
                && lines[0] == 0.0
                && *lines.last().unwrap_or(&0.0) == 1.0
                && lines.windows(2).all(|w| w[0] < w[1]);
            if !ok {
                return Err(Error::InvalidArgument(format!(
                    "grid {name} lines must start at 0, end at 1 and increase strictly: {lines:?}"
                )));
            }
        }
        Ok(Grid { s, t })
    }

    /// A uniform grid of `m` × `n` lines.
    pub fn uniform(m: usize, n: usize) -> Grid {
        let lines = |k: usize| {
            (0..k.max(2))
                .map(|i| i as f64 / (k.max(2) - 1) as f64)
                .collect()
        };
        Grid {
            s: lines(m),
            t: lines(n),
        }
    }

    /// Number of unknowns of the axis-aligned problem, M + N − 4.
    pub fn unknowns(&self) -> usize {
        self.s.len() + self.t.len() - 4
    }

    /// x = (s₁ … s_{M−2}, t₁ … t_{N−2}).
    pub fn to_unknowns(&self) -> Vec<f64> {
        let (m, n) = (self.s.len(), self.t.len());
        self.s[1..m - 1]
            .iter()
            .chain(&self.t[1..n - 1])
            .copied()
            .collect()
    }

    /// The grid with interior lines taken from `x` (the inverse of [`Grid::to_unknowns`]).
    pub fn with_unknowns(&self, x: &[f64]) -> Grid {
        let mut g = self.clone();
        g.set_unknowns(x);
        g
    }

    /// Set the interior lines to `x` (as [`Grid::with_unknowns`], in place).
    pub fn set_unknowns(&mut self, x: &[f64]) {
        let m = self.s.len();
        self.s[1..m - 1].copy_from_slice(&x[..m - 2]);
        let n = self.t.len();
        self.t[1..n - 1].copy_from_slice(&x[m - 2..]);
    }
}

/// Seed Algorithm 1, one axis: r_j = max over the other axis of R in column j; a new line
/// wherever |r_j − r_{j+1}| > ε, on the boundary (j + 1)/W between the two columns.
///
/// The extracted seed garbles the line's exact position ("placed toward the rigid side" between
/// two candidate fractions); the boundary itself is what its §4 asks for ("rigid areas are
/// enclosed in cells as tightly as possible"): the rigid column's cell starts or ends exactly
/// where the rigid texels do.
pub fn lines_from_profile(profile: &[f64], epsilon: f64) -> Vec<f64> {
    let w = profile.len() as f64;
    let mut lines = vec![0.0];
    for j in 0..profile.len().saturating_sub(1) {
        if (profile[j] - profile[j + 1]).abs() > epsilon {
            lines.push((j + 1) as f64 / w);
        }
    }
    lines.push(1.0);
    lines
}

/// The starting grid from the rigidity map `r` and threshold ε (seed Algorithm 1): s lines from
/// the column maxima, t lines from the row maxima.
pub fn grid_from_rigidity(r: &Field, epsilon: f64) -> Grid {
    let columns: Vec<f64> = (0..r.width)
        .map(|x| {
            (0..r.height)
                .map(|y| r.values[y * r.width + x])
                .fold(f64::MIN, f64::max)
        })
        .collect();
    let rows: Vec<f64> = (0..r.height)
        .map(|y| {
            r.values[y * r.width..(y + 1) * r.width]
                .iter()
                .copied()
                .fold(f64::MIN, f64::max)
        })
        .collect();
    Grid {
        s: lines_from_profile(&columns, epsilon),
        t: lines_from_profile(&rows, epsilon),
    }
}
