//! OBJ loading and writing: round trip, UV seams, typed errors naming file and element.

use std::fs;
use std::path::{Path, PathBuf};

use reparam::mesh::{load_obj, procedural, write_obj, Adjacency};
use reparam::Error;

/// Write `text` to `name` inside `dir` and return the path.
fn write_file(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    if let Some(parent) = path.parent() {
        fs::create_dir_all(parent).unwrap();
    }
    fs::write(&path, text).unwrap();
    path
}

/// Load an OBJ given as text.
fn load_text(text: &str) -> (tempfile::TempDir, PathBuf, reparam::Result<reparam::mesh::TriMesh>) {
    let dir = tempfile::tempdir().unwrap();
    let path = write_file(dir.path(), "model.obj", text);
    let result = load_obj(&path);
    (dir, path, result)
}

#[test]
fn round_trip_keeps_every_face_corner() {
    let dir = tempfile::tempdir().unwrap();
    let mut original = procedural::two_charts_mirrored(3);
    original.texture = Some(dir.path().join("textures/albedo.png"));
    let path = dir.path().join("out/roundtrip.obj");
    write_obj(&original, &path).unwrap();
    let loaded = load_obj(&path).unwrap();

    assert_eq!(loaded.name, path.display().to_string());
    assert_eq!(loaded.faces.len(), original.faces.len());
    assert_eq!(loaded.positions.len(), original.positions.len());
    assert_eq!(loaded.uvs.len(), original.uvs.len());
    // The loader may renumber vertices; the geometry of every face corner must be identical.
    for f in 0..original.faces.len() {
        assert_eq!(loaded.face_positions(f), original.face_positions(f), "face {f}");
        assert_eq!(loaded.face_uvs(f), original.face_uvs(f), "face {f}");
    }
    assert_eq!(loaded.texture, original.texture);
}

#[test]
fn texture_next_to_the_obj_is_written_relative() {
    let dir = tempfile::tempdir().unwrap();
    let mut mesh = procedural::flat_star(5);
    mesh.texture = Some(dir.path().join("maps/albedo.png"));
    let path = dir.path().join("star.obj");
    write_obj(&mesh, &path).unwrap();
    let mtl = fs::read_to_string(dir.path().join("star.mtl")).unwrap();
    assert!(mtl.contains("map_Kd maps/albedo.png"), "{mtl}");
    assert_eq!(load_obj(&path).unwrap().texture, mesh.texture);
}

#[test]
fn round_trip_without_uvs() {
    let dir = tempfile::tempdir().unwrap();
    let mut mesh = procedural::wavy_grid(2);
    mesh.uvs.clear();
    mesh.uv_faces.clear();
    let path = dir.path().join("plain.obj");
    write_obj(&mesh, &path).unwrap();
    let loaded = load_obj(&path).unwrap();
    assert!(!loaded.has_uvs());
    assert_eq!(loaded.faces.len(), 8);
    assert_eq!(loaded.texture, None);
}

const SEAM_OBJ: &str = "\
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 0.5 0
vt 0.5 0.5
vt 0.6 0.5
vt 0.6 0
vt 1 0.5
f 1/1 2/2 3/3
f 1/5 3/4 4/6
";

#[test]
fn uv_seam_keeps_one_position_per_3d_vertex() {
    let (_dir, _path, mesh) = load_text(SEAM_OBJ);
    let mesh = mesh.unwrap();
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.uvs.len(), 6);
    let adjacency = Adjacency::new(&mesh);
    assert_eq!(adjacency.seam_edges, 1);
    assert_eq!(adjacency.boundary_edges, 4);
}

#[test]
fn groups_and_materials_stay_connected() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng left\nf 1 2 3\ng right\nusemtl other\nf 1 3 4\n";
    let (_dir, _path, mesh) = load_text(text);
    let mesh = mesh.unwrap();
    assert_eq!(mesh.positions.len(), 4);
    let adjacency = Adjacency::new(&mesh);
    assert_eq!(adjacency.boundary_edges, 4, "the diagonal must be an interior edge");
}

#[test]
fn polygons_are_triangulated_and_polylines_ignored() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nl 1 2 3\n";
    let (_dir, _path, mesh) = load_text(text);
    assert_eq!(mesh.unwrap().faces.len(), 2);
}

#[test]
fn missing_file_is_an_io_error_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("does_not_exist.obj");
    match load_obj(&path) {
        Err(Error::Io { path: p, .. }) => assert_eq!(p, path),
        other => panic!("expected Error::Io, got {other:?}"),
    }
}

#[test]
fn nan_coordinate_names_the_vertex_and_line() {
    for token in ["nan", "NaN", "inf", "-infinity"] {
        let text = format!("v 0 0 0\nv 1 {token} 0\nv 0 1 0\nf 1 2 3\n");
        let (_dir, path, mesh) = load_text(&text);
        match mesh {
            Err(Error::NonFinite { mesh, what, index, .. }) => {
                assert_eq!((what, index), ("vertex", 1));
                assert_eq!(mesh, format!("{}:2", path.display()));
            }
            other => panic!("{token}: expected NonFinite, got {other:?}"),
        }
    }
}

#[test]
fn nan_texture_coordinate_is_an_error() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt inf 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    let (_dir, _path, mesh) = load_text(text);
    assert!(matches!(mesh, Err(Error::NonFinite { what: "texture coordinate", index: 1, .. })));
}

#[test]
fn face_index_out_of_range_names_the_face() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 5 3\n";
    let (_dir, path, mesh) = load_text(text);
    match mesh {
        Err(Error::IndexOutOfRange { mesh, face, what, index, count }) => {
            assert_eq!((face, what, index, count), (1, "vertex", 4, 4));
            assert_eq!(mesh, format!("{}:6", path.display()));
        }
        other => panic!("expected IndexOutOfRange, got {other:?}"),
    }
}

#[test]
fn texture_index_out_of_range_and_bad_relative_indices_are_errors_not_panics() {
    let cases = [
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-5 2/-5 3/-5\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -9\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x 2 3\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
        "v 0 0\n",
    ];
    for text in cases {
        let (_dir, _path, mesh) = load_text(text);
        assert!(mesh.is_err(), "{text:?} should fail");
    }
}

#[test]
fn relative_indices_are_resolved() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\n";
    let (_dir, _path, mesh) = load_text(text);
    let mesh = mesh.unwrap();
    assert_eq!(mesh.face_uvs(0)[1], nalgebra::Point2::new(1.0, 0.0));
}

#[test]
fn corners_without_uvs_in_a_file_with_uvs_are_partial_uvs() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nf 2 4 3\n";
    let (_dir, _path, mesh) = load_text(text);
    assert!(matches!(mesh, Err(Error::PartialUvs { face: 1, .. })), "{mesh:?}");
}

#[test]
fn empty_file_is_an_empty_mesh() {
    for text in ["", "# only a comment\nv 0 0 0\n"] {
        let (_dir, _path, mesh) = load_text(text);
        assert!(matches!(mesh, Err(Error::EmptyMesh { .. })), "{mesh:?}");
    }
}

#[test]
fn mtl_texture_is_resolved_relative_to_the_obj() {
    let dir = tempfile::tempdir().unwrap();
    write_file(dir.path(), "assets/materials.mtl", "newmtl plain\nKd 1 1 1\nnewmtl skin\nmap_Kd tex/skin color.png\n");
    let obj = write_file(
        dir.path(),
        "assets/model.obj",
        &format!("mtllib materials.mtl\nusemtl skin\n{SEAM_OBJ}"),
    );
    let mesh = load_obj(&obj).unwrap();
    assert_eq!(mesh.texture, Some(dir.path().join("assets/tex/skin color.png")));
}

#[test]
fn missing_mtl_means_no_texture() {
    let (_dir, _path, mesh) = load_text(&format!("mtllib nowhere.mtl\nusemtl x\n{SEAM_OBJ}"));
    assert_eq!(mesh.unwrap().texture, None);
}
