//! One row of a cross-check table: a kernel (or a whole run) compared with the f64 reference on
//! one input, its error figures in the kernel's natural unit, the derived bound (formula and
//! value), how many elements exceed it, the verdict and the times.
//!
//! Every algorithm's cross-check (`crosscheck::{bpm, gridwarp, unwarp, maps, skinsimp}`) builds
//! its rows with [`Row::compare`], from per-element errors and the bound functions of its own
//! module, which the tests call too: a bound is written once.

// `!(e <= bound)` is meant throughout: a NaN error counts as over any bound.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use serde::Serialize;

use super::summary::{round_significant, ErrorSummary};

/// What a row concludes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Every element within its bound, and every GPU value finite.
    Pass,
    /// Some element over its bound, or a NaN/∞ from the GPU.
    Fail,
    /// Figures shown for comparison, not judged (e.g. the seed's determinant fit, whose
    /// speckling is the point of showing it).
    Info,
    /// The reference has this computation and the GPU side has no kernel for it.
    Missing,
}

impl Verdict {
    /// The word printed in tables.
    pub fn word(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Fail => "FAIL",
            Verdict::Info => "info",
            Verdict::Missing => "no GPU kernel",
        }
    }
}

/// The bound each element is held to: one value for all, or one per element (then the row
/// shows the largest).
#[derive(Clone, Debug)]
pub enum Bounds {
    Uniform(f64),
    PerElement(Vec<f64>),
}

impl Bounds {
    fn of(&self, n: usize) -> f64 {
        match self {
            Bounds::Uniform(b) => *b,
            Bounds::PerElement(b) => b[n],
        }
    }
}

/// Wall-clock times of one row, in milliseconds (absent where not measured).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Timing {
    /// GPU time of the kernel's dispatches alone, submission to completion
    /// (`reparam_gpu::Clock`), without uploads and readbacks.
    pub gpu_kernel_ms: Option<f64>,
    /// The whole GPU call: uploads, dispatches, readback.
    pub gpu_total_ms: Option<f64>,
    /// The f64 reference on the CPU (all threads).
    pub cpu_ms: Option<f64>,
}

/// One row of a cross-check table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// `bpm`, `gridwarp`, `unwarp`, `maps` or `skinsimp`.
    pub algorithm: String,
    /// The WGSL kernel and the quantity compared, e.g. `gridwarp_aa: JᵀJ`; whole runs are
    /// named `run: …`.
    pub kernel: String,
    /// The input (mesh, scene or map name).
    pub input: String,
    /// Error figures; `count` is 0 for a missing kernel.
    pub errors: ErrorSummary,
    /// The bound's formula (ε = u = 2⁻²³ is one WGSL rounding (up or down: one ULP)) …
    pub bound_formula: String,
    /// … and its value: the bound itself, or, when each element has its own, their median
    /// (`bound_per_element`) …
    pub bound: f64,
    /// … whether each element has its own bound …
    pub bound_per_element: bool,
    /// … and the largest of them (= `bound` for a uniform bound).
    pub bound_max: f64,
    /// Elements over their own bound (NaN/∞ included).
    pub over: usize,
    /// Elements the GPU returned as NaN or ∞ where the reference is finite (= `errors.non_finite`).
    pub non_finite: usize,
    /// max error / bound over the elements (≤ 1 when all pass); `f64::MAX` when an error is
    /// NaN or ∞ or exceeds a zero bound (JSON has no ∞; the verdict is a fail either way).
    pub worst_ratio: f64,
    pub verdict: Verdict,
    /// Anything the figures need to be read right (what was left out and why).
    pub note: String,
    pub timing: Timing,
}

impl Row {
    /// Compare: `errors[n]` in `unit` against `bounds`; `magnitudes[n]` are the reference
    /// values' sizes in the same unit (for the relative error; pass `&[]` when not meaningful).
    #[allow(clippy::too_many_arguments)] // the row's eight facts, each named at the call
    pub fn compare(
        algorithm: &str,
        kernel: &str,
        input: &str,
        unit: &str,
        errors: &[f64],
        magnitudes: &[f64],
        bounds: Bounds,
        bound_formula: &str,
    ) -> Row {
        let (shown, largest) = match &bounds {
            Bounds::Uniform(b) => (*b, *b),
            Bounds::PerElement(b) => {
                // Unbounded elements (f64::MAX, as JSON has no ∞) are counted in the notes,
                // not shown as the largest bound.
                let mut sorted: Vec<f64> = b.iter().copied().filter(|&x| x < f64::MAX).collect();
                sorted.sort_by(f64::total_cmp);
                let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
                (median, sorted.last().copied().unwrap_or(0.0))
            }
        };
        let ones;
        let magnitudes = if magnitudes.len() == errors.len() {
            magnitudes
        } else {
            ones = vec![0.0; errors.len()];
            &ones
        };
        let summary = ErrorSummary::from_errors(unit, errors, magnitudes, largest);
        let mut over = 0;
        let mut worst: f64 = 0.0;
        for (n, &e) in errors.iter().enumerate() {
            let b = bounds.of(n);
            if !(e <= b) {
                over += 1;
            }
            let ratio = if e == 0.0 { 0.0 } else { e / b };
            worst = if ratio.is_nan() {
                f64::MAX
            } else {
                worst.max(ratio.min(f64::MAX))
            };
        }
        let errors = ErrorSummary {
            over_tolerance: over,
            ..summary
        };
        let non_finite = errors.non_finite;
        let verdict = if over == 0 && non_finite == 0 {
            Verdict::Pass
        } else {
            Verdict::Fail
        };
        Row {
            algorithm: algorithm.into(),
            kernel: kernel.into(),
            input: input.into(),
            errors,
            bound_formula: bound_formula.into(),
            bound: shown,
            bound_per_element: matches!(bounds, Bounds::PerElement(_)),
            bound_max: largest,
            over,
            non_finite,
            worst_ratio: worst,
            verdict,
            note: String::new(),
            timing: Timing::default(),
        }
    }

    /// A row from a summary made elsewhere, whose elements were each held to their own bound:
    /// `over` of them exceeded it, the worst by `worst_ratio`. The summary's `tolerance` is
    /// the bound shown (the largest per-element bound).
    pub fn from_summary(
        algorithm: &str,
        kernel: &str,
        input: &str,
        summary: &ErrorSummary,
        over: usize,
        worst_ratio: f64,
        bound_formula: &str,
    ) -> Row {
        let verdict = if over == 0 && summary.non_finite == 0 {
            Verdict::Pass
        } else {
            Verdict::Fail
        };
        Row {
            algorithm: algorithm.into(),
            kernel: kernel.into(),
            input: input.into(),
            errors: ErrorSummary {
                over_tolerance: over,
                ..summary.clone()
            },
            bound_formula: bound_formula.into(),
            bound: summary.tolerance,
            bound_per_element: false,
            bound_max: summary.tolerance,
            over,
            non_finite: summary.non_finite,
            worst_ratio: if worst_ratio.is_nan() {
                f64::MAX
            } else {
                worst_ratio.min(f64::MAX)
            },
            verdict,
            note: String::new(),
            timing: Timing::default(),
        }
    }

    /// A computation of the reference that has no GPU kernel: a row of its own, so the table
    /// never leaves it out silently.
    pub fn missing(algorithm: &str, kernel: &str, input: &str, why: &str) -> Row {
        Row {
            algorithm: algorithm.into(),
            kernel: kernel.into(),
            input: input.into(),
            errors: ErrorSummary::from_errors("", &[], &[], 0.0),
            bound_formula: String::new(),
            bound: 0.0,
            bound_per_element: false,
            bound_max: 0.0,
            over: 0,
            non_finite: 0,
            worst_ratio: 0.0,
            verdict: Verdict::Missing,
            note: why.into(),
            timing: Timing::default(),
        }
    }

    /// The same row, shown for comparison and not judged.
    pub fn informative(self, why: &str) -> Row {
        Row {
            verdict: Verdict::Info,
            note: why.into(),
            ..self
        }
    }

    /// [`Self::informative`] when `condition` holds, else the row unchanged.
    pub fn informative_if(self, condition: bool, why: &str) -> Row {
        if condition {
            self.informative(why)
        } else {
            self
        }
    }

    /// The same row with a note.
    pub fn with_note(self, note: &str) -> Row {
        Row {
            note: note.into(),
            ..self
        }
    }

    /// The same row with its times.
    pub fn with_timing(self, timing: Timing) -> Row {
        Row { timing, ..self }
    }

    /// The same row with its figures rounded to `digits` significant digits.
    pub fn rounded(&self, digits: u32) -> Row {
        let r = |x: f64| round_significant(x, digits);
        let t = |x: Option<f64>| x.map(r);
        Row {
            errors: self.errors.rounded(digits),
            bound: r(self.bound),
            bound_max: r(self.bound_max),
            worst_ratio: r(self.worst_ratio),
            timing: Timing {
                gpu_kernel_ms: t(self.timing.gpu_kernel_ms),
                gpu_total_ms: t(self.timing.gpu_total_ms),
                cpu_ms: t(self.timing.cpu_ms),
            },
            ..self.clone()
        }
    }

    /// Whether the row fails its bound (missing kernels and informative rows do not).
    pub fn fails(&self) -> bool {
        self.verdict == Verdict::Fail
    }
}
