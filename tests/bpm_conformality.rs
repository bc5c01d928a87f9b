//! Issue #36: the input map's conformality (cross-ratio mismatch s), the per-face QC figures,
//! and the authors' vertex-evaluation rule, on small procedural meshes.
//!
//! Tolerances: cross-ratios of O(1) layouts and UVs are a few dozen f64 operations, exact to
//! ≈ 1e-15 relative; 1e-10 leaves a wide margin. The QC protocol's per-face means recombine
//! to the overall mean up to summation order (≈ 1e-15 relative); 1e-12 is used.

use std::collections::HashMap;

use num_complex::Complex64 as C;
use reparam::bpm::conformality::*;
use reparam::bpm::quality::{mean_over_faces, qc_protocol_faces};
use reparam::bpm::vertex_rule::{authors_vertex_owners, grid_index, last_columns};
use reparam::bpm::*;
use reparam::mesh::{procedural, Adjacency, TriMesh};

const TOL: f64 = 1e-10;

fn mobius(z: C) -> C {
    (C::new(0.7, 0.2) * z + C::new(0.1, -0.3)) / (C::new(0.2, 0.1) * z + C::new(1.0, 0.4))
}

#[test]
fn edge_mismatch_is_zero_under_a_mobius_map_and_symmetric() {
    let z = [
        C::new(0.0, 0.0),
        C::new(1.0, 0.0),
        C::new(0.3, 0.8),
        C::new(0.6, -0.7),
    ];
    assert!(edge_mismatch(z, z.map(mobius)) < TOL);
    // An anisotropic affine map changes the cross-ratio.
    let affine = z.map(|p| C::new(2.0 * p.re + 0.3 * p.im, 0.5 * p.im));
    let m = edge_mismatch(z, affine);
    assert!(m > 0.1, "{m}");
    // m ↦ 1/m (a ↔ b, c ↔ d) and a Möbius map of the image leave it unchanged.
    let swap = |q: [C; 4]| [q[1], q[0], q[3], q[2]];
    assert!((edge_mismatch(swap(z), swap(affine)) - m).abs() < TOL);
    assert!((edge_mismatch(z, affine.map(mobius)) - m).abs() < TOL);
    // The definition: |log(CR_w / CR_z)| with the principal log.
    let cr = |q: [C; 4]| cross_ratio(q[0], q[1], q[2], q[3]);
    let direct = (cr(affine) / cr(z)).ln().norm();
    assert!((direct - m).abs() < TOL, "{direct} vs {m}");
    // Scale- and translation-free: coordinates near f64's range give the same figure, and a
    // quad that cannot be normalised gives NaN (no value), never ∞.
    let far = |q: [C; 4], k: f64| q.map(|p| p * k + C::new(3.0 * k, -k));
    assert!((edge_mismatch(far(z, 1e300), far(affine, 1e-300)) - m).abs() < TOL);
    assert!(edge_mismatch([z[0]; 4], affine).is_nan());
    let huge = [C::new(-1.5e308, 0.0), C::new(1.5e308, 0.0), z[2], z[3]];
    assert!(edge_mismatch(huge, affine).is_nan());
}

#[test]
fn a_mobius_mesh_is_conformal_and_gets_no_warning() {
    for mesh in [
        procedural::mobius_mesh(6, procedural::default_mobius()),
        procedural::flat_star(8),
    ] {
        let c = conformality(&mesh).unwrap();
        let s_max = c.face_s.iter().cloned().fold(0.0, f64::max);
        assert!(s_max < 1e-9, "{}: s max {s_max}", mesh.name);
        let d = s_distribution(&c);
        assert!((d.area_share[0] - 1.0).abs() < 1e-12, "{d:?}");
        assert!(!needs_warning(&c, &ConformalityOptions::default()));
        assert!(
            conformality_report(&c, None, &ConformalityOptions::default())
                .warning
                .is_none()
        );
    }
}

#[test]
fn an_affine_map_is_not_conformal_and_every_edge_sees_the_same_value_from_both_sides() {
    let mesh = procedural::flat_star_affine(8);
    let c = conformality(&mesh).unwrap();
    let adjacency = Adjacency::new(&mesh);
    let stars = precompute::gather_stars(&mesh, &adjacency);
    for f in 0..mesh.face_count() {
        let own = star_mismatches(&stars[f]);
        #[allow(clippy::needless_range_loop)] // e names the edge in `adjacency.neighbour(f, e)`
        for e in 0..3 {
            match adjacency.neighbour(f, e) {
                Some((g, eg)) => {
                    assert!(own[e] > 1e-3, "face {f} edge {e}: {}", own[e]);
                    // Neither face is mirrored: both stars give the same value.
                    let theirs = star_mismatches(&stars[g])[eg];
                    assert!((own[e] - theirs).abs() < TOL, "{} vs {theirs}", own[e]);
                    assert_eq!(c.edge[f][e], own[e].max(theirs));
                }
                None => assert!(c.edge[f][e].is_nan()),
            }
        }
        let expected = own
            .iter()
            .filter(|m| !m.is_nan())
            .fold(0.0, |a: f64, &m| a.max(m));
        assert!((c.face_s[f] - expected).abs() < TOL);
    }
}

#[test]
fn s_bins_follow_the_bin_edges() {
    assert_eq!(s_bin(0.0), Some(0));
    assert_eq!(s_bin(0.4999), Some(0));
    assert_eq!(s_bin(0.5), Some(1));
    assert_eq!(s_bin(1.0), Some(2));
    assert_eq!(s_bin(3.9), Some(3));
    assert_eq!(s_bin(4.0), Some(4));
    assert_eq!(s_bin(1e300), Some(4));
    assert_eq!(s_bin(f64::NAN), None);
}

/// A hand-made measurement: four faces of areas 1, 2, 3, 4 with s = 0.1, 0.7, 1.5, NaN.
fn hand_made() -> Conformality {
    Conformality {
        edge: vec![[f64::NAN; 3]; 4],
        face_s: vec![0.1, 0.7, 1.5, f64::NAN],
        face_area: vec![1.0, 2.0, 3.0, 4.0],
    }
}

#[test]
fn the_distribution_and_the_warning_weigh_by_area_and_leave_degenerate_faces_out() {
    let c = hand_made();
    let d = s_distribution(&c);
    assert_eq!(d.area_share, [1.0 / 6.0, 2.0 / 6.0, 3.0 / 6.0, 0.0, 0.0]);
    assert_eq!(d.faces, [1, 1, 1, 0, 0]);
    assert_eq!(d.unmeasured_faces, 1);
    assert!((d.mean - (0.1 + 1.4 + 4.5) / 6.0).abs() < 1e-15);
    assert_eq!(d.max, 1.5);
    assert_eq!(area_share_at_least(&c, 1.0), 0.5);
    let options = ConformalityOptions::default();
    assert!(needs_warning(&c, &options));
    let strict = ConformalityOptions {
        warn_area_share: 0.6,
        ..options
    };
    assert!(!needs_warning(&c, &strict));
    // With per-face QC: the warning quotes the s ≥ 1 faces' means, the bins their own.
    let qc = |mean: f64| FaceQc {
        mean,
        max: mean,
        folded: 0,
        collapsed: 0,
        measured_area: 1.0,
    };
    let bpm = [qc(1.0), qc(1.2), qc(5.0), qc(f64::NAN)];
    let linear = [qc(1.1), qc(1.3), qc(3.0), qc(f64::NAN)];
    let report = conformality_report(
        &c,
        Some(FaceMeans {
            bpm: &bpm,
            linear: &linear,
        }),
        &options,
    );
    let w = report.warning.expect("a warning");
    assert_eq!((w.bpm_mean, w.linear_mean), (Some(5.0), Some(3.0)));
    assert!(w.message.contains("near-conformal"), "{}", w.message);
    assert!(w.message.contains("50.0%"), "{}", w.message);
    assert!(w.message.contains("BPM is worse"), "{}", w.message);
    assert_eq!(report.by_bin[0].bpm_mean, Some(1.0));
    assert_eq!(report.by_bin[2].linear_mean, Some(3.0));
    assert_eq!(report.by_bin[3].bpm_mean, None);
}

#[test]
fn per_face_figures_recombine_to_the_protocol_figures() {
    let mesh = procedural::flat_star_affine(6);
    let bpm = precompute(&mesh, BpmOptions::default()).unwrap();
    for interp in [Interp::Bpm, Interp::Linear] {
        let (stats, faces) = qc_protocol_faces(&bpm, interp, 2, None);
        assert_eq!(faces.len(), mesh.face_count());
        assert_eq!(stats, qc_protocol(&bpm, interp, 2));
        let mean = mean_over_faces(&faces, |_| true);
        assert!(
            (mean - stats.mean).abs() < 1e-12 * stats.mean,
            "{mean} vs {}",
            stats.mean
        );
        let max = faces.iter().map(|q| q.max).fold(0.0, f64::max);
        assert_eq!(max, stats.max);
        let folded: u32 = faces.iter().map(|q| q.folded).sum();
        assert_eq!(folded as usize, stats.folded);
    }
}

#[test]
fn last_columns_after_one_subdivision() {
    // Grid order: (0,0) v1, (1,0) m12, (2,0) v2, (0,1) m31, (1,1) m23, (0,2) v3. Children
    // [v1 m12 m31], [m12 v2 m23], [m23 v3 m31], [m12 m23 m31]: v3 appears only in column 2.
    assert_eq!(last_columns(1), vec![0, 1, 1, 2, 2, 1]);
    assert_eq!(last_columns(0), vec![0, 1, 2]);
}

/// A literal transcription of the authors' pipeline for ownership: `meshSubdivision` applied
/// `subdiv` times to the whole mesh (one midpoint per undirected edge, children of row r at
/// rows 4r−3 … 4r), then `Vzsubd_origF(F_subd(:)) = orig_F` (column-major, last assignment
/// wins). Returns, per (face, grid index), the face that evaluates that sub-vertex.
fn authors_owner_table(mesh: &TriMesh, subdiv: u32) -> Vec<Vec<usize>> {
    let n = 1usize << subdiv;
    // Vertex ids: input vertices by (position, UV) pair, midpoints by their edge's id pair.
    let mut ids: HashMap<(u64, u64), usize> = HashMap::new();
    let id_of = |key: (u64, u64), ids: &mut HashMap<(u64, u64), usize>| {
        let next = ids.len();
        *ids.entry(key).or_insert(next)
    };
    // Rows: (vertex ids, original face, grid coordinates of the corners).
    type Row = ([usize; 3], usize, [(usize, usize); 3]);
    let mut rows: Vec<Row> = (0..mesh.face_count())
        .map(|f| {
            let v = [0, 1, 2].map(|c| {
                let key = (
                    mesh.faces[f][c] as u64,
                    (1 << 40) + mesh.uv_faces[f][c] as u64,
                );
                id_of(key, &mut ids)
            });
            (v, f, [(0, 0), (n, 0), (0, n)])
        })
        .collect();
    for _ in 0..subdiv {
        let mut next = Vec::with_capacity(4 * rows.len());
        for (v, f, g) in &rows {
            let mut mid = |a: usize, b: usize| {
                let key = (v[a].min(v[b]) as u64, v[a].max(v[b]) as u64 + (1 << 50));
                let id = id_of(key, &mut ids);
                let grid = ((g[a].0 + g[b].0) / 2, (g[a].1 + g[b].1) / 2);
                (id, grid)
            };
            let (m12, m23, m31) = (mid(0, 1), mid(1, 2), mid(2, 0));
            let (v1, v2, v3) = ((v[0], g[0]), (v[1], g[1]), (v[2], g[2]));
            for child in [
                [v1, m12, m31],
                [m12, v2, m23],
                [m23, v3, m31],
                [m12, m23, m31],
            ] {
                next.push((child.map(|x| x.0), *f, child.map(|x| x.1)));
            }
        }
        rows = next;
    }
    let mut owner = vec![usize::MAX; ids.len()];
    for column in 0..3 {
        for (v, f, _) in &rows {
            owner[v[column]] = *f;
        }
    }
    let mut table = vec![vec![usize::MAX; grid_index(0, n, n) + 1]; mesh.face_count()];
    for (v, f, g) in &rows {
        for c in 0..3 {
            table[*f][grid_index(g[c].0, g[c].1, n)] = owner[v[c]];
        }
    }
    table
}

#[test]
fn the_vertex_rule_matches_a_transcription_of_the_authors_subdivision() {
    let meshes = [
        procedural::folded_star(150f64.to_radians()),
        procedural::torus(6, 4, 1.0, 0.4),
        procedural::two_charts_mirrored(2),
    ];
    for mesh in &meshes {
        for subdiv in 0..=3 {
            let table = authors_owner_table(mesh, subdiv);
            let owners = authors_vertex_owners(mesh, &Adjacency::new(mesh), subdiv);
            let n = 1usize << subdiv;
            for f in 0..mesh.face_count() {
                let mut ours = vec![f; table[f].len()];
                for b in &owners.borrowed[f] {
                    ours[b.grid_index] = b.owner;
                    // The owner's barycentrics name the same sub-vertex there.
                    let (r, s) = (
                        (b.bary[1] * n as f64).round() as usize,
                        (b.bary[2] * n as f64).round() as usize,
                    );
                    assert_eq!(table[b.owner][grid_index(r, s, n)], b.owner);
                }
                assert_eq!(ours, table[f], "{} subdiv {subdiv} face {f}", mesh.name);
            }
        }
    }
}

#[test]
fn the_vertex_rule_matters_only_under_the_authors_unfolding() {
    let mesh = procedural::folded_star(150f64.to_radians());
    let owners = authors_vertex_owners(&mesh, &Adjacency::new(&mesh), 3);
    let figures = |unfold: Unfold| {
        let bpm = precompute(
            &mesh,
            BpmOptions {
                unfold,
                ..Default::default()
            },
        )
        .unwrap();
        let per_face = qc_protocol_faces(&bpm, Interp::Bpm, 3, None).0.mean;
        let authors = qc_protocol_faces(&bpm, Interp::Bpm, 3, Some(&owners))
            .0
            .mean;
        (per_face, authors)
    };
    // Correct unfolding: BPM is continuous across edges, the rule changes only rounding.
    let (a, b) = figures(Unfold::Correct);
    assert!((a - b).abs() < 1e-12 * a, "{a} vs {b}");
    // Authors' unfolding: the two faces of the 150° edge disagree there.
    let (a, b) = figures(Unfold::Authors);
    assert!((a - b).abs() > 1e-6 * a, "{a} vs {b}");
}

/// The authors' MATLAB code (shirrorbe/BPM e5054766, run under GNU Octave 7.3 with
/// `tools/bpm_octave`) on `procedural:folded_star` written as an OBJ (the neighbour across t's
/// first edge folded by 150°), n = 4: BPM area-average QC 2.168216422, max 123.702703; per
/// face (their `bpm_qc.m` per-face CSV) the means below. Printed to 10 and 17 digits; the
/// codes differ by rounding only (≈ 1e-13 relative per face), so 1e-9 relative.
#[test]
fn the_authors_unfolding_and_vertex_rule_reproduce_their_code_on_a_folded_star() {
    let mesh = procedural::folded_star(150f64.to_radians());
    let bpm = precompute(
        &mesh,
        BpmOptions {
            unfold: Unfold::Authors,
            ..Default::default()
        },
    )
    .unwrap();
    let owners = authors_vertex_owners(&mesh, &Adjacency::new(&mesh), 4);
    let (stats, faces) = qc_protocol_faces(&bpm, Interp::Bpm, 4, Some(&owners));
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b;
    assert!(close(stats.mean, 2.168216422), "{}", stats.mean);
    assert!(close(stats.max, 123.702703), "{}", stats.max);
    let octave = [
        3.796017879138307,
        2.111030853880805,
        1.1464681611318883,
        1.174197895777918,
    ];
    for (f, (q, o)) in faces.iter().zip(octave).enumerate() {
        assert!(close(q.mean, o), "face {f}: {} vs {o}", q.mean);
    }
    // Each face evaluating its own sub-vertices gives another figure.
    let per_face = qc_protocol_faces(&bpm, Interp::Bpm, 4, None).0.mean;
    assert!(!close(per_face, 2.168216422), "{per_face}");
}

/// The authors' code has no orientation fix: under `Unfold::Authors` a face with clockwise UVs
/// keeps its counter-clockwise layout (on spot this gives their 2.571507 instead of 2.28913),
/// while the report still counts the clockwise faces and folds are counted against the UV
/// triangle's orientation (so linear interpolation, exact and per face, has none in both).
#[test]
fn the_authors_layout_does_not_mirror_clockwise_uv_faces() {
    let mesh = procedural::two_charts_mirrored(3);
    let run = |unfold: Unfold| {
        let bpm = precompute(
            &mesh,
            BpmOptions {
                unfold,
                ..Default::default()
            },
        )
        .unwrap();
        let linear = qc_protocol(&bpm, Interp::Linear, 2);
        (bpm, linear)
    };
    let (correct, linear_correct) = run(Unfold::Correct);
    let (authors, linear_authors) = run(Unfold::Authors);
    let clockwise = correct.maps.iter().filter(|t| t.mirrored).count();
    assert!(clockwise > 0 && clockwise < mesh.face_count());
    assert!(authors.maps.iter().all(|t| !t.mirrored));
    assert_eq!(authors.report.mirrored_faces, clockwise);
    assert_eq!(correct.report.mirrored_faces, clockwise);
    assert_eq!(linear_correct.folded, 0);
    assert_eq!(linear_authors.folded, 0);
    assert!((linear_correct.mean - linear_authors.mean).abs() < 1e-12);
    // The clockwise chart's Möbius maps turn its triangles inside out: BPM is far off there.
    let bpm_correct = qc_protocol(&correct, Interp::Bpm, 2).mean;
    let bpm_authors = qc_protocol(&authors, Interp::Bpm, 2).mean;
    assert!(bpm_correct < 1.0 + 1e-9, "{bpm_correct}");
    assert!(bpm_authors > 10.0, "{bpm_authors}");
}
