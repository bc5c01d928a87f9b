//! The `reparam` binary end to end: JSON output, and clear errors (never a panic) on bad files.

mod common;

use common::cli::reparam;

#[test]
fn bpm_qc_prints_json() {
    let (code, stdout, stderr) =
        reparam(&["bpm", "qc", "procedural:cone", "--subdiv", "2", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("valid JSON");
    for interp in ["linear", "bpm"] {
        let mean = v[interp]["mean"].as_f64().unwrap();
        assert!(mean >= 1.0, "{interp}: {mean}");
        assert_eq!(
            v[interp]["sub_triangles"].as_u64().unwrap(),
            16 * v["precompute"]["faces"].as_u64().unwrap()
        );
    }
}

#[test]
fn bpm_qc_reports_folded_neighbours_and_both_unfoldings() {
    let qc = |unfold: &str| {
        let (code, stdout, stderr) = reparam(&[
            "bpm",
            "qc",
            "procedural:folded_star",
            "--subdiv",
            "2",
            "--unfold",
            unfold,
            "--json",
        ]);
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str::<serde_json::Value>(&stdout).expect("valid JSON")
    };
    let (correct, authors) = (qc("correct"), qc("authors"));
    assert_eq!(correct["unfold"], "Correct");
    assert_eq!(authors["unfold"], "Authors");
    // One neighbour folded by 150°, seen from both faces of its edge.
    for v in [&correct, &authors] {
        assert_eq!(v["precompute"]["neighbours_folded_past_90"], 2);
        assert_eq!(v["precompute"]["neighbours_folded_past_135"], 2);
    }
    // Linear interpolation never reads the neighbours; BPM does.
    assert_eq!(correct["linear"], authors["linear"]);
    assert_ne!(correct["bpm"]["mean"], authors["bpm"]["mean"]);
    // The default is the correct unfolding.
    let (code, stdout, stderr) = reparam(&[
        "bpm",
        "qc",
        "procedural:folded_star",
        "--subdiv",
        "2",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let default: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(default["unfold"], "Correct");
    assert_eq!(default["bpm"], correct["bpm"]);
}

#[test]
fn bpm_render_refuses_the_authors_unfolding_on_the_gpu() {
    let (code, _, stderr) = reparam(&[
        "bpm",
        "render",
        "procedural:folded_star",
        "--backend",
        "gpu",
        "--unfold",
        "authors",
    ]);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("--unfold authors needs --backend cpu"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn bpm_render_writes_a_png() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cone.png");
    let (code, stdout, stderr) = reparam(&[
        "bpm",
        "render",
        "procedural:cone",
        "--size",
        "64x48",
        "-o",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["width"], 64);
    let img = reparam::texture::load_rgba8(&out).unwrap();
    assert_eq!((img.width, img.height), (64, 48));
}

#[test]
fn an_obj_without_uvs_gives_a_clear_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no_uv.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let (code, _, stderr) = reparam(&["bpm", "qc", path.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("no_uv.obj") && stderr.contains("texture coordinates"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn a_missing_texture_and_a_missing_file_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("m.obj");
    std::fs::write(dir.path().join("m.mtl"), "newmtl a\nmap_Kd gone.png\n").unwrap();
    std::fs::write(&obj, "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\nf 1/1 2/2 3/3\n").unwrap();
    let out = dir.path().join("x.png");
    let (code, _, stderr) = reparam(&[
        "bpm",
        "render",
        obj.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("gone.png") && stderr.contains("--texture"),
        "{stderr}"
    );

    let (code, _, stderr) = reparam(&["bpm", "qc", "/definitely/not/here.obj"]);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("/definitely/not/here.obj") && !stderr.contains("panicked"),
        "{stderr}"
    );

    let (code, _, stderr) = reparam(&["bpm", "qc", "procedural:no_such_mesh"]);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("no_such_mesh") && stderr.contains("cone"),
        "{stderr}"
    );
}

#[test]
fn gridwarp_prints_json_and_reduces_rigid_stretch() {
    let dir = tempfile::tempdir().unwrap();
    let (code, stdout, stderr) = reparam(&[
        "gridwarp",
        "--scene",
        "plane",
        "--frames",
        "2",
        "--size",
        "32",
        "--out",
        dir.path().to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let last = &v["rois"][0]["frames"][1];
    // The warp must lower the stretch of rigid features (the point of the method).
    assert!(
        last["rigid_stretch_after"]["max"].as_f64().unwrap()
            < last["rigid_stretch_before"]["max"].as_f64().unwrap()
    );
    assert!(last["energy_after"].as_f64().unwrap() < last["energy_before"].as_f64().unwrap());
    assert!(
        dir.path().join("gridwarp_plane_grid.png").exists()
            && dir.path().join("gridwarp_plane_lines.json").exists()
    );
    let (code, _, stderr) = reparam(&[
        "gridwarp",
        "--scene",
        "plane",
        "--grid",
        "1x5",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(code != 0 && stderr.contains("--grid"), "{stderr}");
}

#[test]
fn bpm_qc_on_only_degenerate_faces_is_an_error_not_null_figures() {
    // Issue #25: every face skipped left the QC mean and percentiles NaN (`null`) with exit 0.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flat.obj");
    std::fs::write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let (code, stdout, stderr) = reparam(&["bpm", "qc", path.to_str().unwrap(), "--json"]);
    assert_ne!(code, 0, "{stdout}");
    assert!(!stdout.contains("null"), "{stdout}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("flat.obj") && stderr.contains("no face can be measured"),
        "{stderr}"
    );
}

#[test]
fn the_200000_corner_polygon_of_issue_25_is_measured_and_rendered_quickly() {
    // One face line of 200 000 corners cycling over three vertices (800 KB): 199 998 faces,
    // four edges each shared by tens of thousands of them. Before: minutes (quadratic).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("polygon.obj");
    let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf");
    for k in 0..200_000 {
        text += &format!(" {0}/{0}", k % 3 + 1);
    }
    std::fs::write(&path, text + "\n").unwrap();
    let start = std::time::Instant::now();
    let (code, stdout, stderr) = reparam(&[
        "bpm",
        "qc",
        path.to_str().unwrap(),
        "--subdiv",
        "0",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["precompute"]["faces"], 199_998);
    assert_eq!(v["precompute"]["non_manifold_edges"], 4);
    assert!(v["bpm"]["mean"].as_f64().unwrap().is_finite(), "{stdout}");
    let out = dir.path().join("polygon.png");
    let (code, _, stderr) = reparam(&[
        "bpm",
        "render",
        path.to_str().unwrap(),
        "--size",
        "32x32",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    // About 1 s in a debug build on a loaded machine; the quadratic code took minutes.
    let took = start.elapsed();
    assert!(took < std::time::Duration::from_secs(30), "took {took:?}");
}
