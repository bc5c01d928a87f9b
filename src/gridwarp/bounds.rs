//! Bound constraints on the grid lines between frames (seed §5.2), for one axis at a time and
//! then packed like the unknowns.
//!
//! - Foldover C_F: line i stays between the midpoints to its neighbours in the previous solution,
//!   (s_{i−1} + s_i)/2 ≤ s_i' ≤ (s_i + s_{i+1})/2, shrunk by a relative margin so that lines stay
//!   strictly increasing (two lines could otherwise meet at a shared midpoint).
//! - Smoothness C_S: |s_i' − s_i| ≤ o.
//! - Looping C_L (frame j of K): |s_i' − s_i⁰| ≤ d_j·o with d_j = min(j, K − 1 − j), the seed's
//!   (K − |2(j+1) − K − 1| − 1)/2 simplified, so the last frame returns to the first frame's lines.
//! - Merge by priority (looping > foldover > smoothness): F(C_high, C_low) = C_high ∩ C_low when
//!   they intersect, else C_high. (The seed's three cases — disjoint or C_low ⊇ C_high: C_high;
//!   C_low ⊂ C_high: C_low; otherwise the intersection — are all this rule.)

use super::grid::Grid;
use crate::lm::Bounds;

/// A closed interval [lo, hi] (lo = hi freezes the variable).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    /// Everything.
    pub const ALL: Interval = Interval {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// [centre − radius, centre + radius].
    pub fn around(centre: f64, radius: f64) -> Interval {
        Interval {
            lo: centre - radius,
            hi: centre + radius,
        }
    }
}

/// The seed's merge F(C_high, C_low): the intersection if non-empty, else C_high.
pub fn merge(high: Interval, low: Interval) -> Interval {
    let both = Interval {
        lo: high.lo.max(low.lo),
        hi: high.hi.min(low.hi),
    };
    if both.lo <= both.hi {
        both
    } else {
        high
    }
}

/// A line may come no closer to a neighbour's midpoint than this fraction of their spacing:
/// keeps every cell's width positive (a_i > 0) while costing nothing measurable.
pub const FOLDOVER_MARGIN: f64 = 1e-6;

/// Foldover interval of interior line i of `lines` (seed eq. 5, with the margin).
pub fn foldover(lines: &[f64], i: usize) -> Interval {
    let (prev, here, next) = (lines[i - 1], lines[i], lines[i + 1]);
    Interval {
        lo: 0.5 * (prev + here) + FOLDOVER_MARGIN * (here - prev),
        hi: 0.5 * (here + next) - FOLDOVER_MARGIN * (next - here),
    }
}

/// d_j = min(j, K − 1 − j): how many smoothness steps frame j may be away from frame 0 in a
/// loop of K frames.
pub fn loop_distance(frame: usize, frames: usize) -> f64 {
    frame.min(frames.saturating_sub(1).saturating_sub(frame)) as f64
}

/// What constrains the lines of the next frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundOptions {
    /// Maximum movement o of a line between consecutive frames (None: unlimited).
    pub smoothness: Option<f64>,
    /// Looping animation: (this frame's index j, number of frames K).
    pub looping: Option<(usize, usize)>,
}

/// The merged bounds F(C_L, F(C_F, C_S)) of every unknown, given the previous frame's grid and,
/// for looping, the first frame's grid.
pub fn frame_bounds(previous: &Grid, first: &Grid, options: &BoundOptions) -> Bounds {
    let mut lower = Vec::new();
    let mut upper = Vec::new();
    for (lines, first_lines) in [(&previous.s, &first.s), (&previous.t, &first.t)] {
        for i in 1..lines.len() - 1 {
            let smooth = options
                .smoothness
                .map_or(Interval::ALL, |o| Interval::around(lines[i], o));
            let mut bound = merge(foldover(lines, i), smooth);
            if let (Some((frame, frames)), Some(o)) = (options.looping, options.smoothness) {
                bound = merge(
                    Interval::around(first_lines[i], loop_distance(frame, frames) * o),
                    bound,
                );
            }
            lower.push(bound.lo);
            upper.push(bound.hi);
        }
    }
    Bounds { lower, upper }
}
