//! NAA sequences, NAA fields rasterised from meshes, NAA figure of merit, automatic rigidity.

use nalgebra::{Point3, Vector3};
use reparam::gridwarp::energy_naa::{naa_frame_bounds, VectorField};
use reparam::gridwarp::merit::{rigid_stretch, rigid_stretch_naa};
use reparam::gridwarp::rasterize::{frames_fields, rigidity_from_image_of_size, Roi};
use reparam::gridwarp::rigidity::{parse_discs, rigidity_from_texture, AutoRigidityOptions};
use reparam::gridwarp::scene::{disc_rigidity, flat_rest};
use reparam::gridwarp::*;
use reparam::mesh::TriMesh;
use reparam::texture::Image;
use reparam::Error;

/// The x-stretch ramp of `plane_stretch`, bent along t (vertical lines want to bend).
fn bent_stretch(size: usize, sigma: f64) -> DeformedJacobian {
    DeformedJacobian::from_partials(size, move |s: f64, t: f64| {
        let ramp = (3.0 * s * s - 2.0 * s * s * s).clamp(0.0, 1.0);
        (
            Vector3::x() * (1.0 + (sigma - 1.0) * ramp * (0.5 + t)),
            Vector3::y() + Vector3::z() * (0.3 * s),
        )
    })
}

fn setup() -> (RestFields, Grid, Vec<DeformedJacobian>) {
    let rigidity = disc_rigidity(32, &[(0.7, 0.5, 0.15)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let frames = [1.3, 1.6, 1.9]
        .iter()
        .map(|&s| bent_stretch(32, s))
        .collect();
    (flat_rest(32, rigidity), grid, frames)
}

fn small() -> SolveOptions {
    SolveOptions {
        samples: (3, 3),
        ..Default::default()
    }
}

#[test]
fn the_sequence_is_frame_by_frame_solves_warm_started_from_the_previous_frame() {
    let (rest, grid, frames) = setup();
    let start = VertexGrid::from_grid(&grid);
    let options = SolveOptions {
        smoothness: Some(0.02),
        ..small()
    };
    let seq = solve_naa_sequence(&rest, &grid, &start, &frames, &options).unwrap();
    assert_eq!(seq.len(), 3);
    let mut previous = start.clone();
    for (j, (s, f)) in seq.iter().zip(&frames).enumerate() {
        // The sequence builds its rest samples once (`NaaRestSamples`), a single solve its
        // own: the same vertices bit for bit.
        let single = solve_naa_frame(&rest, &grid, f, &previous, &start, (j, 3), &options).unwrap();
        assert_eq!(single.vertices, s.vertices, "frame {j}");
        assert_eq!(
            single.lm.energy.to_bits(),
            s.lm.energy.to_bits(),
            "frame {j}"
        );
        assert!(s.lm.energy < s.rest_energy);
        // Smoothness: no coordinate moved more than o from the previous frame.
        let bounds = naa_frame_bounds(&previous, &start, &options.bound_options(j, frames.len()));
        for (k, x) in s.vertices.to_unknowns().iter().enumerate() {
            assert!(bounds.lower[k] <= *x && *x <= bounds.upper[k]);
        }
        // The box [x − o, x + o] is computed in floating point: its ends are o away up to one
        // rounding of an O(1) value (≤ 1.2e-16).
        for (p, q) in s.vertices.points.iter().zip(&previous.points) {
            assert!((p[0] - q[0]).abs() <= 0.02 + 1e-15 && (p[1] - q[1]).abs() <= 0.02 + 1e-15);
        }
        previous = s.vertices.clone();
    }
    // Warm start from a converged frame: the same frame again needs at most one step.
    let free = solve_naa_sequence(&rest, &grid, &start, &frames, &small()).unwrap();
    let again =
        solve_naa_sequence(&rest, &grid, &free[2].vertices, &frames[2..], &small()).unwrap();
    assert!(again[0].lm.iterations <= 1, "{}", again[0].lm.iterations);
}

#[test]
fn a_looping_sequence_returns_to_the_first_frame() {
    let (rest, grid, mut frames) = setup();
    let back: Vec<_> = frames.iter().rev().skip(1).cloned().collect();
    frames.extend(back);
    let start = VertexGrid::from_grid(&grid);
    let options = SolveOptions {
        smoothness: Some(0.01),
        looping: true,
        ..small()
    };
    let seq = solve_naa_sequence(&rest, &grid, &start, &frames, &options).unwrap();
    // d_{K−1} = 0: the last frame's box around frame 0's solution has zero width.
    assert_eq!(seq.last().unwrap().vertices, seq[0].vertices);
}

#[test]
fn a_start_of_the_wrong_shape_is_a_typed_error() {
    let (rest, grid, frames) = setup();
    let wrong = VertexGrid::from_grid(&Grid::uniform(3, 3));
    let e = solve_naa_sequence(&rest, &grid, &wrong, &frames, &small()).unwrap_err();
    assert!(matches!(e, Error::InvalidArgument(_)), "{e}");
}

/// An `n`×`n` quad grid over UV [0, 1]², positions x(u, v).
fn grid_mesh(n: usize, x: impl Fn(f64, f64) -> Point3<f64>) -> TriMesh {
    reparam::mesh::procedural::param_grid("grid", n, n, x)
}

#[test]
fn rasterised_derivative_vectors_match_their_lengths_and_a_shear() {
    let rest = grid_mesh(6, |u, v| Point3::new(u, v, 0.0));
    // A shear X = (u + 0.5 v, 2 v, 0): X_u = (1, 0, 0), X_v = (0.5, 2, 0), exactly per triangle.
    let sheared = grid_mesh(6, |u, v| Point3::new(u + 0.5 * v, 2.0 * v, 0.0));
    let roi = Roi::new(0.1, 0.6, 0.2, 0.9).unwrap();
    let f = frames_fields(&rest, &[sheared], &roi, (12, 10)).unwrap();
    let (j, d) = (&f.jacobians[0], &f.frames[0]);
    let (du, dv) = roi.size();
    let norm = |v: &VectorField, i: usize| {
        (v.x.values[i].powi(2) + v.y.values[i].powi(2) + v.z.values[i].powi(2)).sqrt()
    };
    for i in 0..12 * 10 {
        // Same per-face partials, O(1) values: equal to rounding.
        assert!((norm(&j.d_s, i) - d.d_s.values[i]).abs() < 1e-14);
        assert!((norm(&j.d_t, i) - d.d_t.values[i]).abs() < 1e-14);
        assert!((j.d_s.x.values[i] - du).abs() < 1e-14 && j.d_s.y.values[i].abs() < 1e-14);
        assert!((j.d_t.x.values[i] - 0.5 * dv).abs() < 1e-14);
        assert!((j.d_t.y.values[i] - 2.0 * dv).abs() < 1e-14);
    }
}

#[test]
fn the_naa_merit_of_axis_aligned_vertices_is_the_aa_merit() {
    // D_s = c_s x̂, D_t = c_t ŷ: ‖J_D W_s‖ = c_s a on an axis-aligned grid, as the AA merit says.
    let n = 48;
    let cs = |s: f64, t: f64| 1.3 + 0.4 * (3.0 * s).sin() * t;
    let ct = |s: f64, _t: f64| 0.9 + 0.2 * s;
    let aa = DeformedFields {
        d_s: Field::from_fn(n, n, cs),
        d_t: Field::from_fn(n, n, ct),
    };
    let naa = DeformedJacobian {
        d_s: VectorField::from_fn(n, n, |s, t| [cs(s, t), 0.0, 0.0]),
        d_t: VectorField::from_fn(n, n, |s, t| [0.0, ct(s, t), 0.0]),
    };
    let rest = flat_rest(n, disc_rigidity(n, &[(0.5, 0.5, 0.3)], 0.2));
    let grid = Grid::new(vec![0.0, 0.3, 0.7, 1.0], vec![0.0, 0.5, 1.0]).unwrap();
    let warped = Grid::new(vec![0.0, 0.25, 0.8, 1.0], vec![0.0, 0.4, 1.0]).unwrap();
    let a = rigid_stretch(&rest, &aa, &grid, &warped, 64);
    let b = rigid_stretch_naa(&rest, &naa, &grid, &VertexGrid::from_grid(&warped), 64);
    // Bilinear sampling of the same values (the vector field's x component is c_s itself):
    // only the order of operations differs.
    assert!(
        (a.mean - b.mean).abs() < 1e-12 && (a.max - b.max).abs() < 1e-12,
        "{a:?} {b:?}"
    );
    assert!(a.mean > 0.05);
}

#[test]
fn automatic_rigidity_marks_the_texture_edges() {
    // Left half black, right half white: the only edge is at u = ½.
    let texture = Image::from_fn(64, 64, |x, _| {
        if x < 32 {
            [0, 0, 0, 255]
        } else {
            [255, 255, 255, 255]
        }
    });
    let options = AutoRigidityOptions {
        blur: 1.0,
        ..Default::default()
    };
    let r = rigidity_from_texture(&texture, &Roi::full(), (32, 8), None, &options).unwrap();
    for y in 0..8 {
        for x in 0..32 {
            let v = r.values[y * 32 + x];
            // The edge sits between texels 15 and 16; blur σ = 1 spreads it over ±3 texels with
            // the threshold 0.25 reached within ≈ 1.7σ of the peak.
            let near = (14..=17).contains(&x);
            let far = !(11..=20).contains(&x);
            if near {
                assert_eq!(v, 1.0, "({x}, {y})");
            }
            if far {
                assert_eq!(v, options.background, "({x}, {y})");
            }
        }
    }
    // A flat texture has no detail: background everywhere, no NaN.
    let flat = Image::from_fn(8, 8, |_, _| [90, 90, 90, 255]);
    let r = rigidity_from_texture(&flat, &Roi::full(), (8, 8), None, &options).unwrap();
    assert!(r.values.iter().all(|&v| v == options.background));
    // Uncovered texels (outside the charts) contribute no edges.
    let mask: Vec<bool> = (0..32 * 8).map(|i| i % 32 < 12).collect();
    let r = rigidity_from_texture(&texture, &Roi::full(), (32, 8), Some(&mask), &options).unwrap();
    assert!(r.values.iter().all(|&v| v == options.background));
    // Bad input.
    assert!(rigidity_from_texture(&texture, &Roi::full(), (0, 8), None, &options).is_err());
    assert!(rigidity_from_texture(&texture, &Roi::full(), (4, 4), Some(&mask), &options).is_err());
    let bad = AutoRigidityOptions {
        threshold: f64::NAN,
        ..options
    };
    assert!(rigidity_from_texture(&texture, &Roi::full(), (4, 4), None, &bad).is_err());
}

#[test]
fn disc_specs_parse_or_fail_with_the_text() {
    assert_eq!(
        parse_discs("0.2,0.3,0.1; 0.7,0.5,0.05").unwrap(),
        vec![(0.2, 0.3, 0.1), (0.7, 0.5, 0.05)]
    );
    for bad in ["", "0.2,0.3", "0.2,0.3,0", "a,b,c", "0.1,0.1,inf"] {
        let e = parse_discs(bad).unwrap_err();
        assert!(matches!(e, Error::InvalidArgument(_)), "{bad}");
        assert!(e.to_string().contains(&format!("'{bad}'")), "{e}");
    }
}

#[test]
fn a_rigidity_map_of_the_wrong_size_is_a_typed_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.png");
    image::GrayImage::from_raw(10, 6, vec![255; 60])
        .unwrap()
        .save(&path)
        .unwrap();
    assert!(rigidity_from_image_of_size(&path, None, (8, 8), (10, 6), 0).is_ok());
    assert!(rigidity_from_image_of_size(&path, None, (8, 8), (11, 7), 1).is_ok());
    let e = rigidity_from_image_of_size(&path, None, (8, 8), (12, 6), 1).unwrap_err();
    assert!(matches!(e, Error::Image { .. }), "{e}");
    assert!(
        e.to_string().contains("10x6") && e.to_string().contains("12x6"),
        "{e}"
    );
    // Unreadable: names the file.
    let e = rigidity_from_image_of_size(&dir.path().join("no.png"), None, (8, 8), (1, 1), 0)
        .unwrap_err();
    assert!(e.to_string().contains("no.png"), "{e}");
}

/// A minimal glTF (no mesh) whose one material's base colour is `image` (a glTF image object).
fn write_material_gltf(dir: &std::path::Path, image: serde_json::Value) -> std::path::PathBuf {
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "buf.bin", "byteLength": std::fs::metadata(dir.join("buf.bin")).unwrap().len()}],
        "bufferViews": [{"buffer": 0, "byteLength": std::fs::metadata(dir.join("buf.bin")).unwrap().len()}],
        "images": [image],
        "textures": [{"source": 0}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    });
    let path = dir.join("m.gltf");
    std::fs::write(&path, doc.to_string()).unwrap();
    path
}

#[test]
fn the_base_colour_image_of_a_gltf_is_read_from_a_buffer_view_or_a_file() {
    use reparam::mesh::load_gltf_base_colour;
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("tex.png");
    let mut img = image::RgbaImage::from_pixel(3, 2, image::Rgba([10, 20, 30, 255]));
    img.put_pixel(2, 1, image::Rgba([200, 100, 50, 255]));
    img.save(&png).unwrap();
    std::fs::copy(&png, dir.path().join("buf.bin")).unwrap();
    let check = |path: &std::path::Path| {
        let t = load_gltf_base_colour(path).unwrap().expect("has a texture");
        assert_eq!((t.width, t.height), (3, 2));
        assert_eq!(t.get(0, 0), [10, 20, 30, 255]);
        assert_eq!(t.get(2, 1), [200, 100, 50, 255]);
    };
    check(&write_material_gltf(
        dir.path(),
        serde_json::json!({"bufferView": 0, "mimeType": "image/png"}),
    ));
    check(&write_material_gltf(
        dir.path(),
        serde_json::json!({"uri": "tex.png"}),
    ));
    // Not an image: a typed error naming the file and the image.
    std::fs::write(dir.path().join("buf.bin"), b"not a png at all").unwrap();
    let path = write_material_gltf(
        dir.path(),
        serde_json::json!({"bufferView": 0, "mimeType": "image/png"}),
    );
    let e = load_gltf_base_colour(&path).unwrap_err();
    assert!(matches!(e, Error::Gltf { .. }), "{e}");
    assert!(e.to_string().contains("image 0"), "{e}");
}
