//! Properties of the MAPS reference (notes `maps.md`, "Tests that pin it down", 1–9), the
//! PLY/OFF loaders and the manifold check.

use std::collections::{BTreeSet, HashSet};
use std::f64::consts::{PI, TAU};
use std::path::Path;

use nalgebra::{Point2, Point3};
use reparam::maps::flatten::{cumulative_angles, flatten_ring, FlattenReject, RingShape};
use reparam::maps::remesh::{adaptive, uniform, uniform_counts, AdaptiveOptions, VKey};
use reparam::maps::retriangulate::barycentric;
use reparam::maps::smooth::{
    even_weights, loop_beta, smoothed_net, uniform_smoothed, uniform_smoothed_with, LoopBeta,
    SmoothOptions, CREASE_EVEN_WEIGHTS, CREASE_ODD_WEIGHTS, ODD_WEIGHTS,
};
use reparam::maps::{
    build, detect_features, parse_features, BasePoint, FeatureOptions, Features, Maps, MapsOptions,
};
use reparam::mesh::distance::SurfaceTree;
use reparam::mesh::{check_manifold, load_mesh, procedural, TriMesh};
use reparam::Error;

// ---------------------------------------------------------------- fixtures

/// Icosphere: the icosahedron with every face quadrisected `n` times, vertices on the unit
/// sphere (closed, genus 0, 20·4ⁿ faces).
fn icosphere(n: usize) -> TriMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pos: Vec<Point3<f64>> = [
        [-1., t, 0.],
        [1., t, 0.],
        [-1., -t, 0.],
        [1., -t, 0.],
        [0., -1., t],
        [0., 1., t],
        [0., -1., -t],
        [0., 1., -t],
        [t, 0., -1.],
        [t, 0., 1.],
        [-t, 0., -1.],
        [-t, 0., 1.],
    ]
    .iter()
    .map(|p| Point3::from(nalgebra::Vector3::new(p[0], p[1], p[2]).normalize()))
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..n {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for f in &faces {
            let m = [0, 1, 2].map(|e| {
                let (a, b) = (f[e], f[(e + 1) % 3]);
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let p = Point3::from(
                        ((pos[a as usize].coords + pos[b as usize].coords) / 2.0).normalize(),
                    );
                    pos.push(p);
                    pos.len() as u32 - 1
                })
            });
            next.extend([
                [f[0], m[0], m[2]],
                [m[0], f[1], m[1]],
                [m[2], m[1], f[2]],
                [m[0], m[1], m[2]],
            ]);
        }
        faces = next;
    }
    TriMesh::with_shared_indices("test:icosphere", pos, Vec::new(), faces)
}

/// A flat `n × n` grid on [0, 1]² (z = 0), with boundary; the four corners are its corners.
fn flat_grid(n: usize) -> TriMesh {
    let mut m = procedural::wavy_grid(n);
    for p in &mut m.positions {
        p.z = 0.0;
    }
    m.uvs.clear();
    m.uv_faces.clear();
    m.name = "test:flat_grid".into();
    m
}

/// The four corner vertices of [`flat_grid`].
fn grid_corners(m: &TriMesh) -> Features {
    let mut f = Features::default();
    for (i, p) in m.positions.iter().enumerate() {
        if (p.x == 0.0 || p.x == 1.0) && (p.y == 0.0 || p.y == 1.0) {
            f.corners.insert(i as u32);
        }
    }
    f
}

/// The surface of the cube [−1, 1]³, each face an `n × n` grid (closed, sharp edges and
/// corners for the feature tests).
fn cube(n: usize) -> TriMesh {
    let mut pos: Vec<Point3<f64>> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut faces = Vec::new();
    let mut vid = |p: [i64; 3], pos: &mut Vec<Point3<f64>>| {
        *index.entry(p).or_insert_with(|| {
            pos.push(
                Point3::new(p[0] as f64, p[1] as f64, p[2] as f64) * (2.0 / n as f64)
                    - nalgebra::Vector3::repeat(1.0),
            );
            pos.len() as u32 - 1
        })
    };
    let n = n as i64;
    // (fixed axis, value, u axis, v axis) with u × v pointing outwards.
    let sides = [
        (0, n, 1, 2),
        (0, 0, 2, 1),
        (1, n, 2, 0),
        (1, 0, 0, 2),
        (2, n, 0, 1),
        (2, 0, 1, 0),
    ];
    for (axis, value, ua, va) in sides {
        for i in 0..n {
            for j in 0..n {
                let at = |a: i64, b: i64| {
                    let mut p = [0i64; 3];
                    p[axis] = value;
                    p[ua] = a;
                    p[va] = b;
                    p
                };
                let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]
                    .map(|p| vid(p, &mut pos));
                faces.push([q[0], q[1], q[2]]);
                faces.push([q[0], q[2], q[3]]);
            }
        }
    }
    TriMesh::with_shared_indices("test:cube", pos, Vec::new(), faces)
}

/// A bipyramid: an `n`-gon equator and two apexes of valence `n` at z = ±`h` (closed; high
/// valence, and sharp cones for large h).
fn bipyramid(n: usize, h: f64) -> TriMesh {
    let mut pos = vec![Point3::new(0.0, 0.0, h), Point3::new(0.0, 0.0, -h)];
    for k in 0..n {
        let a = TAU * k as f64 / n as f64;
        pos.push(Point3::new(a.cos(), a.sin(), 0.0));
    }
    let mut faces = Vec::new();
    for k in 0..n as u32 {
        let (a, b) = (2 + k, 2 + (k + 1) % n as u32);
        faces.push([0, a, b]);
        faces.push([1, b, a]);
    }
    TriMesh::with_shared_indices("test:bipyramid", pos, Vec::new(), faces)
}

/// A wavy grid whose middle row of vertices is pushed to within 1e-7 of the row below it:
/// near-degenerate (sliver) triangles, still valid.
fn sliver_grid(n: usize) -> TriMesh {
    let mut m = procedural::wavy_grid(n);
    m.uvs.clear();
    m.uv_faces.clear();
    let row = n / 2;
    let h = 1.0 / n as f64;
    for p in &mut m.positions {
        if (p.y - row as f64 * h).abs() < 1e-12 {
            p.y = (row as f64 - 1.0) * h + 1e-7;
        }
    }
    m.name = "test:sliver_grid".into();
    m
}

fn diagonal(m: &TriMesh) -> f64 {
    let (lo, hi) = m.bounding_box();
    (hi - lo).norm()
}

fn built(m: &TriMesh, f: &Features) -> Maps {
    build(m, f, &MapsOptions::default()).expect("maps builds")
}

/// Undirected edges of a face list.
fn edges_of(faces: &[[u32; 3]]) -> BTreeSet<(u32, u32)> {
    faces
        .iter()
        .flat_map(|f| (0..3).map(move |e| (f[e].min(f[(e + 1) % 3]), f[e].max(f[(e + 1) % 3]))))
        .collect()
}

/// Edges used by one face only.
fn boundary_edges(faces: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let mut count = std::collections::BTreeMap::new();
    for f in faces {
        for e in 0..3 {
            let (a, b) = (f[e], f[(e + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    count
        .into_iter()
        .filter(|&(_, c)| c == 1)
        .map(|(e, _)| e)
        .collect()
}

fn euler(faces: &[[u32; 3]]) -> i64 {
    let v: HashSet<u32> = faces.iter().flatten().copied().collect();
    v.len() as i64 - edges_of(faces).len() as i64 + faces.len() as i64
}

/// Deterministic pseudo-random numbers in [0, 1) (64-bit LCG, top 53 bits).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

// ---------------------------------------------------------------- 1. flattening

#[test]
fn flattening_angles_are_cumulative_and_scaled_to_a_full_turn() {
    // A non-planar ring with unequal sectors around a centre at the origin.
    let centre = Point3::origin();
    let ring: Vec<Point3<f64>> = [
        (0.0, 1.0, 0.3),
        (0.7, 1.4, -0.2),
        (1.9, 0.8, 0.4),
        (3.0, 1.2, 0.0),
        (4.4, 0.9, -0.3),
    ]
    .iter()
    .map(|&(a, r, z)| Point3::new(r * f64::cos(a), r * f64::sin(a), z))
    .collect();
    let theta = cumulative_angles(&centre, &ring, true);
    let mu = flatten_ring(&centre, &ring, RingShape::Disk).unwrap();
    let a = TAU / theta[ring.len()];
    // a·θ_K = 2π up to rounding of one division and one multiplication (a few ulps of 2π).
    assert!((a * theta[ring.len()] - TAU).abs() < 1e-14);
    for k in 0..ring.len() {
        let arg = mu[k][1].atan2(mu[k][0]).rem_euclid(TAU);
        // arg μ_k = a θ_k (cumulative, not the total for every vertex): the angles are O(1), so
        // atan2 and cos/sin round-trip to ~1e-15.
        assert!(
            (arg - a * theta[k]).abs() < 1e-12,
            "k={k}: {arg} vs {}",
            a * theta[k]
        );
        let r = (ring[k] - centre).norm();
        assert!(((mu[k][0].hypot(mu[k][1])) - r.powf(a)).abs() < 1e-12);
        if k > 0 {
            assert!(theta[k] > theta[k - 1], "strictly increasing");
        }
    }
    // The half disk of the open ring: ends on the real axis at angles 0 and π.
    let half = flatten_ring(&centre, &ring, RingShape::HalfDisk).unwrap();
    let last = ring.len() - 1;
    assert_eq!(half[0][1], 0.0);
    assert_eq!(half[last][1], 0.0);
    assert!(half[0][0] > 0.0 && half[last][0] < 0.0);
    let theta_open = cumulative_angles(&centre, &ring, false);
    let a_half = PI / theta_open[last];
    for k in 1..last {
        let arg = half[k][1].atan2(half[k][0]);
        assert!((arg - a_half * theta_open[k]).abs() < 1e-12);
        assert!(
            half[k][1] > 0.0,
            "interior of the half disk is the upper half plane"
        );
    }
}

#[test]
fn flattening_guard_keeps_every_fan_counter_clockwise() {
    // Random closed rings (clustered or spread, non-planar): a·φ_k ≤ π always holds (a sector
    // is at most the sum of the others), so they flatten, and every fan triangle
    // (0, μ_k, μ_k+1) is counter-clockwise.
    let mut rng = Lcg(7);
    for _ in 0..200 {
        let k = 3 + (rng.next() * 6.0) as usize;
        let spread = 0.05 + 0.95 * rng.next();
        let mut angles: Vec<f64> = (0..k).map(|_| spread * rng.next()).collect();
        angles.sort_by(f64::total_cmp);
        let ring: Vec<Point3<f64>> = angles
            .iter()
            .map(|&t| {
                let a = t * TAU;
                Point3::new(a.cos(), a.sin(), 0.6 * rng.next() - 0.3)
            })
            .collect();
        let theta = cumulative_angles(&Point3::origin(), &ring, true);
        if theta.windows(2).any(|w| w[1] <= w[0]) {
            continue; // two coincident directions: degenerate, rejected as such
        }
        let mu = flatten_ring(&Point3::origin(), &ring, RingShape::Disk).expect("flattens");
        for m in 0..k {
            let (p, q) = (mu[m], mu[(m + 1) % k]);
            assert!(p[0] * q[1] - p[1] * q[0] > 0.0, "fan triangle {m} of {k}");
        }
    }
    // A side with a single sector would map its triangle onto the chord (a·φ = π): rejected,
    // for a boundary vertex with one face and for a feature line with one face on a side.
    let c = Point3::origin();
    let open = [Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.2)];
    assert_eq!(
        flatten_ring(&c, &open, RingShape::HalfDisk),
        Err(FlattenReject::FlippedFan)
    );
    let ring: Vec<Point3<f64>> = (0..6)
        .map(|k| Point3::new((k as f64).cos(), (k as f64).sin(), 0.0))
        .collect();
    assert_eq!(
        flatten_ring(&c, &ring, RingShape::FeatureLine { s: 1, t: 2 }),
        Err(FlattenReject::FlippedFan)
    );
    assert!(flatten_ring(&c, &ring, RingShape::FeatureLine { s: 1, t: 4 }).is_ok());
    // A zero-length spoke is degenerate, not a NaN.
    let mut bad = ring.clone();
    bad[2] = c;
    assert_eq!(
        flatten_ring(&c, &bad, RingShape::Disk),
        Err(FlattenReject::Degenerate)
    );
}

// ---------------------------------------------------------------- 2. flat-mesh oracle

#[test]
fn flat_mesh_oracle_holds_at_every_level() {
    let m = flat_grid(8);
    let corners = grid_corners(&m);
    let full = built(&m, &corners);
    assert!(full.level_count() >= 3);
    for levels in 1..=full.level_count() {
        let options = MapsOptions {
            max_levels: levels,
            ..MapsOptions::default()
        };
        let maps = build(&m, &corners, &options).unwrap();
        for v in 0..m.positions.len() {
            // On a planar mesh every a = 1 and μ is rigid, so Σ b_c P(corner_c) = p_v up to the
            // rounding of a few levels of affine combinations of O(1) coordinates (≤ 1e-15
            // each); 1e-12 leaves room for ~1000 such steps and still catches any real error.
            let p = maps.base_position(v).unwrap();
            assert!(
                (p - m.positions[v]).norm() < 1e-12,
                "level {levels}, vertex {v}: {p} vs {}",
                m.positions[v]
            );
        }
    }
}

// ---------------------------------------------------------------- 3. bijectivity, 4. round trip

/// Notes test 3 and 4 on one mesh.
fn check_bijective(m: &TriMesh, features: &Features) -> Maps {
    let maps = built(m, features);
    let diag = diagonal(m);
    for (v, &(f, b)) in maps.location.iter().enumerate() {
        assert!((f as usize) < maps.base_faces.len(), "vertex {v}");
        // Barycentrics from robust orientations, normalised: within [−ε, 1 + ε] with ε a few
        // ulps; 1e-12 is generous and still rejects a wrong triangle (off by O(1)).
        assert!(
            b.iter().all(|&x| (-1e-12..=1.0 + 1e-12).contains(&x)),
            "vertex {v}: {b:?}"
        );
        assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
    // Every level map preserves orientation: old fans and new triangles are all CCW in μ.
    assert_eq!(maps.param.count_flipped(), 0);
    // Random probes in every base face have a preimage (Π⁻¹ finds a containing input face at
    // every step) and map back onto themselves (Π(Π⁻¹(q)) = q): covered, and by exactly one
    // point, since Π⁻¹ and Π replay the same planar bijections.
    let mut rng = Lcg(11);
    for t in 0..maps.base_faces.len() as u32 {
        for _ in 0..4 {
            let (mut x, mut y) = (rng.next(), rng.next());
            if x + y > 1.0 {
                (x, y) = (1.0 - x, 1.0 - y);
            }
            let q = BasePoint {
                face: t,
                bary: [1.0 - x - y, x, y],
            };
            let found = maps.param.inverse(&q).expect("Π⁻¹ finds a face");
            assert!(
                found.min_bary >= 0.0,
                "base face {t}: probe outside by {}",
                found.min_bary
            );
            let back = maps.param.forward(found.face, found.bary).unwrap();
            assert_eq!(
                back.face, t,
                "probe in base face {t} came back in {}",
                back.face
            );
            // Each level step rounds u = Σ b μ and the robust barycentrics to ~1e-16 of O(1)
            // numbers; over ≤ 30 levels and two directions the drift stays below 1e-12.
            for c in 0..3 {
                assert!(
                    (back.bary[c] - q.bary[c]).abs() < 1e-12,
                    "base face {t}: {:?} vs {:?}",
                    back.bary,
                    q.bary
                );
            }
        }
    }
    // Round trip Π⁻¹(Π(p_v)) = p_v, and for random points of input faces.
    for v in 0..m.positions.len() as u32 {
        let q = maps.param.vertex(v).unwrap();
        let back = maps.param.inverse(&q).unwrap();
        // The point is recovered as an interpolation in the face whose chart image contains
        // it: error ≈ rounding of the chart coordinates (1e-16 relative) times the face size.
        assert!(
            (back.position - m.positions[v as usize]).norm() < 1e-9 * diag,
            "vertex {v}"
        );
    }
    for f in (0..m.faces.len() as u32).step_by(7) {
        let (x, y) = (rng.next() * 0.5, rng.next() * 0.5);
        let b = [1.0 - x - y, x, y];
        let q = maps.param.forward(f, b).unwrap();
        let back = maps.param.inverse(&q).unwrap();
        let tri = m.faces[f as usize];
        let p = m.positions[tri[0] as usize].coords * b[0]
            + m.positions[tri[1] as usize].coords * b[1]
            + m.positions[tri[2] as usize].coords * b[2];
        assert!((back.position.coords - p).norm() < 1e-9 * diag, "face {f}");
    }
    maps
}

#[test]
fn sphere_is_bijective_and_round_trips() {
    check_bijective(&icosphere(3), &Features::default());
}

#[test]
fn torus_genus_one_is_bijective_and_round_trips() {
    let mut t = procedural::torus(24, 12, 1.0, 0.4);
    t.uvs.clear();
    t.uv_faces.clear();
    let maps = check_bijective(&t, &Features::default());
    assert_eq!(euler(&maps.base_faces), 0);
}

#[test]
fn boundary_mesh_is_bijective_and_round_trips() {
    let mut m = procedural::wavy_grid(12);
    m.uvs.clear();
    m.uv_faces.clear();
    let corners = grid_corners(&m);
    check_bijective(&m, &corners);
}

#[test]
fn high_valence_sharp_cones_and_slivers_work() {
    // Apexes of valence 40 (above the degree limit: they stay) on sharp cones (h = 6).
    let maps = check_bijective(&bipyramid(40, 6.0), &Features::default());
    assert!(maps.base_faces.iter().flatten().any(|&v| v == 0));
    let mut m = sliver_grid(10);
    let corners = grid_corners(&m);
    m.name = "test:sliver_grid".into();
    check_bijective(&m, &corners);
}

// ---------------------------------------------------------------- 5. per level, 6. bound

#[test]
fn every_level_is_an_independent_maximal_set_and_keeps_the_topology() {
    for m in [icosphere(2), cube(4)] {
        let maps = built(&m, &Features::default());
        let chi = euler(&m.faces);
        for (l, level) in maps.levels.iter().enumerate() {
            let edges = edges_of(&level.faces);
            let adjacent = |a: u32, b: u32| edges.contains(&(a.min(b), a.max(b)));
            for (i, &a) in level.selected.iter().enumerate() {
                for &b in &level.selected[i + 1..] {
                    assert!(!adjacent(a, b), "level {l}: {a} and {b} are neighbours");
                }
            }
            if !level.truncated {
                let selected: HashSet<u32> = level.selected.iter().copied().collect();
                for &c in &level.candidates {
                    let covered =
                        selected.contains(&c) || level.selected.iter().any(|&s| adjacent(c, s));
                    assert!(covered, "level {l}: candidate {c} could have been added");
                }
                let mut done: Vec<u32> = level
                    .removed
                    .iter()
                    .chain(&level.rejected)
                    .copied()
                    .collect();
                let mut sel = level.selected.clone();
                done.sort_unstable();
                sel.sort_unstable();
                assert_eq!(done, sel);
            }
            assert_eq!(euler(&level.faces), chi, "level {l}");
            let mesh = TriMesh::with_shared_indices(
                "level",
                m.positions.clone(),
                Vec::new(),
                level.faces.clone(),
            );
            check_manifold(&mesh).unwrap_or_else(|e| panic!("level {l}: {e}"));
        }
        assert_eq!(euler(&maps.base_faces), chi);
        check_manifold(&maps.base_mesh()).unwrap();
    }
}

#[test]
fn level_count_is_within_the_dobkin_kirkpatrick_bound() {
    for m in [icosphere(3), {
        let mut t = procedural::torus(32, 16, 1.0, 0.4);
        t.uv_faces.clear();
        t.uvs.clear();
        t
    }] {
        let maps = built(&m, &Features::default());
        let v_top = m.positions.len() as f64;
        let v_base = maps
            .base_faces
            .iter()
            .flatten()
            .copied()
            .collect::<HashSet<_>>()
            .len() as f64;
        let bound = ((v_top / v_base).ln() / (24.0f64 / 23.0).ln()).ceil() as usize;
        // The last level removes nothing (that is how the loop stops): not counted.
        let productive = maps.levels.iter().filter(|l| !l.removed.is_empty()).count();
        assert!(
            productive <= bound,
            "{}: {productive} levels, bound {bound}",
            m.name
        );
        assert!(v_base < v_top / 4.0, "{}: base {v_base} of {v_top}", m.name);
    }
}

// ---------------------------------------------------------------- 7. features

#[test]
fn cube_corners_survive_and_feature_chains_map_onto_base_edges() {
    let m = cube(4);
    let features = detect_features(&m, &FeatureOptions::default());
    // 12 cube edges of 4 segments each are sharp (90° between normals); no face diagonal is.
    assert_eq!(features.edges.len(), 48);
    let maps = built(&m, &features);
    let base_vertices: HashSet<u32> = maps.base_faces.iter().flatten().copied().collect();
    for (v, p) in m.positions.iter().enumerate() {
        if p.x.abs() == 1.0 && p.y.abs() == 1.0 && p.z.abs() == 1.0 {
            assert!(
                base_vertices.contains(&(v as u32)),
                "cube corner {v} was removed"
            );
        }
    }
    let base_edges = edges_of(&maps.base_faces);
    assert!(maps
        .base_feature_edges
        .iter()
        .all(|e| base_edges.contains(e)));
    // Every input feature edge lies on one base feature edge: both ends have a zero
    // barycentric for the third corner (exactly: points on the chord stay on the real axis).
    for &(a, b) in &features.edges {
        // The base feature edges a vertex lies on: all those at a base vertex, else the one
        // whose opposite corner has barycentric exactly 0.
        let on_feature_edge = |v: u32| -> Vec<(u32, u32)> {
            let (t, bary) = maps.location[v as usize];
            let f = maps.base_faces[t as usize];
            if let Some(c) = (0..3).find(|&c| bary[c] == 1.0) {
                let at = f[c];
                return maps
                    .base_feature_edges
                    .iter()
                    .copied()
                    .filter(|e| e.0 == at || e.1 == at)
                    .collect();
            }
            (0..3)
                .filter(|&c| bary[c] == 0.0)
                .map(|c| {
                    let (x, y) = (f[(c + 1) % 3], f[(c + 2) % 3]);
                    (x.min(y), x.max(y))
                })
                .filter(|e| maps.base_feature_edges.contains(e))
                .collect()
        };
        let (ea, eb) = (on_feature_edge(a), on_feature_edge(b));
        assert!(
            ea.iter().any(|e| eb.contains(e)),
            "input feature edge ({a}, {b}) is not on one base feature edge: {ea:?} {eb:?}"
        );
    }
}

#[test]
fn tagged_features_from_a_sidecar_survive() {
    let m = icosphere(2);
    let [a, b, _] = m.faces[0];
    let text = format!("# corners and one edge\nv 17\nv 100\ne {a} {b}\n");
    let features = parse_features(&text, Path::new("tags.txt")).unwrap();
    assert_eq!(features.corners.len(), 2);
    let maps = built(&m, &features);
    let base: HashSet<u32> = maps.base_faces.iter().flatten().copied().collect();
    assert!(base.contains(&17) && base.contains(&100));
    // A single tagged edge has free ends: both are corners (feature degree 1) and the edge
    // itself survives as a base edge.
    assert!(edges_of(&maps.base_faces).contains(&(a.min(b), a.max(b))));
    assert!(base.contains(&a) && base.contains(&b));
    let err = parse_features("v 1\nx 2\n", Path::new("tags.txt")).unwrap_err();
    assert!(
        matches!(err, Error::MeshParse { ref message, .. } if message.starts_with("line 2")),
        "{err}"
    );
    let bad = Features {
        corners: [999_999].into(),
        ..Features::default()
    };
    assert!(matches!(
        build(&m, &bad, &MapsOptions::default()),
        Err(Error::InvalidArgument(_))
    ));
}

// ---------------------------------------------------------------- 8. remeshing

#[test]
fn uniform_remesh_counts_and_vertices_on_the_surface() {
    let m = icosphere(3);
    let maps = built(&m, &Features::default());
    let f0 = maps.base_faces.len();
    let e0 = edges_of(&maps.base_faces).len();
    let v0 = maps
        .base_faces
        .iter()
        .flatten()
        .copied()
        .collect::<HashSet<_>>()
        .len();
    let tree = SurfaceTree::new(&m.positions, &m.faces);
    let diag = diagonal(&m);
    let mut previous = f64::INFINITY;
    for j in 0..=3 {
        let r = uniform(&maps, j).unwrap();
        let (v, f) = uniform_counts(v0, e0, f0, j);
        assert_eq!(r.mesh.faces.len(), f, "j={j}");
        let used = r
            .mesh
            .faces
            .iter()
            .flatten()
            .copied()
            .collect::<HashSet<_>>()
            .len();
        assert_eq!(used, v, "j={j}");
        assert_eq!(r.unmapped, 0);
        for p in &r.mesh.positions {
            // Π⁻¹ interpolates inside an input face: on the surface up to rounding.
            assert!(tree.distance(p) < 1e-9 * diag);
        }
        // Smooth shape: the sampled Hausdorff distance does not grow with j (2% slack for the
        // sampling, which is itself refined with j).
        let h = r.hausdorff.max();
        assert!(h <= previous * 1.02, "j={j}: {h} after {previous}");
        previous = h;
        check_manifold(&TriMesh {
            name: "remesh".into(),
            ..r.mesh.clone()
        })
        .unwrap();
    }
}

#[test]
fn adaptive_remesh_meets_epsilon() {
    let m = icosphere(3);
    let maps = built(&m, &Features::default());
    let (lo, hi) = m.bounding_box();
    let b = (hi - lo).max();
    let mut faces = 0;
    for eps in [0.02, 0.005] {
        let r = adaptive(
            &maps,
            &AdaptiveOptions {
                epsilon: eps,
                max_depth: 8,
            },
        )
        .unwrap();
        check_manifold(&TriMesh {
            name: "adaptive".into(),
            ..r.mesh.clone()
        })
        .unwrap();
        let tree = SurfaceTree::new(&r.mesh.positions, &r.mesh.faces);
        for p in &m.positions {
            // The guarantee is per input vertex against its own remesh triangle, so the
            // distance to the whole remesh is at most that.
            assert!(tree.distance(p) <= eps * b * (1.0 + 1e-12), "eps {eps}");
        }
        assert!(r.mesh.faces.len() > faces, "a smaller epsilon refines more");
        faces = r.mesh.faces.len();
    }
}

// ---------------------------------------------------------------- 9. determinism

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let m = icosphere(3);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let maps = built(&m, &Features::default());
                let r = uniform(&maps, 2).unwrap();
                let bits = |p: &Point3<f64>| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
                (
                    maps.base_faces.clone(),
                    maps.location
                        .iter()
                        .map(|(f, b)| (*f, b.map(f64::to_bits)))
                        .collect::<Vec<_>>(),
                    r.mesh.positions.iter().map(bits).collect::<Vec<_>>(),
                    r.hausdorff.max().to_bits(),
                )
            })
    };
    assert_eq!(run(1), run(2));
}

// ---------------------------------------------------------------- loaders and bad input

#[test]
fn ply_and_off_loaders_read_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("quad.ply");
    std::fs::write(
        &ply,
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    )
    .unwrap();
    let off = dir.path().join("quad.off");
    std::fs::write(
        &off,
        "OFF\n# a quad\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    )
    .unwrap();
    let a = load_mesh(&ply).unwrap();
    let b = load_mesh(&off).unwrap();
    assert_eq!(a.faces, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(a.faces, b.faces);
    assert_eq!(a.positions, b.positions);
    let bad = dir.path().join("bad.off");
    std::fs::write(&bad, "OFF\n4 1 0\n0 0 0\n1 0 zero\n1 1 0\n0 1 0\n3 0 1 2\n").unwrap();
    let err = load_mesh(&bad).unwrap_err();
    assert!(
        matches!(err, Error::MeshParse { ref message, .. } if message.starts_with("line 4")),
        "{err}"
    );
    let nan = dir.path().join("nan.off");
    std::fs::write(&nan, "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n").unwrap();
    assert!(matches!(
        load_mesh(&nan),
        Err(Error::NonFinite { index: 1, .. })
    ));
    let missing = dir.path().join("missing.ply");
    assert!(matches!(load_mesh(&missing), Err(Error::Io { .. })));
    let garbage = dir.path().join("garbage.ply");
    std::fs::write(&garbage, "not a ply file\n").unwrap();
    assert!(matches!(load_mesh(&garbage), Err(Error::MeshParse { .. })));
}

#[test]
fn bad_meshes_give_typed_errors() {
    let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
    // Three triangles on edge (0, 1): non-manifold edge.
    let fin = TriMesh::with_shared_indices(
        "fin",
        vec![
            p(0., 0., 0.),
            p(1., 0., 0.),
            p(0., 1., 0.),
            p(0., -1., 0.),
            p(0., 0., 1.),
        ],
        Vec::new(),
        vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
    );
    match build(&fin, &Features::default(), &MapsOptions::default()) {
        Err(Error::NonManifoldMesh { edges, .. }) => assert!(edges.contains(&(0, 1))),
        other => panic!("expected a non-manifold error, got {other:?}"),
    }
    // Two triangles touching at vertex 0 only: a non-manifold vertex.
    let bowtie = TriMesh::with_shared_indices(
        "bowtie",
        vec![
            p(0., 0., 0.),
            p(1., 0., 0.),
            p(1., 1., 0.),
            p(-1., 0., 0.),
            p(-1., -1., 0.),
        ],
        Vec::new(),
        vec![[0, 1, 2], [0, 3, 4]],
    );
    match check_manifold(&bowtie) {
        Err(Error::NonManifoldMesh { vertices, .. }) => assert_eq!(vertices, vec![0]),
        other => panic!("expected a non-manifold vertex, got {other:?}"),
    }
    let empty = TriMesh::with_shared_indices("empty", Vec::new(), Vec::new(), Vec::new());
    assert!(matches!(
        build(&empty, &Features::default(), &MapsOptions::default()),
        Err(Error::EmptyMesh { .. })
    ));
    let mut nan = icosphere(0);
    nan.positions[3].y = f64::NAN;
    assert!(matches!(
        build(&nan, &Features::default(), &MapsOptions::default()),
        Err(Error::NonFinite { index: 3, .. })
    ));
    let mut repeated = icosphere(0);
    repeated.faces[5] = [1, 1, 2];
    assert!(matches!(
        check_manifold(&repeated),
        Err(Error::DegenerateFace { face: 5, .. })
    ));
    let flat = TriMesh::with_shared_indices(
        "flat",
        vec![p(0., 0., 0.), p(1., 0., 0.), p(2., 0., 0.)],
        Vec::new(),
        vec![[0, 1, 2]],
    );
    assert!(matches!(
        check_manifold(&flat),
        Err(Error::DegenerateFace { face: 0, .. })
    ));
    let m = icosphere(1);
    let bad_lambda = MapsOptions {
        lambda: 2.0,
        ..MapsOptions::default()
    };
    assert!(matches!(
        build(&m, &Features::default(), &bad_lambda),
        Err(Error::InvalidArgument(_))
    ));
    let maps = built(&m, &Features::default());
    assert!(matches!(uniform(&maps, 11), Err(Error::InvalidArgument(_))));
    assert!(matches!(
        adaptive(
            &maps,
            &AdaptiveOptions {
                epsilon: 0.0,
                max_depth: 4
            }
        ),
        Err(Error::InvalidArgument(_))
    ));
    assert!(matches!(
        adaptive(
            &maps,
            &AdaptiveOptions {
                epsilon: f64::NAN,
                max_depth: 4
            }
        ),
        Err(Error::InvalidArgument(_))
    ));
    let _ = Point2::new(0.0, 0.0);
}

// ---------------------------------------------------------------- command line

#[test]
fn cli_writes_the_base_domain_remeshes_pictures_and_a_json_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
        .args([
            "maps",
            "procedural:torus",
            "--remesh",
            "uniform:1",
            "--remesh",
            "adaptive:0.02",
        ])
        .args(["--picture-size", "64", "--json", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["input_faces"], 2304);
    let base = json["base_faces"].as_u64().unwrap();
    assert!(base > 0 && base < 2304);
    assert_eq!(
        json["per_level"].as_array().unwrap().len() as u64,
        json["levels"].as_u64().unwrap()
    );
    let remeshes = json["remeshes"].as_array().unwrap();
    assert_eq!(remeshes[0]["faces"].as_u64().unwrap(), 4 * base);
    for r in remeshes {
        assert!(Path::new(r["file"].as_str().unwrap()).exists());
        assert!(r["hausdorff_relative"].as_f64().unwrap() > 0.0);
    }
    for p in json["pictures"].as_array().unwrap() {
        assert!(dir.path().join(p.as_str().unwrap()).exists());
    }
    assert!(dir.path().join("torus_base.obj").exists());
    // Bad input: a non-manifold OFF file is refused with the offending edge named.
    let fin = dir.path().join("fin.off");
    std::fs::write(
        &fin,
        "OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n0 -1 0\n0 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n",
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
        .args(["maps"])
        .arg(&fin)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not a 2-manifold") && err.contains("(0, 1)"),
        "{err}"
    );
}

#[test]
fn cli_relax_adds_a_relaxed_remesh_and_the_warning_suggests_it() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
            .args(["maps", "procedural:torus", "--remesh", "uniform:1"])
            .args(extra)
            .args(["--picture-size", "0", "--json", "--out"])
            .arg(dir.path())
            .output()
            .unwrap()
    };
    let plain = run(&[]);
    assert!(plain.status.success());
    let stderr = String::from_utf8_lossy(&plain.stderr);
    // uniform:1 of a torus misses the targets (16 faces per base face are not enough), so the
    // warning names the option; once a relaxed remesh is made it does not.
    assert!(stderr.contains("Try --relax"), "{stderr}");
    let out = run(&["--relax"]);
    assert!(out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("Try --relax"));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let remeshes = json["remeshes"].as_array().unwrap();
    assert_eq!(remeshes.len(), 2);
    assert_eq!(remeshes[1]["kind"], "uniform:1 relaxed");
    assert_eq!(remeshes[1]["faces"], remeshes[0]["faces"]);
    assert_eq!(
        remeshes[1]["relaxation"]["iterations"].as_u64(),
        Some(reparam::maps::relax::DEFAULT_SWEEPS as u64)
    );
    assert!(remeshes[0].get("relaxation").is_none());
    assert!(dir.path().join("torus_uniform_1_relaxed.obj").exists());
    let three = run(&["--relax", "3"]);
    let json: serde_json::Value = serde_json::from_slice(&three.stdout).unwrap();
    assert_eq!(json["remeshes"][1]["relaxation"]["iterations"], 3);
}

#[test]
fn cli_equalise_adds_the_remesh_of_pi_prime_and_the_warning_suggests_it() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
            .args(["maps", "procedural:torus", "--remesh", "uniform:1"])
            .args(extra)
            .args(["--picture-size", "32", "--json", "--out"])
            .arg(dir.path())
            .output()
            .unwrap()
    };
    let plain = run(&[]);
    assert!(plain.status.success());
    let stderr = String::from_utf8_lossy(&plain.stderr);
    // The torus's coarsest base domain gives Π an area distortion (p95 1.09) above the
    // input's own spread (0.41), so the warning names the option; once it is used, not.
    assert!(stderr.contains("--equalise ("), "{stderr}");
    let json: serde_json::Value = serde_json::from_slice(&plain.stdout).unwrap();
    assert!(json.get("equalised").is_none());
    let out = run(&["--equalise", "3", "--relax", "2"]);
    assert!(out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("--equalise ("));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let kinds: Vec<&str> = json["remeshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["kind"].as_str().unwrap())
        .collect();
    assert_eq!(
        kinds,
        [
            "uniform:1",
            "uniform:1 relaxed",
            "uniform:1 equalised",
            "uniform:1 equalised relaxed"
        ]
    );
    let e = &json["equalised"];
    assert_eq!(e["solve"]["depth"], 3);
    let (before, after) = (
        e["solve"]["stretch_before"].as_f64().unwrap(),
        e["solve"]["stretch_after"].as_f64().unwrap(),
    );
    assert!(after < before, "{e}");
    assert!(e["distortion"]["area_p95"].as_f64().unwrap().is_finite());
    assert!(dir.path().join("torus_uniform_1_equalised.obj").exists());
    assert!(dir
        .path()
        .join("torus_equalised_area_distortion.png")
        .exists());
    let bad = run(&["--equalise", "9"]);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("depth 9 is above 7"), "{err}");
    // The edge stage (`maps::flaps`) is on by default with --equalise, at depth 4; it lowers
    // its own stretch; two rounds by default (Φ, Φ_E, Φ, Φ_E). `--edge-flaps 0` leaves the
    // edge stage out; `--edge-rounds N` sets the rounds; `--refine-faces` ends with a per-face
    // stage.
    let stages = |json: &serde_json::Value| -> Vec<(String, u64)> {
        json["equalised"]["later"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| {
                (
                    s["stage"].as_str().unwrap().to_string(),
                    s["solve"]["depth"].as_u64().unwrap(),
                )
            })
            .collect()
    };
    let rounds = reparam::maps::equalise::DEFAULT_EDGE_ROUNDS;
    assert_eq!(rounds, 2);
    assert_eq!(
        stages(&json),
        [("edges", 4), ("faces", 3), ("edges", 4)].map(|(s, d)| (s.to_string(), d))
    );
    let edge = &e["later"][0]["solve"];
    assert!(edge["stretch_after"].as_f64().unwrap() < edge["stretch_before"].as_f64().unwrap());
    let faces_only = run(&["--equalise", "3", "--edge-flaps", "0"]);
    let json: serde_json::Value = serde_json::from_slice(&faces_only.stdout).unwrap();
    assert!(stages(&json).is_empty(), "{json}");
    let more = run(&[
        "--equalise",
        "3",
        "--edge-flaps",
        "2",
        "--edge-rounds",
        "1",
        "--refine-faces",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&more.stdout).unwrap();
    let want = [("edges", 2), ("faces", 3)];
    assert_eq!(
        stages(&json),
        want.map(|(s, d)| (s.to_string(), d)).to_vec()
    );
    let deep = run(&["--equalise", "3", "--edge-flaps", "8"]);
    assert!(!deep.status.success());
    let err = String::from_utf8_lossy(&deep.stderr);
    assert!(err.contains("edge-flap depth 8 is above 7"), "{err}");
    let zero = run(&["--equalise", "3", "--edge-rounds", "0"]);
    assert!(!zero.status.success());
}

#[test]
fn surface_tree_distance_equals_brute_force() {
    use reparam::mesh::distance::point_triangle_distance;
    let m = icosphere(2);
    let tree = SurfaceTree::new(&m.positions, &m.faces);
    let mut rng = Lcg(5);
    for _ in 0..300 {
        // Points inside, near and far outside the sphere's bounding box.
        let s = 3.0 * rng.next();
        let p = Point3::new(
            s * (2.0 * rng.next() - 1.0),
            s * (2.0 * rng.next() - 1.0),
            s * (2.0 * rng.next() - 1.0),
        );
        let brute = m
            .faces
            .iter()
            .map(|f| {
                point_triangle_distance(
                    &p,
                    &m.positions[f[0] as usize],
                    &m.positions[f[1] as usize],
                    &m.positions[f[2] as usize],
                )
            })
            .fold(f64::INFINITY, f64::min);
        // The same function on the same triangles: the tree must find the minimiser exactly.
        assert_eq!(tree.distance(&p), brute, "{p}");
    }
}

// ---------------------------------------------------------------- smoothing (issue #5)

#[test]
fn loop_stencil_weights_sum_to_one() {
    for rule in [LoopBeta::Loop, LoopBeta::Warren] {
        for n in 3..=24 {
            let (w0, beta) = even_weights(n, rule);
            // (1 − nβ) + nβ: two roundings of O(1) numbers, a few ulps of 1.
            assert!((w0 + n as f64 * beta - 1.0).abs() < 1e-15, "{rule:?} n={n}");
            assert!(w0 > 0.0 && beta > 0.0, "{rule:?} n={n}: convex stencil");
        }
        // The regular valence 6: both give 1/16 (10/16 for the vertex), the classic weights;
        // the Loop value is (5/8 − (3/8 + 1/8)²)/6 = (5/8 − 1/4)/6 = 1/16 up to cos(π/3) rounding.
        assert!((loop_beta(6, rule) - 1.0 / 16.0).abs() < 1e-16);
    }
    // Loop's β(3) = (5/8 − (3/8 − 1/8)²)/3 = (5/8 − 1/16)/3 = 3/16, Warren's is 3/16 by definition.
    assert!((loop_beta(3, LoopBeta::Loop) - 3.0 / 16.0).abs() < 1e-16);
    assert_eq!(loop_beta(3, LoopBeta::Warren), 3.0 / 16.0);
    assert_eq!(loop_beta(8, LoopBeta::Warren), 3.0 / 64.0);
    // Dyadic weights: exact sums.
    assert_eq!(ODD_WEIGHTS.iter().sum::<f64>(), 1.0);
    assert_eq!(CREASE_EVEN_WEIGHTS.iter().sum::<f64>(), 1.0);
    assert_eq!(CREASE_ODD_WEIGHTS.iter().sum::<f64>(), 1.0);
}

#[test]
fn smoothed_remesh_has_the_uniform_connectivity_and_lies_on_the_surface() {
    let m = icosphere(3);
    let maps = built(&m, &Features::default());
    let tree = SurfaceTree::new(&m.positions, &m.faces);
    let diag = diagonal(&m);
    for j in 0..=3 {
        let plain = uniform(&maps, j).unwrap();
        let s = uniform_smoothed_with(&maps, j, &SmoothOptions::default()).unwrap();
        let r = &s.remesh;
        // Same faces with the same vertex numbering: only the positions differ.
        assert_eq!(r.mesh.faces, plain.mesh.faces, "j={j}");
        assert_eq!(r.mesh.positions.len(), plain.mesh.positions.len());
        assert_eq!(r.unmapped, 0);
        // Every stencil point was found in its (grown) chart.
        assert_eq!(s.stats.fallbacks, 0, "j={j}: {:?}", s.stats);
        for (p, q) in r.mesh.positions.iter().zip(&r.params) {
            // Π⁻¹ interpolates inside an input face: on the surface up to rounding.
            assert!(tree.distance(p) < 1e-9 * diag, "j={j}");
            assert!(q.bary.iter().all(|&b| (0.0..=1.0).contains(&b)));
            assert!((q.bary.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
        if j == 0 {
            // No round: the base vertices themselves (Π⁻¹ of a base corner is the vertex up to
            // the rounding of the level maps, ~1e-15 of the unit sphere).
            for (p, q) in r.mesh.positions.iter().zip(&plain.mesh.positions) {
                assert!((p - q).norm() < 1e-12);
            }
        } else {
            // Smoothing moves the parameters (otherwise this test would not see it).
            let moved = r
                .mesh
                .positions
                .iter()
                .zip(&plain.mesh.positions)
                .filter(|(p, q)| (*p - *q).norm() > 1e-6 * diag)
                .count();
            assert!(moved > 0, "j={j}");
        }
    }
    assert!(matches!(
        uniform_smoothed(&maps, 11),
        Err(Error::InvalidArgument(_))
    ));
    // Genus 1, and a curved mesh with boundary and corners (crease rules, sector charts): every
    // stencil point found, every vertex on the surface, boundary vertices on the boundary.
    let mut torus = procedural::torus(24, 12, 1.0, 0.4);
    torus.uvs.clear();
    torus.uv_faces.clear();
    let mut wavy = procedural::wavy_grid(12);
    wavy.uvs.clear();
    wavy.uv_faces.clear();
    let wavy_corners = grid_corners(&wavy);
    for (m, features) in [(torus, Features::default()), (wavy, wavy_corners)] {
        let maps = built(&m, &features);
        let s = uniform_smoothed_with(&maps, 2, &SmoothOptions::default()).unwrap();
        assert_eq!(s.stats.fallbacks, 0, "{}: {:?}", m.name, s.stats);
        let tree = SurfaceTree::new(&m.positions, &m.faces);
        let diag = diagonal(&m);
        for p in &s.remesh.mesh.positions {
            assert!(tree.distance(p) < 1e-9 * diag, "{}", m.name);
        }
        // The wavy grid's boundary is the square's outline: x or y at 0 or 1 exactly in the
        // input, so Π⁻¹ of a point on a boundary base edge has it up to rounding (1e-12).
        if !boundary_edges(&m.faces).is_empty() {
            let on_outline = |p: &Point3<f64>| {
                [p.x, p.y]
                    .iter()
                    .any(|c| c.abs() < 1e-12 || (c - 1.0).abs() < 1e-12)
            };
            let r = &s.remesh.mesh;
            let outline = boundary_edges(&r.faces);
            assert!(!outline.is_empty());
            for (a, b) in outline {
                assert!(
                    on_outline(&r.positions[a as usize]) && on_outline(&r.positions[b as usize])
                );
            }
        }
    }
}

/// Loop subdivision of a planar triangle mesh, written out independently of the library:
/// boundary edges use the crease rules (½, ½ and ⅛, ¾, ⅛ along the boundary), `fixed` vertices
/// stay, interior vertices use Loop's β. Returns the positions after `rounds` (old vertices keep
/// their indices; new ones are appended).
fn planar_loop(
    mut pos: Vec<[f64; 2]>,
    mut faces: Vec<[u32; 3]>,
    fixed: &BTreeSet<u32>,
    rounds: u32,
) -> Vec<[f64; 2]> {
    for _ in 0..rounds {
        let mut opposite: std::collections::BTreeMap<(u32, u32), Vec<u32>> = Default::default();
        for f in &faces {
            for e in 0..3 {
                let (a, b) = (f[e], f[(e + 1) % 3]);
                opposite
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push(f[(e + 2) % 3]);
            }
        }
        let n = pos.len();
        let mut ring: Vec<BTreeSet<u32>> = vec![BTreeSet::new(); n];
        let mut border: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (&(a, b), opp) in &opposite {
            ring[a as usize].insert(b);
            ring[b as usize].insert(a);
            if opp.len() == 1 {
                border[a as usize].push(b);
                border[b as usize].push(a);
            }
        }
        let lerp = |terms: &[(f64, [f64; 2])]| {
            let mut p = [0.0; 2];
            for (w, q) in terms {
                p[0] += w * q[0];
                p[1] += w * q[1];
            }
            p
        };
        let mut next: Vec<[f64; 2]> = (0..n)
            .map(|v| {
                let p = pos[v];
                if fixed.contains(&(v as u32)) {
                    p
                } else if border[v].len() == 2 {
                    let (a, b) = (pos[border[v][0] as usize], pos[border[v][1] as usize]);
                    lerp(&[(0.125, a), (0.75, p), (0.125, b)])
                } else {
                    let k = ring[v].len() as f64;
                    let c = 0.375 + 0.25 * (TAU / k).cos();
                    let beta = (0.625 - c * c) / k;
                    let mut terms = vec![(1.0 - k * beta, p)];
                    terms.extend(ring[v].iter().map(|&w| (beta, pos[w as usize])));
                    lerp(&terms)
                }
            })
            .collect();
        let mut mid = std::collections::HashMap::new();
        for (&(a, b), opp) in &opposite {
            let (pa, pb) = (pos[a as usize], pos[b as usize]);
            let p = if opp.len() == 1 {
                lerp(&[(0.5, pa), (0.5, pb)])
            } else {
                let (c, d) = (pos[opp[0] as usize], pos[opp[1] as usize]);
                lerp(&[(0.375, pa), (0.375, pb), (0.125, c), (0.125, d)])
            };
            next.push(p);
            mid.insert((a, b), next.len() as u32 - 1);
        }
        let m = |a: u32, b: u32| mid[&(a.min(b), a.max(b))];
        faces = faces
            .iter()
            .flat_map(|f| {
                let (ab, bc, ca) = (m(f[0], f[1]), m(f[1], f[2]), m(f[2], f[0]));
                [[f[0], ab, ca], [ab, f[1], bc], [ca, bc, f[2]], [ab, bc, ca]]
            })
            .collect();
        pos = next;
    }
    pos
}

#[test]
fn smoothing_a_planar_parameterisation_is_planar_loop_subdivision() {
    // Flat-mesh oracle: on a planar mesh the base domain is planar, every chart (face, hinge,
    // z^a disk with a = 1, half disk of a straight boundary with a = 1, a corner's 3D angles) is
    // a rigid image of the plane, and Π⁻¹ is the identity of the plane (flat-mesh oracle). So
    // the smoothed remesh must be exactly Loop subdivision of the planar base mesh.
    let m = flat_grid(8);
    let corners = grid_corners(&m);
    // Stop at ≤ 40 triangles: the coarsest base is 2 triangles with no interior vertex, which
    // would leave the vertex charts and the extraordinary even rule untested.
    let options = MapsOptions {
        base_size: 40,
        ..MapsOptions::default()
    };
    let maps = build(&m, &corners, &options).unwrap();
    let boundary: HashSet<u32> = boundary_edges(&maps.base_faces)
        .iter()
        .flat_map(|&(a, b)| [a, b])
        .collect();
    let valence = |v: u32| {
        edges_of(&maps.base_faces)
            .iter()
            .filter(|e| e.0 == v || e.1 == v)
            .count()
    };
    let extraordinary = maps
        .base_faces
        .iter()
        .flatten()
        .filter(|v| !boundary.contains(v) && valence(**v) != 6)
        .count();
    println!(
        "base {} faces, {extraordinary} extraordinary interior vertex corners",
        maps.base_faces.len()
    );
    assert!(
        extraordinary > 0,
        "the base has an interior vertex of valence ≠ 6"
    );
    let base_pos: Vec<[f64; 2]> = m.positions.iter().map(|p| [p.x, p.y]).collect();
    for j in 1..=3 {
        let s = uniform_smoothed_with(&maps, j, &SmoothOptions::default()).unwrap();
        assert_eq!(s.stats.fallbacks, 0);
        let expected = planar_loop(
            base_pos.clone(),
            maps.base_faces.clone(),
            &corners.corners,
            j,
        );
        // Old vertices keep their indices in planar_loop: only the base vertices' and the new
        // vertices' positions are compared (unreferenced input vertices are not in the net).
        let used: HashSet<u32> = maps.base_faces.iter().flatten().copied().collect();
        let oracle: Vec<[f64; 2]> = expected
            .iter()
            .enumerate()
            .filter(|(i, _)| *i >= m.positions.len() || used.contains(&(*i as u32)))
            .map(|(_, p)| *p)
            .collect();
        let got = &s.remesh.mesh.positions;
        assert_eq!(oracle.len(), got.len(), "j={j}");
        let mut taken = vec![false; got.len()];
        for p in &oracle {
            // Each round's stencils and the chart layouts round O(1) coordinates to ~1e-16;
            // Π⁻¹ adds the flat oracle's ~1e-15 per level. 1e-12 is far above that and far below
            // the spacing of the net (1/8 · 2^-j ≥ 1/64 of the grid), so the nearest remesh vertex
            // is the right one.
            let (k, d) = got
                .iter()
                .enumerate()
                .map(|(k, q)| (k, (q.x - p[0]).hypot(q.y - p[1])))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            assert!(
                d < 1e-12,
                "j={j}: Loop point {p:?} is {d} from the smoothed remesh"
            );
            assert!(!taken[k], "j={j}: two Loop points on one remesh vertex");
            taken[k] = true;
        }
        for q in got {
            // In the plane and inside the domain [0, 1]² (up to the same rounding).
            assert!(q.z.abs() < 1e-12);
            assert!((-1e-12..=1.0 + 1e-12).contains(&q.x) && (-1e-12..=1.0 + 1e-12).contains(&q.y));
        }
    }
}

/// A sphere with bumps: radius 1 + 0.12 sin(4x) sin(4y) sin(4z) over the icosphere.
fn bumpy_sphere(n: usize) -> TriMesh {
    let mut m = icosphere(n);
    for p in &mut m.positions {
        let r = 1.0 + 0.12 * (4.0 * p.x).sin() * (4.0 * p.y).sin() * (4.0 * p.z).sin();
        *p = Point3::from(p.coords * r);
    }
    m.name = "test:bumpy_sphere".into();
    m
}

/// Mean squared umbrella Laplacian |p_i − mean of the neighbours|² over the vertices: the mean
/// squared second difference of the positions along the remesh edges.
fn umbrella_energy(mesh: &TriMesh) -> f64 {
    let mut ring: Vec<BTreeSet<u32>> = vec![BTreeSet::new(); mesh.positions.len()];
    for (a, b) in edges_of(&mesh.faces) {
        ring[a as usize].insert(b);
        ring[b as usize].insert(a);
    }
    let mut sum = 0.0;
    for (p, r) in mesh.positions.iter().zip(&ring) {
        let mean = r
            .iter()
            .map(|&w| mesh.positions[w as usize].coords)
            .sum::<nalgebra::Vector3<f64>>()
            / r.len() as f64;
        sum += (p.coords - mean).norm_squared();
    }
    sum / mesh.positions.len() as f64
}

#[test]
fn smoothing_lowers_the_second_differences_on_a_bumpy_sphere() {
    // A base domain of 40 triangles (the paper's bases have 100–250). Measured (umbrella energy
    // unsmoothed → smoothed): base 40, j = 2: 2.2e-3 → 9.2e-4, j = 3: 2.5e-4 → 7.6e-5; base 200,
    // j = 3: 4.1e-5 → 6.3e-6. On the coarsest base of this mesh, a tetrahedron (a = 2 in every
    // vertex chart), smoothing *raises* it by 10–30 %: the test does not use that base.
    let m = bumpy_sphere(3);
    let options = MapsOptions {
        base_size: 40,
        ..MapsOptions::default()
    };
    let maps = build(&m, &Features::default(), &options).unwrap();
    for j in 2..=3 {
        let plain = umbrella_energy(&uniform(&maps, j).unwrap().mesh);
        let smooth = umbrella_energy(&uniform_smoothed(&maps, j).unwrap().mesh);
        println!("j={j}: umbrella energy unsmoothed {plain:.4e}, smoothed {smooth:.4e}");
        assert!(smooth < plain, "j={j}: {smooth} vs {plain}");
    }
}

#[test]
fn smoothing_keeps_feature_lines_and_corners() {
    let m = cube(4);
    let features = detect_features(&m, &FeatureOptions::default());
    let maps = built(&m, &features);
    let (net, stats) = smoothed_net(&maps, 2, &SmoothOptions::default()).unwrap();
    assert_eq!(stats.fallbacks, 0);
    let (positions, _) = net.positions(&maps);
    let on_crease = |k: &VKey| match *k {
        VKey::Vertex(v) => maps
            .base_feature_edges
            .iter()
            .any(|&(a, b)| a == v || b == v),
        VKey::Edge { lo, hi, .. } => maps.base_feature_edges.contains(&(lo, hi)),
        VKey::Face { .. } => false,
    };
    let mut checked = 0;
    for ((k, p), q) in net.keys.iter().zip(&positions).zip(&net.params) {
        if on_crease(k) {
            // The 1-D rules keep the parameter on a base feature edge (a barycentric exactly 0),
            // and Π⁻¹ maps base feature edges onto the cube's edges: two coordinates at ±1, up to
            // the rounding of Π⁻¹ (1e-12 on this unit-size mesh, as in the flat oracle).
            assert!(q.bary.contains(&0.0), "{k:?}: {:?}", q.bary);
            let at_one = [p.x, p.y, p.z]
                .iter()
                .filter(|c| (c.abs() - 1.0).abs() < 1e-12)
                .count();
            assert!(at_one >= 2, "{k:?} left the cube edge: {p}");
            checked += 1;
        }
        if let VKey::Vertex(v) = k {
            let c = m.positions[*v as usize];
            if c.x.abs() == 1.0 && c.y.abs() == 1.0 && c.z.abs() == 1.0 {
                assert!((p - c).norm() < 1e-12, "cube corner {v} moved");
            }
        }
    }
    assert!(checked > 0);
}

#[test]
fn smoothing_does_not_depend_on_the_thread_count() {
    let m = bumpy_sphere(2);
    let maps = built(&m, &Features::default());
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let r = uniform_smoothed(&maps, 3).unwrap();
                r.mesh
                    .positions
                    .iter()
                    .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                    .collect::<Vec<_>>()
            })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn cli_takes_feature_lists_and_writes_the_smoothed_remesh() {
    let dir = tempfile::tempdir().unwrap();
    let m = icosphere(2);
    let input = dir.path().join("ico.obj");
    reparam::mesh::write_obj(&m, &input).unwrap();
    let [a, b, _] = m.faces[0];
    let run = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
            .arg("maps")
            .arg(&input)
            .args(extra)
            .args(["--picture-size", "0", "--json", "--out"])
            .arg(dir.path())
            .output()
            .unwrap()
    };
    let edge = format!("{a}-{b}");
    let out = run(&[
        "--feature-vertices",
        "17, 100",
        "--feature-edges",
        &edge,
        "--remesh",
        "uniform:1",
        "--smooth",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["feature_corners"], 2);
    assert_eq!(json["feature_edges"], 1);
    // The tagged corners and the tagged edge are in the base domain (the OBJ keeps the input's
    // vertex numbering, 1-based).
    let text = std::fs::read_to_string(dir.path().join("ico_base.obj")).unwrap();
    let faces: Vec<[u32; 3]> = text
        .lines()
        .filter_map(|l| l.strip_prefix("f "))
        .map(|l| {
            let v: Vec<u32> = l
                .split_whitespace()
                .map(|w| w.split('/').next().unwrap().parse::<u32>().unwrap() - 1)
                .collect();
            [v[0], v[1], v[2]]
        })
        .collect();
    let base: HashSet<u32> = faces.iter().flatten().copied().collect();
    assert!(base.contains(&17) && base.contains(&100));
    assert!(edges_of(&faces).contains(&(a.min(b), a.max(b))));
    // Both remeshes: same size, the smoothed one with its stencil counts and its own OBJ.
    let remeshes = json["remeshes"].as_array().unwrap();
    assert_eq!(remeshes.len(), 2);
    assert_eq!(remeshes[1]["kind"], "uniform:1 smoothed");
    assert_eq!(remeshes[0]["faces"], remeshes[1]["faces"]);
    assert_eq!(remeshes[1]["smoothing"]["fallbacks"], 0);
    assert!(remeshes[1]["smoothing"]["stencils"].as_u64().unwrap() > 0);
    assert!(remeshes[0].get("smoothing").is_none());
    for r in remeshes {
        assert!(Path::new(r["file"].as_str().unwrap()).exists());
        let h = r["hausdorff_relative"].as_f64().unwrap();
        assert!(h > 0.0 && h < 1.0, "{h}");
    }
    // Bad lists are refused with the option named; indices outside the mesh by the validation.
    for (bad, says) in [
        (["--feature-edges", "3"], "--feature-edges `3`"),
        (["--feature-edges", "3-3"], "two different vertices"),
        (["--feature-vertices", "1,x"], "--feature-vertices `x`"),
        (
            ["--feature-vertices", "999999"],
            "feature corner 999999 is not a vertex",
        ),
        (["--feature-edges", "0-161"], "is not an edge of the mesh"),
    ] {
        let out = run(&bad);
        assert!(!out.status.success(), "{bad:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{bad:?}: {err}");
    }
}

// ---------------------------------------------------------------- 3. mapped areas

/// Twice the signed area of a polygon (shoelace).
fn signed_area2(poly: &[[f64; 2]]) -> f64 {
    (0..poly.len())
        .map(|k| {
            let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
            p[0] * q[1] - p[1] * q[0]
        })
        .sum()
}

/// Sutherland–Hodgman: `poly` (either orientation) clipped to the counter-clockwise triangle
/// `tri`; the result keeps the orientation of `poly`.
fn clip_to_triangle(poly: &[[f64; 2]], tri: &[[f64; 2]; 3]) -> Vec<[f64; 2]> {
    let mut out = poly.to_vec();
    for e in 0..3 {
        let (a, b) = (tri[e], tri[(e + 1) % 3]);
        let side = |p: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        let input = std::mem::take(&mut out);
        for k in 0..input.len() {
            let (p, q) = (input[k], input[(k + 1) % input.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                let t = sp / (sp - sq);
                out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

/// A piece of the image of an input triangle under the level maps: a convex polygon, in
/// barycentric coordinates of one face of the decimation.
struct Piece {
    input: u32,
    poly: Vec<[f64; 3]>,
}

/// Twice the signed area of a barycentric polygon relative to its face: the shoelace of
/// (b₁, b₂), whose reference triangle (0,0), (1,0), (0,1) has twice-area 1.
fn bary_area_fraction(poly: &[[f64; 3]]) -> f64 {
    let flat: Vec<[f64; 2]> = poly.iter().map(|b| [b[1], b[2]]).collect();
    signed_area2(&flat)
}

/// The exact image of every input triangle in the base domain, pushed level by level. Each
/// committed removal maps its star faces onto its new faces through the flattened hole μ: a
/// point with barycentrics b in a star face goes to u = Σ b_c μ(corner_c) (μ of the removed
/// vertex is 0), linearly on each star face, and the new faces tile the same planar polygon.
/// So the image of an input triangle is a union of convex polygons: each removal maps the
/// pieces in its star faces into its plane and clips them to each new face
/// (Sutherland–Hodgman), and the pieces left in the faces that survive (the base faces) are the
/// images, curvilinear as a whole, straight piece by piece. This is the map Π evaluates point by
/// point ([`reparam::maps::Param::forward`]). Returns the pieces by base face index.
fn mapped_pieces(maps: &Maps) -> Vec<Vec<Piece>> {
    let param = &maps.param;
    let mut pieces: std::collections::HashMap<u32, Vec<Piece>> = (0..maps.input_faces.len() as u32)
        .map(|f| {
            let poly = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            (f, vec![Piece { input: f, poly }])
        })
        .collect();
    for r in param.removals() {
        let mu = |v: u32| match r.ring.iter().position(|&w| w == v) {
            Some(k) => r.mu[k],
            None => [0.0, 0.0],
        };
        let new_faces: Vec<(u32, [[f64; 2]; 3])> = (r.new_first..r.new_first + r.new_count)
            .map(|n| (n, param.face(n).map(mu)))
            .collect();
        for &old in &r.old_faces {
            let star = param.face(old).map(mu);
            for piece in pieces.remove(&old).unwrap_or_default() {
                let plane: Vec<[f64; 2]> = piece
                    .poly
                    .iter()
                    .map(|b| {
                        let x = b[0] * star[0][0] + b[1] * star[1][0] + b[2] * star[2][0];
                        let y = b[0] * star[0][1] + b[1] * star[1][1] + b[2] * star[2][1];
                        [x, y]
                    })
                    .collect();
                for (n, tri) in &new_faces {
                    let clipped = clip_to_triangle(&plane, tri);
                    if clipped.len() < 3 || signed_area2(&clipped) == 0.0 {
                        continue;
                    }
                    let poly = clipped
                        .iter()
                        .map(|&u| barycentric(u, tri[0], tri[1], tri[2]))
                        .collect();
                    pieces.entry(*n).or_default().push(Piece {
                        input: piece.input,
                        poly,
                    });
                }
            }
        }
    }
    // The surviving faces are the base faces: match them by their corners.
    let key = |t: [u32; 3]| {
        let k = (0..3).min_by_key(|&c| t[c]).unwrap();
        [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
    };
    let base_index: std::collections::HashMap<[u32; 3], usize> = maps
        .base_faces
        .iter()
        .enumerate()
        .map(|(i, &t)| (key(t), i))
        .collect();
    let mut by_base: Vec<Vec<Piece>> = (0..maps.base_faces.len()).map(|_| Vec::new()).collect();
    for (face, list) in pieces {
        let b = base_index[&key(param.face(face))];
        by_base[b].extend(list);
    }
    by_base
}

/// Whether barycentric point `b` lies in the convex counter-clockwise barycentric polygon
/// `poly`, up to `slack` (in barycentric units).
fn in_bary_polygon(b: [f64; 3], poly: &[[f64; 3]], slack: f64) -> bool {
    (0..poly.len()).all(|k| {
        let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
        let cross = (q[1] - p[1]) * (b[2] - p[2]) - (q[2] - p[2]) * (b[1] - p[1]);
        let len = ((q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2)).sqrt();
        // Edges shorter than the slack (rounding duplicates of a corner) decide nothing.
        len <= slack || cross >= -slack * len
    })
}

#[test]
fn mapped_areas_sum_to_the_base_triangle_areas() {
    // The exact images (`mapped_pieces`) of the input triangles, on a flat grid, two spheres,
    // a torus (genus 1: saddle base vertices whose angle sums exceed 2π, where charts unfolded
    // around a base triangle wrap over it) and a mesh with boundary.
    //
    // What a bijective, orientation-preserving Π implies: every piece has positive area (a
    // folded star or new face would map a piece with the wrong orientation), and the pieces in
    // each base face tile it, so their area fractions sum to 1. Tolerance: each of the L ≈ 10–20
    // levels re-rounds every piece corner by a few ulps (one 3-term dot product, one
    // Sutherland–Hodgman intersection, one barycentric conversion), so neighbouring pieces
    // overlap or leave gaps of width ~ L·ε along shared boundaries; summed over the pieces'
    // boundary length inside a face (a few hundred piece edges of length ≲ 1 in barycentric
    // units) that is ≲ 1e3 · 20 · 1.1e-16 ≈ 2e-12; 1e-11 allows a factor 5. Measured worst:
    // 2.9e-15 (icosphere), 1.2e-15 (torus 48 × 24, 120 base faces, 15 390 pieces).
    // Each piece must also agree with Π point by point: Π of the centroid of every input
    // triangle lies in one of that triangle's pieces, in the base face Π names (slack 1e-9 in
    // barycentric units, the same accumulated rounding scaled up by the ~1e2 conditioning of
    // the barycentric conversion in thin new faces).
    let mut torus = procedural::torus(24, 12, 1.0, 0.4);
    torus.uvs.clear();
    torus.uv_faces.clear();
    // Clipping a polygon to an edge that a corner lies on (corners mapped onto base edges)
    // leaves slivers with an area of rounding size, either sign: ≲ 1e2 ε of the face.
    const SLIVER: f64 = 1e-13;
    let mut wavy = procedural::wavy_grid(12);
    wavy.uvs.clear();
    wavy.uv_faces.clear();
    let mut big_torus = procedural::torus(48, 24, 1.0, 0.4);
    big_torus.uvs.clear();
    big_torus.uv_faces.clear();
    let base_120 = MapsOptions {
        base_size: 120,
        ..MapsOptions::default()
    };
    let flat = flat_grid(8);
    let cases = [
        (built(&flat, &grid_corners(&flat)), "flat grid"),
        (built(&icosphere(3), &Features::default()), "icosphere"),
        (
            built(&bumpy_sphere(3), &Features::default()),
            "bumpy sphere",
        ),
        (built(&torus, &Features::default()), "torus"),
        (
            build(&big_torus, &Features::default(), &base_120).unwrap(),
            "torus 48 × 24 to a base of 120",
        ),
        (built(&wavy, &grid_corners(&wavy)), "wavy grid"),
    ];
    for (maps, name) in &cases {
        assert_eq!(maps.param.count_flipped(), 0, "{name}");
        let pieces = mapped_pieces(maps);
        let mut worst: f64 = 0.0;
        for (t, list) in pieces.iter().enumerate() {
            let mut sum = 0.0;
            for p in list {
                let a = bary_area_fraction(&p.poly);
                assert!(
                    a > -SLIVER,
                    "{name}: base face {t}: piece of input face {} has area {a}",
                    p.input
                );
                sum += a;
            }
            assert!(
                (sum - 1.0).abs() < 1e-11,
                "{name}: base face {t}: mapped areas sum to {sum} of its area"
            );
            worst = worst.max((sum - 1.0).abs());
        }
        for f in 0..maps.input_faces.len() as u32 {
            let p = maps.param.forward(f, [1.0 / 3.0; 3]).unwrap();
            assert!(
                pieces[p.face as usize]
                    .iter()
                    .any(|q| q.input == f && in_bary_polygon(p.bary, &q.poly, 1e-9)),
                "{name}: Π of the centroid of input face {f} is in none of its pieces"
            );
        }
        let count: usize = pieces.iter().map(Vec::len).sum();
        println!(
            "{name}: {} input faces, {} base faces, {count} pieces, worst area-sum defect {worst:.1e}",
            maps.input_faces.len(),
            maps.base_faces.len()
        );
    }
}
