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
fn load_text(
    text: &str,
) -> (
    tempfile::TempDir,
    PathBuf,
    reparam::Result<reparam::mesh::TriMesh>,
) {
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
    // The texture lies outside the OBJ's folder: written by its absolute path, which is
    // followed only when allowed (issue #35).
    assert!(matches!(
        load_obj(&path),
        Err(reparam::Error::Reference { .. })
    ));
    use reparam::input::{with_reference_policy, ReferencePolicy};
    let loaded = with_reference_policy(ReferencePolicy::Anywhere, || load_obj(&path)).unwrap();

    assert_eq!(loaded.name, path.display().to_string());
    assert_eq!(loaded.faces.len(), original.faces.len());
    assert_eq!(loaded.positions.len(), original.positions.len());
    assert_eq!(loaded.uvs.len(), original.uvs.len());
    // Nothing is renumbered: the file order is the mesh order, numbers round-trip exactly.
    assert_eq!(loaded.positions, original.positions);
    assert_eq!(loaded.uvs, original.uvs);
    assert_eq!(loaded.faces, original.faces);
    assert_eq!(loaded.uv_faces, original.uv_faces);
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
    let text =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng left\nf 1 2 3\ng right\nusemtl other\nf 1 3 4\n";
    let (_dir, _path, mesh) = load_text(text);
    let mesh = mesh.unwrap();
    assert_eq!(mesh.positions.len(), 4);
    let adjacency = Adjacency::new(&mesh);
    assert_eq!(
        adjacency.boundary_edges, 4,
        "the diagonal must be an interior edge"
    );
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
            Err(Error::NonFinite {
                mesh, what, index, ..
            }) => {
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
    assert!(matches!(
        mesh,
        Err(Error::NonFinite {
            what: "texture coordinate",
            index: 1,
            ..
        })
    ));
}

#[test]
fn face_index_out_of_range_names_the_face() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 5 3\n";
    let (_dir, path, mesh) = load_text(text);
    match mesh {
        Err(Error::IndexOutOfRange {
            mesh,
            face,
            what,
            index,
            count,
        }) => {
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
    let text =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nf 2 4 3\n";
    let (_dir, _path, mesh) = load_text(text);
    assert!(
        matches!(mesh, Err(Error::PartialUvs { face: 1, .. })),
        "{mesh:?}"
    );
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
    write_file(
        dir.path(),
        "assets/materials.mtl",
        "newmtl plain\nKd 1 1 1\nnewmtl skin\nmap_Kd tex/skin color.png\n",
    );
    let obj = write_file(
        dir.path(),
        "assets/model.obj",
        &format!("mtllib materials.mtl\nusemtl skin\n{SEAM_OBJ}"),
    );
    let mesh = load_obj(&obj).unwrap();
    assert_eq!(
        mesh.texture,
        Some(dir.path().join("assets/tex/skin color.png"))
    );
}

#[test]
fn missing_mtl_means_no_texture() {
    let (_dir, _path, mesh) = load_text(&format!("mtllib nowhere.mtl\nusemtl x\n{SEAM_OBJ}"));
    assert_eq!(mesh.unwrap().texture, None);
}

#[test]
fn faces_without_uvs_before_faces_with_uvs_name_face_0() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nf 2 4 3\nf 1/1 2/1 3/1\n";
    let (_dir, path, mesh) = load_text(text);
    match mesh {
        Err(Error::PartialUvs { mesh, face }) => {
            assert_eq!(face, 0);
            assert_eq!(mesh, format!("{}:6", path.display()));
        }
        other => panic!("expected PartialUvs, got {other:?}"),
    }
    // `vt` lines that no face uses: a mesh without UVs.
    let (_dir, _path, mesh) = load_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1 2 3\n");
    assert!(!mesh.unwrap().has_uvs());
}

#[test]
fn comments_continuations_weights_and_colours() {
    let text = "\
v 0 0 0 # origin
v 1 0 0 1.0
v 0 1 \\
  0 0.5 0.5 0.5
vt 0.25 0.75 0
# a comment ending in a backslash does not continue \\
f 1/1 2/1 \\
3/1
";
    let (_dir, _path, mesh) = load_text(text);
    let mesh = mesh.unwrap();
    let expected = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert_eq!(
        mesh.positions,
        expected.map(nalgebra::Point3::from).to_vec()
    );
    assert_eq!(mesh.uvs, vec![nalgebra::Point2::new(0.25, 0.75)]);
    assert_eq!(mesh.faces, vec![[0, 1, 2]]);
    assert_eq!(mesh.uv_faces, vec![[0, 0, 0]]);
}

/// Vertices whose faces use them in another order than the `v` lines, a vertex that coincides
/// with another one, and a face that refers to `v` lines further down the file.
const ORDER_OBJ: &str = "\
# vertex numbers from 0 in the comments
f 6 4 2
v 0 0 1  # 0
v 1 0 0  # 1
v 0 1 0  # 2
v 0 0 0  # 3
v 0 -1 0 # 4
v 0 0 0  # 5, same place as 3
g other
f 4 6 3
f 6 4 5
f 1 2 3
";

#[test]
fn vertex_order_is_the_order_of_the_v_lines() {
    let (_dir, _path, mesh) = load_text(ORDER_OBJ);
    let mesh = mesh.unwrap();
    let v_lines = [
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 0.0],
    ];
    assert_eq!(mesh.positions, v_lines.map(nalgebra::Point3::from).to_vec());
    assert_eq!(mesh.faces, vec![[5, 3, 1], [3, 5, 2], [5, 3, 4], [0, 1, 2]]);
    // Edge 3–5 has three faces; vertices 3 and 5 are the 4th and 6th `v` lines (not welded,
    // not renumbered in order of first use).
    let adjacency = Adjacency::new(&mesh);
    assert_eq!(adjacency.non_manifold_edges, 1);
    assert_eq!(adjacency.first_non_manifold, Some((3, 5)));
}

#[test]
fn an_error_naming_vertex_k_means_the_kth_v_line() {
    let text = ORDER_OBJ.replace("v 0 1 0  # 2", "v 0 inf 0  # 2");
    let (_dir, path, mesh) = load_text(&text);
    let error = mesh.unwrap_err();
    assert!(
        matches!(
            error,
            Error::NonFinite {
                what: "vertex",
                index: 2,
                ..
            }
        ),
        "{error:?}"
    );
    // `v 0 inf 0` is on line 5 of the file.
    let message = error.to_string();
    assert!(
        message.starts_with(&format!("{}:5: vertex 2 is not finite", path.display())),
        "{message}"
    );
}

/// Files for the comparison with `tobj`: objects, groups and material runs, quads and
/// polygons, relative indices, `v//vn` corners, a weight, UV seams. (`tobj` rejects vertex
/// colours on only some vertices, and divides by the weight: both are ignored here.)
const ORACLE_FILES: [(&str, &str); 3] = [
    (
        "parts.obj",
        "\
mtllib parts.mtl
o first
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
g quad
usemtl red
f 1/1/1 2/2/1 3/3/1 4/4/1
v 2 0 0.5
v 2 1 0.5
vt 0.5 0
vt 0.5 1
vt 0.9 0
vt 0.9 1
g relative
usemtl blue
s 1
f -5/-4/-1 -2/-2/-1 -1/-1/-1 -4/-3/-1
o second
v 3 0 0 1.0
v 4 0 0
v 4.5 1 0
v 3.5 1.7 0.25
v 2.5 1 0
vt 0.1 0.1
vt 0.2 0.1
vt 0.25 0.2
vt 0.15 0.3
vt 0.05 0.2
vp 0.5 0.5
l 7 8
p 10
usemtl red
f 7/9 8/10 9/11 10/12 11/13
usemtl blue
f 11/13 9/11 2/7 1/1
",
    ),
    (
        "normals.obj",
        "\
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0.5 2 1
vn 0 0 1
vn 0 1 0
g a
f 1//1 2//1 3//2
g b
f -3//-1 -1//-2 -2//1
f 1 3 4
",
    ),
    (
        "streamed.obj",
        "\
v 0 0 0
v 1 0 0
v 0 1 0
vt 0 0
vt 1 0
vt 0 1
f -3/-3 -2/-2 -1/-1
v 1 1 0
v 0 1 0
vt 1 1
vt 0.5 1
g next
f -4/-4 -2/-2 -1/-1
v 2 2 0
v 3 2 0
v 3 3 0
v 2.5 3.5 0
v 2 3 0
v 1.5 2.5 0
vt 0 0
vt 1 0
vt 1 1
vt 0.5 1.5
vt 0 1
vt -0.5 0.5
o hexagon
f -6/-6 -5/-5 -4/-4 -3/-3 -2/-2 -1/-1
",
    ),
];

const ORACLE_MTL: &str = "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n";

/// One triangle as its three corner positions and, when the mesh has UVs, corner UVs.
type Triangle = ([[f64; 3]; 3], Option<[[f64; 2]; 3]>);

fn our_triangles(mesh: &reparam::mesh::TriMesh) -> Vec<Triangle> {
    (0..mesh.face_count())
        .map(|f| {
            let positions = mesh.face_positions(f).map(|p| [p.x, p.y, p.z]);
            let uvs = mesh.has_uvs().then(|| mesh.face_uvs(f).map(|t| [t.x, t.y]));
            (positions, uvs)
        })
        .collect()
}

/// The triangles `tobj` reads from `path` (models in file order), and the number of models.
fn tobj_triangles(path: &Path) -> (Vec<Triangle>, usize) {
    // `..Default::default()` covers the fields that optional tobj features add.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let text = fs::read_to_string(path).unwrap();
    let dir = path.parent().unwrap().to_path_buf();
    let load_mtl = |name: &Path| {
        let mtl =
            fs::read_to_string(dir.join(name)).map_err(|_| tobj::LoadError::OpenFileFailed)?;
        tobj::load_mtl_buf(&mut mtl.as_bytes())
    };
    let (models, materials) = tobj::load_obj_buf(&mut text.as_bytes(), &options, load_mtl).unwrap();
    materials.unwrap();
    let mut triangles = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let position = |i: u32| {
            let i = 3 * i as usize;
            [m.positions[i], m.positions[i + 1], m.positions[i + 2]]
        };
        let uv = |i: u32| [m.texcoords[2 * i as usize], m.texcoords[2 * i as usize + 1]];
        for t in 0..m.indices.len() / 3 {
            let corners = [3 * t, 3 * t + 1, 3 * t + 2];
            let uvs = (!m.texcoord_indices.is_empty())
                .then(|| corners.map(|c| uv(m.texcoord_indices[c])));
            triangles.push((corners.map(|c| position(m.indices[c])), uvs));
        }
    }
    (triangles, models.len())
}

#[test]
fn loader_agrees_with_tobj_on_the_triangles() {
    let dir = tempfile::tempdir().unwrap();
    write_file(dir.path(), "parts.mtl", ORACLE_MTL);
    for (name, text) in ORACLE_FILES {
        let path = write_file(dir.path(), name, text);
        let mesh = load_obj(&path).unwrap();
        let (expected, models) = tobj_triangles(&path);
        assert!(
            models >= 2,
            "{name}: the file should be split into parts by tobj"
        );
        assert_eq!(our_triangles(&mesh), expected, "{name}");
    }
}

#[test]
fn uv_seams_of_the_oracle_files_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_file(dir.path(), "parts.obj", ORACLE_FILES[0].1);
    let mesh = load_obj(&path).unwrap();
    assert_eq!((mesh.positions.len(), mesh.uvs.len()), (11, 13));
    assert_eq!(mesh.face_count(), 2 + 2 + 3 + 2);
    // Edge 2–3 (quad | relative face) and edge 1–2 (quad | last face) are UV seams.
    let adjacency = Adjacency::new(&mesh);
    assert_eq!((adjacency.seam_edges, adjacency.non_manifold_edges), (2, 0));
}
