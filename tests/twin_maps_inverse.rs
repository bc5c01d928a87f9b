//! `maps_inverse` through its f32 twin (`src/twin/maps_inverse.rs`):
//! - under every arithmetic model a conforming GPU may use (correctly rounded, FMA-contracted,
//!   reordered, at the edge of the WGSL table) the canonical vectors accept it;
//! - no bound is 0;
//! - the porting mistakes below (mutants) are all rejected. The printed table is the one in
//!   `src/vectors/README.md`.

mod common;

use common::mutation::MutationTable;
use reparam::twin::candidate::maps_inverse::{candidate, candidate_with, Body};
use reparam::twin::maps_inverse::{
    barycentric, chart_corner, clamp_bary, inverse, min3, position, removal, InverseResult,
    Located, Tables, NONE,
};
use reparam::twin::{Model, Real, F, V2, V3};
use reparam::vectors::KernelVectors;

fn dir() -> std::path::PathBuf {
    common::canonical::dir("maps")
}

fn kernel() -> KernelVectors {
    common::canonical::kernel("maps", "maps_inverse")
}

/// The porting mistakes, each one step of the walk done wrong.
#[derive(Clone, Copy, PartialEq)]
enum Mistake {
    None,
    ChartsSwapped,
    ChartLayout,
    BarycentricRotated,
    OneStep,
    BaseFaceDirect,
    CornersRotated,
    LastFaceFallback,
}

/// Corner c of a chart as the mutant reads it (`ChartsSwapped`: `removed` for `created` and
/// back; `ChartLayout`: the 6 floats taken as x0 x1 x2 y0 y1 y2).
fn corner(m: Mistake, tables: &Tables, face: u32, which: usize, c: usize) -> V2<F> {
    match m {
        Mistake::ChartsSwapped => chart_corner(tables, face, 1 - which, c),
        Mistake::ChartLayout => {
            let o = 12 * face as usize + 6 * which;
            V2::new(
                F::new(tables.charts[o + c]),
                F::new(tables.charts[o + 3 + c]),
            )
        }
        _ => chart_corner(tables, face, which, c),
    }
}

fn locate(m: Mistake, tables: &Tables, r: [u32; 2], u: V2<F>) -> Located<F> {
    let mut best = Located {
        face: tables.old_faces[r[0] as usize],
        bary: V3::splat(F::lit(0.0)),
    };
    let mut best_min = f64::from(-f32::MAX);
    for k in 0..r[1] {
        let f = tables.old_faces[(r[0] + k) as usize];
        let c = |i| corner(m, tables, f, 1, i);
        let mut l = barycentric(u, c(0), c(1), c(2));
        if m == Mistake::BarycentricRotated {
            l = V3::new(l.y, l.z, l.x);
        }
        let lowest = min3(l).value();
        if lowest >= 0.0 {
            return Located { face: f, bary: l };
        }
        if m == Mistake::LastFaceFallback || lowest > best_min {
            best_min = lowest;
            best = Located { face: f, bary: l };
        }
    }
    best
}

/// The twin's `inverse` with mistake `m` (none: the twin, step for step).
fn mutated(m: Mistake, tables: &Tables, base: u32, b: V3<F>) -> InverseResult<F> {
    let mut face = if m == Mistake::BaseFaceDirect {
        base
    } else {
        tables.base_to_face[base as usize]
    };
    let mut bary = b;
    let mut min_bary = min3(bary);
    let steps = if m == Mistake::OneStep {
        1
    } else {
        tables.face_count()
    };
    for _ in 0..steps {
        let created_by = tables.created_by[face as usize];
        if created_by == NONE {
            break;
        }
        let mu = |c| corner(m, tables, face, 0, c);
        let u = mu(0) * bary.x + mu(1) * bary.y + mu(2) * bary.z;
        let found = locate(m, tables, removal(tables, created_by), u);
        min_bary = min_bary.min(min3(found.bary));
        face = found.face;
        bary = clamp_bary(found.bary);
    }
    let t = &tables.corners[3 * face as usize..3 * face as usize + 3];
    let w = if m == Mistake::CornersRotated {
        [bary.y, bary.z, bary.x]
    } else {
        [bary.x, bary.y, bary.z]
    };
    let p = V3::sum(&[
        position(tables, t[0]) * w[0],
        position(tables, t[1]) * w[1],
        position(tables, t[2]) * w[2],
    ]);
    InverseResult {
        position: p,
        face,
        bary,
        min_bary,
    }
}

macro_rules! body {
    ($m:expr) => {
        |tables: &Tables, base: u32, b: V3<F>| mutated($m, tables, base, b)
    };
}

const MUTANTS: [(&str, &str, Body); 7] = [
    (
        "charts_swapped",
        "u from the `removed` chart, star faces in the `created` one",
        body!(Mistake::ChartsSwapped),
    ),
    (
        "chart_layout",
        "a chart's 6 floats read as x₀ x₁ x₂ y₀ y₁ y₂",
        body!(Mistake::ChartLayout),
    ),
    (
        "barycentric_rotated",
        "λ = (o(a, u, c), o(a, b, u), o(u, b, c)) / s",
        body!(Mistake::BarycentricRotated),
    ),
    (
        "one_step",
        "one removal replayed, not every one down to an input face",
        body!(Mistake::OneStep),
    ),
    (
        "base_face_direct",
        "the walk starts at face q, not base_to_face\\[q\\]",
        body!(Mistake::BaseFaceDirect),
    ),
    (
        "corners_rotated",
        "the input face's corners weighted by (b₁, b₂, b₀)",
        body!(Mistake::CornersRotated),
    ),
    (
        "last_face_fallback",
        "outside every star face: the last face, not the largest smallest λ",
        body!(Mistake::LastFaceFallback),
    ),
];

#[test]
fn every_model_passes_every_mutant_fails_and_no_bound_is_zero() {
    let run = |model: Model, body: Option<Body>| match body {
        Some(body) => candidate_with(&dir(), &kernel(), model, body).unwrap(),
        None => candidate(&dir(), &kernel(), model).unwrap(),
    };
    MutationTable::judge_kernel(&dir(), &kernel(), run, &MUTANTS);
}

/// The mutants' harness with no mistake is the twin, bit for bit.
#[test]
fn the_harness_without_a_mistake_is_the_twin() {
    let k = kernel();
    MutationTable::assert_bit_identical(
        &candidate(&dir(), &k, Model::Nearest).unwrap(),
        &candidate_with(&dir(), &k, Model::Nearest, body!(Mistake::None)).unwrap(),
    );
    let _: Body = inverse;
}
