//! Bad input to BPM gets a typed error naming the element and the file, or documented handling
//! (degenerate faces fall back to linear, non-manifold edges count as boundary): never a panic
//! or a NaN.

use nalgebra::{Point2, Point3};
use reparam::bpm::render::resolve_texture;
use reparam::bpm::{precompute, BpmOptions, Interp};
use reparam::mesh::TriMesh;
use reparam::Error;

/// Two triangles sharing the edge 1–2, plus whatever `extra` adds; UVs = positions' x, y.
fn quad(extra_positions: &[[f64; 3]], extra_faces: &[[u32; 3]]) -> TriMesh {
    let mut p = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.1],
    ];
    p.extend_from_slice(extra_positions);
    let mut faces = vec![[0, 1, 2], [1, 3, 2]];
    faces.extend_from_slice(extra_faces);
    let positions: Vec<Point3<f64>> = p.iter().map(|q| Point3::new(q[0], q[1], q[2])).collect();
    let uvs = positions
        .iter()
        .map(|q| Point2::new(0.3 + 0.5 * q.x, 0.2 + 0.5 * q.y + 0.1 * q.z))
        .collect();
    TriMesh::with_shared_indices("test:quad", positions, uvs, faces)
}

fn all_finite(mesh: &TriMesh) {
    let bpm = precompute(mesh, BpmOptions::default()).unwrap();
    for f in 0..mesh.face_count() {
        for b in [
            [1.0 / 3.0; 3],
            [0.5, 0.5, 0.0],
            [1.0, 0.0, 0.0],
            [0.1, 0.2, 0.7],
        ] {
            let w = bpm.eval(f, b, Interp::Bpm);
            assert!(
                w.re.is_finite() && w.im.is_finite(),
                "face {f} at {b:?}: {w}"
            );
        }
    }
}

#[test]
fn a_mesh_without_uvs_is_a_typed_error_naming_the_mesh() {
    let mut mesh = quad(&[], &[]);
    mesh.uvs.clear();
    mesh.uv_faces.clear();
    let err = precompute(&mesh, BpmOptions::default()).unwrap_err();
    assert!(matches!(err, Error::MissingUvs { .. }), "{err:?}");
    assert!(err.to_string().contains("test:quad"), "{err}");
}

#[test]
fn nan_and_infinite_coordinates_are_typed_errors_naming_the_vertex() {
    let mut mesh = quad(&[], &[]);
    mesh.positions[3].y = f64::NAN;
    let err = precompute(&mesh, BpmOptions::default()).unwrap_err();
    assert!(matches!(err, Error::NonFinite { index: 3, .. }), "{err:?}");
    assert!(err.to_string().contains("vertex 3"), "{err}");

    let mut mesh = quad(&[], &[]);
    mesh.uvs[2].x = f64::INFINITY;
    let err = precompute(&mesh, BpmOptions::default()).unwrap_err();
    assert!(matches!(err, Error::NonFinite { index: 2, .. }), "{err:?}");
}

#[test]
fn an_empty_mesh_is_a_typed_error() {
    let mesh = TriMesh::with_shared_indices("test:empty", vec![], vec![], vec![]);
    let err = precompute(&mesh, BpmOptions::default()).unwrap_err();
    assert!(matches!(err, Error::EmptyMesh { .. }), "{err:?}");
}

#[test]
fn out_of_range_indices_are_typed_errors_naming_the_face() {
    let mut mesh = quad(&[], &[]);
    mesh.faces[1] = [1, 7, 2];
    let err = precompute(&mesh, BpmOptions::default()).unwrap_err();
    assert!(
        matches!(
            err,
            Error::IndexOutOfRange {
                face: 1,
                index: 7,
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn degenerate_faces_fall_back_to_linear_and_are_counted() {
    // Face 2 = (1, 4, 3) has zero 3D area: vertex 4 lies on the line 1→3 (at twice the distance).
    // Face 3 = (0, 5, 1) is fine in 3D but its UV triangle is flat: vertex 5's UV is the
    // midpoint of the UVs of 0 and 1.
    let mut mesh = quad(&[[0.0; 3], [0.5, -1.0, 0.0]], &[[1, 4, 3], [0, 5, 1]]);
    mesh.positions[4] = mesh.positions[1] + (mesh.positions[3] - mesh.positions[1]) * 2.0;
    mesh.uvs[4] = mesh.uvs[1] + (mesh.uvs[3] - mesh.uvs[1]) * 2.0;
    mesh.uvs[5] = mesh.uvs[0] + (mesh.uvs[1] - mesh.uvs[0]) * 0.5;
    let bpm = precompute(&mesh, BpmOptions::default()).unwrap();
    assert_eq!(bpm.report.degenerate_faces, 2, "{:?}", bpm.report);
    assert_eq!(bpm.report.degenerate_examples, vec![2, 3]);
    for f in [2, 3] {
        assert!(bpm.maps[f].fallback_linear);
        let b = [0.2, 0.3, 0.5];
        assert_eq!(bpm.eval(f, b, Interp::Bpm), bpm.eval(f, b, Interp::Linear));
    }
    // Face 1 = (1, 3, 2) borders the degenerate face 2 across its local edge 0 (1→3): that edge
    // is treated as a boundary (zero log), while its edge 2→1 (local 2) still blends with face 0.
    assert_eq!(bpm.maps[1].logs[0].max_abs(), 0.0);
    assert!(bpm.maps[1].logs[2].max_abs() > 0.0);
    all_finite(&mesh);
}

#[test]
fn non_manifold_edges_are_counted_and_treated_as_boundary() {
    // A third face on the edge 1–2.
    let mesh = quad(&[[0.5, 0.5, 1.0]], &[[2, 1, 4]]);
    let bpm = precompute(&mesh, BpmOptions::default()).unwrap();
    assert_eq!(bpm.report.non_manifold_edges, 1, "{:?}", bpm.report);
    // Edge 1–2 is face 0's local edge 1 (jk): its log is zero, so f = M_t there.
    assert_eq!(bpm.maps[0].logs[1].max_abs(), 0.0);
    all_finite(&mesh);
}

#[test]
fn a_missing_material_texture_is_a_typed_error_naming_both_files() {
    let mut mesh = quad(&[], &[]);
    mesh.name = "/data/model.obj".into();
    mesh.texture = Some("/data/does_not_exist.png".into());
    let err = resolve_texture(&mesh, None).unwrap_err();
    assert!(matches!(err, Error::MissingTexture { .. }), "{err:?}");
    let text = err.to_string();
    assert!(
        text.contains("/data/model.obj") && text.contains("does_not_exist.png"),
        "{text}"
    );
    // No texture at all: the built-in UV grid.
    mesh.texture = None;
    assert!(resolve_texture(&mesh, None).unwrap().width > 0);
    // --texture that cannot be read: an error naming that file.
    let err = resolve_texture(&mesh, Some(std::path::Path::new("/nowhere/t.png"))).unwrap_err();
    assert!(err.to_string().contains("/nowhere/t.png"), "{err}");
}

#[test]
fn a_mirrored_face_next_to_a_normal_one_stays_finite() {
    // Flip the UVs of face 1 only (different uv indices → a seam, as in a real mirrored chart).
    let mut mesh = quad(&[], &[]);
    let flipped: Vec<Point2<f64>> = mesh
        .uvs
        .iter()
        .map(|t| Point2::new(1.0 - t.x, t.y))
        .collect();
    let base = mesh.uvs.len() as u32;
    mesh.uvs.extend(flipped);
    mesh.uv_faces[1] = mesh.faces[1].map(|v| v + base);
    let bpm = precompute(&mesh, BpmOptions::default()).unwrap();
    assert_eq!(bpm.report.mirrored_faces, 1);
    assert_eq!(bpm.report.seam_edges, 1);
    all_finite(&mesh);
}
