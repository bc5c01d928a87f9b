//! The canonical `gridwarp_aa` manifest against its data: the residuals computed in f64 from
//! the manifest's words alone (cell c = i·(N − 1) + j, the slopes, the warped point, the
//! clamped bilinear lookup with its texel centres) must meet the expected values within their
//! bounds, and the other reading of the cell order ("column i, row j" as c = j·(M − 1) + i),
//! which an implementer once took, must not (issue #33).

// `!(x > y)` is meant: a NaN fails, as in the manifest's "not u > 0".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::{Path, PathBuf};

use reparam::vectors::{read_manifest, Array};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors/gridwarp")
}

fn load(name: &str) -> (Vec<f64>, Vec<usize>) {
    let a = Array::load(&dir().join(format!("gridwarp_aa.residuals.{name}.npy"))).unwrap();
    (a.to_f64(), a.shape.clone())
}

/// The manifest's bilinear lookup of a field of `shape` = [H, W] at (s, t).
fn bilinear(field: &[f64], shape: &[usize], s: f64, t: f64) -> f64 {
    let axis = |x: f64, n: usize| -> (usize, f64) {
        let u = x * n as f64 - 0.5;
        if n == 1 || !(u > 0.0) {
            (0, 0.0)
        } else if u >= (n - 1) as f64 {
            (n - 1, 0.0)
        } else {
            (u.floor() as usize, u - u.floor())
        }
    };
    let (h, w) = (shape[0], shape[1]);
    let ((x0, f), (y0, g)) = (axis(s, w), axis(t, h));
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let d = |y: usize, x: usize| field[y * w + x];
    let row0 = d(y0, x0) + f * (d(y0, x1) - d(y0, x0));
    let row1 = d(y1, x0) + f * (d(y1, x1) - d(y1, x0));
    (1.0 - g) * row0 + g * row1
}

/// Residuals r^s, r^t of every sample, with the cells in the order `cell(c) = (i, j)`.
fn residuals(cell: impl Fn(usize, usize, usize) -> (usize, usize)) -> Vec<f64> {
    let (samples, _) = load("samples");
    let per_cell = load("per_cell").0[0] as usize;
    let (h, k) = (load("rest_h").0, load("rest_k").0);
    let (s, t) = (load("s").0, load("t").0);
    let (d_s, shape_s) = load("d_s");
    let (d_t, shape_t) = load("d_t");
    let (columns, rows) = (s.len() - 1, t.len() - 1);
    let mut out = Vec::new();
    for (n, x) in samples.chunks(5).enumerate() {
        let (alpha, beta, sigma, o_s, o_t) = (x[0], x[1], x[2], x[3], x[4]);
        let (i, j) = cell(n / per_cell, columns, rows);
        let a = (s[i + 1] - s[i]) / h[i];
        let b = (t[j + 1] - t[j]) / k[j];
        let p = (
            s[i] + alpha * (s[i + 1] - s[i]),
            t[j] + beta * (t[j + 1] - t[j]),
        );
        let c_s = bilinear(&d_s, &shape_s, p.0, p.1);
        let c_t = bilinear(&d_t, &shape_t, p.0, p.1);
        out.push(sigma * (c_s * a - o_s));
        out.push(sigma * (c_t * b - o_t));
    }
    out
}

/// Elements over their bound.
fn over(got: &[f64]) -> usize {
    let expected = Array::load(&dir().join("gridwarp_aa.residuals.expected.npy"))
        .unwrap()
        .to_f64();
    let bound = Array::load(&dir().join("gridwarp_aa.residuals.bound.npy"))
        .unwrap()
        .to_f64();
    assert_eq!(got.len(), expected.len());
    got.iter()
        .zip(&expected)
        .zip(&bound)
        .filter(|((g, e), b)| !((*g - *e).abs() <= **b))
        .count()
}

#[test]
fn the_manifests_formula_reproduces_the_residuals_and_the_other_cell_order_does_not() {
    let manifest = read_manifest(&dir()).unwrap();
    let k = manifest
        .kernels
        .iter()
        .find(|k| k.name == "gridwarp_aa.residuals")
        .unwrap();
    for claim in [
        "c = i·(N − 1) + j",
        "u = s W − ½",
        "r^s = σ(c_s a − o_s)",
        "min(x0 + 1, W − 1)",
    ] {
        assert!(
            k.description.contains(claim) || k.inputs.iter().any(|i| i.meaning.contains(claim)),
            "the manifest no longer says: {claim}"
        );
    }
    // As the manifest says: c = i·(N − 1) + j.
    assert_eq!(over(&residuals(|c, _, rows| (c / rows, c % rows))), 0);
    // The other reading, c = j·(M − 1) + i, fails (the canonical grid is not square in its
    // rest sizes, so the two orders differ).
    assert!(over(&residuals(|c, columns, _| (c % columns, c / columns))) > 0);
}
