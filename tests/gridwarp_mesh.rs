//! Meshes → gridwarp fields (src/gridwarp/rasterize.rs). Every mesh is built here.

use nalgebra::{Point2, Point3};
use reparam::gridwarp::field::Field;
use reparam::gridwarp::rasterize::{
    frames_fields, rasterize_fields, rigidity_from_image, Coverage, Roi,
};
use reparam::mesh::TriMesh;
use reparam::Error;

/// An `nu`×`nv`-quad grid over UV [0, 1]² (UV = (u, v) at each vertex), positions `x(u, v)`,
/// each quad split along its (i, j)–(i+1, j+1) diagonal.
fn grid(name: &str, nu: usize, nv: usize, x: impl Fn(f64, f64) -> Point3<f64>) -> TriMesh {
    reparam::mesh::procedural::param_grid(name, nu, nv, x)
}

fn flat(scale_x: f64, scale_y: f64) -> TriMesh {
    grid("flat", 10, 8, move |u, v| {
        Point3::new(scale_x * u, scale_y * v, 0.0)
    })
}

fn assert_const(field: &Field, value: f64, tol: f64) {
    for (i, &f) in field.values.iter().enumerate() {
        assert!((f - value).abs() <= tol, "texel {i}: {f} vs {value}");
    }
}

#[test]
fn flat_grid_scaled_by_two() {
    let mesh = flat(2.0, 2.0);
    let roi = Roi::new(0.2, 0.7, 0.1, 0.5).unwrap();
    let (s, t, cov) = rasterize_fields(&mesh, &roi, (32, 24)).unwrap();
    assert_eq!((s.width, s.height), (32, 24));
    assert_const(&s, 2.0 * 0.5, 1e-12);
    assert_const(&t, 2.0 * 0.4, 1e-12);
    assert_eq!(cov.covered, 32 * 24);
    assert_eq!(cov.fraction, 1.0);
    assert_eq!(
        cov.overlapping_texels, 0,
        "shared edges must not count as overlaps"
    );
}

#[test]
fn texel_centres_on_shared_edges_and_vertices_belong_to_one_triangle() {
    // 4×4 quads and a 8×8 field: many texel centres lie exactly on diagonals and vertices.
    let mesh = grid("aligned", 4, 4, |u, v| Point3::new(u, v, 0.0));
    let (_, _, cov) = rasterize_fields(&mesh, &Roi::full(), (8, 8)).unwrap();
    assert_eq!(cov.covered, 64);
    assert_eq!(cov.overlapping_texels, 0);
    let (_, _, cov) = rasterize_fields(&mesh, &Roi::full(), (4, 4)).unwrap();
    assert_eq!((cov.covered, cov.overlapping_texels), (16, 0));
}

#[test]
fn stretched_frame_gives_the_stretch_ratio() {
    let rest = flat(2.0, 2.0);
    let mut frame = rest.clone();
    frame.name = "stretched".into();
    for p in &mut frame.positions {
        p.x *= 1.6;
    }
    let roi = Roi::new(0.1, 0.9, 0.25, 0.75).unwrap();
    let fields = frames_fields(&rest, &[rest.clone(), frame], &roi, (16, 16)).unwrap();
    assert_eq!(fields.frames.len(), 2);
    assert_const(&fields.o_s, 2.0 * 0.8, 1e-12);
    assert_const(&fields.o_t, 2.0 * 0.5, 1e-12);
    assert_eq!(fields.frames[0].d_s, fields.o_s);
    for (d, o) in fields.frames[1].d_s.values.iter().zip(&fields.o_s.values) {
        assert!((d / o - 1.6).abs() < 1e-12);
    }
    for (d, o) in fields.frames[1].d_t.values.iter().zip(&fields.o_t.values) {
        assert!((d / o - 1.0).abs() < 1e-12);
    }
    assert_eq!(fields.coverage.fraction, 1.0);
}

/// Half-cylinder X = (R sin θu, L v, R cos θu): ‖X_u‖ = Rθ, ‖X_v‖ = L exactly. A triangle
/// spanning Δu = 1/n interpolates the chord, so ‖X_u‖_mesh = 2R sin(φ)/Δu with φ = θΔu/2:
/// relative error 1 − sin φ/φ ∈ [0, φ²/6]. ‖X_v‖ is exact (the v edges are straight).
#[test]
fn cylinder_against_analytic_derivatives() {
    let (r, theta, l) = (0.7, std::f64::consts::PI, 1.3);
    let roi = Roi::new(0.1, 0.85, 0.2, 0.9).unwrap();
    let (du, dv) = roi.size();
    for n in [8usize, 16, 32] {
        let mesh = grid("cylinder", n, 5, |u, v| {
            Point3::new(r * (theta * u).sin(), l * v, r * (theta * u).cos())
        });
        let (s, t, cov) = rasterize_fields(&mesh, &roi, (40, 30)).unwrap();
        assert_eq!(cov.fraction, 1.0);
        let exact_s = r * theta * du;
        let phi = theta / n as f64 / 2.0;
        let bound = exact_s * phi * phi / 6.0;
        let mut max_err: f64 = 0.0;
        for &v in &s.values {
            assert!(
                v <= exact_s + 1e-12,
                "chord longer than arc: {v} > {exact_s}"
            );
            max_err = max_err.max(exact_s - v);
        }
        assert!(
            max_err <= bound * (1.0 + 1e-9) + 1e-14,
            "n={n}: {max_err} > {bound}"
        );
        // The bound is tight (1 − sin φ/φ = φ²/6 − O(φ⁴)), so the tolerance is not loose.
        assert!(max_err >= 0.95 * bound, "n={n}: {max_err} ≪ {bound}");
        assert_const(&t, l * dv, 1e-12);
    }
}

#[test]
fn roi_outside_the_unit_square_is_an_error() {
    let e = Roi::new(0.2, 1.2, 0.0, 0.5).unwrap_err();
    assert!(matches!(e, Error::InvalidArgument(_)));
    assert!(e.to_string().contains("u1 = 1.2"), "{e}");
    let e = Roi::new(-0.1, 0.5, 0.0, 0.5).unwrap_err();
    assert!(e.to_string().contains("-0.1"), "{e}");
    let e = Roi::new(0.5, 0.5, 0.0, 0.5).unwrap_err();
    assert!(e.to_string().contains("positive size"), "{e}");
    assert!(Roi::new(0.0, 0.5, f64::NAN, 0.5).is_err());
    let mesh = flat(1.0, 1.0);
    assert!(rasterize_fields(&mesh, &Roi::full(), (0, 4)).is_err());
}

#[test]
fn frames_with_different_connectivity_name_the_frame_and_face() {
    let rest = flat(1.0, 1.0);
    let mut bad = rest.clone();
    bad.name = "remeshed".into();
    bad.faces[7] = [bad.faces[7][1], bad.faces[7][2], bad.faces[7][0]];
    let roi = Roi::full();
    let e = frames_fields(&rest, &[rest.clone(), bad.clone()], &roi, (8, 8)).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, Error::InvalidArgument(_)));
    assert!(
        msg.contains("frame 1") && msg.contains("remeshed") && msg.contains("face 7"),
        "{msg}"
    );

    let mut fewer = rest.clone();
    fewer.faces.pop();
    fewer.uv_faces.pop();
    let msg = frames_fields(&rest, &[fewer], &roi, (8, 8))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("frame 0") && msg.contains("faces"), "{msg}");

    let mut moved_uv = rest.clone();
    moved_uv.uvs[12].x += 0.01;
    let msg = frames_fields(&rest, &[rest.clone(), rest.clone(), moved_uv], &roi, (8, 8))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("frame 2") && msg.contains("face "), "{msg}");
}

#[test]
fn degenerate_uv_triangle_in_the_roi_names_the_face() {
    let mut mesh = flat(1.0, 1.0);
    mesh.name = "collapsed.obj".into();
    // Face 45 (quad i = 2, j = 2) gets three collinear UVs of its own.
    let base = mesh.uvs.len() as u32;
    mesh.uvs.extend([
        Point2::new(0.2, 0.25),
        Point2::new(0.25, 0.3),
        Point2::new(0.3, 0.35),
    ]);
    let f = 2 * (2 * 10 + 2) + 1;
    mesh.uv_faces[f] = [base, base + 1, base + 2];
    let e = rasterize_fields(&mesh, &Roi::new(0.0, 0.5, 0.0, 0.5).unwrap(), (16, 16)).unwrap_err();
    match &e {
        Error::DegenerateFace { mesh, face, .. } => {
            assert_eq!(*face, f);
            assert_eq!(mesh, "collapsed.obj");
        }
        other => panic!("unexpected {other}"),
    }
    assert!(e.to_string().contains(&format!("face {f}")));
    // Outside the ROI it does not matter.
    assert!(rasterize_fields(&mesh, &Roi::new(0.6, 1.0, 0.6, 1.0).unwrap(), (16, 16)).is_ok());
}

#[test]
fn coverage_of_a_roi_partly_outside_the_chart() {
    // The chart covers u ∈ [0, 0.5]; X = (u, 3v) so ‖X_u‖ varies nowhere but ‖X_t‖ = 3·Δv.
    let mut mesh = grid("half", 6, 6, |u, v| Point3::new(u, 3.0 * v, 0.0));
    for p in &mut mesh.uvs {
        p.x *= 0.5;
    }
    let roi = Roi::new(0.25, 0.75, 0.0, 1.0).unwrap();
    let (s, t, cov) = rasterize_fields(&mesh, &roi, (20, 10)).unwrap();
    assert_eq!(
        cov,
        Coverage {
            covered: 100,
            total: 200,
            fraction: 0.5,
            overlapping_texels: 0,
            faces: cov.faces
        }
    );
    // X_u = 2 (the UVs were halved), X_s = 2·0.5; filled texels repeat the nearest chart texel.
    assert_const(&s, 1.0, 1e-12);
    assert_const(&t, 3.0, 1e-12);
    // No covered texel at all.
    let e = rasterize_fields(&mesh, &Roi::new(0.6, 1.0, 0.0, 1.0).unwrap(), (8, 8)).unwrap_err();
    assert!(e.to_string().contains("no UV triangle"), "{e}");
}

#[test]
fn nearest_fill_uses_the_nearest_covered_texel() {
    // Chart: u ∈ [0, 0.5] with ‖X_u‖ growing with u (X = (u², v)): the fill beyond u = 0.5 copies
    // the last covered column.
    let mut mesh = grid("ramp", 8, 2, |u, v| Point3::new(u * u, v, 0.0));
    for p in &mut mesh.uvs {
        p.x *= 0.5;
    }
    let (s, _, cov) = rasterize_fields(&mesh, &Roi::full(), (16, 4)).unwrap();
    assert_eq!(cov.covered, 8 * 4);
    for y in 0..4 {
        let row = &s.values[y * 16..(y + 1) * 16];
        for x in 8..16 {
            assert_eq!(row[x], row[7], "row {y} col {x}");
        }
        assert!(row[7] > row[0]);
    }
}

#[test]
fn overlapping_charts_take_the_lowest_face_and_are_counted() {
    let a = grid("a", 4, 4, |u, v| Point3::new(u, v, 0.0));
    let b = grid("b", 4, 4, |u, v| Point3::new(5.0 * u, v, 1.0));
    let mut both = a.clone();
    let off = both.positions.len() as u32;
    let uoff = both.uvs.len() as u32;
    both.positions.extend(&b.positions);
    both.uvs.extend(&b.uvs);
    both.faces
        .extend(b.faces.iter().map(|f| f.map(|i| i + off)));
    both.uv_faces
        .extend(b.uv_faces.iter().map(|f| f.map(|i| i + uoff)));
    let (s, _, cov) = rasterize_fields(&both, &Roi::full(), (10, 10)).unwrap();
    assert_eq!(cov.overlapping_texels, 100);
    assert_const(&s, 1.0, 1e-12);
}

#[test]
fn rigidity_map_resampled_and_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.png");
    let e = rigidity_from_image(&missing, None, (8, 8)).unwrap_err();
    assert!(e.to_string().contains("nope.png"), "{e}");
    let garbage = dir.path().join("garbage.png");
    std::fs::write(&garbage, b"not a png").unwrap();
    let e = rigidity_from_image(&garbage, None, (8, 8)).unwrap_err();
    assert!(e.to_string().contains("garbage.png"), "{e}");

    // 2×2 image: top row white, bottom row black (v = 0 is the bottom of the image).
    let path = dir.path().join("r.png");
    image::GrayImage::from_raw(2, 2, vec![255, 255, 0, 0])
        .unwrap()
        .save(&path)
        .unwrap();
    let r = rigidity_from_image(&path, None, (4, 4)).unwrap();
    assert_eq!((r.width, r.height), (4, 4));
    assert_eq!(r.values[0], 0.0); // row 0 = t = 0 = bottom.
    assert_eq!(r.values[15], 1.0);
    assert!(r.values.iter().all(|v| (0.0..=1.0).contains(v)));
    // The top half of the texture only: all rigid.
    let top = Roi::new(0.0, 1.0, 0.75, 1.0).unwrap();
    let r = rigidity_from_image(&path, Some(&top), (3, 5)).unwrap();
    assert!(r.values.iter().all(|&v| v == 1.0));
}

#[test]
fn deterministic_with_one_and_two_threads() {
    let rest = grid("cyl", 24, 12, |u, v| {
        Point3::new((3.0 * u).sin(), v + 0.1 * (5.0 * u).sin(), (3.0 * u).cos())
    });
    let mut frame = rest.clone();
    for (i, p) in frame.positions.iter_mut().enumerate() {
        p.z += 0.01 * (i % 7) as f64;
    }
    let roi = Roi::new(0.13, 0.91, 0.05, 0.77).unwrap();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| frames_fields(&rest, std::slice::from_ref(&frame), &roi, (67, 45)).unwrap())
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.o_s, b.o_s);
    assert_eq!(a.o_t, b.o_t);
    assert_eq!(a.frames[0].d_s, b.frames[0].d_s);
    assert_eq!(a.frames[0].d_t, b.frames[0].d_t);
    assert_eq!(a.coverage, b.coverage);
}
