//! Exit codes that never lie (issue #33): `verify` and `crosscheck` exit 0 on pass, 1 on a
//! failing verdict and 2 on bad input whatever happens to their standard output: written
//! normally, closed before the first byte (`| head -0`), or closed after one line (`| head -1`).
//! When stdout is gone the verdict also goes to stderr. Under `--json` bad input writes
//! `{"error": …, "exit_code": 2}` on stdout, and `verify --json` carries the verdict, the worst
//! error/bound ratio, the count over and the NaN/∞ count.
#![cfg(feature = "gpu")]

mod common;

use std::path::{Path, PathBuf};

use common::cli::{reparam_with_stdout as reparam, Stdout};
use reparam::vectors::{read_manifest, Array, Metric};
use reparam_gpu::gpu_or_skip;
use serde_json::Value;

const ALL: [Stdout; 3] = [
    Stdout::Read,
    Stdout::ClosedAtOnce,
    Stdout::ClosedAfterOneLine,
];

/// A kernel of the canonical BPM vectors with a per-element vector metric (`bpm_eval`): the
/// folder, its name, the expected array and the per-element bounds.
fn kernel() -> (PathBuf, String, Array, Vec<f64>) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors/bpm");
    let manifest = read_manifest(&dir).unwrap();
    let k = manifest
        .kernels
        .iter()
        .find(|k| matches!(k.metric, Metric::NormOfLastAxis { .. }))
        .unwrap();
    let expected = Array::load(&dir.join(&k.expected.file)).unwrap();
    let bound = Array::load(&dir.join(&k.bound.file)).unwrap().to_f64();
    (dir, k.name.clone(), expected, bound)
}

/// Candidates for [`kernel`]: the expected values themselves (pass), one element moved by
/// three times its bound (fail), a NaN (fail) and a wrong shape (bad input), in `dir`.
fn candidates(dir: &Path) -> [(PathBuf, i32); 4] {
    let (_, _, expected, bound) = kernel();
    let values = expected.to_f64();
    let last = *expected.shape.last().unwrap();
    let save = |name: &str, shape: &[usize], v: Vec<f64>| {
        let path = dir.join(name);
        Array::f64(shape, v).save(&path).unwrap();
        path
    };
    let mut off = values.clone();
    // Element 3 is the vector values[3·last..4·last]: its first coordinate moved by
    // 3 · bound / scale, so that its error scale · |Δ| is three times its bound.
    let scale = match kernel_metric() {
        Metric::NormOfLastAxis { scale, .. } => scale,
        _ => unreachable!(),
    };
    off[3 * last] += 3.0 * bound[3] / scale;
    let mut nan = values.clone();
    nan[0] = f64::NAN;
    [
        (save("pass.npy", &expected.shape, values.clone()), 0),
        (save("off.npy", &expected.shape, off), 1),
        (save("nan.npy", &expected.shape, nan), 1),
        (save("shape.npy", &[values.len()], values), 2),
    ]
}

fn kernel_metric() -> Metric {
    let (dir, name, _, _) = kernel();
    read_manifest(&dir)
        .unwrap()
        .kernels
        .into_iter()
        .find(|k| k.name == name)
        .unwrap()
        .metric
}

#[test]
fn verify_exits_by_its_verdict_whatever_happens_to_stdout() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, name, _, _) = kernel();
    for (candidate, code) in candidates(tmp.path()) {
        for json in [false, true] {
            for stdout in ALL {
                let mut args = vec![
                    "verify",
                    dir.to_str().unwrap(),
                    "--candidate",
                    candidate.to_str().unwrap(),
                    "--kernel",
                    &name,
                ];
                if json {
                    args.push("--json");
                }
                let (got, _, stderr) = reparam(&args, stdout);
                assert_eq!(
                    got,
                    code,
                    "{} {stdout:?} json {json}: {stderr}",
                    candidate.display()
                );
                if matches!(stdout, Stdout::ClosedAtOnce) && code != 2 {
                    let word = if code == 0 { "pass" } else { "FAIL" };
                    assert!(
                        stderr.contains(&format!("verify {name}: {word}")),
                        "the verdict on stderr when stdout is gone: {stderr}"
                    );
                }
            }
        }
    }
}

#[test]
fn verify_json_carries_the_verdict_and_bad_input_an_error_object() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, name, _, _) = kernel();
    let [pass, off, nan, shape] = candidates(tmp.path());
    let json = |candidate: &Path| {
        let (code, stdout, _) = reparam(
            &[
                "verify",
                dir.to_str().unwrap(),
                "--candidate",
                candidate.to_str().unwrap(),
                "--kernel",
                &name,
                "--json",
            ],
            Stdout::Read,
        );
        (code, serde_json::from_str::<Value>(&stdout).unwrap())
    };
    let (_, v) = json(&pass.0);
    assert_eq!(v["verdict"], "pass");
    assert_eq!(v["worst_ratio"], 0.0);
    assert_eq!(v["over"], 0);
    let (_, v) = json(&off.0);
    assert_eq!(v["verdict"], "fail");
    assert_eq!(v["over"], 1);
    let ratio = v["worst_ratio"].as_f64().unwrap();
    assert!((ratio - 3.0).abs() < 1e-6, "worst ratio {ratio}");
    // The error is not 0, so neither is its relative size.
    assert!(v["errors"]["max_rel"].as_f64().unwrap() > 0.0, "{v}");
    let (_, v) = json(&nan.0);
    assert_eq!(v["verdict"], "fail");
    assert_eq!(v["non_finite"], 1);
    assert!(v["worst_ratio"].as_f64().unwrap() > 1e300);
    let (code, v) = json(&shape.0);
    assert_eq!(code, 2);
    assert_eq!(v["exit_code"], 2);
    assert!(v["error"].as_str().unwrap().contains("shape"), "{v}");
}

#[test]
fn crosscheck_exits_by_its_verdict_whatever_happens_to_stdout() {
    if gpu_or_skip().is_none() {
        return;
    }
    let cases: [(&[&str], i32); 3] = [
        (&["crosscheck", "bpm", "--mesh", "procedural:cone"], 0),
        (
            &[
                "crosscheck",
                "bpm",
                "--mesh",
                "procedural:cone",
                "--perturb-gpu-input",
            ],
            1,
        ),
        (&["crosscheck", "bpm", "--mesh", "no/such/mesh.obj"], 2),
    ];
    for (args, code) in cases {
        for json in [false, true] {
            for stdout in ALL {
                let mut args = args.to_vec();
                if json {
                    args.push("--json");
                }
                let (got, read, stderr) = reparam(&args, stdout);
                assert_eq!(got, code, "{args:?} {stdout:?}: {stderr}");
                if matches!(stdout, Stdout::ClosedAtOnce) && code != 2 {
                    let word = if code == 0 { "pass" } else { "FAIL" };
                    assert!(stderr.contains(&format!("crosscheck: {word}")), "{stderr}");
                }
                if json && code == 2 && matches!(stdout, Stdout::Read) {
                    let v: Value = serde_json::from_str(&read).unwrap();
                    assert_eq!(v["exit_code"], 2);
                    assert!(v["error"].as_str().unwrap().contains("mesh.obj"), "{v}");
                }
            }
        }
    }
}
