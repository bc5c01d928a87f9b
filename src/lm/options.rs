//! [`LmOptions`](super::LmOptions) (ALGLIB `minlm`'s tolerances and iteration cap, with their defaults) and what
//! [`super::minimize`] reports ([`LmReport`], [`StopCode`](super::StopCode)).

use std::fmt;

use serde::Serialize;

use crate::error::{Error, Result};

// ------------------------------------------------------------------------------------------
// Options and report
// ------------------------------------------------------------------------------------------

/// Stopping tolerances. Each tolerance 0 turns its test off.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LmOptions {
    /// Stop (code 4) when the projected gradient ∇F = 2Jᵀr has max-norm ≤ epsg (absolute,
    /// units of F per unit of x). Default 1e-12.
    pub epsg: f64,
    /// Stop (code 1) when an accepted step changes F by (F − F_new)/F ≤ epsf (relative).
    /// Default 1e-12: about 4500 ulps, far below any visible difference in a warped texture.
    pub epsf: f64,
    /// Stop (code 2) when a proposed step has max_i |h_i| ≤ epsx (absolute, units of x),
    /// before evaluating it: it could not move x by more than epsx.
    /// Default 1e-12 (the grid-warp unknowns live in [0, 1]).
    pub epsx: f64,
    /// Stop (code 5) after this many accepted steps. Default 100 (the paper's). 0 = no step.
    pub max_iterations: usize,
}

impl LmOptions {
    /// The paper's ALGLIB settings (seed §9, "Results"): all tolerances 0, 100 iterations. Runs end by
    /// code 7 (λ overflow after a string of rejected trials) or 5.
    pub fn paper() -> Self {
        LmOptions {
            epsg: 0.0,
            epsf: 0.0,
            epsx: 0.0,
            max_iterations: 100,
        }
    }

    /// Tolerances finite and ≥ 0.
    pub(super) fn check(&self) -> Result<()> {
        for (name, v) in [
            ("epsg", self.epsg),
            ("epsf", self.epsf),
            ("epsx", self.epsx),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::InvalidArgument(format!(
                    "lm: tolerance {name} = {v} must be finite and ≥ 0"
                )));
            }
        }
        Ok(())
    }
}

impl Default for LmOptions {
    /// epsg = epsf = epsx = 1e-12, 100 iterations: reaches the paper preset's energy (to about
    /// 1e-12 relative) without the paper preset's final string of rejected trials.
    fn default() -> Self {
        LmOptions {
            epsg: 1e-12,
            epsf: 1e-12,
            epsx: 1e-12,
            max_iterations: 100,
        }
    }
}

/// Why the solver stopped; the discriminants are ALGLIB's termination codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[repr(u8)]
pub enum StopCode {
    /// 1: the relative energy change of an accepted step was ≤ epsf.
    RelativeEnergyChange = 1,
    /// 2: a proposed step's max-norm was ≤ epsx (the run stops before evaluating it).
    SmallStep = 2,
    /// 4: the projected gradient's max-norm was ≤ epsg, or F = 0.
    SmallGradient = 4,
    /// 5: `max_iterations` steps were accepted.
    MaxIterations = 5,
    /// 7: no further decrease possible: zero box step, or λ overflow.
    NoProgress = 7,
}

impl StopCode {
    /// ALGLIB's numeric termination code.
    pub fn code(self) -> u8 {
        self as u8
    }
}

impl fmt::Display for StopCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let why = match self {
            StopCode::RelativeEnergyChange => "relative energy change ≤ epsf",
            StopCode::SmallStep => "step ≤ epsx",
            StopCode::SmallGradient => "projected gradient ≤ epsg (or zero energy)",
            StopCode::MaxIterations => "maximum number of iterations",
            StopCode::NoProgress => "no further progress possible (λ overflow or zero step)",
        };
        write!(f, "{} ({why})", self.code())
    }
}

/// The outcome of [`minimize`](super::minimize).
#[derive(Clone, Debug, Serialize)]
pub struct LmReport {
    /// The last accepted point (x₀ clamped into the bounds if no step was accepted).
    pub x: Vec<f64>,
    /// F(x).
    pub energy: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Calls to [`Residuals::energy`](super::Residuals::energy) (one per trial point).
    pub energy_evaluations: usize,
    /// Calls to [`Residuals::normal_equations`](super::Residuals::normal_equations) (x₀ and accepted points).
    pub jacobian_evaluations: usize,
    /// Why it stopped.
    pub stop: StopCode,
    /// F(x₀) followed by the energy after each accepted step (length `iterations + 1`),
    /// strictly decreasing.
    pub accepted_energies: Vec<f64>,
}
