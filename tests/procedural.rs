//! Built-in meshes: valid, the advertised sizes and the advertised special features.

use nalgebra::Point2;
use num_complex::Complex64;
use reparam::mesh::{procedural, Adjacency, TriMesh};

/// Signed area of UV triangle f: positive when counter-clockwise.
fn signed_uv_area(mesh: &TriMesh, f: usize) -> f64 {
    let [a, b, c] = mesh.face_uvs(f);
    0.5 * ((b - a).perp(&(c - a)))
}

#[test]
fn every_small_mesh_is_valid_named_and_deterministic() {
    let first = procedural::all_small();
    let second = procedural::all_small();
    assert_eq!(first.len(), 8);
    for (a, b) in first.iter().zip(&second) {
        a.validate_with_uvs()
            .unwrap_or_else(|e| panic!("{}: {e}", a.name));
        assert!(a.name.starts_with("procedural:"), "{}", a.name);
        assert_eq!(a.positions, b.positions, "{}", a.name);
        assert_eq!(a.uvs, b.uvs, "{}", a.name);
        let adjacency = Adjacency::new(a);
        assert_eq!(adjacency.non_manifold_edges, 0, "{}", a.name);
        assert_eq!(adjacency.misoriented_edges, 0, "{}", a.name);
    }
}

#[test]
fn fans_have_n_triangles() {
    for mesh in [
        procedural::flat_star(7),
        procedural::flat_star_affine(7),
        procedural::cone_fan(7, 1.0),
    ] {
        assert_eq!(
            (mesh.faces.len(), mesh.positions.len(), mesh.uvs.len()),
            (7, 8, 8),
            "{}",
            mesh.name
        );
        assert!(
            (0..7).all(|f| signed_uv_area(&mesh, f) > 0.0),
            "{}",
            mesh.name
        );
    }
    assert_eq!(procedural::flat_star(1).faces.len(), 3, "n is raised to 3");
}

#[test]
fn cone_apex_uv_is_origin_and_rim_on_unit_circle() {
    let cone = procedural::cone_fan(9, 2.0);
    assert_eq!(cone.uvs[0], Point2::origin());
    assert_eq!(cone.positions[0].z, 2.0);
    for uv in &cone.uvs[1..] {
        approx::assert_relative_eq!(uv.coords.norm(), 1.0, epsilon = 1e-15);
    }
}

#[test]
fn star_uvs_are_a_similarity_and_affine_star_is_not() {
    // A similarity scales every edge length by the same factor.
    let ratios = |mesh: &TriMesh| -> Vec<f64> {
        mesh.faces
            .iter()
            .zip(&mesh.uv_faces)
            .map(|(p, t)| {
                let d3 = (mesh.positions[p[1] as usize] - mesh.positions[p[2] as usize]).norm();
                let d2 = (mesh.uvs[t[1] as usize] - mesh.uvs[t[2] as usize]).norm();
                d2 / d3
            })
            .collect()
    };
    let similar = ratios(&procedural::flat_star(10));
    assert!(similar.iter().all(|r| (r - 0.35).abs() < 1e-12));
    let affine = ratios(&procedural::flat_star_affine(10));
    let spread = affine.iter().cloned().fold(f64::MIN, f64::max)
        - affine.iter().cloned().fold(f64::MAX, f64::min);
    assert!(
        spread > 0.05,
        "affine star edge ratios should vary, spread {spread}"
    );
}

#[test]
fn torus_is_closed_with_seams_in_both_directions() {
    let (major, minor) = (8, 5);
    let torus = procedural::torus(major, minor, 1.0, 0.3);
    assert_eq!(
        torus.faces.len(),
        procedural::torus_triangle_count(major, minor)
    );
    assert_eq!(torus.faces.len(), 80);
    assert_eq!(torus.positions.len(), 40);
    assert_eq!(torus.uvs.len(), 54);
    let adjacency = Adjacency::new(&torus);
    assert_eq!(adjacency.boundary_edges, 0);
    assert_eq!(adjacency.seam_edges, major + minor);
    assert!(torus
        .uvs
        .iter()
        .all(|t| (0.0..=1.0).contains(&t.x) && (0.0..=1.0).contains(&t.y)));
    assert!((0..torus.faces.len()).all(|f| signed_uv_area(&torus, f) > 0.0));
}

#[test]
fn torus_faces_point_outwards() {
    let torus = procedural::torus(12, 6, 1.0, 0.3);
    for f in 0..torus.faces.len() {
        let [a, b, c] = torus.face_positions(f);
        let normal = (b - a).cross(&(c - a));
        let centre = (a.coords + b.coords + c.coords) / 3.0;
        // Outward = away from the tube's centre circle.
        let ring = nalgebra::Vector3::new(centre.x, centre.y, 0.0).normalize();
        assert!(normal.dot(&(centre - ring)) > 0.0, "face {f}");
    }
}

#[test]
fn big_torus_has_a_million_triangles() {
    let (major, minor) = procedural::BIG_TORUS_SEGMENTS;
    assert!(procedural::torus_triangle_count(major, minor) >= 1_000_000);
    assert_eq!(procedural::torus_triangle_count(major, minor), 1_048_576);
}

#[test]
fn mobius_mesh_uvs_are_the_mobius_image_and_not_affine() {
    let m = procedural::default_mobius();
    let mesh = procedural::mobius_mesh(6, m);
    assert_eq!(mesh.faces.len(), 72);
    for (p, t) in mesh.positions.iter().zip(&mesh.uvs) {
        assert_eq!(p.z, 0.0);
        let w = procedural::apply_mobius(&m, Complex64::new(p.x, p.y));
        assert_eq!((t.x, t.y), (w.re, w.im));
    }
    // An affine map would send the midpoint of two vertices to the midpoint of their UVs.
    let (p, q) = (mesh.positions[0], *mesh.positions.last().unwrap());
    let mid = nalgebra::center(&p, &q);
    let w_mid = procedural::apply_mobius(&m, Complex64::new(mid.x, mid.y));
    let uv_mid = nalgebra::center(&mesh.uvs[0], mesh.uvs.last().unwrap());
    assert!((Point2::new(w_mid.re, w_mid.im) - uv_mid).norm() > 0.05);
    assert!((0..mesh.faces.len()).all(|f| signed_uv_area(&mesh, f) > 0.0));
}

#[test]
fn second_chart_is_mirrored_and_the_ridge_is_a_seam() {
    let n = 4;
    let mesh = procedural::two_charts_mirrored(n);
    let per_chart = 2 * n * n;
    assert_eq!(mesh.faces.len(), 2 * per_chart);
    assert!((0..per_chart).all(|f| signed_uv_area(&mesh, f) > 0.0));
    assert!((per_chart..2 * per_chart).all(|f| signed_uv_area(&mesh, f) < 0.0));
    let adjacency = Adjacency::new(&mesh);
    assert_eq!(adjacency.seam_edges, n);
    // Slopes are 1 long: both UV charts are the 3D slopes scaled by 0.4.
    let total_uv: f64 = (0..mesh.faces.len())
        .map(|f| signed_uv_area(&mesh, f).abs())
        .sum();
    approx::assert_relative_eq!(total_uv, 2.0 * 0.16, epsilon = 1e-12);
}

#[test]
fn tiny_far_uv_triangles_are_tiny_and_far() {
    let mesh = procedural::tiny_far_uv(5);
    for t in &mesh.uvs {
        assert!(t.x >= 2.6 && t.x <= 2.6 + 5.0 * procedural::TINY_UV_CELL + 1e-12);
        assert!(t.y >= 2.6 && t.y <= 2.6 + 5.0 * procedural::TINY_UV_CELL + 1e-12);
    }
    for f in 0..mesh.faces.len() {
        let area = signed_uv_area(&mesh, f);
        assert!(
            area > 0.0 && area < procedural::TINY_UV_CELL.powi(2),
            "face {f}: {area}"
        );
    }
}

#[test]
fn wavy_grid_is_curved_without_folds() {
    let mesh = procedural::wavy_grid(10);
    assert_eq!(mesh.faces.len(), 200);
    let z_range = mesh.positions.iter().map(|p| p.z).fold(f64::MIN, f64::max)
        - mesh.positions.iter().map(|p| p.z).fold(f64::MAX, f64::min);
    assert!(z_range > 0.2);
    assert!((0..mesh.faces.len()).all(|f| signed_uv_area(&mesh, f) > 0.0));
    assert_eq!(Adjacency::new(&mesh).boundary_edges, 40);
}
