//! Issue #36 end to end: `bpm qc` and `bpm render` report the input map's conformality, write
//! the per-face figures and the s picture, and refuse bad output names with typed errors.

mod common;

use common::cli::reparam;

/// Shape and values of a float64 `.npy` file.
fn load_npy(path: &std::path::Path) -> (Vec<u64>, Vec<f64>) {
    let bytes = std::fs::read(path).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    let shape = npy.shape().to_vec();
    (shape, npy.into_vec::<f64>().unwrap())
}

fn json(args: &[&str]) -> serde_json::Value {
    let (code, stdout, stderr) = reparam(args);
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str(&stdout).expect("valid JSON")
}

#[test]
fn bpm_qc_reports_the_s_distribution_and_the_per_face_figures() {
    let dir = tempfile::tempdir().unwrap();
    let npy = dir.path().join("faces.npy");
    let v = json(&[
        "bpm",
        "qc",
        "procedural:star_affine",
        "--subdiv",
        "2",
        "--per-face",
        npy.to_str().unwrap(),
        "--json",
        "--json-faces",
    ]);
    let shares = v["conformality"]["distribution"]["area_share"]
        .as_array()
        .unwrap();
    let total: f64 = shares.iter().map(|x| x.as_f64().unwrap()).sum();
    assert!((total - 1.0).abs() < 1e-12, "{shares:?}");
    assert_eq!(v["conformality"]["by_bin"].as_array().unwrap().len(), 5);
    assert_eq!(v["vertex_rule"], "PerFace");
    let faces = v["faces"].as_array().unwrap();
    let n = v["precompute"]["faces"].as_u64().unwrap() as usize;
    assert_eq!(faces.len(), n);
    let (shape, values) = load_npy(&npy);
    assert_eq!(shape, vec![n as u64, 8]);
    // serde_json's default float parsing may be off by an ulp: compare to 1e-15 relative.
    let same = |a: f64, b: &serde_json::Value| {
        let b = b.as_f64().unwrap();
        assert!((a - b).abs() <= 1e-15 * b.abs(), "{a} vs {b}");
    };
    for (f, face) in faces.iter().enumerate() {
        let row = &values[8 * f..8 * f + 8];
        same(row[0], &face["bpm"]["mean"]);
        same(row[1], &face["bpm"]["max"]);
        same(row[2], &face["linear"]["mean"]);
        same(row[3], &face["linear"]["max"]);
        same(row[4], &face["s"]);
        same(row[5], &face["area"]);
        same(row[6], &face["bpm"]["folded"]);
        same(row[7], &face["linear"]["folded"]);
    }
    // Without --json-faces the per-face rows stay out of the JSON.
    let v = json(&[
        "bpm",
        "qc",
        "procedural:star_affine",
        "--subdiv",
        "1",
        "--json",
    ]);
    assert!(v.get("faces").is_none());
}

#[test]
fn bpm_qc_warns_on_a_map_far_from_conformal_and_not_on_a_mobius_map() {
    let (code, stdout, stderr) = reparam(&["bpm", "qc", "procedural:star_affine", "--subdiv", "2"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("input map conformality"), "{stdout}");
    assert!(
        stdout.contains("warning: BPM assumes a near-conformal"),
        "{stdout}"
    );
    let (code, stdout, stderr) = reparam(&["bpm", "qc", "procedural:mobius", "--subdiv", "2"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("input map conformality"), "{stdout}");
    assert!(!stdout.contains("warning"), "{stdout}");
}

#[test]
fn bpm_qc_and_render_write_the_s_picture() {
    let dir = tempfile::tempdir().unwrap();
    for (command, view) in [("qc", "surface"), ("render", "uv")] {
        let png = dir.path().join(format!("s_{command}.png"));
        let out = dir.path().join("render.png");
        let mut args = vec![
            "bpm",
            command,
            "procedural:star_affine",
            "--s-picture",
            png.to_str().unwrap(),
            "--s-view",
            view,
            "--json",
        ];
        if command == "qc" {
            args.extend(["--subdiv", "1"]);
        } else {
            args.extend(["--size", "160x120", "-o", out.to_str().unwrap()]);
        }
        let v = json(&args);
        assert_eq!(v["s_picture"], png.to_str().unwrap());
        assert!(v["conformality"]["distribution"]["max"].as_f64().unwrap() > 0.0);
        let image = reparam::texture::load_rgba8(&png).unwrap();
        assert!(
            image.width > 160 && image.height >= 120,
            "{}x{}",
            image.width,
            image.height
        );
    }
}

#[test]
fn bpm_qc_refuses_output_names_with_the_wrong_extension() {
    let dir = tempfile::tempdir().unwrap();
    let txt = dir.path().join("faces.txt");
    let (code, _, stderr) = reparam(&[
        "bpm",
        "qc",
        "procedural:cone",
        "--per-face",
        txt.to_str().unwrap(),
    ]);
    // A refused argument is bad input: exit status 2 (`Error::exit_status`).
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("--per-face") && stderr.contains(".npy"),
        "{stderr}"
    );
    assert!(!txt.exists());
    let jpg = dir.path().join("s.jpg");
    for command in ["qc", "render"] {
        let (code, _, stderr) = reparam(&[
            "bpm",
            command,
            "procedural:cone",
            "--s-picture",
            jpg.to_str().unwrap(),
        ]);
        assert_eq!(code, 2, "{command}: {stderr}");
        assert!(
            stderr.contains("--s-picture") && stderr.contains(".png"),
            "{stderr}"
        );
    }
    // --json-faces needs --json (a usage error).
    let (code, _, stderr) = reparam(&["bpm", "qc", "procedural:cone", "--json-faces"]);
    assert_eq!(code, 2, "{stderr}");
}

#[test]
fn bpm_qc_under_the_authors_unfolding_uses_their_vertex_rule() {
    let qc = |unfold: &str| {
        json(&[
            "bpm",
            "qc",
            "procedural:folded_star",
            "--subdiv",
            "2",
            "--unfold",
            unfold,
            "--json",
        ])
    };
    let (correct, authors) = (qc("correct"), qc("authors"));
    assert_eq!(correct["vertex_rule"], "PerFace");
    assert_eq!(authors["vertex_rule"], "Authors");
    // Their linear interpolation evaluates every face separately.
    assert_eq!(correct["linear"], authors["linear"]);
}
