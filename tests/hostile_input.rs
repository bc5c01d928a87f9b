//! Hostile input (issue #25): every malformed file found by fuzzing the command line gives a
//! typed, one-line error naming the file and the element (or a correct result) in linear time
//! and bounded memory, never a panic, a hang, an abort or a NaN.
//!
//! The time bounds below are generous (tens of times what the linear code takes in a debug build
//! on a loaded machine) and far below what the quadratic code they replace took at these sizes.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use nalgebra::{Point2, Point3, Vector3};
use reparam::bpm::{precompute, BpmOptions};
use reparam::gridwarp::rasterize::{frames_fields, Roi};
use reparam::input::{with_reference_policy, ReferencePolicy};
use reparam::mesh::{
    check_manifold, load_gltf, load_gltf_base_colour, load_mesh, load_obj, Adjacency, TriMesh,
};
use reparam::raster::{rasterize, Camera};
use reparam::texture::{load_gray_f32, save_exr_rg};
use reparam::Error;

/// Write `bytes` as `name` in `dir`.
fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    fs::write(&path, bytes).unwrap();
    path
}

/// The error's message, checked to be one line that names `path`.
fn one_line_naming(error: &Error, path: &Path) -> String {
    let shown = error.to_string();
    assert!(!shown.contains('\n'), "not one line: {shown:?}");
    assert!(
        shown.contains(&path.display().to_string()),
        "does not name {}: {shown}",
        path.display()
    );
    shown
}

/// A fixture of tests/fixtures/hostile.
fn hostile(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/hostile")
        .join(name)
}

/// Run `f`, asserting it takes less than `limit`.
fn within<T>(limit: Duration, what: &str, f: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let result = f();
    let took = start.elapsed();
    assert!(took < limit, "{what} took {took:?} (limit {limit:?})");
    result
}

// ---------------------------------------------------------------------------------------------
// Super-linear paths
// ---------------------------------------------------------------------------------------------

/// An OBJ with one triangle's three vertices and UVs and one face line of `corners` corners
/// cycling through them: its fan has `corners − 2` faces, about two thirds of them on each of
/// the three edges (one degenerate, non-manifold edge shared by tens of thousands of faces).
fn huge_polygon_obj(corners: usize) -> String {
    let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf");
    for k in 0..corners {
        let i = k % 3 + 1;
        write!(text, " {i}/{i}").unwrap();
    }
    text.push('\n');
    text
}

#[test]
fn a_polygon_of_many_corners_on_one_edge_is_handled_in_linear_time() {
    // Before: the faces sharing an edge were found by scanning from every record to both ends
    // of its run (quadratic in the run): 8 000 corners took 0.45 s in release, 40 000 over 10 s.
    let corners = 40_000;
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "polygon.obj", huge_polygon_obj(corners));
    let mesh = load_obj(&path).unwrap();
    assert_eq!(mesh.face_count(), corners - 2);
    let adjacency = within(Duration::from_secs(3), "adjacency", || {
        Adjacency::new(&mesh)
    });
    // The fan (1, 2, 3), (1, 3, 1), (1, 1, 2), … uses the edges 12, 23, 13 and 11, each in
    // thousands of faces.
    assert_eq!(adjacency.non_manifold_edges, 4);
    let bpm = within(Duration::from_secs(5), "BPM precompute", || {
        precompute(&mesh, BpmOptions::default()).unwrap()
    });
    // Every face but the first of each cycle repeats a vertex: linear fallback, counted.
    assert_eq!(bpm.report.non_manifold_edges, 4);
    assert!(bpm.report.degenerate_faces >= 2 * (corners - 2) / 3 - 1);
    // `maps` refuses it (a repeated vertex) at once.
    let error = within(Duration::from_secs(3), "manifold check", || {
        check_manifold(&mesh).unwrap_err()
    });
    assert!(matches!(error, Error::DegenerateFace { .. }), "{error}");
}

#[test]
fn a_vertex_in_every_face_of_a_huge_fan_is_checked_in_linear_time() {
    // A disk fanned from one boundary vertex: every edge is manifold, so the vertex check runs,
    // and vertex 0 is in all 150 000 faces. Before: each neighbour was looked up by a linear
    // scan of the vertex's faces (quadratic in its degree, about 10¹⁰ comparisons here).
    let n = 150_000;
    let positions = (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            Point3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    let faces = (1..n as u32 - 1).map(|k| [0, k, k + 1]).collect();
    let mesh = TriMesh::with_shared_indices("fan", positions, Vec::new(), faces);
    within(Duration::from_secs(5), "manifold check of the fan", || {
        check_manifold(&mesh).unwrap()
    });
}

#[test]
fn a_long_run_of_continued_lines_is_read_in_linear_time() {
    // 200 000 lines `1 \` continuing one face statement. Before: the statement was re-formatted
    // at every line (quadratic: about 10¹¹ bytes copied here).
    let lines = 200_000;
    let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 \\\n");
    for _ in 0..lines {
        text.push_str("1 \\\n");
    }
    text.push_str("2\n");
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "continued.obj", text);
    let mesh = within(Duration::from_secs(5), "loading", || {
        load_obj(&path).unwrap()
    });
    assert_eq!(mesh.face_count(), lines + 2);
}

#[test]
fn a_triangle_repeated_many_times_is_rasterised_once() {
    // 40 000 exact copies of one of a quad's two triangles: the copies can never win a pixel
    // (equal depth, higher face index), so the picture is the quad's. Before: each copy was
    // drawn over half the picture (the 200 000-corner polygon rendered in 15 s at 256²).
    let positions = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(1.0, 1.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
    ];
    let quad = vec![[0, 1, 2], [0, 2, 3]];
    let mut repeated = quad.clone();
    repeated.extend(std::iter::repeat_n([0, 1, 2], 40_000));
    let mesh = |faces| TriMesh::with_shared_indices("quad", positions.clone(), Vec::new(), faces);
    let (quad, repeated) = (mesh(quad), mesh(repeated));
    let camera = Camera::frame_mesh(&quad, Vector3::new(0.0, 0.0, 1.0), 1.0);
    let expected = rasterize(&quad, &camera.view_proj(), 256, 256);
    assert!(expected.covered_pixels() > 10_000);
    let drawn = within(Duration::from_secs(3), "rasterising", || {
        rasterize(&repeated, &camera.view_proj(), 256, 256)
    });
    assert!(drawn == expected, "the repeats changed the picture");
}

// ---------------------------------------------------------------------------------------------
// Declared counts that the file cannot hold
// ---------------------------------------------------------------------------------------------

#[test]
fn off_counts_beyond_the_file_are_errors_without_allocating_them() {
    let dir = tempfile::tempdir().unwrap();
    for (name, header) in [
        // 99 999 999 999 vertices in a 14-byte file: was reserved up front (an abort).
        ("huge.off", "99999999999 1\n"),
        // 2⁶³ vertices: was a "capacity overflow" panic.
        ("two63.off", "OFF\n9223372036854775808 1 0\n"),
        // Above u64: not a count.
        ("two64.off", "OFF\n18446744073709551616 1 0\n"),
        (
            "faces.off",
            "OFF\n3 9223372036854775807 0\n0 0 0\n1 0 0\n0 1 0\n",
        ),
    ] {
        let path = write(dir.path(), name, header);
        let error = within(Duration::from_secs(1), name, || {
            load_mesh(&path).unwrap_err()
        });
        assert!(matches!(error, Error::MeshParse { .. }), "{name}: {error}");
        one_line_naming(&error, &path);
    }
}

/// A PLY header of `format` with the `elements` lines, and `data` after it.
fn ply(format: &str, elements: &str, data: &[u8]) -> Vec<u8> {
    let mut bytes = format!("ply\nformat {format} 1.0\n{elements}end_header\n").into_bytes();
    bytes.extend_from_slice(data);
    bytes
}

#[test]
fn ply_headers_that_overflow_or_overstate_their_counts_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let vertex = "property float x\nproperty float y\nproperty float z\n";
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        // A count above u64: `ply-rs` unwrapped its parse (a panic).
        (
            "above_u64.ply",
            ply(
                "ascii",
                &format!("element vertex 99999999999999999999999\n{vertex}"),
                b"",
            ),
            "does not fit in 64 bits",
        ),
        // A version above u64: the same unwrap.
        (
            "version.ply",
            b"ply\nformat ascii 99999999999999999999999.0\nend_header\n".to_vec(),
            "version number",
        ),
        // No properties and 10¹² elements: read 10¹² empty elements from nothing (8 GB).
        (
            "no_properties.ply",
            ply(
                "binary_little_endian",
                "element vertex 1000000000000\n",
                b"",
            ),
            "needs at least",
        ),
        // 10¹² vertices declared, three given.
        (
            "declared.ply",
            ply(
                "ascii",
                &format!("element vertex 1000000000000\n{vertex}"),
                b"0 0 0\n1 0 0\n0 1 0\n",
            ),
            "needs at least",
        ),
        // An empty file: `ply-rs` printed three lines of debug dump.
        ("empty.ply", Vec::new(), "not a PLY file"),
        // A malformed property line: `ply-rs`'s message, its first line only.
        (
            "property.ply",
            ply("ascii", "element vertex 1\nproperty float\n", b"0\n"),
            "Line 4",
        ),
    ];
    for (name, bytes, expected) in cases {
        let path = write(dir.path(), name, bytes);
        let error = within(Duration::from_secs(1), name, || {
            load_mesh(&path).unwrap_err()
        });
        let shown = one_line_naming(&error, &path);
        assert!(shown.contains(expected), "{name}: {shown}");
        assert!(
            !shown.contains("ParseError"),
            "{name}: a debug dump: {shown}"
        );
    }
}

#[test]
fn a_valid_binary_ply_still_loads() {
    let mut data = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        for c in p {
            data.extend_from_slice(&c.to_le_bytes());
        }
    }
    data.push(3);
    for i in [0i32, 1, 2] {
        data.extend_from_slice(&i.to_le_bytes());
    }
    let bytes = ply(
        "binary_little_endian",
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\n",
        &data,
    );
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "tri.ply", bytes);
    let mesh = load_mesh(&path).unwrap();
    assert_eq!((mesh.positions.len(), mesh.faces.len()), (3, 1));
}

// ---------------------------------------------------------------------------------------------
// Material libraries that never end
// ---------------------------------------------------------------------------------------------

#[test]
fn a_material_library_that_is_a_device_is_refused_not_read() {
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "device.obj",
        "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    );
    // By default an absolute path is outside the model's folder (issue #35); allowed, the
    // device is still refused, not read.
    let error = within(Duration::from_secs(2), "loading", || {
        load_obj(&path).unwrap_err()
    });
    let shown = one_line_naming(&error, &path);
    assert!(
        shown.contains("mtllib \"/dev/zero\": an absolute path"),
        "{shown}"
    );
    let error = within(Duration::from_secs(2), "loading", || {
        with_reference_policy(ReferencePolicy::Anywhere, || load_obj(&path)).unwrap_err()
    });
    let shown = one_line_naming(&error, &path);
    assert!(
        shown.contains("mtllib \"/dev/zero\": a character device, not a regular file"),
        "{shown}"
    );
    // A missing library is still no texture, not an error.
    let path = write(
        dir.path(),
        "missing.obj",
        "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    assert!(load_obj(&path).unwrap().texture.is_none());
}

// ---------------------------------------------------------------------------------------------
// Gridwarp: a degenerate rest frame
// ---------------------------------------------------------------------------------------------

/// A 2×2-quad grid over UV [0, 1]², vertex 1 moved onto vertex 0 when `collapse` (the edge
/// along u of face 0 then has zero length: X_u = 0 there).
fn grid_mesh(collapse: bool) -> TriMesh {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            let (u, v) = (i as f64 / 2.0, j as f64 / 2.0);
            positions.push(Point3::new(u, v, 0.0));
            uvs.push(Point2::new(u, v));
        }
    }
    if collapse {
        positions[1] = positions[0];
    }
    let id = |i: u32, j: u32| j * 3 + i;
    let mut faces = Vec::new();
    for j in 0..2 {
        for i in 0..2 {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    TriMesh::with_shared_indices("rest.obj", positions, uvs, faces)
}

#[test]
fn coincident_rest_vertices_are_an_error_naming_the_face_not_a_nan() {
    // Before: O_s = 0 under the collapsed face, and the rigid-stretch mean and max were NaN
    // (`null` in --json) with exit 0.
    let roi = Roi::new(0.0, 1.0, 0.0, 1.0).unwrap();
    let fine = frames_fields(&grid_mesh(false), &[grid_mesh(false)], &roi, (8, 8)).unwrap();
    assert!(fine.o_s.values.iter().all(|v| v.is_finite() && *v > 0.0));
    let rest = grid_mesh(true);
    let error = frames_fields(&rest, &[grid_mesh(false)], &roi, (8, 8)).unwrap_err();
    let shown = error.to_string();
    assert!(!shown.contains('\n'), "{shown}");
    assert!(
        matches!(error, Error::DegenerateFace { ref mesh, .. } if mesh == "rest.obj"),
        "{shown}"
    );
    assert!(shown.contains("rest frame"), "{shown}");
}

// ---------------------------------------------------------------------------------------------
// Images whose header declares more pixels than anyone should allocate
// ---------------------------------------------------------------------------------------------

#[test]
fn a_png_declaring_100000_by_100000_pixels_is_refused_from_its_header() {
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&100_000u32.to_be_bytes());
    ihdr.extend_from_slice(&100_000u32.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    // A few bytes of (empty-block) zlib data: the header is all there is to this image.
    for (kind, data) in [
        (b"IHDR", ihdr.as_slice()),
        (b"IDAT", &[0x78, 0x01, 0x01, 0x00, 0x00, 0xff, 0xff][..]),
        (b"IEND", &[][..]),
    ] {
        png.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let chunk = [&kind[..], data].concat();
        png.extend_from_slice(&chunk);
        png.extend_from_slice(&crc32fast::hash(&chunk).to_be_bytes());
    }
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "huge.png", png);
    let error = within(Duration::from_secs(1), "decoding", || {
        load_gray_f32(&path).unwrap_err()
    });
    let shown = one_line_naming(&error, &path);
    assert!(shown.contains("100000x100000"), "{shown}");
    assert!(shown.contains("REPARAM_MAX_IMAGE_PIXELS"), "{shown}");
}

/// Found by the parser fuzzer once PNG checksums were repaired after mutation: a 54-byte PNG
/// declaring 8 388 616 × 8 RGBA16 pixels (under the pixel limit) made the decoder reserve
/// 256 MiB before it ran out of data. Refused from the header: no deflate stream expands past
/// 1032:1 (`MAX_EXPANSION` 2048 with 1 MiB of slack). A real, highly compressible image (a
/// constant 2048² grey map, 16 MiB of RGBA samples in ~86 KB) still loads.
#[test]
fn a_png_declaring_more_than_its_bytes_can_hold_is_refused() {
    let fixture = hostile("png_54_bytes_declaring_256_mib.png");
    let error = within(Duration::from_secs(1), "decoding", || {
        load_gray_f32(&fixture).unwrap_err()
    });
    let shown = one_line_naming(&error, &fixture);
    assert!(
        shown.contains("8388616x8") && shown.contains("54-byte file"),
        "{shown}"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flat.png");
    let n = 2048;
    let image = reparam::texture::Image {
        width: n,
        height: n,
        pixels: vec![[128, 128, 128, 255]; n * n],
    };
    reparam::texture::save_png(&image, &path).unwrap();
    let bytes = std::fs::metadata(&path).unwrap().len();
    // 16 MiB of RGBA samples in ~86 KB (the encoder's default level, ~200:1).
    assert!(bytes < 256 << 10, "{bytes}");
    let loaded = load_gray_f32(&path).unwrap();
    assert_eq!((loaded.width, loaded.height), (n, n));
}

#[test]
fn an_exr_data_window_with_ymin_above_ymax_is_refused_before_allocation() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("window.exr");
    save_exr_rg(&path, 4, 4, &[[0.5, 0.5]; 16]).unwrap();
    assert_eq!(load_gray_f32(&path).unwrap().width, 4);
    // dataWindow (box2i): xmin ymin xmax ymax. ymin = 10⁹ above ymax = 3: the crate swaps them
    // into a window of 10⁹ rows and reserved it (8 GB and more) before failing.
    let mut bytes = fs::read(&path).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes
        .windows(key.len())
        .position(|w| w == key)
        .expect("a dataWindow attribute")
        + key.len()
        + 4;
    bytes[at + 4..at + 8].copy_from_slice(&1_000_000_000i32.to_le_bytes());
    fs::write(&path, &bytes).unwrap();
    let error = within(Duration::from_secs(1), "decoding", || {
        load_gray_f32(&path).unwrap_err()
    });
    let shown = one_line_naming(&error, &path);
    assert!(shown.contains("data window"), "{shown}");
}

#[test]
fn an_exr_that_makes_the_exr_crate_assert_is_an_error_naming_the_file() {
    // Found by tests/fuzz_parsers.rs: exr 1.74 panics ("line should have been filtered") on
    // this mutated 8x8 EXR instead of returning an error; contained at the loader boundary.
    let path = hostile("exr_line_not_filtered.exr");
    let error = load_gray_f32(&path).unwrap_err();
    let shown = one_line_naming(&error, &path);
    assert!(shown.contains("malformed block data"), "{shown}");
}

/// Found by the long run of tests/fuzz_parsers.rs (case 851 928 of 1 000 000): an 806-byte
/// EXR whose header declares a data window within the pixel limit but far beyond what the file
/// can hold at any compression; the exr crate reserved the whole image (257 MiB peak heap,
/// against the harness's 67 MiB for that size) before failing. Refused from the header.
#[test]
fn an_exr_declaring_more_samples_than_its_bytes_can_hold_is_refused() {
    let path = hostile("exr_window_beyond_the_file.exr");
    let error = within(Duration::from_secs(1), "decoding", || {
        load_gray_f32(&path).unwrap_err()
    });
    let shown = one_line_naming(&error, &path);
    assert!(
        shown.contains("more than a 806-byte file can hold"),
        "{shown}"
    );
    // A real EXR of the same kind still loads.
    let dir = tempfile::tempdir().unwrap();
    let ok = dir.path().join("ok.exr");
    save_exr_rg(&ok, 64, 64, &[[0.25, 0.5]; 64 * 64]).unwrap();
    assert_eq!(load_gray_f32(&ok).unwrap().width, 64);
}

/// skinsimp's surface distances (a GLB with one vertex flipped to x = 2·10¹⁰ took 6 s instead
/// of 0.9 s): the uniform grid sized by the bounding box put every other triangle in one cell,
/// so each query measured every triangle. The tree's queries measure a few dozen triangles
/// whatever the coordinates, and still find the exact minimum.
#[test]
fn one_huge_coordinate_does_not_make_surface_distances_quadratic() {
    use reparam::mesh::distance::{point_triangle_distance, SurfaceTree};
    use reparam::skinsimp::distance::surface_error;
    let mut mesh = reparam::mesh::procedural::wavy_grid(100);
    let faces = mesh.faces.len();
    let queries: Vec<Point3<f64>> = mesh
        .faces
        .iter()
        .step_by(7)
        .map(|f| {
            let [a, b, c] = f.map(|v| mesh.positions[v as usize].coords);
            Point3::from((a + 2.0 * b + 3.0 * c) / 6.0 + Vector3::new(0.0, 0.0, 0.01))
        })
        .collect();
    let work = |mesh: &TriMesh| {
        let tree = SurfaceTree::new(&mesh.positions, &mesh.faces);
        let (mut most, mut total) = (0, 0);
        for (n, p) in queries.iter().enumerate() {
            let (d, w) = tree.distance_and_work(p);
            (most, total) = (w.max(most), total + w);
            if n % 97 == 0 {
                let brute = mesh
                    .faces
                    .iter()
                    .map(|f| {
                        let [a, b, c] = f.map(|v| mesh.positions[v as usize]);
                        point_triangle_distance(p, &a, &b, &c)
                    })
                    .fold(f64::INFINITY, f64::min);
                assert_eq!(d, brute, "{p}");
            }
        }
        (most, total as f64 / queries.len() as f64)
    };
    let (most, mean) = work(&mesh);
    mesh.positions[5050].x = 2e10;
    let (most_huge, mean_huge) = work(&mesh);
    // Measured: 28 and 77 at most; the grid measured all 20 000 triangles per query with the
    // huge coordinate.
    assert!(
        most <= 200 && most_huge <= 200,
        "{most} {most_huge} of {faces}"
    );
    assert!(mean_huge <= 2.0 * mean + 8.0, "{mean} → {mean_huge}");
    println!("triangles per query: at most {most} → {most_huge}, mean {mean:.1} → {mean_huge:.1}");
    let start = Instant::now();
    let e = surface_error(&mesh.positions, &mesh.faces, &mesh.positions, &mesh.faces);
    // A surface against itself: 0 up to rounding, which on the slivers 2·10¹⁰ long (closest
    // points from products of order 10⁴⁰) reaches 3.3·10⁻³ (measured).
    assert!(e.rms < 1e-2 && e.hausdorff < 1e-2, "{e:?}");
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );
}

// ---------------------------------------------------------------------------------------------
// Found by fuzzing the commands in-process (tests/fuzz_commands.rs)
// ---------------------------------------------------------------------------------------------

/// `reparam vectors bpm` into a fresh folder, in-process.
fn bpm_vectors(dir: &Path) -> PathBuf {
    let out = dir.join("vectors");
    let (result, _) = reparam::cli::run_captured([
        "reparam",
        "vectors",
        "bpm",
        "--out",
        &out.display().to_string(),
    ]);
    result.unwrap();
    out
}

/// A candidate with a NaN and a 1e308 (errors whose squares overflow): `verify --json` reports
/// it as failing with finite figures (the NaN's worst-element error is `null`, counted in
/// `non_finite`), where it printed `null` for the RMS and the error (NaN written by serde_json).
#[test]
fn verify_reports_nan_and_huge_candidate_values_with_finite_figures() {
    use reparam::vectors::npy::Array;
    let dir = tempfile::tempdir().unwrap();
    let vectors = bpm_vectors(dir.path());
    let expected = Array::load(&vectors.join("bpm_eval.expected.npy")).unwrap();
    let mut values = expected.to_f64();
    values[0] = f64::NAN;
    values[3] = 1e308;
    let candidate = dir.path().join("bpm_eval.npy");
    Array::f64(&expected.shape, values)
        .save(&candidate)
        .unwrap();
    let (result, stdout) = reparam::cli::run_captured([
        "reparam",
        "verify",
        &vectors.display().to_string(),
        "--candidate",
        &candidate.display().to_string(),
        "--json",
    ]);
    assert_eq!(result.unwrap(), std::process::ExitCode::from(1));
    let report: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    assert_eq!(report["pass"], false);
    assert_eq!(report["errors"]["non_finite"], 1);
    assert!(report["errors"]["rms"].as_f64().unwrap() > 1e300);
    assert_eq!(report["worst"][0]["error"], serde_json::Value::Null);
    assert!(report["worst"][1]["error"].as_f64().unwrap() > 1e307);
}

/// npyz quotes a bad header over several lines; the error is one line naming the file.
#[test]
fn a_npy_with_a_broken_header_is_a_one_line_error() {
    use reparam::vectors::npy::Array;
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "bad.npy",
        b"\x93NUMPY\x01\x00\x76\x00{'descr': '<f8', 'fortran_order': False, 'shape': (2, ), } } }                                         \n\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0",
    );
    let e = Array::load(&path).unwrap_err();
    let shown = one_line_naming(&e, &path);
    assert!(shown.contains("not a .npy file"), "{shown}");
}

/// stdout closed by its reader (`reparam … | head`): the command ends quietly (status 0, no
/// panic message) instead of panicking in `println!` ("failed printing to stdout: Broken
/// pipe").
#[test]
fn a_closed_stdout_ends_the_command_quietly() {
    use std::process::{Command, Stdio};
    for args in [
        &["bpm", "qc", "procedural:star", "--subdiv", "1"][..],
        &["bpm", "qc", "procedural:star", "--subdiv", "1", "--json"][..],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_reparam"))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Close the reading end before the command writes anything.
        drop(child.stdout.take());
        let output = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(
            output.status.success(),
            "{args:?}: {:?} {stderr}",
            output.status
        );
    }
}

/// `bpm qc --subdiv 8` keeps 65 536 records per face: 800 faces would be 52 M records (1.2 GB);
/// refused before anything is allocated, naming the figure, the limit and how to raise it.
#[test]
fn bpm_qc_subdivision_beyond_the_memory_limit_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grid.obj");
    reparam::mesh::write_obj(&reparam::mesh::procedural::wavy_grid(20), &path).unwrap();
    let path_text = path.display().to_string();
    let (result, _) = within(Duration::from_secs(10), "bpm qc --subdiv 8", || {
        reparam::cli::run_captured(["reparam", "bpm", "qc", &path_text, "--subdiv", "8"])
    });
    let e = result.unwrap_err();
    assert!(matches!(
        e,
        Error::TooManySubTriangles {
            faces: 800,
            subdiv: 8,
            needed: 52_428_800,
            limit: 33_554_432,
            ..
        }
    ));
    let shown = one_line_naming(&e, &path);
    assert!(shown.contains("REPARAM_MAX_QC_SUB_TRIANGLES"), "{shown}");
    // The variable sets the limit (here lower than 800 · 4).
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
        .args(["bpm", "qc", &path_text, "--subdiv", "1"])
        .env("REPARAM_MAX_QC_SUB_TRIANGLES", "3000")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("3200 sub-triangles, more than the limit of 3000"),
        "{stderr}"
    );
}

/// A UV of 4 294 967 295 on the star: the f32 kernel's errors are NaN or ∞ and the row fails,
/// with `worst_ratio` = f64::MAX in `--json` (it was ∞, written as `null`).
#[test]
fn crosscheck_of_a_huge_uv_fails_with_finite_figures() {
    // Rounding for the report kept f64::MAX in range (it rounded up to 1.8e308 = ∞).
    assert_eq!(
        reparam::crosscheck::round_significant(f64::MAX, 2),
        f64::MAX
    );
    if reparam_gpu::gpu_or_skip().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from(
        "v 0 0 0\nv 1.28 0.163 0\nv 0.682 0.813 0\nv -0.448 1.004 0\nv -0.822 -0.197 0\n\
         v -0.364 -0.769 0\nv 0.249 -0.938 0\n\
         vt 0.5 0.5\nvt 1.1 0.47\nvt 0.93 0.63\nvt 4294967295 0.72\nvt 0.1 0.5\nvt 0.22 0.36\n\
         vt 0.47 0.3\n",
    );
    for k in 2..=7 {
        let next = if k == 7 { 2 } else { k + 1 };
        writeln!(text, "f 1/1 {k}/{k} {next}/{next}").unwrap();
    }
    let path = write(dir.path(), "star.obj", text);
    let (result, stdout) = reparam::cli::run_captured([
        "reparam",
        "crosscheck",
        "bpm",
        "--mesh",
        &path.display().to_string(),
        "--plots",
        &dir.path().display().to_string(),
        "--json",
    ]);
    assert_eq!(result.unwrap(), std::process::ExitCode::from(1));
    let report: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    let rows = report["adapters"][0]["rows"].as_array().unwrap();
    assert!(
        rows.iter()
            .any(|r| r["worst_ratio"].as_f64() == Some(f64::MAX)),
        "{rows:?}"
    );
}

/// The wavy grid with one vertex thrown to z = 1e308 (areas overflow: the input area spread
/// was ∞, written as `null`) or to y = 9.2·10¹⁸ (an edge of the smoothed remesh off the
/// creases with one face: `unreachable!` panicked) or y = −1e308 (its dot in the picture at
/// pixel i64::MAX + 1 overflowed): `maps --json` gives finite figures.
#[test]
fn maps_of_a_grid_with_one_vertex_thrown_far_is_finite_and_does_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    for (vertex, axis, value) in [
        (12usize, 2usize, 1e308),
        (22, 1, 9223372036854775807.0),
        (24, 1, -1e308),
    ] {
        let mut mesh = reparam::mesh::procedural::wavy_grid(4);
        mesh.positions[vertex][axis] = value;
        let path = dir.path().join(format!("far{vertex}.obj"));
        reparam::mesh::write_obj(&mesh, &path).unwrap();
        let (result, stdout) = reparam::cli::run_captured([
            "reparam",
            "maps",
            &path.display().to_string(),
            "--picture-size",
            "16",
            "--out",
            &dir.path().display().to_string(),
            "--json",
        ]);
        match result {
            Ok(_) => {
                let summary: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
                assert!(
                    summary["distortion"]["input_area_spread"].is_f64(),
                    "{summary}"
                );
            }
            Err(e) => {
                assert!(!matches!(e, Error::NonFiniteOutput { .. }), "{e}");
                one_line_naming(&e, &path);
            }
        }
    }
}

/// Found by the command fuzzer: `crosscheck maps` on the wavy grid with one coordinate thrown
/// to 1e23 wrote an infinite tolerance (the f32 kernels' products overflow): now refused,
/// naming the vertex. With one vertex at y = 4 294 967 295 instead (the fixture), the other
/// vertices are 1e-10 of the diagonal apart, so the kernels' squares underflow: the area and
/// angle bounds now carry underflow terms, rings with a vertex on the centre after rounding to
/// f32 are not compared, and the kernel's atan2(0, 0) is 0 (it was NaN): exit 0, finite.
#[test]
fn crosscheck_maps_refuses_f32_overflow_and_bounds_underflow() {
    let mut mesh = reparam::mesh::procedural::wavy_grid(4);
    mesh.positions[18].x = 1e23;
    let e = reparam::crosscheck::check_f32_range("far.obj", &mesh.positions).unwrap_err();
    assert!(matches!(e, Error::OutOfF32Range { vertex: 18, .. }), "{e}");
    let shown = e.to_string();
    assert!(
        shown.starts_with("far.obj: vertex 18 has a coordinate of 1e23") && !shown.contains('\n'),
        "{shown}"
    );
    // At the limit itself: accepted.
    mesh.positions[18].x = reparam::crosscheck::F32_COORDINATE_MAX;
    assert!(reparam::crosscheck::check_f32_range("far.obj", &mesh.positions).is_ok());
    if reparam_gpu::gpu_or_skip().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    mesh.positions[18].x = 1e23;
    let far = dir.path().join("far.obj");
    reparam::mesh::write_obj(&mesh, &far).unwrap();
    let plots = dir.path().display().to_string();
    let run = |path: &Path| {
        reparam::cli::run_captured([
            "reparam",
            "crosscheck",
            "maps",
            &path.display().to_string(),
            "--plots",
            &plots,
            "--json",
        ])
    };
    let (result, _) = run(&far);
    let e = result.unwrap_err();
    assert!(matches!(e, Error::OutOfF32Range { vertex: 18, .. }), "{e}");
    one_line_naming(&e, &far);
    let fixture = hostile("maps_vertex_at_4e9.obj");
    let (result, stdout) = run(&fixture);
    assert_eq!(result.unwrap(), std::process::ExitCode::SUCCESS);
    let report: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    for row in report["adapters"][0]["rows"].as_array().unwrap() {
        assert_eq!(row["verdict"], "pass", "{row}");
        assert!(row["errors"]["tolerance"].is_f64(), "{row}");
    }
}

/// Found by the command fuzzer: a skinned tube whose animation (a mutated GLB) throws a vertex
/// to 2.7e18 in the rest pose's unit box made `crosscheck skinsimp` compare overflowed f32
/// quadrics (∞ against 1e31, exit 1): the posed positions are now held to ±2¹⁶ of the unit box
/// (`skinsimp::gpu::POSED_COORDINATE_MAX`), a typed error naming the vertex and the pose.
#[test]
fn crosscheck_skinsimp_refuses_poses_beyond_f32() {
    if reparam_gpu::gpu_or_skip().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str| {
        let fixture = hostile(name);
        let (result, stdout) = reparam::cli::run_captured([
            "reparam",
            "crosscheck",
            "skinsimp",
            &fixture.display().to_string(),
            "--poses",
            "2",
            "--plots",
            &dir.path().display().to_string(),
            "--json",
        ]);
        (fixture, result, stdout)
    };
    let (fixture, result, _) = run("skinsimp_pose_beyond_f32.glb");
    let e = result.unwrap_err();
    assert!(matches!(e, Error::OutOfF32Range { vertex: 2, .. }), "{e}");
    let shown = one_line_naming(&e, &fixture);
    assert!(
        shown.contains("training pose 0 (skinned): vertex 2"),
        "{shown}"
    );
    // A vertex at 2.2e7 of the unit box: within the meshes' ±2⁴⁸ but the quadrics (quartic) and
    // costs (sextic) overflow f32 there: refused at skinsimp's own ±2¹⁶.
    let (fixture, result, _) = run("skinsimp_pose_at_2e7.glb");
    let e = result.unwrap_err();
    assert!(
        matches!(e, Error::OutOfF32Range { limit, .. } if limit == 65536.0),
        "{e}"
    );
    one_line_naming(&e, &fixture);
    // A joint matrix entry of 4.5e-44 (subnormal in f32): the skinning bound carries f32's
    // flush of subnormals (2⁻¹²⁶ per operation); without it the row failed on an error of
    // 1.1e-46 against a bound of 1.2e-51.
    let (_, result, stdout) = run("skinsimp_subnormal_joint_entry.glb");
    result.unwrap();
    let report: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    let lbs = &report["adapters"][0]["rows"][0];
    assert_eq!(lbs["kernel"], "skinsimp_lbs: posed positions");
    assert_eq!(lbs["verdict"], "pass", "{lbs}");
    // Joint matrices with large entries give collapse quadrics with B entries near 1e10: the
    // kernel's cofactors (≈ 1e20) squared overflowed f32 in ‖B⁻¹‖_F, so it took cond = ∞,
    // refused well-conditioned solutions (cond 36 in f64) and kept an endpoint whose value
    // was 1.8e8 above the reference's: the near-tie row failed at 2590× its bound. The kernel
    // now scales B and b by 2^−e (exact) before the solve: every row passes.
    let (_, result, stdout) = run("skinsimp_cofactors_overflow_f32.glb");
    assert_eq!(result.unwrap(), std::process::ExitCode::SUCCESS);
    let report: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    for row in report["adapters"][0]["rows"].as_array().unwrap() {
        assert_eq!(row["verdict"], "pass", "{row}");
    }
}

/// A .npy header whose shape multiplies past u64 (132 × 2⁶³ − 1) made npyz overflow (a panic in
/// debug builds); a shape larger than the file is refused before npyz reads it.
#[test]
fn a_npy_shape_that_overflows_or_exceeds_the_file_is_refused() {
    use reparam::vectors::npy::Array;
    let dir = tempfile::tempdir().unwrap();
    for shape in ["(132, 9223372036854775807, )", "(1000000, 2)"] {
        let dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
        let mut header = format!("{dict:<118}\n").into_bytes();
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
        bytes.append(&mut header);
        bytes.extend_from_slice(&[0u8; 64]);
        let path = write(dir.path(), "shape.npy", &bytes);
        let e = Array::load(&path).unwrap_err();
        let shown = one_line_naming(&e, &path);
        assert!(shown.contains("declares more elements"), "{shown}");
    }
}

/// Found by the remesh fuzzer (`fuzz_maps_remesh`): a wavy grid with one z of 1e307 built its
/// hierarchy, but its remesh's distance figures overflowed to a NaN Hausdorff distance (the
/// command then refused to write the NaN, a failure without a cause). A mesh with a coordinate
/// beyond ±2²⁰⁰ (`maps::quality::DISTANCE_COORDINATE_MAX`) is now refused when a remesh is
/// asked for, naming the vertex and the file; the hierarchy alone still runs; and a mesh whose
/// largest coordinate is the limit itself gets finite figures.
#[test]
fn maps_remesh_refuses_coordinates_whose_distance_figures_overflow() {
    use reparam::maps::quality::DISTANCE_COORDINATE_MAX;
    assert_eq!(DISTANCE_COORDINATE_MAX, 2f64.powi(200));
    let fixture = hostile("maps_remesh_z_at_1e307.obj");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().display().to_string();
    let run = |path: &Path, remesh: bool| {
        let path = path.display().to_string();
        let mut args = vec![
            "reparam",
            "maps",
            &path,
            "--picture-size",
            "0",
            "--out",
            &out,
        ];
        if remesh {
            args.extend(["--remesh", "uniform:1", "--relax", "2", "--json"]);
        }
        reparam::cli::run_captured(args)
    };
    let (result, _) = run(&fixture, true);
    let e = result.unwrap_err();
    assert!(
        matches!(e, Error::OutOfDistanceRange { vertex: 22, .. }),
        "{e}"
    );
    let shown = one_line_naming(&e, &fixture);
    assert!(
        shown.contains("vertex 22 has a coordinate of 1e307"),
        "{shown}"
    );
    let (result, _) = run(&fixture, false);
    assert_eq!(result.unwrap(), std::process::ExitCode::SUCCESS);
    // At the limit: a torus scaled so that its largest coordinate is 2²⁰⁰ (a power of two
    // times the torus's, so every coordinate stays ≤ the limit): every figure is finite.
    let mut torus = reparam::mesh::procedural::torus(12, 6, 1.0, 0.35);
    let largest = torus
        .positions
        .iter()
        .flat_map(|p| p.iter().map(|x| x.abs()))
        .fold(0.0, f64::max);
    let scale = DISTANCE_COORDINATE_MAX / 2f64.powi(largest.log2().ceil() as i32);
    for p in &mut torus.positions {
        *p = Point3::from(p.coords * scale);
    }
    let at_limit = dir.path().join("at_limit.obj");
    reparam::mesh::write_obj(&torus, &at_limit).unwrap();
    let (result, stdout) = run(&at_limit, true);
    assert_eq!(result.unwrap(), std::process::ExitCode::SUCCESS);
    let json: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    for r in json["remeshes"].as_array().unwrap() {
        for key in [
            "hausdorff_relative",
            "mean_distance_relative",
            "area_spread",
        ] {
            assert!(r[key].as_f64().is_some_and(f64::is_finite), "{key}: {r}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Integer limits, files that never end, references outside the model (issue #35)
// ---------------------------------------------------------------------------------------------

/// Run the `reparam` binary: its exit status and standard error.
fn reparam_binary(args: &[&str]) -> (Option<i32>, String) {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
        .args(args)
        .env("REPARAM_NO_PROGRESS", "1")
        .output()
        .unwrap();
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// Stderr holding exactly one line, `error: …`, that names `model`.
fn one_error_line(stderr: &str, model: &Path) -> String {
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "not one line: {stderr:?}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert!(lines[0].contains(&model.display().to_string()), "{stderr}");
    lines[0].to_string()
}

#[test]
fn issue_35_an_off_corner_count_of_2_pow_64_minus_1_is_a_one_line_error_with_status_2() {
    // Was `Vec::with_capacity(corners)` in `load_off`: a `capacity overflow` panic, exit 101.
    let path = hostile("off_corner_count_2e64.off");
    let error = within(Duration::from_secs(1), "loading", || {
        load_mesh(&path).unwrap_err()
    });
    assert!(matches!(error, Error::MeshParse { .. }), "{error}");
    let shown = one_line_naming(&error, &path);
    assert!(
        shown.contains("line 7: the corner count 18446744073709551615 needs at least"),
        "{shown}"
    );
    let out = tempfile::tempdir().unwrap();
    let out_dir = out.path().display().to_string();
    let args = [
        "maps",
        path.to_str().unwrap(),
        "--out",
        &out_dir,
        "--picture-size",
        "16",
    ];
    let (status, stderr) = within(Duration::from_secs(2), "reparam maps", || {
        reparam_binary(&args)
    });
    assert_eq!(status, Some(2), "{stderr}");
    let line = one_error_line(&stderr, &path);
    assert!(line.contains("corner count 18446744073709551615"), "{line}");
}

#[test]
fn every_integer_limit_as_an_off_count_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let limits = [
        "2147483647",
        "4294967296",
        "9223372036854775807",
        "18446744073709551615",
        "18446744073709551616",
        "-1",
        "1e308",
        "NaN",
    ];
    for (k, limit) in limits.iter().enumerate() {
        let square = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
        for (what, text) in [
            ("corners", format!("OFF\n4 1 0\n{square}{limit} 0 1 2 3\n")),
            ("vertices", format!("OFF\n{limit} 1 0\n{square}4 0 1 2 3\n")),
            ("faces", format!("OFF\n4 {limit} 0\n{square}4 0 1 2 3\n")),
        ] {
            let path = write(dir.path(), &format!("{what}{k}.off"), text);
            let error = within(Duration::from_secs(1), &format!("{what} {limit}"), || {
                load_mesh(&path).unwrap_err()
            });
            assert!(
                matches!(error, Error::MeshParse { .. }),
                "{what} {limit}: {error}"
            );
            one_line_naming(&error, &path);
        }
    }
}

/// The skinned tube as a `.gltf` document and its binary buffer, for a buffer URI of one's
/// choice.
fn tube_gltf() -> (serde_json::Value, Vec<u8>) {
    let glb =
        reparam::skinsimp::glb::glb_bytes(&reparam::skinsimp::tube::skinned_tube(6, 2)).unwrap();
    let chunk = |at: usize| {
        let length = u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
        glb[at + 8..at + 8 + length].to_vec()
    };
    let json = chunk(12);
    let bin = chunk(12 + 8 + json.len());
    (serde_json::from_slice(&json).unwrap(), bin)
}

/// The tube's glTF written as `model/tube.gltf` under `root`, its buffer URI set to `uri`.
fn tube_with_buffer_uri(root: &Path, uri: &str) -> PathBuf {
    let (mut document, _) = tube_gltf();
    document["buffers"][0]["uri"] = uri.into();
    fs::create_dir_all(root.join("model")).unwrap();
    write(&root.join("model"), "tube.gltf", document.to_string())
}

/// The message of a refused reference, checked to be an [`Error::Reference`] on one line that
/// names the model.
fn refused(result: reparam::Result<impl std::fmt::Debug>, model: &Path) -> String {
    let error = result.unwrap_err();
    assert!(matches!(error, Error::Reference { .. }), "{error}");
    one_line_naming(&error, model)
}

#[test]
fn issue_35_a_gltf_buffer_on_dev_urandom_is_a_one_line_error_with_status_2() {
    // Was read until the kernel killed the process (128 s, memory exhausted).
    if !Path::new("/dev/urandom").exists() {
        return;
    }
    let path = hostile("gltf_buffer_dev_urandom.gltf");
    let shown = within(Duration::from_secs(1), "loading", || {
        refused(load_gltf(&path), &path)
    });
    assert!(
        shown.contains(
            "buffer 0 URI \"/dev/urandom\": an absolute path, outside the model's folder"
        ),
        "{shown}"
    );
    let shown = within(Duration::from_secs(1), "loading, allowed", || {
        refused(
            with_reference_policy(ReferencePolicy::Anywhere, || load_gltf(&path)),
            &path,
        )
    });
    assert!(
        shown.contains("buffer 0 URI \"/dev/urandom\": a character device, not a regular file"),
        "{shown}"
    );
    let out = tempfile::tempdir().unwrap();
    let glb = out.path().join("s.glb").display().to_string();
    for (flag, reason) in [
        (None, "an absolute path"),
        (Some("--allow-outside-references"), "a character device"),
    ] {
        let mut args = vec![
            "skinsimp",
            path.to_str().unwrap(),
            "--target-ratio",
            "0.5",
            "-o",
            &glb,
        ];
        args.extend(flag);
        let (status, stderr) = within(Duration::from_secs(2), "reparam skinsimp", || {
            reparam_binary(&args)
        });
        assert_eq!(status, Some(2), "{stderr}");
        let line = one_error_line(&stderr, &path);
        assert!(line.contains(reason), "{line}");
    }
}

#[cfg(unix)]
#[test]
fn a_buffer_that_is_a_fifo_a_directory_or_shorter_than_declared_is_refused() {
    let root = tempfile::tempdir().unwrap();
    let folder = root.path().join("model");
    fs::create_dir_all(folder.join("a directory")).unwrap();
    let fifo = std::ffi::CString::new(folder.join("pipe.bin").to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0);
    let (_, bin) = tube_gltf();
    fs::write(folder.join("short.bin"), &bin[..bin.len() / 2]).unwrap();
    // A FIFO without a writer would block the open; a directory is no data.
    for (uri, reason) in [
        ("pipe.bin", "a FIFO (named pipe), not a regular file"),
        ("a%20directory", "a directory, not a regular file"),
        (
            "short.bin",
            &format!("the file has {} bytes, the model declares", bin.len() / 2),
        ),
    ] {
        let path = tube_with_buffer_uri(root.path(), uri);
        let shown = within(Duration::from_secs(2), uri, || {
            refused(load_gltf(&path), &path)
        });
        assert!(shown.contains(reason), "{uri}: {shown}");
    }
    // A longer file: the declared bytes are read, the rest is not.
    let mut longer = bin.clone();
    longer.extend_from_slice(&[0; 4096]);
    fs::write(folder.join("longer.bin"), &longer).unwrap();
    load_gltf(&tube_with_buffer_uri(root.path(), "longer.bin")).unwrap();
}

#[cfg(unix)]
#[test]
fn references_outside_the_model_folder_are_refused_by_default_and_followed_when_allowed() {
    let root = tempfile::tempdir().unwrap();
    let (_, bin) = tube_gltf();
    fs::write(root.path().join("outside.bin"), &bin).unwrap();
    fs::create_dir_all(root.path().join("model/sub")).unwrap();
    fs::write(root.path().join("model/sub/inside.bin"), &bin).unwrap();
    std::os::unix::fs::symlink(
        root.path().join("outside.bin"),
        root.path().join("model/link.bin"),
    )
    .unwrap();
    let absolute = root.path().join("outside.bin").display().to_string();
    let file_uri = format!("file://{absolute}");
    // Inside the folder, `..` that stays inside included: read under both policies.
    for uri in ["sub/inside.bin", "sub/../sub/inside.bin"] {
        let path = tube_with_buffer_uri(root.path(), uri);
        load_gltf(&path).unwrap();
    }
    for (uri, why) in [
        ("../outside.bin", "`..` leads above the model's folder"),
        (
            "sub/../../outside.bin",
            "`..` leads above the model's folder",
        ),
        (absolute.as_str(), "an absolute path"),
        (file_uri.as_str(), "an absolute path"),
        ("link.bin", "a symbolic link to"),
    ] {
        let path = tube_with_buffer_uri(root.path(), uri);
        let shown = refused(load_gltf(&path), &path);
        assert!(shown.contains(why), "{uri}: {shown}");
        assert!(shown.contains("--allow-outside-references"), "{shown}");
        with_reference_policy(ReferencePolicy::Anywhere, || load_gltf(&path)).unwrap();
        // The policy is restored after the scope.
        refused(load_gltf(&path), &path);
    }

    // OBJ: `mtllib` and the texture its `map_Kd` names.
    let obj = "mtllib {lib}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    write(
        root.path(),
        "outside.mtl",
        "newmtl a\nmap_Kd model/tex.png\n",
    );
    write(
        &root.path().join("model"),
        "inside.mtl",
        "newmtl a\nmap_Kd ../tex.png\n",
    );
    for (lib, what) in [
        (
            "../outside.mtl",
            "mtllib \"../outside.mtl\": `..` leads above",
        ),
        (
            "inside.mtl",
            "map_Kd (in the material library) \"../tex.png\": `..` leads above",
        ),
    ] {
        let path = write(
            &root.path().join("model"),
            "m.obj",
            obj.replace("{lib}", lib),
        );
        let shown = refused(load_obj(&path), &path);
        assert!(shown.contains(what), "{shown}");
        let mesh = with_reference_policy(ReferencePolicy::Anywhere, || load_obj(&path)).unwrap();
        assert!(mesh.texture.is_some());
    }

    // glTF image URIs: the texture path and the decoded base colour.
    let (mut document, _) = tube_gltf();
    fs::write(root.path().join("model/tube.bin"), &bin).unwrap();
    document["buffers"][0]["uri"] = "tube.bin".into();
    document["images"] = serde_json::json!([{"uri": "/dev/zero"}]);
    document["textures"] = serde_json::json!([{"source": 0}]);
    document["materials"] =
        serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    document["meshes"][0]["primitives"][0]["material"] = 0.into();
    let path = write(
        &root.path().join("model"),
        "image.gltf",
        document.to_string(),
    );
    let shown = refused(load_gltf(&path), &path);
    assert!(
        shown.contains("image 0 URI \"/dev/zero\": an absolute path"),
        "{shown}"
    );
    let shown = refused(load_gltf_base_colour(&path).map(|i| i.is_some()), &path);
    assert!(
        shown.contains("image 0 URI \"/dev/zero\": an absolute path"),
        "{shown}"
    );
    let allowed =
        |f: fn(&Path) -> String| with_reference_policy(ReferencePolicy::Anywhere, || f(&path));
    let shown = allowed(|p| refused(load_gltf(p), p));
    assert!(
        shown.contains("a character device, not a regular file"),
        "{shown}"
    );
    let shown = allowed(|p| refused(load_gltf_base_colour(p).map(|i| i.is_some()), p));
    assert!(
        shown.contains("a character device, not a regular file"),
        "{shown}"
    );
}

#[cfg(unix)]
#[test]
fn an_input_that_is_a_device_a_fifo_or_a_directory_is_refused_not_read() {
    let dir = tempfile::tempdir().unwrap();
    let fifo_path = dir.path().join("pipe.off");
    let fifo = std::ffi::CString::new(fifo_path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0);
    fs::create_dir_all(dir.path().join("folder.ply")).unwrap();
    let mut inputs = vec![
        (fifo_path, "a FIFO (named pipe)"),
        (dir.path().join("folder.ply"), "a directory"),
    ];
    if Path::new("/dev/zero").exists() {
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.obj")).unwrap();
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.png")).unwrap();
        inputs.push((dir.path().join("zero.obj"), "a character device"));
    }
    for (path, kind) in &inputs {
        let error = within(Duration::from_secs(2), kind, || {
            load_mesh(path).unwrap_err()
        });
        assert!(matches!(error, Error::NotAFile { .. }), "{error}");
        let shown = one_line_naming(&error, path);
        assert!(
            shown.contains(&format!("{kind}, not a regular file")),
            "{shown}"
        );
    }
    if Path::new("/dev/zero").exists() {
        let path = dir.path().join("zero.png");
        let error = within(Duration::from_secs(2), "an image", || {
            load_gray_f32(&path).unwrap_err()
        });
        assert!(matches!(error, Error::NotAFile { .. }), "{error}");
    }
}

#[test]
fn a_gltf_accessor_count_at_an_integer_limit_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bin) = tube_gltf();
    fs::write(dir.path().join("tube.bin"), &bin).unwrap();
    for (k, count) in [
        "4294967296",
        "9223372036854775807",
        "18446744073709551615",
        "1e308",
    ]
    .iter()
    .enumerate()
    {
        let (document, _) = tube_gltf();
        let mut text = document.to_string();
        text = text.replacen("\"buffers\":[{", "\"buffers\":[{\"uri\":\"tube.bin\",", 1);
        let first = text.find("\"count\":").unwrap() + "\"count\":".len();
        let end = first + text[first..].find([',', '}']).unwrap();
        text.replace_range(first..end, count);
        let path = write(dir.path(), &format!("count{k}.gltf"), text);
        let error = within(Duration::from_secs(1), count, || {
            load_gltf(&path).unwrap_err()
        });
        one_line_naming(&error, &path);
    }
}

#[test]
fn references_too_large_or_not_naming_a_file_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let folder = root.path().join("model");
    fs::create_dir_all(&folder).unwrap();
    // A material library one byte over its limit (sparse: nothing is written).
    let big = fs::File::create(folder.join("big.mtl")).unwrap();
    big.set_len(reparam::mesh::io::MAX_MTL_BYTES + 1).unwrap();
    let path = write(
        &folder,
        "big.obj",
        "mtllib big.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let shown = within(Duration::from_secs(1), "a large library", || {
        refused(load_obj(&path), &path)
    });
    assert!(
        shown.contains(&format!(
            "mtllib \"big.mtl\": the file has {} bytes, more than the limit of {}",
            reparam::mesh::io::MAX_MTL_BYTES + 1,
            reparam::mesh::io::MAX_MTL_BYTES
        )),
        "{shown}"
    );
    // Buffer URIs that name no file: another scheme, a bad percent-encoding.
    for (uri, why) in [
        ("http://example.com/tube.bin", "unsupported URI scheme"),
        ("tube%FF.bin", "not valid percent-encoded UTF-8"),
    ] {
        let path = tube_with_buffer_uri(root.path(), uri);
        let shown = refused(load_gltf(&path), &path);
        assert!(shown.contains(why), "{uri}: {shown}");
    }
}

#[test]
fn refused_input_exits_2_and_a_missing_file_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().display().to_string();
    let missing = dir.path().join("missing.off");
    let args = ["maps", missing.to_str().unwrap(), "--out", &out];
    let (status, stderr) = reparam_binary(&args);
    assert_eq!(status, Some(1), "{stderr}");
    one_error_line(&stderr, &missing);
    let bad = write(
        dir.path(),
        "bad.off",
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
    );
    let args = ["maps", bad.to_str().unwrap(), "--out", &out];
    let (status, stderr) = reparam_binary(&args);
    assert_eq!(status, Some(2), "{stderr}");
    one_error_line(&stderr, &bad);
}

#[test]
fn a_gltf_image_without_a_source_is_an_error_not_a_panic() {
    // Found by the reference mutation (issue #35): `gltf` 1.4 unwraps an image's `uri`, or its
    // `mimeType` next to a `bufferView`, when the material's texture is read.
    let dir = tempfile::tempdir().unwrap();
    let (mut document, bin) = tube_gltf();
    fs::write(dir.path().join("tube.bin"), &bin).unwrap();
    document["buffers"][0]["uri"] = "tube.bin".into();
    document["textures"] = serde_json::json!([{"source": 0}]);
    document["materials"] =
        serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    document["meshes"][0]["primitives"][0]["material"] = 0.into();
    for (k, (image, expected)) in [
        (
            serde_json::json!({"name": "no source"}),
            "neither a `uri` nor a `bufferView`",
        ),
        (
            serde_json::json!({"bufferView": 0}),
            "a `bufferView` but no `mimeType`",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        document["images"] = serde_json::json!([image]);
        let path = write(dir.path(), &format!("image{k}.gltf"), document.to_string());
        for loaded in [
            load_gltf(&path).map(|_| ()),
            load_gltf_base_colour(&path).map(|_| ()),
        ] {
            let error = loaded.unwrap_err();
            let shown = one_line_naming(&error, &path);
            assert!(
                shown.contains(&format!("images[0]: has {expected}")),
                "{shown}"
            );
        }
    }
}

#[test]
fn maps_remesh_of_a_spike_over_a_two_face_base_domain_is_finite() {
    // Found by the long command fuzz run of issue #35: one vertex of a 5×5 wavy grid moved to
    // z = −30 (a byte inserted). A star flattened to a segment gave barycentrics 0/0 = NaN,
    // which `Param::inverse` kept (a NaN never compared worse), so a remesh vertex was NaN and
    // `hausdorff_remesh_to_input` infinite: the command stopped on a non-finite --json figure.
    let fixture = hostile("maps_remesh_spike_degenerate_star.obj");
    let dir = tempfile::tempdir().unwrap();
    let (out, path) = (
        dir.path().display().to_string(),
        fixture.display().to_string(),
    );
    for relax in [false, true] {
        let mut args = vec!["reparam", "maps", &path, "--remesh", "uniform:1", "--json"];
        args.extend(["--picture-size", "0", "--out", &out]);
        if relax {
            args.extend(["--smooth", "--relax", "3", "--equalise", "2"]);
        }
        let (result, stdout) = reparam::cli::run_captured(args);
        assert_eq!(result.unwrap(), std::process::ExitCode::SUCCESS);
        let json: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
        for remesh in json["remeshes"].as_array().unwrap() {
            let hausdorff = remesh["hausdorff_remesh_to_input"].as_f64().unwrap();
            assert!(hausdorff.is_finite(), "{remesh}");
        }
    }
}

/// `verify`'s candidate and manifest are inputs too: a FIFO or a device as the candidate `.npy`
/// or as `manifest.json` is refused at once (it once hung, reading forever).
#[cfg(all(unix, feature = "gpu"))]
#[test]
fn a_verify_candidate_or_manifest_that_is_a_fifo_or_a_device_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let fifo_path = dir.path().join("candidate.npy");
    let fifo = std::ffi::CString::new(fifo_path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0);
    let mut inputs = vec![(fifo_path, "a FIFO (named pipe)")];
    if Path::new("/dev/zero").exists() {
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.npy")).unwrap();
        inputs.push((dir.path().join("zero.npy"), "a character device"));
    }
    for (path, kind) in &inputs {
        let error = within(Duration::from_secs(2), kind, || {
            reparam::vectors::Array::load(path).unwrap_err()
        });
        assert!(matches!(error, Error::NotAFile { .. }), "{error}");
        assert!(one_line_naming(&error, path).contains(kind), "{error}");
    }
    let manifest_dir = dir.path().join("vectors");
    fs::create_dir_all(&manifest_dir).unwrap();
    let manifest =
        std::ffi::CString::new(manifest_dir.join("manifest.json").to_str().unwrap()).unwrap();
    // SAFETY: as above.
    assert_eq!(unsafe { libc::mkfifo(manifest.as_ptr(), 0o600) }, 0);
    let error = within(Duration::from_secs(2), "a FIFO manifest", || {
        reparam::vectors::read_manifest(&manifest_dir).unwrap_err()
    });
    assert!(matches!(error, Error::NotAFile { .. }), "{error}");
}
