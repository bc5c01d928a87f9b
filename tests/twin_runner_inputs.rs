//! The twin runners over a vectors folder (`src/twin/candidate/`) refuse inconsistent inputs
//! with a typed error naming the kernel, never a panic: a residual kernel whose rest sizes do
//! not match its lines, a source whose corner is not a posed vertex, LBS matrices shorter than
//! [P, J, 12].
#![cfg(feature = "gpu")]

use std::path::Path;

use reparam::twin::candidate::runner;
use reparam::twin::Model;
use reparam::vectors::{read_manifest, Array};
use reparam::Error;

/// A copy of the canonical vectors of `algorithm` with `file` replaced by `array`, then kernel
/// `kernel`'s twin run over it.
fn run_with(algorithm: &str, kernel: &str, file: &str, array: Array) -> reparam::Result<Array> {
    let canonical = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("reference_data/vectors")
        .join(algorithm);
    let dir = tempfile::tempdir().unwrap();
    for entry in std::fs::read_dir(&canonical).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.path().join(path.file_name().unwrap())).unwrap();
    }
    array.save(&dir.path().join(file)).unwrap();
    let manifest = read_manifest(dir.path()).unwrap();
    let k = manifest.kernels.iter().find(|k| k.name == kernel).unwrap();
    runner(kernel).unwrap()(dir.path(), k, Model::Nearest)
}

fn assert_names(result: reparam::Result<Array>, kernel: &str) {
    match result {
        Err(Error::Vectors { file, reason }) => {
            assert_eq!(file, kernel, "{reason}");
        }
        other => panic!("{kernel}: expected a Vectors error, got {other:?}"),
    }
}

#[test]
fn inconsistent_inputs_are_refused_with_the_kernels_name() {
    let k = "gridwarp_aa.residuals";
    assert_names(
        run_with(
            "gridwarp",
            k,
            &format!("{k}.rest_h.npy"),
            Array::f32(&[1], vec![0.5]),
        ),
        k,
    );
    let k = "skinsimp_quadrics.source";
    assert_names(
        run_with(
            "skinsimp",
            k,
            &format!("{k}.corners.npy"),
            Array::f32(&[1, 3], vec![0.0, 1.0, 1e6]),
        ),
        k,
    );
    let k = "skinsimp_lbs";
    assert_names(
        run_with(
            "skinsimp",
            k,
            &format!("{k}.matrices.npy"),
            Array::f32(&[1, 1, 2], vec![1.0, 0.0]),
        ),
        k,
    );
}
