//! `gridwarp_aa.residuals` through its f32 twin (`src/twin/gridwarp_aa.rs`): the canonical
//! vectors accept it under every arithmetic model a conforming GPU may use and reject the
//! porting mistakes below (mutants). The printed table is the README's.

use std::path::{Path, PathBuf};

use reparam::twin::gridwarp_aa::{
    field_bilinear, residual, sample_residuals, slope, warped_point, CellLines, Field, RestSample,
};
use reparam::twin::{with_model, Model, Real, F};
use reparam::vectors::verify::{verify_array, VerifyReport};
use reparam::vectors::{read_manifest, Array, KernelVectors};

const KERNEL: &str = "gridwarp_aa.residuals";

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors/gridwarp")
}

fn load(name: &str) -> Array {
    Array::load(&dir().join(format!("{KERNEL}.{name}.npy"))).unwrap()
}

fn f32s(a: &Array) -> Vec<F> {
    a.to_f64().into_iter().map(|x| F::new(x as f32)).collect()
}

/// The canonical inputs as the kernel receives them.
struct Inputs {
    samples: Vec<F>,
    per_cell: usize,
    h: Vec<F>,
    k: Vec<F>,
    s: Vec<F>,
    t: Vec<F>,
    d_s: (Vec<F>, usize, usize),
    d_t: (Vec<F>, usize, usize),
}

fn inputs() -> Inputs {
    let field = |name: &str| {
        let a = load(name);
        (f32s(&a), a.shape[1], a.shape[0])
    };
    Inputs {
        samples: f32s(&load("samples")),
        per_cell: load("per_cell").to_f64()[0] as usize,
        h: f32s(&load("rest_h")),
        k: f32s(&load("rest_k")),
        s: f32s(&load("s")),
        t: f32s(&load("t")),
        d_s: field("d_s"),
        d_t: field("d_t"),
    }
}

/// What a port does with one sample: its cell's lines and rest size, the sample, the fields.
type Body = fn(&CellLines<F>, &RestSample<F>, &Field<F>, &Field<F>) -> [F; 2];
/// How a port maps the cell index c to (column i, row j), given (columns, rows).
type CellOrder = fn(usize, usize, usize) -> (usize, usize);

fn row_inner(c: usize, _: usize, rows: usize) -> (usize, usize) {
    (c / rows, c % rows)
}

fn column_inner(c: usize, columns: usize, _: usize) -> (usize, usize) {
    (c % columns, c / columns)
}

/// The candidate of `body` under `model`: [samples, 2].
fn candidate(x: &Inputs, body: Body, order: CellOrder, model: Model) -> Array {
    let d_s = Field {
        values: &x.d_s.0,
        width: x.d_s.1,
        height: x.d_s.2,
    };
    let d_t = Field {
        values: &x.d_t.0,
        width: x.d_t.1,
        height: x.d_t.2,
    };
    let (columns, rows) = (x.s.len() - 1, x.t.len() - 1);
    let mut out = Vec::new();
    for (n, v) in x.samples.chunks(5).enumerate() {
        let (i, j) = order(n / x.per_cell, columns, rows);
        let lines = CellLines {
            s0: x.s[i],
            s1: x.s[i + 1],
            t0: x.t[j],
            t1: x.t[j + 1],
            h: x.h[i],
            k: x.k[j],
        };
        let sample = RestSample {
            alpha: v[0],
            beta: v[1],
            sigma: v[2],
            o_s: v[3],
            o_t: v[4],
        };
        let r = with_model(model, || body(&lines, &sample, &d_s, &d_t));
        out.extend([r[0].get(), r[1].get()]);
    }
    Array::f32(&[out.len() / 2, 2], out)
}

fn correct(l: &CellLines<F>, s: &RestSample<F>, d_s: &Field<F>, d_t: &Field<F>) -> [F; 2] {
    sample_residuals(l, s, d_s, d_t)
}

/// The residuals from the slopes a, b and the stretches at p, with `lookup` for the fields.
fn with_lookup(
    l: &CellLines<F>,
    s: &RestSample<F>,
    d_s: &Field<F>,
    d_t: &Field<F>,
    lookup: impl Fn(&Field<F>, F, F) -> F,
) -> [F; 2] {
    let a = slope(l.s0, l.s1, l.h);
    let b = slope(l.t0, l.t1, l.k);
    let p = warped_point(l.s0, l.s1, l.t0, l.t1, s.alpha, s.beta);
    [
        residual(s.sigma, lookup(d_s, p.x, p.y), a, s.o_s),
        residual(s.sigma, lookup(d_t, p.x, p.y), b, s.o_t),
    ]
}

/// Texel centres taken at x/W (no half-texel offset).
fn no_half_texel(l: &CellLines<F>, s: &RestSample<F>, d_s: &Field<F>, d_t: &Field<F>) -> [F; 2] {
    with_lookup(l, s, d_s, d_t, |f, x, y| {
        let half_s = F::lit(0.5) / F::lit(f.width as f64);
        let half_t = F::lit(0.5) / F::lit(f.height as f64);
        field_bilinear(f, x + half_s, y + half_t)
    })
}

/// The nearest texel instead of the bilinear lookup.
fn nearest_texel(l: &CellLines<F>, s: &RestSample<F>, d_s: &Field<F>, d_t: &Field<F>) -> [F; 2] {
    with_lookup(l, s, d_s, d_t, |f, x, y| {
        let xi = ((x.f64() * f.width as f64) as usize).min(f.width - 1);
        let yi = ((y.f64() * f.height as f64) as usize).min(f.height - 1);
        f.values[yi * f.width + xi]
    })
}

/// The fields' rows read with row 0 at t = 1 (flipped vertically).
fn flipped_rows(l: &CellLines<F>, s: &RestSample<F>, d_s: &Field<F>, d_t: &Field<F>) -> [F; 2] {
    with_lookup(l, s, d_s, d_t, |f, x, y| {
        field_bilinear(f, x, F::lit(1.0) - y)
    })
}

/// Each stretch taken from the other field (D_t for r^s).
fn fields_swapped(l: &CellLines<F>, s: &RestSample<F>, d_s: &Field<F>, d_t: &Field<F>) -> [F; 2] {
    sample_residuals(l, s, d_t, d_s)
}

/// σ left out: r = c a − o.
fn no_sigma(l: &CellLines<F>, s: &RestSample<F>, d_s: &Field<F>, d_t: &Field<F>) -> [F; 2] {
    let s = RestSample {
        sigma: F::lit(1.0),
        ..*s
    };
    sample_residuals(l, &s, d_s, d_t)
}

/// The slopes divided by the other rest size (a by k_j, b by h_i).
fn sizes_swapped(l: &CellLines<F>, s: &RestSample<F>, d_s: &Field<F>, d_t: &Field<F>) -> [F; 2] {
    let l = CellLines {
        h: l.k,
        k: l.h,
        ..*l
    };
    sample_residuals(&l, s, d_s, d_t)
}

/// α and β swapped in the warped point.
fn alpha_beta_swapped(
    l: &CellLines<F>,
    s: &RestSample<F>,
    d_s: &Field<F>,
    d_t: &Field<F>,
) -> [F; 2] {
    let s = RestSample {
        alpha: s.beta,
        beta: s.alpha,
        ..*s
    };
    sample_residuals(l, &s, d_s, d_t)
}

fn judge(k: &KernelVectors, a: Array) -> VerifyReport {
    verify_array(&dir(), k, &a, "twin").unwrap()
}

#[test]
fn every_model_passes_and_every_mutant_fails() {
    let k = read_manifest(&dir())
        .unwrap()
        .kernels
        .into_iter()
        .find(|k| k.name == KERNEL)
        .unwrap();
    let x = inputs();
    let mut table = vec![
        "| mutant | the porter's mistake | verdict | worst error/bound | over |".to_string(),
        "|---|---|---|---|---|".to_string(),
    ];
    let line = |name: &str, mistake: &str, r: &VerifyReport| {
        format!(
            "| `{name}` | {mistake} | {} | {:.3e} | {} of {} |",
            if r.pass { "**survived**" } else { "killed" },
            r.worst_ratio,
            r.over,
            r.errors.count
        )
    };
    let mut wrong = Vec::new();
    for model in Model::CHECKED {
        let r = judge(&k, candidate(&x, correct, row_inner, model));
        table.push(line(&format!("twin ({})", model.name()), "none", &r));
        if !r.pass {
            wrong.push(format!("the twin under {} fails", model.name()));
        }
    }
    let mutants: [(&str, &str, Body, CellOrder); 9] = [
        (
            "cell_order",
            "cells read as c = j·(M − 1) + i",
            correct,
            column_inner,
        ),
        (
            "no_half_texel",
            "texel centres at x/W (no −½)",
            no_half_texel,
            row_inner,
        ),
        (
            "nearest_texel",
            "the nearest texel, not bilinear",
            nearest_texel,
            row_inner,
        ),
        (
            "flipped_rows",
            "field row 0 taken at t = 1",
            flipped_rows,
            row_inner,
        ),
        (
            "fields_swapped",
            "D_t's stretch in r^s and D_s's in r^t",
            fields_swapped,
            row_inner,
        ),
        ("no_sigma", "σ left out", no_sigma, row_inner),
        (
            "sizes_swapped",
            "a divided by k_j, b by h_i",
            sizes_swapped,
            row_inner,
        ),
        (
            "alpha_beta_swapped",
            "α and β swapped in the warped point",
            alpha_beta_swapped,
            row_inner,
        ),
        (
            "o_added",
            "r = σ(c a + o)",
            |l, s, d_s, d_t| {
                let s = RestSample {
                    o_s: -s.o_s,
                    o_t: -s.o_t,
                    ..*s
                };
                sample_residuals(l, &s, d_s, d_t)
            },
            row_inner,
        ),
    ];
    for (name, mistake, body, order) in mutants {
        let r = judge(&k, candidate(&x, body, order, Model::Nearest));
        table.push(line(name, mistake, &r));
        if r.pass {
            wrong.push(format!("mutant {name} survives"));
        }
    }
    println!("{}", table.join("\n"));
    assert!(wrong.is_empty(), "{wrong:?}\n{}", table.join("\n"));
}
