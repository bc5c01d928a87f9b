//! `gridwarp_lookup` through its f32 twin (`src/twin/gridwarp_lookup.rs`) on the canonical
//! vectors ([`reparam::vectors::gridwarp_lookup::canonical_vectors`], written to a temporary
//! folder): the twin passes under every arithmetic model a conforming GPU may use, and every
//! porting mistake below (mutants) fails. The printed table is the conformance guide's
//! (src/vectors/README.md). The inputs reach every branch the covers list names; the test
//! asserts each count is positive.

mod common;

use std::path::PathBuf;

use common::mutation::MutationTable;
use reparam::twin::candidate::gridwarp_lookup::{candidate_with, Body};
use reparam::twin::gridwarp_lookup::{
    cell_of, clamp01, contains, finish, in_bbox, in_lines, inverse_bilinear,
    inverse_bilinear_with_root, located_at, lookup_uv, outside, quad, quadratic, roots, st, uv,
    Located, RoiGrid, Tables, AA,
};
use reparam::twin::{Model, Real, F, V2};
use reparam::vectors::gridwarp_lookup::canonical_vectors;
use reparam::vectors::verify::verify_array;
use reparam::vectors::{read_manifest, write_vectors, Array, KernelVectors};

/// The canonical vectors in a fresh temporary folder of the test `tag`, and their manifest
/// entry.
fn vectors(tag: &str) -> (PathBuf, KernelVectors) {
    let dir =
        std::env::temp_dir().join(format!("reparam-twin-lookup-{tag}-{}", std::process::id()));
    let (kernels, _) = canonical_vectors(None).unwrap();
    write_vectors(&dir, "test", "canonical gridwarp_lookup atlas", &kernels).unwrap();
    let k = read_manifest(&dir).unwrap().kernels.remove(0);
    (dir, k)
}

/// The porting mistakes the harness below can make (one at a time).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Mistake {
    None,
    /// Always the near root C/q of the quadratic.
    WrongRoot,
    /// (α, β) of the nearest cell not clamped to [0, 1], nor p to the unit square.
    NoClamp,
    /// α and β swapped in the rest point (the s and t axes mixed up).
    AxesSwapped,
    /// The border blend's weight left out (w = 0 everywhere).
    BlendDropped,
    /// The rest point at the nearest cell corner (α, β rounded to 0 or 1), not interpolated.
    Nearest,
    /// The NAA location done in UV (vertices stored as u0 + s (u1 − u0) in f32), not in the
    /// ROI's own coordinates re-centred on the cell's P00.
    NotRecentred,
}

/// The twin's `lookup_uv` rebuilt from its parts with `m`; with [`Mistake::None`] it is the
/// twin bit for bit (`the_harness_with_no_mistake_is_the_twin`).
fn harness(t: &Tables, q: V2<F>, m: Mistake) -> V2<F> {
    for k in 0..t.roi_count() {
        let r = t.roi::<F>(k);
        if !contains(&r, q) {
            continue;
        }
        let g = t.grid(k);
        let p_in = st(&r, q);
        let p = if m == Mistake::NoClamp {
            p_in
        } else {
            clamp01(p_in)
        };
        let located = if g.variant == AA {
            let i = cell_of(t, g.warped, g.m, p.x);
            let j = cell_of(t, g.warped + g.m, g.n, p.y);
            Some((i, j, in_lines(t, &g, i, j, p)))
        } else {
            locate_naa(t, &g, k, q, p, m)
        };
        let Some((i, j, ab)) = located else {
            return uv(&r, p_in);
        };
        let ab = match m {
            Mistake::AxesSwapped => V2::new(ab.y, ab.x),
            Mistake::Nearest => V2::new(round01(ab.x), round01(ab.y)),
            _ => ab,
        };
        let at: Located<F> = located_at(t, &g, i, j, ab);
        let out = if m == Mistake::BlendDropped {
            at.rest
        } else {
            finish(&g, &at, p_in)
        };
        return uv(&r, out);
    }
    q
}

fn round01(x: F) -> F {
    F::lit(if x.value() < 0.5 { 0.0 } else { 1.0 })
}

/// `locate_in_vertices` with mistake `m`.
fn locate_naa(
    t: &Tables,
    g: &RoiGrid,
    k: usize,
    q: V2<F>,
    p: V2<F>,
    m: Mistake,
) -> Option<(usize, usize, V2<F>)> {
    let r = t.roi::<F>(k);
    let mut best: Option<(F, usize, usize, V2<F>)> = None;
    for i in 0..g.m - 1 {
        for j in 0..g.n - 1 {
            let mut corners = quad::<F>(t, g, i, j);
            let mut at = p;
            if m == Mistake::NotRecentred {
                corners = corners.map(|c| uv(&r, c));
                at = q;
            }
            if !in_bbox(&corners, at) {
                continue;
            }
            let solved = if m == Mistake::WrongRoot {
                let kq = quadratic(&corners, at);
                inverse_bilinear_with_root(&corners, at, &kq, roots(&kq).near)
            } else {
                inverse_bilinear(&corners, at)
            };
            let Some(ab) = solved else {
                continue;
            };
            let miss = outside(ab);
            if miss.value() <= 0.0 {
                return Some((i, j, ab));
            }
            if best.is_none_or(|b| miss < b.0) {
                best = Some((miss, i, j, ab));
            }
        }
    }
    let clamp = m != Mistake::NoClamp;
    best.map(|(_, i, j, ab)| (i, j, if clamp { clamp01(ab) } else { ab }))
}

const MUTANTS: [(&str, &str, Mistake); 6] = [
    (
        "wrong_root",
        "always the near root C/q of the quadratic in β",
        Mistake::WrongRoot,
    ),
    (
        "no_clamp",
        "p and the nearest cell's (α, β) not clamped to [0, 1]",
        Mistake::NoClamp,
    ),
    (
        "axes_swapped",
        "α and β swapped in the rest point",
        Mistake::AxesSwapped,
    ),
    (
        "blend_dropped",
        "the border blend's weight left out (w = 0)",
        Mistake::BlendDropped,
    ),
    (
        "nearest",
        "the nearest cell corner, not the bilinear position in the cell",
        Mistake::Nearest,
    ),
    (
        "not_recentred",
        "the NAA cells solved in UV (f32 vertices u0 + s (u1 − u0)), not in ROI coordinates re-centred on P00",
        Mistake::NotRecentred,
    ),
];

fn body(m: Mistake) -> Body {
    match m {
        Mistake::None => |t, q| harness(t, q, Mistake::None),
        Mistake::WrongRoot => |t, q| harness(t, q, Mistake::WrongRoot),
        Mistake::NoClamp => |t, q| harness(t, q, Mistake::NoClamp),
        Mistake::AxesSwapped => |t, q| harness(t, q, Mistake::AxesSwapped),
        Mistake::BlendDropped => |t, q| harness(t, q, Mistake::BlendDropped),
        Mistake::Nearest => |t, q| harness(t, q, Mistake::Nearest),
        Mistake::NotRecentred => |t, q| harness(t, q, Mistake::NotRecentred),
    }
}

#[test]
fn every_model_passes_every_mutant_fails() {
    let (dir, k) = vectors("mutants");
    let run = |model: Model, mistake: Option<Mistake>| -> Array {
        match mistake {
            None => candidate_with(&dir, &k, model, lookup_uv).unwrap(),
            Some(m) => candidate_with(&dir, &k, model, body(m)).unwrap(),
        }
    };
    let bounds = Array::load(&dir.join(&k.bound.file)).unwrap().to_f64();
    assert!(bounds.iter().all(|&b| b > 0.0), "a bound is 0");
    let mut table = MutationTable::default();
    for model in Model::CHECKED {
        table.twin(
            &model.name(),
            &verify_array(&dir, &k, &run(model, None), "twin").unwrap(),
        );
    }
    for (name, mistake, m) in MUTANTS {
        let r = verify_array(&dir, &k, &run(Model::Nearest, Some(m)), "twin").unwrap();
        table.mutant(name, mistake, &r);
    }
    let _ = std::fs::remove_dir_all(&dir);
    table.finish();
}

#[test]
fn the_harness_with_no_mistake_is_the_twin() {
    let (dir, k) = vectors("harness");
    let twin = candidate_with(&dir, &k, Model::Nearest, lookup_uv).unwrap();
    let harness = candidate_with(&dir, &k, Model::Nearest, body(Mistake::None)).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    common::mutation::MutationTable::assert_bit_identical(&twin, &harness);
}

/// The covers list (the manifest's) counts every branch the issue names, each at least once;
/// the undecided count is printed.
#[test]
fn the_inputs_reach_every_branch() {
    let (dir, k) = vectors("covers");
    let _ = std::fs::remove_dir_all(&dir);
    for line in &k.covers {
        println!("{line}");
        if line.starts_with("undecided") {
            continue;
        }
        let last: usize = line
            .rsplit(|c: char| !c.is_ascii_digit())
            .find(|s| !s.is_empty())
            .and_then(|s| s.parse().ok())
            .unwrap_or(0);
        assert!(last > 0, "not reached: {line}");
    }
    let near_far = k.covers.iter().find(|l| l.contains("far root")).unwrap();
    let near: usize = near_far
        .split("taken: ")
        .nth(1)
        .and_then(|s| s.split(';').next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap();
    assert!(near > 0, "{near_far}");
}

/// reparam's own kernel on the GPU (lavapipe in CI) on the canonical vectors: judged by the
/// same per-query bounds, it passes; and the cross-check row on the canonical atlas (a 16²
/// pixel grid per ROI) passes. Skipped without an adapter unless REPARAM_REQUIRE_GPU=1.
#[test]
fn the_gpu_kernel_passes_its_vectors_and_row() {
    let Some(gpu) = reparam_gpu::gpu_or_skip() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("reparam-twin-lookup-gpu-{}", std::process::id()));
    let (kernels, candidates) = canonical_vectors(Some(&gpu)).unwrap();
    write_vectors(&dir, "test", "canonical gridwarp_lookup atlas", &kernels).unwrap();
    let k = read_manifest(&dir).unwrap().kernels.remove(0);
    let r = verify_array(&dir, &k, &candidates[0].1, "gpu").unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "GPU kernel on the canonical vectors: pass {} worst error/bound {:.3e}, {} over",
        r.pass, r.worst_ratio, r.over
    );
    assert!(r.pass, "the GPU kernel fails its vectors: {r:?}");
    let atlas = reparam::vectors::gridwarp_lookup::canonical_atlas().unwrap();
    let row = reparam::crosscheck::gridwarp_lookup::lookup_row(
        &gpu,
        "canonical atlas",
        "five ROIs, AA and NAA",
        &atlas,
        16,
    )
    .unwrap();
    println!("{row:?}");
    assert!(!row.fails(), "{row:?}");
}
