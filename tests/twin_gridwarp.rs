//! `gridwarp_aa` through its f32 twin (`src/twin/gridwarp_aa.rs`): the residuals, and the
//! per-cell energies, F, JᵀJ and Jᵀr (the cells' shares added by the host in f64, as
//! gpu/src/gridwarp/aa.rs does). The canonical vectors accept the twin under every arithmetic
//! model a conforming GPU may use and reject the porting mistakes below (mutants). The printed
//! tables are those of src/vectors/README.md.

mod common;

use std::path::{Path, PathBuf};

use common::mutation::MutationTable;
use reparam::twin::candidate::gridwarp_aa::{
    as_numbered, assemble, residuals_with, row_inner, Assembled, Body, CellBody, CellOrder, Inputs,
    UnknownOrder,
};
use reparam::twin::gridwarp_aa::{
    add_residual, cell_contribution, field_bilinear, field_bilinear_sample, line_derivatives,
    residual, sample_residuals, slope, warped_point, CellContribution, CellLines, Field,
    RestSample,
};
use reparam::twin::{Model, Real, F};
use reparam::vectors::verify::{verify_array, VerifyReport};
use reparam::vectors::{read_manifest, Array, KernelVectors};

const KERNEL: &str = "gridwarp_aa.residuals";

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors/gridwarp")
}

/// The residual kernel's canonical inputs as the kernel receives them.
fn inputs() -> Inputs {
    let manifest = read_manifest(&dir()).unwrap();
    let k = manifest.kernels.iter().find(|k| k.name == KERNEL).unwrap();
    Inputs::load(&dir(), k).unwrap()
}

fn column_inner(c: usize, columns: usize, _: usize) -> (usize, usize) {
    (c % columns, c / columns)
}

/// The candidate of `body` under `model`: [samples, 2].
fn candidate(x: &Inputs, body: Body, order: CellOrder, model: Model) -> Array {
    residuals_with(x, body, order, model)
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

/// The porting mistakes of the residual path.
fn residual_mutants() -> [(&'static str, &'static str, Body, CellOrder); 9] {
    [
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
    ]
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
    let mut table = MutationTable::default();
    for model in Model::CHECKED {
        let r = judge(&k, candidate(&x, correct, row_inner, model));
        table.twin(&model.name(), &r);
    }
    let mutants = residual_mutants();
    for (name, mistake, body, order) in mutants {
        let r = judge(&k, candidate(&x, body, order, Model::Nearest));
        table.mutant(name, mistake, &r);
    }
    table.finish();
}

/// The per-cell energies Σ (r^s)² + (r^t)² (in f64) of a residual candidate, and F.
fn energies_of(x: &Inputs, residuals: &Array) -> (Array, Array) {
    let r = residuals.to_f64();
    let cells: Vec<f64> = r
        .chunks(2 * x.per_cell)
        .map(|c| c.iter().map(|v| v * v).sum())
        .collect();
    let total: f64 = cells.iter().sum();
    (
        Array::f64(&[cells.len()], cells),
        Array::f64(&[1], vec![total]),
    )
}

/// `gridwarp_aa.cell_energy` and `.energy` of its own: the twin's residuals squared and summed
/// pass under every model, and every residual mutant fails both (its energies are wrong too).
#[test]
fn the_energies_accept_the_twin_and_reject_every_residual_mutant() {
    let manifest = read_manifest(&dir()).unwrap();
    let kernel = |name: &str| {
        manifest
            .kernels
            .iter()
            .find(|k| k.name == name)
            .unwrap()
            .clone()
    };
    let (cell_k, energy_k) = (
        kernel("gridwarp_aa.cell_energy"),
        kernel("gridwarp_aa.energy"),
    );
    let x = inputs();
    for (k, pick) in [(&cell_k, 0), (&energy_k, 1)] {
        let mut table = MutationTable::default();
        let judge_energy = |a: &Array| {
            let (cells, total) = energies_of(&x, a);
            verify_array(&dir(), k, if pick == 0 { &cells } else { &total }, "twin").unwrap()
        };
        for model in Model::CHECKED {
            table.twin(
                &model.name(),
                &judge_energy(&candidate(&x, correct, row_inner, model)),
            );
        }
        for (name, mistake, body, order) in residual_mutants() {
            let r = judge_energy(&candidate(&x, body, order, Model::Nearest));
            table.mutant(name, mistake, &r);
        }
        println!("{}", k.name);
        table.finish();
    }
}

// ---------------------------------------------------------------------------------------------
// The normal equations: cell_energy, energy, jtj, jtr

/// t unknowns first, then s (the other order).
fn t_first(u: i32, ns: usize) -> i32 {
    if u < 0 {
        u
    } else if (u as usize) < ns {
        u + 3
    } else {
        u - ns as i32
    }
}

/// The four judged outputs of an assembly, by kernel name.
fn candidates(a: &Assembled) -> [(&'static str, Array); 4] {
    [
        "gridwarp_aa.cell_energy",
        "gridwarp_aa.energy",
        "gridwarp_aa.jtj",
        "gridwarp_aa.jtr",
    ]
    .map(|name| (name, a.output(name).unwrap()))
}

/// A cell's contribution with `derivatives` in place of `line_derivatives` and `lookup` in
/// place of the bilinear sample (the mutants' cell body).
fn cell_with(
    l: &CellLines<F>,
    samples: &[RestSample<F>],
    d_s: &Field<F>,
    d_t: &Field<F>,
    derivatives: impl Fn([F; 8]) -> [F; 4],
    t_slots: fn([F; 4]) -> [F; 4],
    t_along_across: bool,
) -> CellContribution<F> {
    let zero = F::lit(0.0);
    let mut out = CellContribution {
        jtj: [zero; 16],
        jtr: [zero; 4],
        energy: zero,
    };
    let a = slope(l.s0, l.s1, l.h);
    let b = slope(l.t0, l.t1, l.k);
    for smp in samples {
        if smp.sigma.value() == 0.0 {
            continue;
        }
        let p = warped_point(l.s0, l.s1, l.t0, l.t1, smp.alpha, smp.beta);
        let c_s = field_bilinear_sample(d_s, p.x, p.y);
        let c_t = field_bilinear_sample(d_t, p.x, p.y);
        let r_s = residual(smp.sigma, c_s.value, a, smp.o_s);
        let r_t = residual(smp.sigma, c_t.value, b, smp.o_t);
        let d1 = derivatives([
            smp.sigma, c_s.value, c_s.ds, c_s.dt, a, l.h, smp.alpha, smp.beta,
        ]);
        let (along, across) = if t_along_across {
            (smp.beta, smp.alpha)
        } else {
            (smp.alpha, smp.beta)
        };
        let d2 = derivatives([smp.sigma, c_t.value, c_t.dt, c_t.ds, b, l.k, along, across]);
        add_residual(&mut out, r_s, d1);
        add_residual(&mut out, r_t, t_slots(d2));
    }
    out
}

fn kernel_derivatives(v: [F; 8]) -> [F; 4] {
    line_derivatives(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7])
}

fn permuted(d: [F; 4]) -> [F; 4] {
    [d[2], d[3], d[0], d[1]]
}

/// The identity of the mutants' cell harness: with nothing changed it is the twin's
/// `cell_contribution`, bit for bit (as `tests/mutants_bpm.rs` checks its precompute harness).
#[test]
fn the_cell_harness_with_nothing_changed_is_the_kernel() {
    let x = inputs();
    let same = |l: &CellLines<F>, s: &[RestSample<F>], a: &Field<F>, b: &Field<F>| {
        cell_with(l, s, a, b, kernel_derivatives, permuted, true)
    };
    let (harness, kernel) = (
        assemble(&x, same, as_numbered, Model::Nearest),
        assemble(&x, cell_contribution, as_numbered, Model::Nearest),
    );
    assert_eq!(harness.jtj, kernel.jtj);
    assert_eq!(harness.jtr, kernel.jtr);
    assert_eq!(harness.cell_energy, kernel.cell_energy);
}

#[test]
fn normal_equations_every_model_passes_every_mutant_fails() {
    let manifest = read_manifest(&dir()).unwrap();
    let kernel = |name: &str| {
        manifest
            .kernels
            .iter()
            .find(|k| k.name == name)
            .unwrap()
            .clone()
    };
    let x = inputs();
    let mut table = vec![
        "| mutant | the porter's mistake | verdict per kernel (cell_energy, energy, jtj, jtr): worst error/bound |".to_string(),
        "|---|---|---|".to_string(),
    ];
    // Judge an assembly on the four kernels: (all pass, any kernel fails, the row).
    let judge_all = |a: &Assembled| -> (bool, bool, String) {
        let mut all_pass = true;
        let mut any_fail = false;
        let mut cells = Vec::new();
        for (name, array) in candidates(a) {
            let r = verify_array(&dir(), &kernel(name), &array, "twin").unwrap();
            all_pass &= r.pass;
            any_fail |= !r.pass;
            cells.push(format!(
                "{} {:.1e}",
                if r.pass { "pass" } else { "FAIL" },
                r.worst_ratio
            ));
        }
        (all_pass, any_fail, cells.join(", "))
    };
    let mut wrong = Vec::new();
    for model in Model::CHECKED {
        let (pass, _, row) = judge_all(&assemble(&x, cell_contribution, as_numbered, model));
        table.push(format!("| `twin ({})` | none | {row} |", model.name()));
        if !pass {
            wrong.push(format!("the twin under {} fails", model.name()));
        }
    }
    let mutants: [(&str, &str, CellBody, UnknownOrder); 6] = [
        (
            "derivative_sign",
            "∂r/∂(near, far line) with σc/h's sign flipped",
            |l, s, a, b| {
                cell_with(
                    l,
                    s,
                    a,
                    b,
                    |v| {
                        let d = kernel_derivatives(v);
                        let w = (v[0] / v[5]) * v[1] * F::lit(2.0);
                        [d[0] + w, d[1] - w, d[2], d[3]]
                    },
                    permuted,
                    true,
                )
            },
            as_numbered,
        ),
        (
            "no_field_gradient",
            "c treated as constant (∂c/∂s = ∂c/∂t = 0)",
            |l, s, a, b| {
                cell_with(
                    l,
                    s,
                    a,
                    b,
                    |mut v| {
                        v[2] = F::lit(0.0);
                        v[3] = F::lit(0.0);
                        kernel_derivatives(v)
                    },
                    permuted,
                    true,
                )
            },
            as_numbered,
        ),
        (
            "t_along_is_alpha",
            "r^t's derivatives with α along and β across",
            |l, s, a, b| cell_with(l, s, a, b, kernel_derivatives, permuted, false),
            as_numbered,
        ),
        (
            "t_slots_not_permuted",
            "r^t's derivatives added to the s slots",
            |l, s, a, b| cell_with(l, s, a, b, kernel_derivatives, |d| d, true),
            as_numbered,
        ),
        (
            "t_unknowns_first",
            "unknowns numbered t first, then s",
            cell_contribution,
            t_first,
        ),
        (
            "gradient_unscaled",
            "∂c/∂s, ∂c/∂t per texel, not per texture width (no ×W, ×H)",
            |l, s, a, b| {
                cell_with(
                    l,
                    s,
                    a,
                    b,
                    |mut v| {
                        v[2] = v[2] / F::lit(32.0);
                        v[3] = v[3] / F::lit(32.0);
                        kernel_derivatives(v)
                    },
                    permuted,
                    true,
                )
            },
            as_numbered,
        ),
    ];
    for (name, mistake, body, order) in mutants {
        let (_, any_fail, row) = judge_all(&assemble(&x, body, order, Model::Nearest));
        table.push(format!("| `{name}` | {mistake} | {row} |"));
        if !any_fail {
            wrong.push(format!("mutant {name} survives"));
        }
    }
    println!("{}", table.join("\n"));
    assert!(wrong.is_empty(), "{wrong:?}\n{}", table.join("\n"));
}
