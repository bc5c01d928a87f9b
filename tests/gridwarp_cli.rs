//! `reparam gridwarp` end to end: the NAA variant, mesh inputs with several ROIs and rigidity
//! maps, and bad input (typed errors, never a panic).

mod common;

use common::cli::reparam;
use std::path::{Path, PathBuf};

/// An OBJ of an `n`×`n` quad grid over UV [0, 1]², positions x(u, v).
fn write_grid_obj(dir: &Path, name: &str, n: usize, x: impl Fn(f64, f64) -> [f64; 3]) -> PathBuf {
    let mut text = String::new();
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let p = x(u, v);
            text += &format!("v {} {} {}\nvt {u} {v}\n", p[0], p[1], p[2]);
        }
    }
    let id = |i: usize, j: usize| j * (n + 1) + i + 1;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            text += &format!("f {a}/{a} {b}/{b} {c}/{c}\nf {a}/{a} {c}/{c} {d}/{d}\n");
        }
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// A rest plane and a frame stretched non-uniformly along x (the right part more).
fn plane_frames(dir: &Path) -> (PathBuf, PathBuf) {
    let rest = write_grid_obj(dir, "rest.obj", 16, |u, v| [u, v, 0.0]);
    let frame = write_grid_obj(dir, "frame.obj", 16, |u, v| [u + 0.8 * u * u * u, v, 0.0]);
    (rest, frame)
}

/// `reparam gridwarp` on the OBJ frames `rest`, `frame` with 16² fields, writing to `out`,
/// with `extra` arguments.
fn gridwarp_on(rest: &Path, frame: &Path, out: &Path, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "gridwarp",
        "--obj",
        rest.to_str().unwrap(),
        frame.to_str().unwrap(),
        "--size",
        "16",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    reparam(&args)
}

fn json(stdout: &str) -> serde_json::Value {
    serde_json::from_str(stdout).expect("valid JSON")
}

#[test]
fn naa_scene_reports_every_frame_and_lowers_the_energy() {
    for (flag, model) in [
        (None, "GaussNewton"),
        (Some("newton"), "Newton"),
        (Some("adaptive"), "Adaptive"),
    ] {
        naa_scene_with_model(flag, model);
    }
}

#[test]
fn naa_model_without_the_naa_variant_is_an_error() {
    let (code, _, stderr) = reparam(&["gridwarp", "--scene", "plane", "--naa-model", "newton"]);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("--naa-model") && stderr.contains("--variant naa"),
        "{stderr}"
    );
}

fn naa_scene_with_model(flag: Option<&str>, model: &str) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let mut args = vec![
        "gridwarp",
        "--scene",
        "plane",
        "--variant",
        "naa",
        "--frames",
        "2",
        "--size",
        "32",
        "--samples",
        "3",
        "--out",
        out,
        "--json",
    ];
    if let Some(flag) = flag {
        args.extend(["--naa-model", flag]);
    }
    let (code, stdout, stderr) = reparam(&args);
    assert_eq!(code, 0, "{stderr}");
    let v = json(&stdout);
    assert_eq!(v["variant"], "naa");
    assert_eq!(v["naa_model"], model);
    let roi = &v["rois"][0];
    assert_eq!(roi["vertices"].as_array().unwrap().len(), 2);
    for f in roi["frames"].as_array().unwrap() {
        assert!(f["energy_after"].as_f64().unwrap() < f["energy_before"].as_f64().unwrap());
        for key in [
            "seconds",
            "iterations",
            "energy_evaluations",
            "jacobian_evaluations",
        ] {
            assert!(f[key].is_number(), "{key}");
        }
        assert!(f["stop"].is_string());
        assert!(f["rigid_stretch_before"]["mean"].is_number());
        assert!(f["rigid_stretch_after"]["max"].is_number());
    }
    for name in [
        "gridwarp_plane_naa_grid.png",
        "gridwarp_plane_naa_render.png",
    ] {
        assert!(dir.path().join(name).exists(), "{name}");
    }
}

#[test]
fn two_rois_on_a_mesh_are_solved_independently_and_combined() {
    let dir = tempfile::tempdir().unwrap();
    let (rest, frame) = plane_frames(dir.path());
    let out = dir.path().join("out");
    for variant in ["aa", "naa"] {
        let (code, stdout, stderr) = reparam(&[
            "gridwarp",
            "--obj",
            rest.to_str().unwrap(),
            frame.to_str().unwrap(),
            "--roi",
            "0,0.45,0,1",
            "--roi",
            "0.5,1,0.1,0.9",
            "--rigidity",
            "discs:0.5,0.5,0.2",
            "--rigidity",
            "discs:0.6,0.4,0.2",
            "--variant",
            variant,
            "--size",
            "24",
            "--samples",
            "3",
            "--out",
            out.to_str().unwrap(),
            "--json",
        ]);
        assert_eq!(code, 0, "{stderr}");
        let v = json(&stdout);
        let rois = v["rois"].as_array().unwrap();
        assert_eq!(rois.len(), 2);
        assert_eq!(rois[1]["roi"][0].as_f64().unwrap(), 0.5);
        let combined = &v["combined"][0];
        let sum: f64 = rois
            .iter()
            .map(|r| r["frames"][0]["seconds"].as_f64().unwrap())
            .sum();
        // serde_json's default float parser may be 1 ulp off the printed value: compare
        // relatively, far below any timing difference.
        let total = combined["seconds"].as_f64().unwrap();
        assert!((total - sum).abs() <= 1e-12 * sum, "{total} vs {sum}");
        let evals: u64 = rois
            .iter()
            .map(|r| r["frames"][0]["energy_evaluations"].as_u64().unwrap())
            .sum();
        assert_eq!(combined["energy_evaluations"].as_u64().unwrap(), evals);
        // The right ROI is stretched (∂x/∂u = 1 + 2.4u² up to 3.4): the warp relieves its rigid disc.
        let f = &rois[1]["frames"][0];
        assert!(
            f["rigid_stretch_after"]["max"].as_f64().unwrap()
                < f["rigid_stretch_before"]["max"].as_f64().unwrap()
        );
    }
    assert!(out.join("gridwarp_rest_roi1_grid.png").exists());
    assert!(out.join("gridwarp_rest_naa_render.png").exists());
}

/// Without --rigidity the map is R ≡ 1: Algorithm 1 places no interior line, the run has 0
/// unknowns and leaves every frame as it is, and says why and what to give instead.
#[test]
fn a_uniform_rigidity_map_leaves_nothing_to_warp_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let (rest, frame) = plane_frames(dir.path());
    let out = dir.path().join("out");
    let (code, stdout, stderr) = gridwarp_on(&rest, &frame, &out, &["--samples", "2"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("0 unknowns"), "{stdout}");
    assert!(stdout.contains("nothing to warp"), "{stdout}");
    assert!(stdout.contains("--rigidity"), "{stdout}");
    let (code, stdout, stderr) = gridwarp_on(&rest, &frame, &out, &["--samples", "2", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let v = json(&stdout);
    let roi = &v["rois"][0];
    assert_eq!(roi["unknowns"].as_u64().unwrap(), 0);
    let f = &roi["frames"][0];
    assert_eq!(f["iterations"].as_u64().unwrap(), 0);
    assert_eq!(f["energy_before"], f["energy_after"]);
}

#[test]
fn bad_rois_and_rigidity_maps_are_errors_naming_the_culprit() {
    let dir = tempfile::tempdir().unwrap();
    let (rest, frame) = plane_frames(dir.path());
    let out = dir.path().join("out");
    let run = |extra: &[&str]| {
        let (code, _, stderr) = gridwarp_on(&rest, &frame, &out, extra);
        assert_ne!(code, 0, "{extra:?} succeeded");
        assert!(!stderr.contains("panicked"), "{stderr}");
        stderr
    };
    let e = run(&["--roi", "0,0.6,0,1", "--roi", "0.5,1,0,1"]);
    assert!(
        e.contains("overlap") && e.contains("ROI 0") && e.contains("ROI 1"),
        "{e}"
    );
    let e = run(&["--roi", "0.5,1.5,0,1"]);
    assert!(e.contains("u1 = 1.5"), "{e}");
    let e = run(&[
        "--roi",
        "0,0.5,0,1",
        "--roi",
        "0.5,1,0,1",
        "--rigidity",
        "discs:0.5,0.5,0.1",
        "--rigidity",
        "discs:0.5,0.5,0.1",
        "--rigidity",
        "discs:0.5,0.5,0.1",
    ]);
    assert!(e.contains("3 --rigidity values for 2 ROIs"), "{e}");
    let e = run(&["--rigidity", "missing.png"]);
    assert!(e.contains("missing.png"), "{e}");
    let e = run(&["--rigidity", "auto"]);
    assert!(e.contains("texture"), "{e}");
    let e = run(&["--rigidity", "discs:0.5,0.5"]);
    assert!(e.contains("discs") || e.contains("three numbers"), "{e}");
    // Frames with a different connectivity.
    let other = write_grid_obj(dir.path(), "other.obj", 8, |u, v| [u, v, 0.0]);
    let (code, _, stderr) = gridwarp_on(&rest, &other, &out, &[]);
    assert!(
        code != 0 && stderr.contains("frame 0") && stderr.contains("faces"),
        "{stderr}"
    );
    // With a texture (map_Kd), a rigidity map must have the size of the region it covers.
    std::fs::write(dir.path().join("m.mtl"), "newmtl a\nmap_Kd tex.png\n").unwrap();
    image::RgbaImage::from_pixel(32, 32, image::Rgba([200, 100, 50, 255]))
        .save(dir.path().join("tex.png"))
        .unwrap();
    let textured = dir.path().join("textured.obj");
    let body = std::fs::read_to_string(&rest).unwrap();
    std::fs::write(&textured, format!("mtllib m.mtl\nusemtl a\n{body}")).unwrap();
    let map = dir.path().join("r.png");
    image::GrayImage::from_pixel(10, 10, image::Luma([255]))
        .save(&map)
        .unwrap();
    let extra = ["--roi", "0,0.5,0,0.5", "--rigidity", map.to_str().unwrap()];
    let (code, _, stderr) = gridwarp_on(&textured, &frame, &out, &extra);
    // The ROI covers 16×16 texture pixels.
    assert!(
        code != 0 && stderr.contains("10x10") && stderr.contains("16x16"),
        "{stderr}"
    );
    // --roi on a built-in scene is refused rather than ignored.
    let (code, _, stderr) = reparam(&["gridwarp", "--scene", "plane", "--roi", "0,1,0,1"]);
    assert!(code != 0 && stderr.contains("--roi"), "{stderr}");
}
