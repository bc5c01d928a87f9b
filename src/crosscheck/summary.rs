//! [`ErrorSummary`]: the differences between a GPU result and the f64 reference, summarised
//! (max, relative max, RMS, quantiles, count over a tolerance, NaN/∞), and the rounding of
//! figures to significant digits. Imports nothing else of the harness, so that every other
//! file of it can import this one.

// `!(e <= tolerance)` is meant throughout: a NaN error counts as over any tolerance.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use serde::Serialize;

/// Differences between a GPU result and the f64 reference over many samples.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorSummary {
    /// What the errors are measured in (e.g. "texels of a 4096² texture").
    pub unit: String,
    /// Number of samples compared.
    pub count: usize,
    /// max |gpu − cpu|.
    pub max_abs: f64,
    /// max |gpu − cpu| / |cpu| over samples with |cpu| > 0.
    pub max_rel: f64,
    /// sqrt(mean |gpu − cpu|²).
    pub rms: f64,
    /// Median and 99th percentile of |gpu − cpu|.
    pub p50: f64,
    pub p99: f64,
    /// The tolerance the kernel is held to, and how many samples exceed it.
    pub tolerance: f64,
    pub over_tolerance: usize,
    /// Samples where the GPU returned NaN or ∞ while the reference was finite.
    pub non_finite: usize,
}

impl ErrorSummary {
    /// Summarise absolute errors `errors[n]` (already in `unit`) with reference magnitudes
    /// `magnitudes[n]` (for the relative error) against `tolerance`.
    pub fn from_errors(unit: &str, errors: &[f64], magnitudes: &[f64], tolerance: f64) -> Self {
        let non_finite = errors.iter().filter(|e| !e.is_finite()).count();
        let mut finite: Vec<f64> = errors.iter().copied().filter(|e| e.is_finite()).collect();
        finite.sort_by(f64::total_cmp);
        let quantile = |q: f64| {
            if finite.is_empty() {
                0.0
            } else {
                finite[((finite.len() - 1) as f64 * q).round() as usize]
            }
        };
        let max_rel = errors
            .iter()
            .zip(magnitudes)
            .filter(|(e, m)| e.is_finite() && **m > 0.0)
            // e / m overflows for a huge error over a subnormal magnitude: f64::MAX then.
            .map(|(e, m)| (e / m).min(f64::MAX))
            .fold(0.0, f64::max);
        let rms = (finite.iter().map(|e| e * e).sum::<f64>() / finite.len().max(1) as f64).sqrt();
        // Errors near f64::MAX (a candidate's 1e308) overflow the sum of squares: scaled by
        // the largest error then.
        let largest = finite.last().copied().unwrap_or(0.0);
        let rms = if rms.is_finite() {
            rms
        } else {
            largest
                * (finite.iter().map(|e| (e / largest).powi(2)).sum::<f64>() / finite.len() as f64)
                    .sqrt()
        };
        ErrorSummary {
            unit: unit.to_string(),
            count: errors.len(),
            max_abs: finite.last().copied().unwrap_or(0.0),
            max_rel,
            rms,
            p50: quantile(0.5),
            p99: quantile(0.99),
            tolerance,
            over_tolerance: errors.iter().filter(|e| !(**e <= tolerance)).count(),
            non_finite,
        }
    }

    /// The same summary with every figure rounded to `digits` significant digits (for
    /// snapshots and tables).
    pub fn rounded(&self, digits: u32) -> Self {
        let r = |x: f64| round_significant(x, digits);
        ErrorSummary {
            max_abs: r(self.max_abs),
            max_rel: r(self.max_rel),
            rms: r(self.rms),
            p50: r(self.p50),
            p99: r(self.p99),
            tolerance: r(self.tolerance),
            ..self.clone()
        }
    }

    /// Fraction of samples whose error exceeds `threshold` (e.g. one texel: the "speckle" rate).
    pub fn fraction_over(errors: &[f64], threshold: f64) -> f64 {
        errors.iter().filter(|e| !(**e <= threshold)).count() as f64 / errors.len().max(1) as f64
    }
}

/// Round `x` to `digits` significant digits: 3.7249e-7 → 3.7e-7 for two digits.
pub fn round_significant(x: f64, digits: u32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let magnitude = x.abs().log10().floor() as i32;
    let factor = 10f64.powi(digits as i32 - 1 - magnitude);
    // Format through a string so that the result is the shortest decimal with those digits.
    let rounded = format!("{:.*e}", (digits - 1) as usize, x)
        .parse()
        .unwrap_or((x * factor).round() / factor);
    // Near f64::MAX rounding up leaves the range (1.8e308): keep x then.
    if rounded.is_finite() {
        rounded
    } else {
        x
    }
}

/// f64 → f32 → f64: the value the GPU sees.
pub fn to_f32_precision(x: f64) -> f64 {
    x as f32 as f64
}
