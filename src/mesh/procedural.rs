//! Built-in meshes for the demo, the tests and the benchmarks. Every mesh is deterministic (the
//! same arguments give the same mesh) and named `procedural:<name>`.
//!
//! Orientation: faces are counter-clockwise seen from outside (from +z for the flat ones), and
//! counter-clockwise in UV unless the mesh is meant to be mirrored. Size arguments below the
//! smallest meaningful value are raised to it (documented per function).

use std::f64::consts::TAU;

use nalgebra::{Point2, Point3};
use num_complex::Complex64;

use super::trimesh::TriMesh;

/// A Möbius map `w = (a z + b) / (c z + d)` written as its matrix `[[a, b], [c, d]]`.
pub type Mobius = [[Complex64; 2]; 2];

/// Planar fan of `n` triangles (`n ≥ 3`) around a centre vertex at the origin, rim vertices at
/// irregular radii and angles (no symmetry). UVs are a similarity of the positions,
/// `uv = 0.35 · R(0.3 rad) · (x, y) + (0.5, 0.5)`.
///
/// For tests where the UV map is conformal: BPM and linear interpolation must agree exactly.
pub fn flat_star(n: usize) -> TriMesh {
    let (cos, sin) = (0.3f64.cos(), 0.3f64.sin());
    let similarity = |p: &Point3<f64>| {
        let s = 0.35;
        Point2::new(
            0.5 + s * (cos * p.x - sin * p.y),
            0.5 + s * (sin * p.x + cos * p.y),
        )
    };
    fan_mesh("flat_star", star_positions(n), similarity)
}

/// The positions of [`flat_star`], with UVs an anisotropic, sheared affine map of them,
/// `u = 0.5 + 0.45 x + 0.15 y`, `v = 0.5 − 0.05 x + 0.2 y` (determinant 0.0975 > 0).
///
/// For tests where the UV map is not conformal, so BPM differs from linear interpolation.
pub fn flat_star_affine(n: usize) -> TriMesh {
    let affine =
        |p: &Point3<f64>| Point2::new(0.5 + 0.45 * p.x + 0.15 * p.y, 0.5 - 0.05 * p.x + 0.2 * p.y);
    fan_mesh("flat_star_affine", star_positions(n), affine)
}

/// A cone: fan of `n` triangles (`n ≥ 3`) around an apex at `(0, 0, height)`, rim a regular
/// n-gon of radius 1 in the plane z = 0. The apex UV is (0, 0), rim vertex k has UV
/// `(cos 2πk/n, sin 2πk/n)`: the UV fan closes a full turn around the apex although the cone's
/// total angle there is smaller, a strongly distorted map (stress case from the BPM notes).
pub fn cone_fan(n: usize, height: f64) -> TriMesh {
    let n = n.max(3);
    let rim = |k: usize| {
        let angle = TAU * k as f64 / n as f64;
        (angle.cos(), angle.sin())
    };
    let mut positions = vec![Point3::new(0.0, 0.0, height)];
    let mut uvs = vec![Point2::new(0.0, 0.0)];
    for k in 0..n {
        let (c, s) = rim(k);
        positions.push(Point3::new(c, s, 0.0));
        uvs.push(Point2::new(c, s));
    }
    TriMesh::with_shared_indices(name("cone_fan"), positions, uvs, fan_faces(n))
}

/// A closed torus around the z axis with `major ≥ 3` segments around the axis and `minor ≥ 3`
/// around the tube, major radius `big_r` and tube radius `small_r`. Vertex (i, j) sits at
/// angles θ = 2πi/major, φ = 2πj/minor:
/// `p = ((R + r cos φ) cos θ, (R + r cos φ) sin θ, r sin φ)`, `uv = (i/major, j/minor)`.
///
/// Positions wrap around (the surface is closed, no boundary); UVs do not: UV rows/columns at
/// u = 1 and v = 1 are separate texture coordinates, so the mesh has UV seams along both
/// wrap-around directions (`major + minor` seam edges). Triangle count `2 · major · minor`
/// (see [`torus_triangle_count`]).
pub fn torus(major: usize, minor: usize, big_r: f64, small_r: f64) -> TriMesh {
    let (major, minor) = (major.max(3), minor.max(3));
    let mut positions = Vec::with_capacity(major * minor);
    for j in 0..minor {
        let phi = TAU * j as f64 / minor as f64;
        for i in 0..major {
            let theta = TAU * i as f64 / major as f64;
            let ring = big_r + small_r * phi.cos();
            positions.push(Point3::new(
                ring * theta.cos(),
                ring * theta.sin(),
                small_r * phi.sin(),
            ));
        }
    }
    let uvs = grid_points(major, minor, |i, j| {
        Point2::new(i as f64 / major as f64, j as f64 / minor as f64)
    });
    let position_index = |i: usize, j: usize| ((j % minor) * major + i % major) as u32;
    TriMesh {
        positions,
        uvs,
        faces: grid_faces(major, minor, position_index),
        uv_faces: grid_faces(major, minor, grid_index(major)),
        texture: None,
        name: name("torus"),
    }
}

/// Number of triangles of `torus(major, minor, ..)` (for sizes ≥ 3): `2 · major · minor`.
pub fn torus_triangle_count(major: usize, minor: usize) -> usize {
    2 * major.max(3) * minor.max(3)
}

/// Segments of [`big_torus`]: 2 · 1024 · 512 = 1,048,576 triangles.
pub const BIG_TORUS_SEGMENTS: (usize, usize) = (1024, 512);

/// A torus of 1,048,576 triangles (524,288 positions, 525,825 UVs) for benchmarks:
/// `torus(1024, 512, 1.0, 0.35)`.
pub fn big_torus() -> TriMesh {
    let (major, minor) = BIG_TORUS_SEGMENTS;
    let mut mesh = torus(major, minor, 1.0, 0.35);
    mesh.name = name("big_torus");
    mesh
}

/// A default Möbius map for [`mobius_mesh`], clearly not affine on [−1, 1]²:
/// `a = 0.35`, `b = 0.5 + 0.5i`, `c = 0.25 + 0.15i`, `d = 1` (pole at z ≈ −2.9 + 1.8i, outside
/// the square; `ad − bc = 0.3 − 0.2i ≠ 0`).
pub fn default_mobius() -> Mobius {
    let c = |re, im| Complex64::new(re, im);
    [[c(0.35, 0.0), c(0.5, 0.5)], [c(0.25, 0.15), c(1.0, 0.0)]]
}

/// `w = (a z + b) / (c z + d)` for `m = [[a, b], [c, d]]`.
pub fn apply_mobius(m: &Mobius, z: Complex64) -> Complex64 {
    let [[a, b], [c, d]] = *m;
    (a * z + b) / (c * z + d)
}

/// A planar `n × n`-cell grid (`n ≥ 1`) on [−1, 1]² in the plane z = 0, interior vertices
/// jittered deterministically by up to a quarter cell, whose UVs are the Möbius image of the
/// layout: `uv = w(x + iy)` with `w = apply_mobius(m, ·)`.
///
/// For BPM: a map that is exactly a Möbius transformation must be reproduced exactly by BPM
/// and not by linear interpolation. The pole `−d/c` must lie outside the square (else some UVs
/// are infinite and `validate` fails).
pub fn mobius_mesh(n: usize, m: Mobius) -> TriMesh {
    let n = n.max(1);
    let positions = grid_points(n, n, |i, j| {
        let (x, y) = jittered_square_point(n, i, j);
        Point3::new(x, y, 0.0)
    });
    let uvs = positions
        .iter()
        .map(|p| {
            let w = apply_mobius(&m, Complex64::new(p.x, p.y));
            Point2::new(w.re, w.im)
        })
        .collect();
    TriMesh::with_shared_indices(
        name("mobius"),
        positions,
        uvs,
        grid_faces(n, n, grid_index(n)),
    )
}

/// Two charts meeting at a 3D edge: a tent (roof) of `2n × n` cells (`n ≥ 1`) with its ridge
/// along the y axis at height 0.6, each slope 1 long and 1 wide. The left slope's UVs are an
/// isometry of the slope scaled by 0.4 (positive area); the right slope's UVs are *mirrored*
/// (negative signed UV area), as for a symmetric model that reuses a texture flipped. The two
/// charts have separate UVs along the ridge, so the ridge is a UV seam.
///
/// Left chart UV: `(0.05 + 0.4 a, 0.3 + 0.4 y)` with `a` ∈ [0, 1] the distance up the slope;
/// right chart UV: `(0.95 − 0.4 a', 0.3 + 0.4 y)` with `a'` the distance down from the ridge.
pub fn two_charts_mirrored(n: usize) -> TriMesh {
    let n = n.max(1);
    let (half_width, height) = (0.8, 0.6); // slope length √(0.8² + 0.6²) = 1
    let positions = grid_points(2 * n, n, |i, j| {
        let x = half_width * (i as f64 / n as f64 - 1.0);
        Point3::new(
            x,
            j as f64 / n as f64,
            height * (1.0 - x.abs() / half_width),
        )
    });
    let chart_uv = |u0: f64, du: f64| {
        grid_points(n, n, move |i, j| {
            Point2::new(
                u0 + du * i as f64 / n as f64,
                0.3 + 0.4 * j as f64 / n as f64,
            )
        })
    };
    let mut uvs = chart_uv(0.05, 0.4);
    uvs.extend(chart_uv(0.95, -0.4));

    let position_index = grid_index(2 * n);
    let mut faces = grid_faces(n, n, &position_index);
    faces.extend(grid_faces(n, n, |i, j| position_index(i + n, j)));
    let chart_offset = ((n + 1) * (n + 1)) as u32;
    let uv_index = grid_index(n);
    let mut uv_faces = grid_faces(n, n, &uv_index);
    uv_faces.extend(grid_faces(n, n, |i, j| uv_index(i, j) + chart_offset));
    TriMesh {
        positions,
        uvs,
        faces,
        uv_faces,
        texture: None,
        name: name("two_charts_mirrored"),
    }
}

/// UV cell width of [`tiny_far_uv`].
pub const TINY_UV_CELL: f64 = 0.004;

/// A planar `n × n`-cell grid (`n ≥ 1`) on the unit square whose UVs are a slightly jittered
/// grid of cell width 0.004 starting at (2.6, 2.6): tiny UV triangles far from the UV origin,
/// the f32 stress case (UV differences lose most of their f32 digits).
pub fn tiny_far_uv(n: usize) -> TriMesh {
    let n = n.max(1);
    let positions = grid_points(n, n, |i, j| {
        Point3::new(i as f64 / n as f64, j as f64 / n as f64, 0.0)
    });
    let uvs = grid_points(n, n, |i, j| {
        let (x, y) = (i as f64, j as f64);
        let jitter = if is_interior(n, i, j) { 0.2 } else { 0.0 };
        Point2::new(
            2.6 + TINY_UV_CELL * (x + jitter * unit_hash(i, j, 7)),
            2.6 + TINY_UV_CELL * (y + jitter * unit_hash(i, j, 8)),
        )
    });
    TriMesh::with_shared_indices(
        name("tiny_far_uv"),
        positions,
        uvs,
        grid_faces(n, n, grid_index(n)),
    )
}

/// A curved, well-shaped height field: `n × n` cells (`n ≥ 1`) on [0, 1]² with
/// `z = 0.15 sin(2πx) sin(πy)` and `uv = (x, y)`. The UV map is smooth and has no folds, for
/// tests that an algorithm keeps a good map good.
pub fn wavy_grid(n: usize) -> TriMesh {
    let n = n.max(1);
    let positions = grid_points(n, n, |i, j| {
        let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
        Point3::new(x, y, 0.15 * (TAU * x).sin() * (0.5 * TAU * y).sin())
    });
    let uvs = positions.iter().map(|p| Point2::new(p.x, p.y)).collect();
    TriMesh::with_shared_indices(
        name("wavy_grid"),
        positions,
        uvs,
        grid_faces(n, n, grid_index(n)),
    )
}

/// A parametric surface as an `nu`×`nv`-cell grid over [0, 1]²: vertex (i, j) at
/// x(u, v) with UV (u, v) = (i/nu, j/nv), each cell split along its (i, j)–(i+1, j+1)
/// diagonal (the layout of [`wavy_grid`]); `mesh_name` is used as given.
pub fn param_grid(
    mesh_name: &str,
    nu: usize,
    nv: usize,
    x: impl Fn(f64, f64) -> Point3<f64>,
) -> TriMesh {
    let (nu, nv) = (nu.max(1), nv.max(1));
    let uv = |i: usize, j: usize| (i as f64 / nu as f64, j as f64 / nv as f64);
    let positions = grid_points(nu, nv, |i, j| {
        let (u, v) = uv(i, j);
        x(u, v)
    });
    let uvs = grid_points(nu, nv, |i, j| {
        let (u, v) = uv(i, j);
        Point2::new(u, v)
    });
    TriMesh::with_shared_indices(
        mesh_name,
        positions,
        uvs,
        grid_faces(nu, nv, grid_index(nu)),
    )
}

/// A triangle t = (0, 1, 2) with its three neighbours (four faces), the neighbour (1, 0, 3)
/// across t's first edge folded about that edge by `fold` radians: 0 leaves it coplanar, π lays
/// it flat back onto t (the fold angle φ of `bpm::precompute::fold_cosine`). The other two
/// neighbours are coplanar with t. UVs are an anisotropic affine map of the unfolded positions,
/// `u = 0.5 + 0.3 x + 0.1 y`, `v = 0.3 − 0.05 x + 0.25 y` (determinant 0.08 > 0), so the correct
/// unfolding reproduces them exactly.
///
/// For the BPM unfolding tests: the authors' layout differs from the correct one only for
/// `fold` > π/2.
pub fn folded_star(fold: f64) -> TriMesh {
    // The flat apex (0.55, −0.7, 0) rotated about the x axis (t's first edge) by `fold`.
    let folded_apex = Point3::new(0.55, -0.7 * fold.cos(), 0.7 * fold.sin());
    let flat = [
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(0.4, 0.8, 0.0),
        Point3::new(0.55, -0.7, 0.0),
        Point3::new(1.25, 0.85, 0.0),
        Point3::new(-0.35, 0.65, 0.0),
    ];
    let uvs = flat
        .iter()
        .map(|p| Point2::new(0.5 + 0.3 * p.x + 0.1 * p.y, 0.3 - 0.05 * p.x + 0.25 * p.y))
        .collect();
    let mut positions = flat.to_vec();
    positions[3] = folded_apex;
    TriMesh::with_shared_indices(
        name("folded_star"),
        positions,
        uvs,
        vec![[0, 1, 2], [1, 0, 3], [2, 1, 4], [0, 2, 5]],
    )
}

/// The BPM conformance mesh: three components chosen so that every term and branch of
/// `bpm_precompute` and `bpm_eval` shows in their outputs (the canonical vectors,
/// `reference_data/vectors/bpm`):
/// - a cone fan of 8 faces (apex at height 1), UVs `(0.27 + 0.2 u, 0.3 + 0.2 v)` of
///   [`cone_fan`]'s: the UV fan closes a full turn where the cone's angle is smaller, so the
///   log ratios are far from 0 (real blending); its rim is a boundary;
/// - a cone fan of 6 faces (height 0.6), moved by (3, 0, 0), its UVs mirrored
///   `(0.75 − 0.2 u, 0.3 + 0.2 v)`: every face has a clockwise UV triangle (mirrored layout);
/// - a 3 × 3 wavy grid moved by (0, 3, 0) with the non-conformal UVs
///   `(0.1 + 0.8 x + 0.1 sin πy, 0.62 + 0.3 y + 0.05 x²)`, where face 4 has UVs of its own on
///   one line (a UV island of zero area: the linear fallback, and seams on its three edges;
///   dyadic UVs, so that the area is exactly 0 in f32 as in f64 and every arithmetic agrees
///   that the face is degenerate).
pub fn bpm_conformance() -> TriMesh {
    let mut mesh = TriMesh {
        name: name("bpm_conformance"),
        ..Default::default()
    };
    let mut add = |part: TriMesh, offset: [f64; 3], uv: &dyn Fn(f64, f64) -> (f64, f64)| {
        let (p0, t0) = (mesh.positions.len() as u32, mesh.uvs.len() as u32);
        mesh.positions.extend(
            part.positions
                .iter()
                .map(|p| Point3::new(p.x + offset[0], p.y + offset[1], p.z + offset[2])),
        );
        mesh.uvs.extend(part.uvs.iter().map(|t| {
            let (u, v) = uv(t.x, t.y);
            Point2::new(u, v)
        }));
        mesh.faces
            .extend(part.faces.iter().map(|f| f.map(|i| i + p0)));
        mesh.uv_faces
            .extend(part.uv_faces.iter().map(|f| f.map(|i| i + t0)));
    };
    add(cone_fan(8, 1.0), [0.0; 3], &|u, v| {
        (0.27 + 0.2 * u, 0.3 + 0.2 * v)
    });
    add(cone_fan(6, 0.6), [3.0, 0.0, 0.0], &|u, v| {
        (0.75 - 0.2 * u, 0.3 + 0.2 * v)
    });
    // The cone fans' 8 + 6 faces come first, so the grid's face 4 is face 18.
    let grid_face = 8 + 6 + 4;
    add(wavy_grid(3), [0.0, 3.0, 0.0], &|x, y| {
        (
            0.1 + 0.8 * x + 0.1 * (std::f64::consts::PI * y).sin(),
            0.62 + 0.3 * y + 0.05 * x * x,
        )
    });
    // Face 4 of the grid gets three UVs of its own on one line.
    let t0 = mesh.uvs.len() as u32;
    mesh.uvs.extend([
        Point2::new(0.375, 0.6875),
        Point2::new(0.5, 0.75),
        Point2::new(0.625, 0.8125),
    ]);
    mesh.uv_faces[grid_face] = [t0, t0 + 1, t0 + 2];
    mesh
}

/// The small built-in meshes (each under a few thousand triangles), for cross-check loops.
pub fn all_small() -> Vec<TriMesh> {
    vec![
        flat_star(12),
        flat_star_affine(12),
        cone_fan(16, 1.0),
        torus(24, 12, 1.0, 0.35),
        mobius_mesh(8, default_mobius()),
        two_charts_mirrored(6),
        tiny_far_uv(8),
        wavy_grid(12),
    ]
}

// ---------------------------------------------------------------------------------------------
// Building blocks

fn name(short: &str) -> String {
    format!("procedural:{short}")
}

/// Centre (index 0) and `n ≥ 3` rim vertices of an irregular star in the plane z = 0:
/// rim vertex k at angle `2π (k + 0.3 h₁) / n` and radius `1 + 0.3 h₂` (h = deterministic
/// values in [−1, 1]); the angles stay increasing because the angular jitter is below half a step.
fn star_positions(n: usize) -> Vec<Point3<f64>> {
    let n = n.max(3);
    let mut positions = vec![Point3::origin()];
    for k in 0..n {
        let angle = TAU * (k as f64 + 0.3 * unit_hash(k, 0, 1)) / n as f64;
        let radius = 1.0 + 0.3 * unit_hash(k, 0, 2);
        positions.push(Point3::new(radius * angle.cos(), radius * angle.sin(), 0.0));
    }
    positions
}

/// A fan mesh around vertex 0 whose UVs are `uv_of(position)`.
fn fan_mesh(
    short: &str,
    positions: Vec<Point3<f64>>,
    uv_of: impl Fn(&Point3<f64>) -> Point2<f64>,
) -> TriMesh {
    let uvs = positions.iter().map(uv_of).collect();
    let n = positions.len() - 1;
    TriMesh::with_shared_indices(name(short), positions, uvs, fan_faces(n))
}

/// Triangles `(0, k, k+1)` of a closed fan around vertex 0 with rim vertices `1..=n`.
fn fan_faces(n: usize) -> Vec<[u32; 3]> {
    (0..n)
        .map(|k| [0, 1 + k as u32, 1 + ((k + 1) % n) as u32])
        .collect()
}

/// The `(nx + 1) × (ny + 1)` grid points `f(i, j)`, row-major (index `j (nx + 1) + i`).
fn grid_points<T>(nx: usize, ny: usize, f: impl Fn(usize, usize) -> T) -> Vec<T> {
    (0..=ny)
        .flat_map(|j| (0..=nx).map(move |i| (i, j)))
        .map(|(i, j)| f(i, j))
        .collect()
}

/// Index of grid point (i, j) in [`grid_points`] order for a grid `nx` cells wide.
fn grid_index(nx: usize) -> impl Fn(usize, usize) -> u32 {
    move |i, j| (j * (nx + 1) + i) as u32
}

/// Two triangles per cell of an `nx × ny` cell grid, counter-clockwise when i runs along x and
/// j along y: corners a = (i, j), b = (i+1, j), c = (i+1, j+1), d = (i, j+1) give (a, b, c) and
/// (a, c, d). `index(i, j)` numbers the grid points (and may wrap around for closed surfaces).
fn grid_faces(nx: usize, ny: usize, index: impl Fn(usize, usize) -> u32) -> Vec<[u32; 3]> {
    let mut faces = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    faces
}

/// Whether grid point (i, j) of an `n × n` cell grid is off the border.
fn is_interior(n: usize, i: usize, j: usize) -> bool {
    i > 0 && j > 0 && i < n && j < n
}

/// Grid point (i, j) of an `n × n` cell grid on [−1, 1]², interior points moved by up to a
/// quarter cell in x and y.
fn jittered_square_point(n: usize, i: usize, j: usize) -> (f64, f64) {
    let cell = 2.0 / n as f64;
    let jitter = if is_interior(n, i, j) {
        0.25 * cell
    } else {
        0.0
    };
    (
        -1.0 + cell * i as f64 + jitter * unit_hash(i, j, 3),
        -1.0 + cell * j as f64 + jitter * unit_hash(i, j, 4),
    )
}

/// A deterministic pseudo-random value in [−1, 1] for `(i, j, salt)`: the SplitMix64 finaliser
/// of the packed integers, mapped to the interval (no floating-point library calls, so the same
/// on every platform).
fn unit_hash(i: usize, j: usize, salt: u64) -> f64 {
    let mut x = (i as u64)
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add((j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
        .wrapping_add(salt.wrapping_mul(0x1656_67B1_9E37_79F9));
    x ^= x >> 30;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^= x >> 31;
    (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

// ---------------------------------------------------------------------------------------------
// Implicit test models for MAPS on hard shapes (issue #23): higher genus with bumps, thin
// features, a flat region next to a detailed one. Each is the zero set of f (f < 0 inside,
// close to a signed distance), extracted by marching tetrahedra on a regular grid and relaxed
// along the surface, so the triangles are irregular in size and shape like a scan's.
// ---------------------------------------------------------------------------------------------

/// Signed distance to a torus around the axis through `c` parallel to z, major radius `big_r`,
/// tube radius `small_r`: √((√((x − c_x)² + (y − c_y)²) − R)² + (z − c_z)²) − r.
fn torus_sdf(p: &Point3<f64>, c: &Point3<f64>, big_r: f64, small_r: f64) -> f64 {
    let d = p - c;
    let ring = (d.x * d.x + d.y * d.y).sqrt() - big_r;
    (ring * ring + d.z * d.z).sqrt() - small_r
}

/// Smooth minimum (polynomial, blend width `k` > 0): min(a, b) − h² k / 4 with
/// h = max(k − |a − b|, 0) / k. Equal to min(a, b) when |a − b| ≥ k.
fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k / 4.0
}

/// Signed distance to an axis-aligned box of centre `c` and half extents `half`.
fn box_sdf(p: &Point3<f64>, c: &Point3<f64>, half: [f64; 3]) -> f64 {
    let q = [0, 1, 2].map(|a| (p[a] - c[a]).abs() - half[a]);
    let outside = q.iter().map(|x| x.max(0.0).powi(2)).sum::<f64>().sqrt();
    outside + q[0].max(q[1]).max(q[2]).min(0.0)
}

/// Distance to the segment a–b minus a radius going linearly from `ra` at a to `rb` at b (a
/// tapered capsule: a horn).
fn horn_sdf(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>, ra: f64, rb: f64) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
    (p - (a + ab * t)).norm() - (ra + (rb - ra) * t)
}

/// Gaussian bumps: Σ_k amplitude · exp(−|p − c_k|² / width²).
fn bumps(p: &Point3<f64>, centres: &[Point3<f64>], amplitude: f64, width: f64) -> f64 {
    centres
        .iter()
        .map(|c| amplitude * (-(p - c).norm_squared() / (width * width)).exp())
        .sum()
}

/// The zero set of `f` over the box [lo, hi] by marching tetrahedra: a grid of cubes of side
/// h = longest side / `cells`, each cube split into six tetrahedra around its main diagonal
/// (the split matches across shared faces, so the surface is a closed 2-manifold when f > 0 on
/// the box's boundary); grid values within 1e-9 h of 0 are moved to +1e-9 h so the surface
/// never passes through a grid point (no zero-area triangle). A tetrahedron with one vertex of
/// different sign gives a triangle, one with two and two a quad split along its shorter
/// diagonal; each triangle faces the positive side (outwards). Vertices are the linear zero
/// crossings on the grid edges, shared between neighbouring tetrahedra.
fn marching_tetrahedra(
    f: &dyn Fn(&Point3<f64>) -> f64,
    lo: Point3<f64>,
    hi: Point3<f64>,
    cells: usize,
) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    const TETS: [[usize; 4]; 6] = [
        [0, 1, 3, 7],
        [0, 3, 2, 7],
        [0, 2, 6, 7],
        [0, 6, 4, 7],
        [0, 4, 5, 7],
        [0, 5, 1, 7],
    ];
    let ext = hi - lo;
    let h = ext.max() / cells.max(4) as f64;
    let n = [0, 1, 2].map(|a| ((ext[a] / h).ceil() as usize).max(1) + 1);
    let node = |i: usize, j: usize, k: usize| (k * n[1] + j) * n[0] + i;
    let point = |id: usize| {
        let (i, j, k) = (id % n[0], (id / n[0]) % n[1], id / (n[0] * n[1]));
        Point3::new(
            lo.x + i as f64 * h,
            lo.y + j as f64 * h,
            lo.z + k as f64 * h,
        )
    };
    let values: Vec<f64> = (0..n[0] * n[1] * n[2])
        .map(|id| {
            let v = f(&point(id));
            if v.abs() < 1e-9 * h {
                1e-9 * h
            } else {
                v
            }
        })
        .collect();
    let mut positions: Vec<Point3<f64>> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut on_edge: std::collections::HashMap<(usize, usize), u32> =
        std::collections::HashMap::new();
    let mut crossing = |a: usize, b: usize, positions: &mut Vec<Point3<f64>>| -> u32 {
        let key = (a.min(b), a.max(b));
        *on_edge.entry(key).or_insert_with(|| {
            let (va, vb) = (values[key.0], values[key.1]);
            let t = va / (va - vb);
            let (pa, pb) = (point(key.0), point(key.1));
            positions.push(pa + (pb - pa) * t);
            positions.len() as u32 - 1
        })
    };
    for k in 0..n[2] - 1 {
        for j in 0..n[1] - 1 {
            for i in 0..n[0] - 1 {
                let corner = |b: usize| node(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
                for tet in TETS {
                    let v = tet.map(corner);
                    let (pos, neg): (Vec<usize>, Vec<usize>) =
                        v.iter().partition(|&&id| values[id] > 0.0);
                    if pos.is_empty() || neg.is_empty() {
                        continue;
                    }
                    let centre = |ids: &[usize]| {
                        ids.iter()
                            .map(|&id| point(id).coords)
                            .sum::<nalgebra::Vector3<f64>>()
                            / ids.len() as f64
                    };
                    let outward = centre(&pos) - centre(&neg);
                    let mut polygon: Vec<u32> = Vec::new();
                    match (pos.len(), neg.len()) {
                        (1, 3) => {
                            for &q in &neg {
                                polygon.push(crossing(pos[0], q, &mut positions));
                            }
                        }
                        (3, 1) => {
                            for &q in &pos {
                                polygon.push(crossing(neg[0], q, &mut positions));
                            }
                        }
                        _ => {
                            let (a, b, c, d) = (pos[0], pos[1], neg[0], neg[1]);
                            for (x, y) in [(a, c), (a, d), (b, d), (b, c)] {
                                polygon.push(crossing(x, y, &mut positions));
                            }
                        }
                    }
                    let tris: Vec<[u32; 3]> = if polygon.len() == 3 {
                        vec![[polygon[0], polygon[1], polygon[2]]]
                    } else {
                        let p = polygon
                            .iter()
                            .map(|&q| positions[q as usize])
                            .collect::<Vec<_>>();
                        if (p[0] - p[2]).norm() <= (p[1] - p[3]).norm() {
                            vec![
                                [polygon[0], polygon[1], polygon[2]],
                                [polygon[0], polygon[2], polygon[3]],
                            ]
                        } else {
                            vec![
                                [polygon[0], polygon[1], polygon[3]],
                                [polygon[1], polygon[2], polygon[3]],
                            ]
                        }
                    };
                    for t in tris {
                        let [a, b, c] = t.map(|q| positions[q as usize]);
                        if (b - a).cross(&(c - a)).dot(&outward) >= 0.0 {
                            faces.push(t);
                        } else {
                            faces.push([t[0], t[2], t[1]]);
                        }
                    }
                }
            }
        }
    }
    (positions, faces)
}

/// ∇f at `p` by central differences of step 10⁻⁴ `h`.
fn implicit_gradient(
    f: &dyn Fn(&Point3<f64>) -> f64,
    p: &Point3<f64>,
    h: f64,
) -> nalgebra::Vector3<f64> {
    let eps = 1e-4 * h;
    nalgebra::Vector3::from([0, 1, 2].map(|a| {
        let mut d = nalgebra::Vector3::zeros();
        d[a] = eps;
        (f(&(p + d)) - f(&(p - d))) / (2.0 * eps)
    }))
}

/// `p` moved onto f = 0 by two Newton steps p ← p − f(p) ∇f / |∇f|² ([`implicit_gradient`]).
fn project_to_zero_set(f: &dyn Fn(&Point3<f64>) -> f64, mut p: Point3<f64>, h: f64) -> Point3<f64> {
    for _ in 0..2 {
        let g = implicit_gradient(f, &p, h);
        let g2 = g.norm_squared();
        if g2 > 0.0 {
            p -= g * (f(&p) / g2);
        }
    }
    p
}

/// `rounds` rounds of relaxation along the surface: every vertex moves halfway to the mean of
/// its neighbours, then back onto f = 0 by two Newton steps p ← p − f(p) ∇f / |∇f|² (∇f by
/// central differences of step 10⁻⁴ `h`). Kept only if no face ends up facing against ∇f at
/// its centroid (otherwise the unrelaxed positions are returned).
fn relax_on_surface(
    f: &dyn Fn(&Point3<f64>) -> f64,
    positions: Vec<Point3<f64>>,
    faces: &[[u32; 3]],
    rounds: usize,
    h: f64,
) -> Vec<Point3<f64>> {
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); positions.len()];
    for t in faces {
        for c in 0..3 {
            let (a, b) = (t[c], t[(c + 1) % 3]);
            if !neighbours[a as usize].contains(&b) {
                neighbours[a as usize].push(b);
                neighbours[b as usize].push(a);
            }
        }
    }
    let gradient = |p: &Point3<f64>| implicit_gradient(f, p, h);
    let project = |p: Point3<f64>| project_to_zero_set(f, p, h);
    let mut relaxed = positions.clone();
    for _ in 0..rounds {
        relaxed = (0..relaxed.len())
            .map(|v| {
                let ns = &neighbours[v];
                if ns.is_empty() {
                    return relaxed[v];
                }
                let mean = ns
                    .iter()
                    .map(|&w| relaxed[w as usize].coords)
                    .sum::<nalgebra::Vector3<f64>>()
                    / ns.len() as f64;
                project(Point3::from((relaxed[v].coords + mean) * 0.5))
            })
            .collect();
    }
    let facing_out = faces.iter().all(|t| {
        let [a, b, c] = t.map(|v| relaxed[v as usize]);
        let g = Point3::from((a.coords + b.coords + c.coords) / 3.0);
        (b - a).cross(&(c - a)).dot(&gradient(&g)) > 0.0
    });
    if facing_out {
        relaxed
    } else {
        positions
    }
}

/// A mesh of the zero set of `f` in [lo, hi] ([`marching_tetrahedra`] with `cells` cubes along
/// the longest side, then three rounds of [`relax_on_surface`]).
fn implicit_mesh(
    short: &str,
    f: &dyn Fn(&Point3<f64>) -> f64,
    lo: Point3<f64>,
    hi: Point3<f64>,
    cells: usize,
) -> TriMesh {
    let (positions, faces) = marching_tetrahedra(f, lo, hi, cells);
    let h = (hi - lo).max() / cells.max(4) as f64;
    let positions = relax_on_surface(f, positions, &faces, 3, h);
    TriMesh::with_shared_indices(name(short), positions, Vec::new(), faces)
}

/// A closed surface of genus `genus` (≥ 1, at most 8): `genus` tori of major radius 1 and tube
/// radius 0.38 in a row along x, centres 2 apart so that neighbouring core circles touch at one
/// point (a chain of rings, genus = number of rings), joined by a smooth minimum of width
/// 0.15, with three Gaussian bumps per ring (height 0.1, width 0.18) at pseudo-random points of
/// its tube. `cells` ≥ 8 grid cubes along the longest side (about 9 × cells² triangles per ring
/// at genus 2: 64 gives ≈ 30k triangles). Euler characteristic 2 − 2·genus.
pub fn genus_bumpy(genus: usize, cells: usize) -> TriMesh {
    let g = genus.clamp(1, 8);
    let (f, lo, hi) = genus_bumpy_field(g);
    implicit_mesh(&format!("genus{g}"), &f, lo, hi, cells.max(8))
}

/// The implicit function of [`genus_bumpy`] (negative inside) and the box around its zero set.
type Field = (Box<dyn Fn(&Point3<f64>) -> f64>, Point3<f64>, Point3<f64>);

/// [`genus_bumpy`]'s field for `g` rings (already clamped to 1..=8).
fn genus_bumpy_field(g: usize) -> Field {
    let (big_r, small_r) = (1.0, 0.38);
    let centres: Vec<Point3<f64>> = (0..g)
        .map(|k| Point3::new(2.0 * big_r * k as f64, 0.0, 0.0))
        .collect();
    let bump_centres: Vec<Point3<f64>> = centres
        .iter()
        .enumerate()
        .flat_map(|(k, c)| {
            (0..3).map(move |m| {
                let theta = std::f64::consts::PI * unit_hash(k, m, 11);
                let phi = std::f64::consts::PI * unit_hash(k, m, 12);
                let ring = big_r + small_r * phi.cos();
                c + nalgebra::Vector3::new(
                    ring * theta.cos(),
                    ring * theta.sin(),
                    small_r * phi.sin(),
                )
            })
        })
        .collect();
    let f = move |p: &Point3<f64>| {
        let rings = centres
            .iter()
            .map(|c| torus_sdf(p, c, big_r, small_r))
            .fold(f64::INFINITY, |a, b| {
                if a.is_infinite() {
                    b
                } else {
                    smooth_min(a, b, 0.15)
                }
            });
        rings - bumps(p, &bump_centres, 0.1, 0.18)
    };
    let margin = small_r + 0.3;
    let lo = Point3::new(-big_r - margin, -big_r - margin, -margin);
    let hi = Point3::new(
        2.0 * big_r * (g - 1) as f64 + big_r + margin,
        big_r + margin,
        margin,
    );
    (Box::new(f), lo, hi)
}

/// Thin features (issue #23, like blub's fins): an ellipsoidal body (semi-axes 1, 0.6, 0.5)
/// with two horns (tapered capsules of length ≈ 0.9, radius 0.14 → 0.08) and a fin (a box
/// 1.0 × 0.14 × 0.5) on its back, blended with a smooth minimum of width 0.08. `cells` ≥ 8
/// grid cubes along the longest side; the horn tips and the fin (0.16 and 0.14 thick) are
/// resolved, as one closed genus-0 surface, from about 48 on (thickness above two cubes).
pub fn horned(cells: usize) -> TriMesh {
    let body = |p: &Point3<f64>| {
        let q = nalgebra::Vector3::new(p.x / 1.0, p.y / 0.6, p.z / 0.5);
        (q.norm() - 1.0) * 0.5
    };
    let f = move |p: &Point3<f64>| {
        let horn1 = horn_sdf(
            p,
            &Point3::new(0.7, 0.25, 0.25),
            &Point3::new(1.3, 0.6, 0.8),
            0.14,
            0.08,
        );
        let horn2 = horn_sdf(
            p,
            &Point3::new(0.7, -0.25, 0.25),
            &Point3::new(1.3, -0.6, 0.8),
            0.14,
            0.08,
        );
        let fin = box_sdf(p, &Point3::new(-0.2, 0.0, 0.6), [0.5, 0.07, 0.25]);
        let mut d = body(p);
        for part in [horn1, horn2, fin] {
            d = smooth_min(d, part, 0.08);
        }
        d
    };
    let lo = Point3::new(-1.3, -1.0, -0.8);
    let hi = Point3::new(1.7, 1.0, 1.2);
    implicit_mesh("horned", &f, lo, hi, cells.max(8))
}

/// A large flat region next to a detailed one (issue #23, like nefertiti's base): a rounded
/// box pedestal (2.4 × 1.6 × 0.6, edges rounded by 0.05) under a sphere of radius 0.75 covered
/// with 24 bumps (height 0.06, width 0.12) and a ripple 0.02 sin 14x sin 14y sin 14z, blended
/// with a smooth minimum of width 0.1. `cells` ≥ 8 grid cubes along the longest side. Genus 0.
pub fn pedestal(cells: usize) -> TriMesh {
    let head = Point3::new(0.0, 0.0, 0.7);
    let bump_centres: Vec<Point3<f64>> = (0..24)
        .map(|k| {
            let theta = std::f64::consts::PI * unit_hash(k, 0, 21);
            let z = 0.2 + 0.8 * (0.5 + 0.5 * unit_hash(k, 0, 22));
            let r = (1.0 - z * z).max(0.0).sqrt();
            head + nalgebra::Vector3::new(r * theta.cos(), r * theta.sin(), z) * 0.75
        })
        .collect();
    let f = move |p: &Point3<f64>| {
        let base = box_sdf(p, &Point3::new(0.0, 0.0, -0.25), [1.15, 0.75, 0.25]) - 0.05;
        let ripple = 0.02 * (14.0 * p.x).sin() * (14.0 * p.y).sin() * (14.0 * p.z).sin();
        let sphere = (p - head).norm() - 0.75 - bumps(p, &bump_centres, 0.06, 0.12) - ripple;
        smooth_min(base, sphere, 0.1)
    };
    let lo = Point3::new(-1.45, -1.05, -0.8);
    let hi = Point3::new(1.45, 1.05, 1.75);
    implicit_mesh("pedestal", &f, lo, hi, cells.max(8))
}

// ---------------------------------------------------------------------------------------------
// Unevenly sampled models (issue #37): one part of the surface sampled 3× finer than the rest,
// like a scan whose face is denser than its cranium.

/// The density ratio of the unevenly sampled models: √3-subdivision (Kobbelt, SIGGRAPH 2000)
/// of the fine part splits every triangle's area in three.
pub const UNEVEN_DENSITY_RATIO: f64 = 3.0;

/// One step of √3-subdivision (Kobbelt 2000, "√3-Subdivision") restricted to the faces for
/// which `fine(centroid)` holds: each such face t = (a, b, c) gets its centroid, moved onto the
/// zero set of `f` by [`project_to_zero_set`], as a new vertex m_t; each of its edges (a, b)
/// then gives one triangle: (a, m_s, m_t) when the face s across it is also fine (the edge
/// flip of √3-subdivision), (a, b, m_t) otherwise. A fine face's area is split in three, the
/// coarse faces are kept, and the result is a closed, consistently oriented 2-manifold when
/// the input is.
fn sqrt3_refine(
    f: &dyn Fn(&Point3<f64>) -> f64,
    mut positions: Vec<Point3<f64>>,
    faces: &[[u32; 3]],
    fine: &dyn Fn(&Point3<f64>) -> bool,
    h: f64,
) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    let mut face_of_edge: std::collections::HashMap<(u32, u32), usize> =
        std::collections::HashMap::new();
    for (t, face) in faces.iter().enumerate() {
        for c in 0..3 {
            face_of_edge.insert((face[c], face[(c + 1) % 3]), t);
        }
    }
    let centre: Vec<Option<u32>> = faces
        .iter()
        .map(|face| {
            let [a, b, c] = face.map(|v| positions[v as usize]);
            let g = Point3::from((a.coords + b.coords + c.coords) / 3.0);
            fine(&g).then(|| {
                positions.push(project_to_zero_set(f, g, h));
                positions.len() as u32 - 1
            })
        })
        .collect();
    let mut refined = Vec::with_capacity(faces.len() * 2);
    for (t, face) in faces.iter().enumerate() {
        let Some(m_t) = centre[t] else {
            refined.push(*face);
            continue;
        };
        for c in 0..3 {
            let (a, b) = (face[c], face[(c + 1) % 3]);
            match face_of_edge.get(&(b, a)).and_then(|&s| centre[s]) {
                Some(m_s) => refined.push([a, m_s, m_t]),
                None => refined.push([a, b, m_t]),
            }
        }
    }
    (positions, refined)
}

/// A mesh of the zero set of `f` in [lo, hi] like [`implicit_mesh`] (`cells` cubes along the
/// longest side, three rounds of [`relax_on_surface`]), then `steps` times the faces whose
/// centroid is `fine` split in three by [`sqrt3_refine`]: the fine part has
/// [`UNEVEN_DENSITY_RATIO`]^steps times the triangles per unit area of the rest. No relaxation after the split (it would smooth
/// the density step away).
fn uneven_implicit_mesh(
    short: &str,
    f: &dyn Fn(&Point3<f64>) -> f64,
    (lo, hi): (Point3<f64>, Point3<f64>),
    cells: usize,
    fine: &dyn Fn(&Point3<f64>) -> bool,
    steps: usize,
) -> TriMesh {
    let (positions, faces) = marching_tetrahedra(f, lo, hi, cells);
    let h = (hi - lo).max() / cells.max(4) as f64;
    let positions = relax_on_surface(f, positions, &faces, 3, h);
    let (mut positions, mut faces) = (positions, faces);
    for _ in 0..steps {
        (positions, faces) = sqrt3_refine(f, positions, &faces, fine, h);
    }
    TriMesh::with_shared_indices(name(short), positions, Vec::new(), faces)
}

/// [`genus_bumpy`] with `genus` rings sampled unevenly (issue #37): the half x < x_mid (x_mid
/// the middle of the row of rings) [`UNEVEN_DENSITY_RATIO`] times finer, by median triangle
/// area, than the half x > x_mid. `cells` ≥ 8 as in [`genus_bumpy`]; at genus 2, 64 gives
/// ≈ 66k triangles (the coarse half ≈ 16k, the fine half ≈ 50k).
pub fn genus_uneven(genus: usize, cells: usize) -> TriMesh {
    genus_uneven_steps(genus, cells, 1)
}

/// [`genus_uneven`] with `steps` √3 splits of the fine half: [`UNEVEN_DENSITY_RATIO`]^steps
/// times denser (2 steps: 9×), a harder case than the 3×.
pub fn genus_uneven_steps(genus: usize, cells: usize, steps: usize) -> TriMesh {
    let g = genus.clamp(1, 8);
    let (f, lo, hi) = genus_bumpy_field(g);
    let x_mid = (g - 1) as f64;
    uneven_implicit_mesh(
        &match steps {
            1 => format!("genus{g}_uneven"),
            _ => format!("genus{g}_uneven{}", 3usize.pow(steps as u32)),
        },
        &f,
        (lo, hi),
        cells.max(8),
        &|p: &Point3<f64>| p.x < x_mid,
        steps,
    )
}

/// A head-like closed genus-0 surface (issue #37, like a skull scan whose face is sampled finer
/// than its cranium): a cranium (ellipsoid centred (−0.15, 0, 0.25), semi-axes 1.0, 0.8, 0.85),
/// a face and jaw (ellipsoid centred (0.45, 0, −0.35), semi-axes 0.6, 0.55, 0.55), a nose (a
/// tapered capsule from (0.95, 0, −0.05) to (1.15, 0, −0.3), radius 0.12 → 0.06) blended with
/// smooth minima of width 0.15 and 0.08, eye sockets (two Gaussian dents, depth 0.08, width
/// 0.15) and brow bumps (height 0.05). Ellipsoid distances are the bounded
/// (|q| − 1)·(smallest semi-axis), q the point in the ellipsoid's unit coordinates. The face
/// side x > 0.3 is [`UNEVEN_DENSITY_RATIO`] times finer than the cranium side. `cells` ≥ 8
/// grid cubes along the longest side; 64 gives ≈ 40k triangles.
pub fn head_uneven(cells: usize) -> TriMesh {
    uneven_implicit_mesh(
        "head_uneven",
        &head_field(false),
        head_box(),
        cells.max(8),
        &|p: &Point3<f64>| p.x > 0.3,
        1,
    )
}

/// [`head_uneven`] with two thin handles like a skull's zygomatic arches (issue #37's scan is a
/// genus-2 skull): each a bent bar of radius 0.07 (two capsules (0.55, ±0.45, −0.45) →
/// (0, ±0.72, −0.45) → (−0.45, ±0.3, −0.4)) from the cheek to the side of the cranium,
/// standing up to 0.21 off the head, blended with a smooth minimum of width 0.05. Genus 2.
/// 64 cubes give ≈ 90k triangles.
pub fn skull_uneven(cells: usize) -> TriMesh {
    uneven_implicit_mesh(
        "skull_uneven",
        &head_field(true),
        head_box(),
        cells.max(8),
        &|p: &Point3<f64>| p.x > 0.3,
        1,
    )
}

/// The box around [`head_field`]'s zero set.
fn head_box() -> (Point3<f64>, Point3<f64>) {
    (
        Point3::new(-1.4, -1.05, -1.15),
        Point3::new(1.45, 1.05, 1.3),
    )
}

/// The implicit function of [`head_uneven`] (negative inside), with the arches of
/// [`skull_uneven`] when `arches`.
fn head_field(arches: bool) -> impl Fn(&Point3<f64>) -> f64 {
    let ellipsoid = |p: &Point3<f64>, c: [f64; 3], r: [f64; 3]| {
        let q = nalgebra::Vector3::new(
            (p.x - c[0]) / r[0],
            (p.y - c[1]) / r[1],
            (p.z - c[2]) / r[2],
        );
        (q.norm() - 1.0) * r[0].min(r[1]).min(r[2])
    };
    let eyes = [Point3::new(0.78, 0.3, 0.1), Point3::new(0.78, -0.3, 0.1)];
    let brows = [Point3::new(0.8, 0.3, 0.3), Point3::new(0.8, -0.3, 0.3)];
    move |p: &Point3<f64>| {
        let cranium = ellipsoid(p, [-0.15, 0.0, 0.25], [1.0, 0.8, 0.85]);
        let face = ellipsoid(p, [0.45, 0.0, -0.35], [0.6, 0.55, 0.55]);
        let nose = horn_sdf(
            p,
            &Point3::new(0.95, 0.0, -0.05),
            &Point3::new(1.15, 0.0, -0.3),
            0.12,
            0.06,
        );
        let mut d = smooth_min(smooth_min(cranium, face, 0.15), nose, 0.08);
        if arches {
            for side in [1.0, -1.0] {
                let a = Point3::new(0.55, 0.45 * side, -0.45);
                let m = Point3::new(0.0, 0.72 * side, -0.45);
                let b = Point3::new(-0.45, 0.3 * side, -0.4);
                let bar = horn_sdf(p, &a, &m, 0.07, 0.07).min(horn_sdf(p, &m, &b, 0.07, 0.07));
                d = smooth_min(d, bar, 0.05);
            }
        }
        d + bumps(p, &eyes, 0.08, 0.15) - bumps(p, &brows, 0.05, 0.12)
    }
}

// ---------------------------------------------------------------------------------------------
// A body with many thin parts (issue #53, like a scanned scorpion or spider): the removal order
// of the coarse levels must keep every limb in the base domain.

/// Signed distance to a square prism along the segment a–b: cross-section a square of half
/// side `half` (its sides along e₁ = n × z / |n × z| and e₂ = n × e₁, n the unit axis, which
/// must not be parallel to z), flat ends at a and b: a limb with sharp edges and corners.
fn prism_sdf(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>, half: f64) -> f64 {
    let axis = b - a;
    let len = axis.norm();
    let n = axis / len;
    let e1 = n.cross(&nalgebra::Vector3::z()).normalize();
    let e2 = n.cross(&e1);
    let d = p - Point3::from((a.coords + b.coords) * 0.5);
    let local = Point3::new(d.dot(&n), d.dot(&e1), d.dot(&e2));
    box_sdf(&local, &Point3::origin(), [0.5 * len, half, half])
}

/// The tips of [`many_limbed`]'s limbs, in its order: eight feet (four on each side, front to
/// back, the +y side first), the two claws' fixed fingers, then the sting of the tail.
pub fn many_limbed_tips() -> Vec<Point3<f64>> {
    let mut tips = Vec::new();
    for side in [1.0, -1.0] {
        for k in 0..4 {
            tips.push(limb_joints(k, side)[2]);
        }
    }
    for side in [1.0, -1.0] {
        tips.push(Point3::new(1.72, 0.52 * side, 0.04));
    }
    tips.push(Point3::new(-1.02, 0.0, 1.3));
    tips
}

/// Hip, knee and foot of leg `k` (0 at the front) on the side `side` (±1) of [`many_limbed`].
fn limb_joints(k: usize, side: f64) -> [Point3<f64>; 3] {
    let x = 0.45 - 0.3 * k as f64;
    let spread = 0.12 * (k as f64 - 1.5);
    [
        Point3::new(x, 0.3 * side, 0.0),
        Point3::new(x + spread, 0.85 * side, 0.32),
        Point3::new(x + 2.0 * spread, 1.25 * side, -0.38),
    ]
}

/// A body with many thin parts (issue #53, like a scanned scorpion): an ellipsoidal body
/// (semi-axes 0.9, 0.42, 0.25), eight legs (four each side, a round thigh of radius 0.06 from
/// the hip to a knee 0.32 above the body's middle, then a square shin of half side 0.05 with
/// sharp edges down to the foot, 1.25 from the axis), two claws (an arm of radius 0.08, a
/// hand, and two tapered fingers 0.07 → 0.02 with sharp tips) and a tail of five tapered
/// segments (radius 0.11 → 0.07) curling up over the back to a sting (0.07 → 0.015), blended
/// with smooth minima of width 0.04. Tips in [`many_limbed_tips`]. `cells` ≥ 8 grid cubes along
/// the longest side (3.7); the thinnest parts (0.1 across) are resolved from about 80 on, as
/// one closed surface (not genus 0: at 96 its Euler characteristic is −8, where the blended
/// parts close loops); 96 gives ≈ 25.6k triangles.
pub fn many_limbed(cells: usize) -> TriMesh {
    let ellipsoid = |p: &Point3<f64>, r: [f64; 3]| {
        let q = nalgebra::Vector3::new(p.x / r[0], p.y / r[1], p.z / r[2]);
        (q.norm() - 1.0) * r[0].min(r[1]).min(r[2])
    };
    let tail: Vec<Point3<f64>> = [
        (-0.8, 0.05),
        (-1.25, 0.18),
        (-1.55, 0.5),
        (-1.6, 0.9),
        (-1.4, 1.22),
        (-1.15, 1.3),
    ]
    .iter()
    .map(|&(x, z)| Point3::new(x, 0.0, z))
    .collect();
    let f = move |p: &Point3<f64>| {
        let mut d = ellipsoid(p, [0.9, 0.42, 0.25]);
        let mut add = |part: f64| d = smooth_min(d, part, 0.04);
        for side in [1.0, -1.0] {
            for k in 0..4 {
                let [hip, knee, foot] = limb_joints(k, side);
                add(horn_sdf(p, &hip, &knee, 0.06, 0.06).min(prism_sdf(p, &knee, &foot, 0.05)));
            }
            let shoulder = Point3::new(0.75, 0.2 * side, 0.0);
            let wrist = Point3::new(1.2, 0.55 * side, 0.0);
            let hand = Point3::new(1.38, 0.6 * side, 0.0);
            let arm = horn_sdf(p, &shoulder, &wrist, 0.08, 0.08);
            let palm = ellipsoid(&(p - hand.coords), [0.2, 0.12, 0.09]);
            let fixed = horn_sdf(p, &hand, &Point3::new(1.72, 0.52 * side, 0.04), 0.07, 0.02);
            let moving = horn_sdf(p, &hand, &Point3::new(1.66, 0.78 * side, -0.02), 0.06, 0.02);
            add(arm.min(palm).min(fixed).min(moving));
        }
        for (s, w) in tail.windows(2).enumerate() {
            let r = 0.11 - 0.01 * s as f64;
            add(horn_sdf(p, &w[0], &w[1], r, r - 0.01));
        }
        add(horn_sdf(
            p,
            &tail[5],
            &Point3::new(-1.02, 0.0, 1.3),
            0.07,
            0.015,
        ));
        d
    };
    let lo = Point3::new(-1.85, -1.45, -0.6);
    let hi = Point3::new(1.9, 1.45, 1.5);
    implicit_mesh("many_limbed", &f, lo, hi, cells.max(8))
}
