//! `skinsimp_quadrics.source` through its f32 twin (`src/twin/skinsimp_quadrics.rs`):
//! - under every arithmetic model a conforming GPU may use (correctly rounded, FMA-contracted,
//!   reordered, at the edge of the WGSL table) the canonical vectors accept it (issue #34: an
//!   FMA port once failed 42 elements whose bound was exactly 0);
//! - no bound is 0;
//! - the porting mistakes below (mutants) are all rejected. The printed table is the README's.

use std::path::{Path, PathBuf};

use reparam::twin::real::{cross, dot, length};
use reparam::twin::skinsimp_quadrics::{
    edge_constraint, from_plane, from_triangle, plane_quadric, unit_normal, zero_quadric, Quadric,
    SOURCE_FACE,
};
use reparam::twin::{with_model, Model, Real, F, V3};
use reparam::vectors::verify::{verify_array, VerifyReport};
use reparam::vectors::{read_manifest, Array, KernelVectors};

const KERNEL: &str = "skinsimp_quadrics.source";

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors/skinsimp")
}

fn kernel() -> KernelVectors {
    read_manifest(&dir())
        .unwrap()
        .kernels
        .into_iter()
        .find(|k| k.name == KERNEL)
        .unwrap()
}

fn input(k: &KernelVectors, name: &str) -> Array {
    let info = k
        .inputs
        .iter()
        .find(|i| i.file.ends_with(&format!(".{name}.npy")))
        .unwrap();
    Array::load(&dir().join(&info.file)).unwrap()
}

/// The body of one source: the twin's or a mutant's.
type Body = fn(u32, [V3<F>; 3], F) -> Quadric<F>;

/// The candidate of `body` on the canonical inputs under `model`: [sources, poses, 10].
fn candidate(k: &KernelVectors, body: Body, model: Model) -> Array {
    let posed = input(k, "posed");
    let poses = posed.shape[1];
    let posed = posed.to_f64();
    let corners = input(k, "corners").to_f64();
    let kind = input(k, "kind").to_f64();
    let weight = F::new(input(k, "boundary_weight").to_f64()[0] as f32);
    let sources = kind.len();
    let mut out = Vec::with_capacity(sources * poses * 10);
    for s in 0..sources {
        for j in 0..poses {
            let p = [0, 1, 2].map(|c| {
                let v = corners[3 * s + c] as usize;
                let o = 3 * (v * poses + j);
                V3::new(
                    F::new(posed[o] as f32),
                    F::new(posed[o + 1] as f32),
                    F::new(posed[o + 2] as f32),
                )
            });
            let q = with_model(model, || body(kind[s] as u32, p, weight));
            out.extend(q.iter().map(|x| x.get()));
        }
    }
    Array::f32(&[sources, poses, 10], out)
}

fn judge(k: &KernelVectors, body: Body, model: Model) -> VerifyReport {
    verify_array(&dir(), k, &candidate(k, body, model), "twin").unwrap()
}

/// `from_triangle` without normalising: q = (c, −c·p0) with c the cross product.
fn unnormalised(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind != SOURCE_FACE {
        return plane_quadric(kind, p, w);
    }
    let c = cross(p[1] - p[0], p[2] - p[0]);
    let area = length(c.to_array()) * F::lit(0.5);
    from_plane(c, -dot(c.to_array(), p[0].to_array()), area)
}

/// The face's weight = |c| (twice the area).
fn twice_area(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    let q = plane_quadric(kind, p, w);
    if kind != SOURCE_FACE {
        return q;
    }
    q.map(|x| x * F::lit(2.0))
}

/// d = +n·p0.
fn d_sign(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind != SOURCE_FACE {
        return plane_quadric(kind, p, w);
    }
    let c = cross(p[1] - p[0], p[2] - p[0]);
    let twice = length(c.to_array());
    if twice.value() == 0.0 {
        return zero_quadric();
    }
    let n = c / twice;
    from_plane(n, dot(n.to_array(), p[0].to_array()), F::lit(0.5) * twice)
}

/// The boundary edge e taken as (corner e, corner e + 2): the wrong edge.
fn wrong_edge(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind == SOURCE_FACE {
        return from_triangle(p[0], p[1], p[2]);
    }
    let e = kind as usize;
    edge_constraint(p[e], p[(e + 2) % 3], unit_normal(p[0], p[1], p[2]), w)
}

/// The constraint weighted by weight · |e| instead of |e|².
fn weight_unsquared(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind == SOURCE_FACE {
        return from_triangle(p[0], p[1], p[2]);
    }
    let e = kind as usize;
    let edge = p[(e + 1) % 3] - p[e];
    let q = edge_constraint(p[e], p[(e + 1) % 3], unit_normal(p[0], p[1], p[2]), w);
    let l = length(edge.to_array());
    q.map(|x| x / l)
}

/// The constraint plane taken as the face's own plane through the edge (no e × n).
fn face_plane_constraint(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind == SOURCE_FACE {
        return from_triangle(p[0], p[1], p[2]);
    }
    let e = kind as usize;
    let n = unit_normal(p[0], p[1], p[2]);
    let edge = p[(e + 1) % 3] - p[e];
    from_plane(
        n,
        -dot(n.to_array(), p[e].to_array()),
        w * dot(edge.to_array(), edge.to_array()),
    )
}

/// Boundary constraints left out.
fn no_constraints(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind == SOURCE_FACE {
        return from_triangle(p[0], p[1], p[2]);
    }
    let _ = w;
    zero_quadric()
}

const MUTANTS: [(&str, &str, Body); 7] = [
    (
        "unnormalised",
        "the face plane not normalised (q = (c, −c·p0))",
        unnormalised,
    ),
    (
        "twice_area",
        "the face weighted by |c| = twice its area",
        twice_area,
    ),
    ("d_sign", "d = +n·p0", d_sign),
    (
        "wrong_edge",
        "boundary edge e taken as (corner e, corner e + 2)",
        wrong_edge,
    ),
    (
        "weight_unsquared",
        "constraint weighted by boundary_weight · |e|, not |e|²",
        weight_unsquared,
    ),
    (
        "face_plane_constraint",
        "constraint plane = the face's plane (no e × n)",
        face_plane_constraint,
    ),
    (
        "no_constraints",
        "boundary constraints left out",
        no_constraints,
    ),
];

#[test]
fn every_model_passes_every_mutant_fails_and_no_bound_is_zero() {
    let k = kernel();
    let bounds = Array::load(&dir().join(&k.bound.file)).unwrap().to_f64();
    let zero = bounds.iter().filter(|&&b| b == 0.0).count();
    assert_eq!(zero, 0, "{zero} of {} bounds are exactly 0", bounds.len());
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
        let r = judge(&k, plane_quadric, model);
        table.push(line(&format!("twin ({})", model.name()), "none", &r));
        if !r.pass {
            wrong.push(format!("the twin under {} fails", model.name()));
        }
    }
    for (name, mistake, body) in MUTANTS {
        let r = judge(&k, body, Model::Nearest);
        table.push(line(name, mistake, &r));
        if r.pass {
            wrong.push(format!("mutant {name} survives"));
        }
    }
    println!("{}", table.join("\n"));
    assert!(wrong.is_empty(), "{wrong:?}\n{}", table.join("\n"));
}
