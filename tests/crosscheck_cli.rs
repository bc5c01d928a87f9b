//! `reparam crosscheck` end to end: every subcommand on built-in data passes with exit 0, a
//! GPU input perturbed on purpose fails with exit 1 naming the kernel, bad inputs exit 2 with the
//! typed message, `--list-adapters` lists the adapter, and the CLI's bounds are the library's
//! (the same functions the GPU tests hold the kernels to).
//!
//! Without an adapter the GPU cases print `skipped: no GPU adapter` and pass; with
//! REPARAM_REQUIRE_GPU=1 they fail instead. Bad-input cases run either way (exit 2).
#![cfg(feature = "gpu")]

mod common;

use common::cli::reparam;
use reparam_gpu::gpu_or_skip;
use serde_json::Value;

/// The rows of the first adapter of a `--json` report.
fn rows(stdout: &str) -> Vec<Value> {
    let v: Value = serde_json::from_str(stdout).expect("valid JSON");
    v["adapters"][0]["rows"].as_array().expect("rows").clone()
}

fn row<'a>(rows: &'a [Value], kernel: &str) -> &'a Value {
    rows.iter()
        .find(|r| r["kernel"] == kernel)
        .unwrap_or_else(|| panic!("no row {kernel}"))
}

/// One subcommand on built-in data: exit 0, every row judged passes, the adapter named.
fn passes(algorithm: &str) -> Vec<Value> {
    passes_args(&[algorithm])
}

/// [`passes`] with the subcommand's arguments.
fn passes_args(args: &[&str]) -> Vec<Value> {
    let algorithm = args[0];
    let mut all = vec!["crosscheck"];
    all.extend_from_slice(args);
    all.push("--json");
    let (code, stdout, stderr) = reparam(&all);
    assert_eq!(code, 0, "{algorithm}: {stderr}\n{stdout}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert!(v["adapters"][0]["adapter"].as_str().unwrap().len() > 3);
    assert_eq!(v["exit_code"], 0);
    let rows = rows(&stdout);
    assert!(!rows.is_empty());
    for r in &rows {
        assert!(
            ["pass", "info", "missing"].contains(&r["verdict"].as_str().unwrap()),
            "{r}"
        );
    }
    rows
}

#[test]
fn every_subcommand_passes_on_built_in_data() {
    if gpu_or_skip().is_none() {
        return;
    }
    let bpm = passes("bpm");
    for kernel in [
        "bpm_eval: BPM uv",
        "bpm_precompute (local fit) → bpm_eval: uv",
        "bpm_render: colour",
    ] {
        assert_eq!(row(&bpm, kernel)["verdict"], "pass");
    }
    assert_eq!(
        row(&bpm, "bpm_precompute (determinant fit) → bpm_eval: uv")["verdict"],
        "info"
    );
    let gridwarp = passes("gridwarp");
    assert_eq!(row(&gridwarp, "gridwarp_aa: JᵀJ")["verdict"], "pass");
    let naa = passes_args(&[
        "gridwarp",
        "--variant",
        "naa",
        "--size",
        "64",
        "--frames",
        "2",
    ]);
    for r in &naa {
        assert_eq!(r["verdict"], "pass", "{r}");
    }
    assert_eq!(row(&naa, "gridwarp_naa: JᵀJ")["verdict"], "pass");
    let unwarp = passes("unwarp");
    assert_eq!(
        row(&unwarp, "coarse moves (hat-weighted block steps)")["verdict"],
        "missing"
    );
    let maps = passes("maps");
    assert_eq!(
        row(&maps, "maps_inverse: position Π⁻¹(p)")["verdict"],
        "pass"
    );
    let skinsimp = passes("skinsimp");
    assert_eq!(
        row(&skinsimp, "skinsimp_lbs: posed positions")["verdict"],
        "pass"
    );
    // Every kernel of reparam-gpu has a row.
    let all: Vec<String> = [&bpm, &gridwarp, &naa, &unwarp, &maps, &skinsimp]
        .iter()
        .flat_map(|rows| {
            rows.iter()
                .map(|r| r["kernel"].as_str().unwrap().to_string())
        })
        .collect();
    for kernel in [
        "bpm_precompute",
        "bpm_eval",
        "bpm_render",
        "gridwarp_aa",
        "gridwarp_naa",
        "unwarp_pass",
        "unwarp_lookup",
        "maps_priority",
        "maps_flatten",
        "maps_inverse",
        "skinsimp_lbs",
        "skinsimp_quadrics",
        "skinsimp_collapse_cost",
    ] {
        assert!(
            all.iter().any(|k| k.starts_with(kernel)),
            "no row for {kernel}"
        );
    }
}

#[test]
fn all_runs_the_five_and_prints_a_table() {
    if gpu_or_skip().is_none() {
        return;
    }
    let (code, stdout, stderr) = reparam(&["crosscheck", "all"]);
    assert_eq!(code, 0, "{stderr}\n{stdout}");
    for algorithm in ["bpm", "gridwarp", "unwarp", "maps", "skinsimp"] {
        assert!(stdout.contains(algorithm), "{algorithm} missing:\n{stdout}");
    }
    assert!(stdout.contains("adapter: "));
    assert!(stdout.contains("every kernel within its bound"));
}

#[test]
fn a_perturbed_gpu_input_is_reported_over_its_bound_with_exit_1() {
    if gpu_or_skip().is_none() {
        return;
    }
    let (code, stdout, stderr) = reparam(&[
        "crosscheck",
        "bpm",
        "--mesh",
        "procedural:star",
        "--perturb-gpu-input",
        "--json",
    ]);
    assert_eq!(code, 1, "{stderr}");
    let rows = rows(&stdout);
    let eval = row(&rows, "bpm_eval: BPM uv");
    assert_eq!(eval["verdict"], "fail");
    assert!(eval["over"].as_u64().unwrap() > 0);
    assert!(
        stderr.contains("over its bound") && stderr.contains("bpm_eval: BPM uv"),
        "{stderr}"
    );
    // The precompute pipeline was not perturbed: it still passes.
    assert_eq!(
        row(&rows, "bpm_precompute (local fit) → bpm_eval: uv")["verdict"],
        "pass"
    );
}

#[test]
fn the_authors_unfolding_checks_the_eval_kernel_only_and_says_why() {
    if gpu_or_skip().is_none() {
        return;
    }
    let (code, stdout, stderr) = reparam(&[
        "crosscheck",
        "bpm",
        "--mesh",
        "procedural:folded_star",
        "--unfold",
        "authors",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}\n{stdout}");
    let rows = rows(&stdout);
    let kernels: Vec<&str> = rows.iter().map(|r| r["kernel"].as_str().unwrap()).collect();
    // The GPU precompute implements only the correct unfolding: its rows, and the render row
    // built on it, are left out rather than compared against the authors' layout.
    assert_eq!(kernels, ["bpm_eval: BPM uv", "bpm_eval: linear uv"]);
    for r in &rows {
        assert_eq!(r["verdict"], "pass", "{r}");
    }
    let note = rows[0].to_string();
    assert!(
        note.contains("--unfold authors") && note.contains("implements only the correct unfolding"),
        "{note}"
    );
}

#[test]
fn list_adapters_lists_at_least_one() {
    if gpu_or_skip().is_none() {
        return;
    }
    let (code, stdout, stderr) = reparam(&["crosscheck", "--list-adapters"]);
    assert_eq!(code, 0, "{stderr}");
    let lines: Vec<&str> = stdout.lines().collect();
    assert!(lines[0].contains("backend") && lines[0].contains("driver"));
    assert!(lines.len() >= 2, "{stdout}");
    assert!(lines[1].trim_start().starts_with('0'));
}

#[test]
fn an_adapter_that_does_not_exist_exits_2_listing_those_that_do() {
    if gpu_or_skip().is_none() {
        return;
    }
    let (code, _, stderr) = reparam(&["crosscheck", "bpm", "--adapter", "no-such-gpu"]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("no-such-gpu") && stderr.contains("0: "),
        "{stderr}"
    );
}

#[test]
fn bad_inputs_exit_2_with_the_typed_message() {
    let dir = tempfile::tempdir().unwrap();
    // A missing file.
    let missing = dir.path().join("missing.obj");
    let (code, _, stderr) = reparam(&["crosscheck", "bpm", "--mesh", missing.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("missing.obj"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    // A mesh without UVs.
    let no_uv = dir.path().join("no_uv.obj");
    std::fs::write(&no_uv, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let (code, _, stderr) = reparam(&["crosscheck", "bpm", "--mesh", no_uv.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("no_uv.obj") || stderr.contains("texture coordinates"),
        "{stderr}"
    );
    // A glTF without a skin.
    let model = reparam::skinsimp::tube::skinned_tube(4, 4);
    let bytes = reparam::skinsimp::glb::glb_bytes(&model).unwrap();
    let glb = gltf::binary::Glb::from_slice(&bytes).unwrap();
    let mut json: Value = serde_json::from_slice(&glb.json).unwrap();
    json.as_object_mut().unwrap().remove("skins");
    for node in json["nodes"].as_array_mut().unwrap() {
        node.as_object_mut().unwrap().remove("skin");
    }
    let out = gltf::binary::Glb {
        header: glb.header,
        json: serde_json::to_vec(&json).unwrap().into(),
        bin: glb.bin.clone(),
    }
    .to_vec()
    .unwrap();
    let noskin = dir.path().join("noskin.glb");
    std::fs::write(&noskin, out).unwrap();
    let (code, _, stderr) = reparam(&["crosscheck", "skinsimp", noskin.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("noskin.glb") && stderr.contains("no skinned mesh"),
        "{stderr}"
    );
    // No algorithm named.
    let (code, _, stderr) = reparam(&["crosscheck"]);
    assert_eq!(code, 2, "{stderr}");
}

#[test]
fn the_cli_holds_kernels_to_the_bounds_the_tests_use() {
    let Some(gpu) = gpu_or_skip() else { return };
    // BPM: the CLI's per-sample bounds are the library's (`crosscheck::bpm_bound`), the
    // twins' over the same f32 mesh and samples: the rows show their median and largest.
    let (code, stdout, stderr) =
        reparam(&["crosscheck", "bpm", "--mesh", "procedural:star", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let rows = rows(&stdout);
    {
        use reparam::bpm::{precompute, BpmOptions, Interp};
        use reparam::crosscheck::bpm::{crosscheck_samples, round_mesh_to_f32};
        use reparam::crosscheck::bpm_bound::{eval_bounds, pipeline_bounds};
        let mesh = round_mesh_to_f32(&reparam::mesh::procedural::flat_star(12));
        let reference = precompute(&mesh, BpmOptions::default()).unwrap();
        let samples = crosscheck_samples(mesh.face_count());
        let expected = reference.eval_many(&samples, Interp::Bpm);
        let largest = |b: Vec<f64>| b.into_iter().fold(0.0, f64::max);
        let eval = largest(eval_bounds(&reference, &samples, Interp::Bpm, &expected));
        let stars = reparam::bpm::gpu::stars(&mesh).unwrap();
        let pipeline = largest(pipeline_bounds(&stars, &samples, &expected));
        let shown = |kernel: &str| row(&rows, kernel)["bound_max"].as_f64().unwrap();
        let r = |x: f64| reparam::crosscheck::round_significant(x, 3);
        assert_eq!(shown("bpm_eval: BPM uv"), r(eval));
        assert_eq!(
            shown("bpm_precompute (local fit) → bpm_eval: uv"),
            r(pipeline)
        );
    }
    // maps: Π⁻¹'s limit.
    let (code, stdout, stderr) = reparam(&["crosscheck", "maps", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    // Per point from the twin over Lin: positive, and below the notes' target of 1e-5.
    let bound = row(&rows_of(&stdout), "maps_inverse: position Π⁻¹(p)")["bound"]
        .as_f64()
        .unwrap();
    assert!(
        bound > 0.0 && bound < reparam::crosscheck::maps::INVERSE_POSITION_MAX,
        "{bound}"
    );
    // gridwarp: the CLI's rows are the library's rows on the same built-in scene (the GPU test
    // calls the same bound functions), figure for figure.
    let (code, stdout, stderr) = reparam(&["crosscheck", "gridwarp", "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let cli = rows_of(&stdout);
    let scene = reparam::gridwarp::scene::analytic_scene("bump", 6)
        .unwrap()
        .fields(128);
    let rigidity = reparam::gridwarp::scene::analytic_scene("bump", 6)
        .unwrap()
        .rigidity;
    let grid = reparam::gridwarp::grid_from_rigidity(&rigidity, 0.5);
    let lib = reparam::crosscheck::gridwarp::kernel_rows(
        &gpu,
        "bump",
        &scene.rest,
        &grid,
        scene.frames.last().unwrap(),
        (8, 8),
    )
    .unwrap();
    for r in &lib {
        let shown = row(&cli, &r.kernel);
        assert_eq!(
            shown["bound"].as_f64().unwrap(),
            reparam::crosscheck::round_significant(r.bound, 3),
            "{}",
            r.kernel
        );
        assert_eq!(shown["bound_formula"], r.bound_formula.as_str());
    }
}

fn rows_of(stdout: &str) -> Vec<Value> {
    rows(stdout)
}

#[test]
fn the_bpm_sweep_writes_its_table_and_plot() {
    if gpu_or_skip().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (code, stdout, stderr) = reparam(&[
        "crosscheck",
        "bpm",
        "--mesh",
        "procedural:star",
        "--sweep",
        "--json",
        "--plots",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    let sweeps = v["sweeps"].as_array().unwrap();
    assert_eq!(
        sweeps.len(),
        3,
        "UV offset, triangle size, arithmetic models"
    );
    // The arithmetic models: seven, each within the bound (the ratio ≤ 1) and none exactly 0
    // (a bound that every model meets by a factor 10⁶ would be a bound to tighten).
    let models = &sweeps[2]["series"];
    for s in models
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["bound"] == false)
    {
        let points = s["points"].as_array().unwrap();
        assert_eq!(points.len(), 7, "{s}");
        for p in points {
            let ratio = p[1].as_f64().unwrap();
            assert!(ratio <= 1.0 && ratio > 1e-6, "{s}");
        }
    }
    for (sweep, plot) in sweeps.iter().zip(v["plots"].as_array().unwrap()).take(2) {
        let series = sweep["series"].as_array().unwrap();
        let points = |label: &str| -> Vec<(f64, f64)> {
            let s = series.iter().find(|s| s["label"] == label).unwrap();
            s["points"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| (p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
                .collect()
        };
        let (local, det) = (points("local fit"), points("determinant fit"));
        assert_eq!(local.len(), det.len());
        // Where the UVs are far from their triangles' size, the determinant fit speckles (> 1
        // texel) and the local fit stays within its own derived bound.
        let last = local.len() - 1;
        assert!(det[last].1 > 1.0, "{}: {det:?}", sweep["name"]);
        let bound = points("local pipeline bound (largest)");
        assert!(local[last].1 <= bound[last].1, "{local:?} vs {bound:?}");
        let image =
            reparam::texture::load_rgba8(std::path::Path::new(plot.as_str().unwrap())).unwrap();
        assert_eq!((image.width, image.height), (640, 420));
    }
}
