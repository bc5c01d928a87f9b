//! The canonical `maps_inverse` manifest against its data: Π⁻¹ computed in f64 from the
//! manifest's words alone (the walk down the removals, the star search, the clamped
//! barycentrics) meets the expected positions within their bounds (issue #33: the manifest
//! once said only "replay the removals backwards").

// `!(e <= b)` is meant: a NaN error is over its bound.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::{Path, PathBuf};

use reparam::vectors::{read_manifest, Array};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors/maps")
}

fn load(name: &str) -> Vec<f64> {
    Array::load(&dir().join(format!("maps_inverse.{name}.npy")))
        .unwrap()
        .to_f64()
}

type P2 = [f64; 2];

/// The manifest's o(p, q, r).
fn orient(p: P2, q: P2, r: P2) -> f64 {
    (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
}

/// The manifest's barycentric(u, a, b, c).
fn barycentric(u: P2, [a, b, c]: [P2; 3]) -> [f64; 3] {
    let l = [orient(u, b, c), orient(a, u, c), orient(a, b, u)];
    let mut s = l[0] + l[1] + l[2];
    if s == 0.0 {
        s = orient(a, b, c);
    }
    l.map(|x| x / s)
}

/// Queries over their bound when Π⁻¹ is computed from the manifest's words, the charts read
/// at columns `created` (the face's own corners in its creating removal's plane) and `removed`
/// (the star faces' corners).
fn over_with(created: usize, removed: usize) -> usize {
    let manifest = read_manifest(&dir()).unwrap();
    let k = manifest
        .kernels
        .iter()
        .find(|k| k.name == "maps_inverse")
        .unwrap();
    for claim in [
        "face_created_by[face] ≠ 4294967295",
        "the first f with min λ ≥ 0",
        "o(a, b, c) if that sum is 0",
    ] {
        assert!(
            k.description.contains(claim),
            "the manifest no longer says: {claim}"
        );
    }
    let positions = load("positions");
    let corners = load("face_corners");
    let created_by = load("face_created_by");
    let charts = load("charts");
    let removals = load("removals");
    let old_faces = load("old_faces");
    let base_to_face = load("base_to_face");
    let query_face = load("query_face");
    let query_bary = load("query_bary");
    let expected = Array::load(&dir().join(&k.expected.file)).unwrap().to_f64();
    let bound = Array::load(&dir().join(&k.bound.file)).unwrap().to_f64();
    let chart = |f: usize, offset: usize| -> [P2; 3] {
        std::array::from_fn(|c| {
            [
                charts[12 * f + offset + 2 * c],
                charts[12 * f + offset + 2 * c + 1],
            ]
        })
    };
    let mut over = 0;
    for q in 0..query_face.len() {
        let mut face = base_to_face[query_face[q] as usize] as usize;
        let mut b = [
            query_bary[3 * q],
            query_bary[3 * q + 1],
            query_bary[3 * q + 2],
        ];
        while created_by[face] != 4294967295.0 {
            let r = created_by[face] as usize;
            let mu = chart(face, created);
            let u = [0, 1].map(|x| b[0] * mu[0][x] + b[1] * mu[1][x] + b[2] * mu[2][x]);
            let (first, count) = (removals[2 * r] as usize, removals[2 * r + 1] as usize);
            let mut best: Option<(usize, [f64; 3], f64)> = None;
            for &f in &old_faces[first..first + count] {
                let f = f as usize;
                let l = barycentric(u, chart(f, removed));
                let lowest = l[0].min(l[1]).min(l[2]);
                if lowest >= 0.0 {
                    best = Some((f, l, f64::INFINITY));
                    break;
                }
                if best.is_none_or(|(_, _, m)| lowest > m) {
                    best = Some((f, l, lowest));
                }
            }
            let (f, l, _) = best.unwrap();
            let c = l.map(|x| x.max(0.0));
            let s = c[0] + c[1] + c[2];
            face = f;
            b = c.map(|x| x / s);
        }
        let p: Vec<f64> = (0..3)
            .map(|x| {
                (0..3)
                    .map(|c| b[c] * positions[4 * corners[3 * face + c] as usize + x])
                    .sum()
            })
            .collect();
        let e = &expected[3 * q..3 * q + 3];
        let error = ((p[0] - e[0]).powi(2) + (p[1] - e[1]).powi(2) + (p[2] - e[2]).powi(2)).sqrt();
        over += usize::from(!(error <= bound[q]));
    }
    over
}

#[test]
fn the_manifests_walk_reproduces_the_inverse_and_the_charts_swapped_do_not() {
    assert_eq!(over_with(0, 6), 0, "the manifest's reading");
    assert!(
        over_with(6, 0) > 0,
        "the two charts of a face swapped must fail"
    );
}
