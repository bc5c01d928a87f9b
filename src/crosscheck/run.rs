//! Running cross-checks: collecting rows per adapter, the text table, and the verdict that
//! becomes `reparam crosscheck`'s exit code (the timing of each side is [`super::timing`]).

use serde::Serialize;

use super::{Row, Verdict};
use crate::error::{Error, Result};
use crate::report::sig;

/// The rows of one adapter.
#[derive(Clone, Debug, Serialize)]
pub struct AdapterRows {
    /// The adapter's one-line summary (name, backend, device type, driver).
    pub adapter: String,
    pub rows: Vec<Row>,
}

impl AdapterRows {
    /// The rows that fail their bound.
    pub fn failures(&self) -> impl Iterator<Item = &Row> {
        self.rows.iter().filter(|r| r.fails())
    }

    /// The same rows with figures rounded to 3 significant digits (for printing and JSON).
    pub fn rounded(&self) -> AdapterRows {
        AdapterRows {
            adapter: self.adapter.clone(),
            rows: self.rows.iter().map(|r| r.rounded(3)).collect(),
        }
    }
}

/// An adapter that `--all-adapters` found but could not run on.
#[derive(Clone, Debug, Serialize)]
pub struct SkippedAdapter {
    /// The adapter's one-line summary.
    pub adapter: String,
    /// Why: the error of its device request.
    pub reason: String,
}

/// What `reparam crosscheck … --json` prints.
#[derive(Clone, Debug, Serialize)]
pub struct CrosscheckReport {
    /// One entry per adapter run (one without `--all-adapters`).
    pub adapters: Vec<AdapterRows>,
    /// `adapter: algorithm kernel (input)` of every row over its bound; empty when all pass.
    pub failures: Vec<String>,
    /// With `--all-adapters`: the adapters that refused a device, so were not checked.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub skipped: Vec<SkippedAdapter>,
    /// 0 when every kernel is within its bound, 1 otherwise (the exit code).
    pub exit_code: u8,
    /// With `--sweep`: the sweeps (first adapter) and the paths of their plots.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sweeps: Vec<super::sweep::Sweep>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub plots: Vec<String>,
}

impl CrosscheckReport {
    /// The report of `adapters`' rows, its failures listed.
    pub fn new(adapters: Vec<AdapterRows>) -> CrosscheckReport {
        let failures: Vec<String> = adapters
            .iter()
            .flat_map(|a| {
                a.failures().map(move |r| {
                    format!("{}: {} {} ({})", a.adapter, r.algorithm, r.kernel, r.input)
                })
            })
            .collect();
        let exit_code = u8::from(!failures.is_empty());
        CrosscheckReport {
            adapters: adapters.iter().map(AdapterRows::rounded).collect(),
            failures,
            skipped: Vec::new(),
            exit_code,
            sweeps: Vec::new(),
            plots: Vec::new(),
        }
    }
}

fn ms(x: Option<f64>) -> String {
    x.map_or("–".into(), |v| sig(v, 2))
}

/// The table of one adapter's rows: kernel, input, count, max, p50, p99, RMS, unit, bound,
/// over, verdict, GPU ms (dispatches / whole call), CPU ms; then each row's bound formula and
/// note, numbered.
pub fn text_table(rows: &[Row]) -> (Vec<String>, Vec<Vec<String>>, Vec<String>) {
    let header = [
        "#",
        "algorithm",
        "kernel",
        "input",
        "count",
        "max",
        "p50",
        "p99",
        "RMS",
        "unit",
        "bound",
        "over",
        "verdict",
        "GPU ms",
        "GPU+IO ms",
        "CPU ms",
    ]
    .map(String::from)
    .to_vec();
    let mut body = Vec::new();
    let mut notes = Vec::new();
    for (n, r) in rows.iter().enumerate() {
        let e = &r.errors;
        let judged = r.verdict != Verdict::Missing;
        let cell = |x: f64| if judged { sig(x, 2) } else { "".into() };
        body.push(vec![
            (n + 1).to_string(),
            r.algorithm.clone(),
            r.kernel.clone(),
            r.input.clone(),
            if judged {
                e.count.to_string()
            } else {
                "".into()
            },
            cell(e.max_abs),
            cell(e.p50),
            cell(e.p99),
            cell(e.rms),
            e.unit.clone(),
            if judged && r.bound_per_element {
                format!("~{}", sig(r.bound, 2))
            } else {
                cell(r.bound)
            },
            if judged {
                r.over.to_string()
            } else {
                "".into()
            },
            r.verdict.word().into(),
            ms(r.timing.gpu_kernel_ms),
            ms(r.timing.gpu_total_ms),
            ms(r.timing.cpu_ms),
        ]);
        let mut text = Vec::new();
        if r.bound_per_element {
            text.push(format!(
                "bound per element (median shown, largest {}): {}",
                sig(r.bound_max, 2),
                r.bound_formula
            ));
        } else if !r.bound_formula.is_empty() {
            text.push(format!("bound {}", r.bound_formula));
        }
        if e.non_finite > 0 {
            text.push(format!("{} NaN/∞ from the GPU", e.non_finite));
        }
        if !r.note.is_empty() {
            text.push(r.note.clone());
        }
        notes.push(format!("{:>3}. {}", n + 1, text.join("; ")));
    }
    (header, body, notes)
}

/// The rows of several adapters side by side: per row, each adapter's max error, worst
/// error/bound and verdict.
pub fn side_by_side(adapters: &[AdapterRows]) -> Result<(Vec<String>, Vec<Vec<String>>)> {
    let Some(first) = adapters.first() else {
        return Err(Error::InvalidArgument("no adapter results".into()));
    };
    let mut header = vec!["kernel".to_string(), "input".to_string()];
    for (k, _) in adapters.iter().enumerate() {
        header.push(format!("[{k}] max"));
        header.push(format!("[{k}] err/bound"));
        header.push(format!("[{k}] verdict"));
    }
    let mut rows = Vec::new();
    for (n, r) in first.rows.iter().enumerate() {
        let mut row = vec![format!("{} {}", r.algorithm, r.kernel), r.input.clone()];
        for a in adapters {
            match a.rows.get(n) {
                Some(x) if x.verdict != Verdict::Missing => {
                    row.push(sig(x.errors.max_abs, 2));
                    row.push(sig(x.worst_ratio, 2));
                    row.push(x.verdict.word().into());
                }
                Some(x) => row.extend(["".into(), "".into(), x.verdict.word().into()]),
                None => row.extend(["".into(), "".into(), "".into()]),
            }
        }
        rows.push(row);
    }
    Ok((header, rows))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skipped_adapters_are_in_the_json_only_when_there_are_some() -> serde_json::Result<()> {
        let mut report = CrosscheckReport::new(Vec::new());
        let json = serde_json::to_value(&report)?;
        assert!(json.get("skipped").is_none(), "{json}");
        report.skipped.push(SkippedAdapter {
            adapter: "GPU (Gl)".into(),
            reason: "Parent device is lost".into(),
        });
        let json = serde_json::to_value(&report)?;
        assert_eq!(json["skipped"][0]["adapter"], "GPU (Gl)");
        assert_eq!(json["skipped"][0]["reason"], "Parent device is lost");
        Ok(())
    }
}
