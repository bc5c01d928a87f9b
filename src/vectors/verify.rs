//! `reparam verify`: judge a candidate implementation's output against conformance vectors,
//! with the metric and per-element bounds of the manifest (the cross-check's own).

// `!(e <= bound)` is meant: a NaN or ∞ error counts as over any bound.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::Path;

use serde::Serialize;

use super::{read_manifest, Array, Dtype, KernelVectors, Metric};
use crate::crosscheck::ErrorSummary;
use crate::error::{Error, Result};

/// How many of the worst elements a report lists.
pub const WORST_LISTED: usize = 5;

/// One of the worst elements.
#[derive(Clone, Debug, Serialize)]
pub struct WorstElement {
    /// Its index in the expected array (the last axis left out for a vector metric).
    pub index: Vec<usize>,
    /// |candidate − expected| in the metric's unit; `None` (JSON `null`) where the candidate's
    /// value is NaN or ∞: the error is unbounded and the element counts in `non_finite`.
    pub error: Option<f64>,
    pub bound: f64,
    /// The kernel's input rows for it: every input whose first axis runs along the element's
    /// first index, at that index (at most 12 values each).
    pub inputs: Vec<(String, Vec<f64>)>,
}

/// What `reparam verify` prints.
#[derive(Clone, Debug, Serialize)]
pub struct VerifyReport {
    pub kernel: String,
    pub candidate: String,
    /// The candidate's dtype as read (`f32` or `f64`).
    pub candidate_dtype: Dtype,
    pub bound_formula: String,
    /// The errors, their quantiles and how many exceed their own bound (`over_tolerance`),
    /// `non_finite` counting each NaN or ∞ of the candidate.
    pub errors: ErrorSummary,
    /// The largest per-element bound.
    pub bound_max: f64,
    pub worst: Vec<WorstElement>,
    /// `true` when every element is finite and within its bound.
    pub pass: bool,
    /// `"pass"` or `"fail"`: [`pass`](Self::pass) as the word scripts compare.
    pub verdict: &'static str,
    /// The largest error / bound over the elements (> 1 fails); `f64::MAX` when an error is NaN
    /// or ∞, or a non-zero error meets a zero bound.
    pub worst_ratio: f64,
    /// Elements over their own bound, NaN/∞ included (= `errors.over_tolerance`).
    pub over: usize,
    /// Elements whose candidate value is NaN or ∞ (= `errors.non_finite`).
    pub non_finite: usize,
}

/// The kernel of `manifest` a candidate is for: `--kernel NAME`, else the only one, else the one
/// named by the candidate's file stem.
pub fn choose<'a>(
    kernels: &'a [KernelVectors],
    name: Option<&str>,
    candidate: &Path,
    dir: &Path,
) -> Result<&'a KernelVectors> {
    let names = || {
        kernels
            .iter()
            .map(|k| k.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let stem = candidate
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let wanted = match name {
        Some(n) => Some(n.to_string()),
        None if kernels.len() == 1 => Some(kernels[0].name.clone()),
        None => kernels
            .iter()
            .find(|k| k.name == stem)
            .map(|k| k.name.clone()),
    };
    let manifest = dir.join("manifest.json").display().to_string();
    match wanted {
        Some(w) => kernels
            .iter()
            .find(|k| k.name == w)
            .ok_or_else(|| Error::Vectors {
                file: manifest,
                reason: format!("no kernel '{w}'; the vectors have: {}", names()),
            }),
        None => Err(Error::Vectors {
            file: manifest,
            reason: format!(
                "name the kernel with --kernel (or name the candidate <kernel>.npy): one of {}",
                names()
            ),
        }),
    }
}

/// Verify the candidate output `candidate` (a `.npy` of the expected shape, f32 or f64) against
/// the vectors in `dir`.
pub fn verify(dir: &Path, candidate: &Path, kernel: Option<&str>) -> Result<VerifyReport> {
    let manifest = read_manifest(dir)?;
    let k = choose(&manifest.kernels, kernel, candidate, dir)?;
    let cand = Array::load(candidate)?;
    verify_array(dir, k, &cand, &candidate.display().to_string())
}

/// [`verify`] of a candidate already in memory (`file` names it in errors and the report), for
/// kernel `k` of the vectors in `dir`: what the mutation tests and the twins' model checks use.
pub fn verify_array(
    dir: &Path,
    k: &KernelVectors,
    cand: &Array,
    file: &str,
) -> Result<VerifyReport> {
    let expected = Array::load(&dir.join(&k.expected.file))?;
    let bound = Array::load(&dir.join(&k.bound.file))?.to_f64();
    let file = file.to_string();
    if !matches!(cand.dtype(), Dtype::F32 | Dtype::F64) {
        return Err(Error::Vectors {
            file,
            reason: format!(
                "dtype {}; a candidate output is f32 (<f4) or f64 (<f8)",
                cand.dtype().descr()
            ),
        });
    }
    let wanted = k.metric.candidate_shape(&expected.shape);
    if cand.shape != wanted {
        return Err(Error::Vectors {
            file,
            reason: format!(
                "shape {:?}; kernel {} expects {:?} ({})",
                cand.shape,
                k.name,
                wanted,
                candidate_meaning(k)
            ),
        });
    }
    let element_shape = k.metric.element_shape(&expected.shape);
    let last = expected.len() / element_shape.iter().product::<usize>().max(1);
    let errors = match k.metric.errors(&expected.to_f64(), &cand.to_f64(), last) {
        Some(e) => e,
        None => super::bpm::errors_at_samples(dir, k, &expected.to_f64(), &cand.to_f64())?,
    };
    if errors.len() != bound.len() {
        return Err(Error::Vectors {
            file: dir.join(&k.bound.file).display().to_string(),
            reason: format!("{} bounds for {} elements", bound.len(), errors.len()),
        });
    }
    let over = errors
        .iter()
        .zip(&bound)
        .filter(|(e, b)| !(**e <= **b))
        .count();
    let bound_max = bound.iter().copied().fold(0.0, f64::max);
    let magnitudes = k.metric.magnitudes(&expected.to_f64(), last);
    let mut summary = ErrorSummary::from_errors(k.metric.unit(), &errors, &magnitudes, bound_max);
    summary.over_tolerance = over;
    // Worst first: non-finite errors, then by error / bound.
    let ratio = |n: usize| {
        if !errors[n].is_finite() {
            f64::INFINITY
        } else if errors[n] == 0.0 {
            0.0
        } else {
            errors[n] / bound[n]
        }
    };
    let worst_ratio = (0..errors.len())
        .map(|n| ratio(n).min(f64::MAX))
        .fold(0.0, f64::max);
    let mut order: Vec<usize> = (0..errors.len()).collect();
    order.sort_by(|&a, &b| ratio(b).total_cmp(&ratio(a)).then(a.cmp(&b)));
    let inputs: Vec<(String, Array)> = k
        .inputs
        .iter()
        .filter(|i| i.indexed_by_element)
        .map(|i| Ok((i.file.clone(), Array::load(&dir.join(&i.file))?)))
        .collect::<Result<_>>()?;
    let worst = order
        .iter()
        .take(WORST_LISTED)
        .map(|&n| {
            let index = unflatten(n, &element_shape);
            let rows = inputs
                .iter()
                .filter(|(_, a)| !index.is_empty() && !a.shape.is_empty() && index[0] < a.shape[0])
                .map(|(name, a)| {
                    let width = a.len() / a.shape[0].max(1);
                    let values = a.to_f64();
                    let row = &values[index[0] * width..(index[0] + 1) * width];
                    (name.clone(), row.iter().take(12).copied().collect())
                })
                .collect();
            WorstElement {
                index,
                error: Some(errors[n]).filter(|e| e.is_finite()),
                bound: bound[n],
                inputs: rows,
            }
        })
        .collect();
    Ok(VerifyReport {
        kernel: k.name.clone(),
        candidate: file,
        candidate_dtype: cand.dtype(),
        bound_formula: k.bound_formula.clone(),
        pass: over == 0 && summary.non_finite == 0,
        verdict: if over == 0 && summary.non_finite == 0 {
            "pass"
        } else {
            "fail"
        },
        worst_ratio,
        over,
        non_finite: summary.non_finite,
        errors: summary,
        bound_max,
        worst,
    })
}

/// What a candidate's array holds: the expected array's meaning, or for a precompute the
/// per-face rows.
fn candidate_meaning(k: &KernelVectors) -> String {
    match k.metric {
        Metric::BpmMapsAtSamples { .. } => super::bpm::CANDIDATE_MAPS_MEANING.to_string(),
        _ => k.expected.meaning.clone(),
    }
}

/// The multi-index of flat position `n` in C order.
fn unflatten(mut n: usize, shape: &[usize]) -> Vec<usize> {
    let mut index = vec![0; shape.len()];
    for (k, &d) in shape.iter().enumerate().rev() {
        index[k] = n % d.max(1);
        n /= d.max(1);
    }
    index
}
