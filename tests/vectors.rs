//! Conformance vectors: arrays round-trip bit for bit, the current reference reproduces
//! `reference_data/vectors` to 1e-13, reparam's own GPU outputs verify for every kernel, and
//! `verify` fails a candidate one element of which is off by twice its bound (naming it), or
//! which holds a NaN; a wrong shape or dtype is a typed error (exit 2 from the CLI).
#![cfg(feature = "gpu")]
// `!(e <= bound)` is meant: a NaN counts as a difference.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod common;

use std::path::{Path, PathBuf};

use common::cli::reparam;
use reparam::vectors::verify::verify;
use reparam::vectors::{canonical, read_manifest, write_vectors, Array, Metric, ALGORITHMS};
use reparam_gpu::gpu_or_skip;

fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors")
}

#[test]
fn arrays_round_trip_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let arrays = [
        Array::f64(
            &[2, 3],
            vec![1.0, -0.0, f64::MIN_POSITIVE, 1e300, -2.5, 1.0 / 3.0],
        ),
        Array::f32(&[3], vec![0.1, f32::MAX, -7.0]),
        Array::u32(&[2, 2], vec![0, 1, u32::MAX, 7]),
        Array::i32(&[1], vec![-1]),
    ];
    for (n, a) in arrays.iter().enumerate() {
        let path = dir.path().join(format!("{n}.npy"));
        a.save(&path).unwrap();
        assert_eq!(&Array::load(&path).unwrap(), a);
    }
}

/// `a` and `b` agree to 1e-13 of the larger magnitude (the array's largest, for values near 0).
fn close(a: &[f64], b: &[f64]) -> Option<usize> {
    let scale = b
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()))
        .max(f64::MIN_POSITIVE);
    a.iter()
        .zip(b)
        .position(|(x, y)| !((x - y).abs() <= 1e-13 * scale.max(y.abs())))
}

#[test]
fn the_reference_reproduces_the_canonical_vectors() {
    for algorithm in ALGORITHMS {
        let dir = reference_dir().join(algorithm);
        let manifest = read_manifest(&dir).unwrap();
        let (_, kernels) = canonical(algorithm).unwrap();
        assert_eq!(manifest.kernels.len(), kernels.len(), "{algorithm}");
        for (info, k) in manifest.kernels.iter().zip(&kernels) {
            assert_eq!(info.name, k.name);
            // Inputs: exactly what the kernel receives (f32 / integer arrays, bit for bit).
            for (file, (_, _, a)) in info.inputs.iter().zip(&k.inputs) {
                let stored = Array::load(&dir.join(&file.file)).unwrap();
                assert_eq!(&stored, a, "{}: {}", k.name, file.file);
            }
            // Expected outputs and bounds: the f64 reference, to 1e-13 relative (libm's last ulps
            // may differ between machines).
            for (file, a) in [(&info.expected, &k.expected.1), (&info.bound, &k.bound.1)] {
                let stored = Array::load(&dir.join(&file.file)).unwrap();
                assert_eq!(stored.shape, a.shape, "{}", file.file);
                if let Some(n) = close(&a.to_f64(), &stored.to_f64()) {
                    panic!("{}: element {n} differs", file.file);
                }
            }
        }
    }
}

/// The vectors of `algorithm` on the canonical input in a temporary folder, with reparam's
/// own GPU candidates.
fn vectors_with_gpu_candidates(
    gpu: &reparam_gpu::Gpu,
    algorithm: &str,
    dir: &Path,
) -> Vec<(String, Array)> {
    let (kernels, candidates) = match algorithm {
        "bpm" => {
            let mesh = reparam::mesh::procedural::flat_star(12);
            (
                reparam::vectors::bpm::vectors(&mesh).unwrap(),
                reparam::vectors::bpm::gpu_candidates(gpu, &mesh).unwrap(),
            )
        }
        "gridwarp" => {
            use reparam::gridwarp::scene::{disc_rigidity, plane_stretch};
            let scene = plane_stretch(32, 1, 2.0, disc_rigidity(32, &[(0.6, 0.5, 0.2)], 0.1));
            let grid = reparam::gridwarp::Grid::uniform(5, 5);
            let options = reparam::gridwarp::SolveOptions {
                samples: (4, 4),
                ..Default::default()
            };
            reparam::vectors::gridwarp::all_vectors(
                Some(gpu),
                &scene.rest,
                &grid,
                &scene.frames,
                &options,
            )
            .unwrap()
        }
        "unwarp" => {
            let heights = reparam::unwarp::procedural("cones", 16).unwrap();
            reparam::vectors::unwarp::vectors(Some(gpu), &heights, &Default::default()).unwrap()
        }
        "maps" => {
            let (built, remesh) = reparam::vectors::canonical_maps().unwrap();
            let rings = reparam::vectors::canonical_rings(&built).unwrap();
            reparam::vectors::maps::all_vectors(Some(gpu), &built, &remesh, &rings).unwrap()
        }
        "skinsimp" => {
            let kernels = reparam::skinsimp::gpu::SkinsimpKernels::new(gpu.clone()).unwrap();
            let (model, sets) = reparam::vectors::canonical_skinned().unwrap();
            reparam::vectors::skinsimp::all_vectors(&model, &sets, Some(&kernels)).unwrap()
        }
        _ => unreachable!(),
    };
    write_vectors(dir, "test", algorithm, &kernels).unwrap();
    assert_eq!(
        candidates.len(),
        kernels.len(),
        "{algorithm}: a candidate per kernel"
    );
    candidates
}

#[test]
fn reparams_own_gpu_outputs_verify_for_every_kernel() {
    let Some(gpu) = gpu_or_skip() else { return };
    let root = tempfile::tempdir().unwrap();
    for algorithm in ALGORITHMS {
        let dir = root.path().join(algorithm);
        for (name, candidate) in vectors_with_gpu_candidates(&gpu, algorithm, &dir) {
            let path = dir.join(format!("candidate.{name}.npy"));
            candidate.save(&path).unwrap();
            let r = verify(&dir, &path, Some(&name)).unwrap();
            assert!(r.pass, "{name}: {:?}", r.errors);
            assert!(r.errors.count > 0);
        }
    }
}

#[test]
fn a_candidate_off_by_twice_its_bound_at_one_element_fails_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let (_, kernels) = canonical("bpm").unwrap();
    let manifest = write_vectors(dir.path(), "test", "star", &kernels).unwrap();
    let k = &manifest.kernels[0];
    let expected = Array::load(&dir.path().join(&k.expected.file)).unwrap();
    let bound = Array::load(&dir.path().join(&k.bound.file))
        .unwrap()
        .to_f64();
    let scale = match &k.metric {
        Metric::NormOfLastAxis { scale, .. } => *scale,
        other => panic!("bpm_eval's metric is a vector norm, not {other:?}"),
    };
    // The exact reference passes.
    let exact = dir.path().join("exact.npy");
    expected.save(&exact).unwrap();
    assert!(verify(dir.path(), &exact, Some(&k.name)).unwrap().pass);
    // Element 17's u moved by twice its bound.
    let mut values = expected.to_f64();
    values[2 * 17] += 2.0 * bound[17] / scale;
    let off = dir.path().join("off.npy");
    Array::f64(&expected.shape, values.clone())
        .save(&off)
        .unwrap();
    let r = verify(dir.path(), &off, Some(&k.name)).unwrap();
    assert!(!r.pass);
    assert_eq!(r.errors.over_tolerance, 1);
    assert_eq!(r.worst[0].index, vec![17]);
    assert!((r.worst[0].error.unwrap() / r.worst[0].bound - 2.0).abs() < 1e-6);
    // The worst element's inputs: its face and barycentrics.
    assert!(r.worst[0]
        .inputs
        .iter()
        .any(|(name, _)| name.ends_with("face.npy")));
    // A NaN fails too, counted as non-finite.
    values[2 * 17] = f64::NAN;
    Array::f64(&expected.shape, values).save(&off).unwrap();
    let r = verify(dir.path(), &off, Some(&k.name)).unwrap();
    assert!(!r.pass);
    assert_eq!(r.errors.non_finite, 1);
    assert_eq!(r.worst[0].index, vec![17]);
}

#[test]
fn the_cli_verifies_exits_1_on_failure_and_2_on_a_wrong_shape_dtype_or_file() {
    let dir = tempfile::tempdir().unwrap();
    let vectors = dir.path().join("vectors");
    let v = vectors.to_str().unwrap();
    let (code, _, stderr) = reparam(&["vectors", "bpm", "--out", v]);
    assert_eq!(code, 0, "{stderr}");
    let manifest = read_manifest(&vectors).unwrap();
    let k = &manifest.kernels[0];
    let expected = Array::load(&vectors.join(&k.expected.file)).unwrap();
    // The reference itself: exit 0.
    let good = dir.path().join("bpm_eval.npy");
    expected.save(&good).unwrap();
    let (code, stdout, stderr) = reparam(&["verify", v, "--candidate", good.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("pass"), "{stdout}");
    // Off by far more than the bound: exit 1, the element named.
    let mut values = expected.to_f64();
    values[0] += 1.0;
    let bad = dir.path().join("bad.npy");
    Array::f64(&expected.shape, values).save(&bad).unwrap();
    let (code, stdout, _) = reparam(&[
        "verify",
        v,
        "--candidate",
        bad.to_str().unwrap(),
        "--kernel",
        "bpm_eval",
    ]);
    assert_eq!(code, 1);
    assert!(
        stdout.contains("FAIL") && stdout.contains("[0]: error"),
        "{stdout}"
    );
    // A wrong shape, a wrong dtype, a missing file: exit 2 with one line naming the problem.
    let shape = dir.path().join("shape.npy");
    Array::f64(&[3], vec![0.0; 3]).save(&shape).unwrap();
    let (code, _, stderr) = reparam(&[
        "verify",
        v,
        "--candidate",
        shape.to_str().unwrap(),
        "--kernel",
        "bpm_eval",
    ]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("shape [3]") && stderr.contains("expects"),
        "{stderr}"
    );
    let dtype = dir.path().join("dtype.npy");
    Array::u32(&expected.shape, vec![0; expected.len()])
        .save(&dtype)
        .unwrap();
    let (code, _, stderr) = reparam(&[
        "verify",
        v,
        "--candidate",
        dtype.to_str().unwrap(),
        "--kernel",
        "bpm_eval",
    ]);
    assert_eq!(code, 2);
    assert!(stderr.contains("dtype <u4"), "{stderr}");
    let (code, _, stderr) = reparam(&[
        "verify",
        v,
        "--candidate",
        "/nonexistent/out.npy",
        "--kernel",
        "bpm_eval",
    ]);
    assert_eq!(code, 2);
    assert!(stderr.contains("/nonexistent/out.npy"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

#[test]
fn a_whole_run_figure_off_by_twice_its_bound_fails_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let (_, kernels) = canonical("unwarp").unwrap();
    let manifest = write_vectors(dir.path(), "test", "cones", &kernels).unwrap();
    let k = manifest
        .kernels
        .iter()
        .find(|k| k.name == "unwarp_run")
        .expect("the whole-run vectors");
    assert!(matches!(k.metric, Metric::Relative { .. }));
    let expected = Array::load(&dir.path().join(&k.expected.file)).unwrap();
    let bound = Array::load(&dir.path().join(&k.bound.file))
        .unwrap()
        .to_f64();
    // The energy after sweep 4 (row 3), relatively 2 × its bound above the reference.
    let mut values = expected.to_f64();
    values[3] *= 1.0 + 2.0 * bound[3];
    let off = dir.path().join("off.npy");
    Array::f64(&expected.shape, values).save(&off).unwrap();
    let r = verify(dir.path(), &off, Some("unwarp_run")).unwrap();
    assert!(!r.pass);
    assert_eq!(r.errors.over_tolerance, 1);
    assert_eq!(r.worst[0].index, vec![3]);
    assert!((r.worst[0].error.unwrap() / r.worst[0].bound - 2.0).abs() < 1e-6);
}

/// A precompute candidate is per face (faces × 45): the expected array's shape (samples × 2)
/// is refused with the shape it needs.
#[test]
fn a_precompute_candidate_of_the_samples_shape_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (_, kernels) = canonical("bpm").unwrap();
    let manifest = write_vectors(dir.path(), "test", "star", &kernels).unwrap();
    let k = manifest
        .kernels
        .iter()
        .find(|k| k.name == "bpm_precompute")
        .unwrap();
    let wrong = dir.path().join("wrong.npy");
    Array::load(&dir.path().join(&k.expected.file))
        .unwrap()
        .save(&wrong)
        .unwrap();
    let e = verify(dir.path(), &wrong, Some("bpm_precompute"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("[32, 45]"), "{e}");
}

/// The worked example's failing candidate: the seed's determinant fit in f32, as per-triangle
/// data, on the speckle stress mesh (UVs far from the origin compared with the triangles), fails
/// bpm_precompute; reparam's own local fit passes on the same vectors.
#[test]
fn the_seeds_determinant_fit_fails_bpm_precompute_on_the_speckle_mesh() {
    let Some(gpu) = gpu_or_skip() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mesh = reparam::mesh::procedural::tiny_far_uv(8);
    let kernels = reparam::vectors::bpm::vectors(&mesh).unwrap();
    write_vectors(dir.path(), "test", "tiny_far_uv", &kernels).unwrap();
    let own = reparam::vectors::bpm::gpu_candidates(&gpu, &mesh).unwrap();
    let (_, local) = own.iter().find(|(n, _)| n == "bpm_precompute").unwrap();
    let path = dir.path().join("local.npy");
    local.save(&path).unwrap();
    assert!(
        verify(dir.path(), &path, Some("bpm_precompute"))
            .unwrap()
            .pass
    );
    let seed = reparam::vectors::bpm::determinant_fit_maps_candidate(&gpu, &mesh).unwrap();
    let path = dir.path().join("determinant.npy");
    seed.save(&path).unwrap();
    let r = verify(dir.path(), &path, Some("bpm_precompute")).unwrap();
    assert!(!r.pass);
    assert!(r.errors.over_tolerance > 0);
    // The worst sample is named with its face.
    assert!(r.worst[0]
        .inputs
        .iter()
        .any(|(n, _)| n.ends_with("face.npy")));
}

/// `reparam vectors <algorithm> --twins`: every kernel's twin under the 7 arithmetic models on
/// the vectors just written, one row per model, exit 0 when all are within their bounds (the
/// failing side: `crosscheck::sweep`'s unit test of `twins_within_bounds`).
#[test]
fn vectors_twins_prints_every_model_and_passes_on_the_built_in_maps() {
    let out = std::env::temp_dir().join(format!("reparam-twins-{}", std::process::id()));
    let (code, stdout, stderr) =
        reparam(&["vectors", "maps", "--twins", "--out", out.to_str().unwrap()]);
    let _ = std::fs::remove_dir_all(&out);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    for needle in [
        "maps_inverse",
        "maps_priority",
        "maps_flatten.points",
        "worst#2",
        "every twin within its bounds under every model",
    ] {
        assert!(stdout.contains(needle), "{needle}: {stdout}");
    }
}
