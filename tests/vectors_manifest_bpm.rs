//! The canonical BPM manifest says what the data are; this test checks each claim it can
//! against the data themselves, so that an implementer who follows the manifest's words
//! follows the data (issue #33: the manifest once named the log slots "opposite corners
//! i, j, k" while the data stored edges ij, jk, ki).
//!
//! Checked: z_i = 0 and z_j on the positive real axis with |z_j| = |p_j − p_i|; |z_k| and
//! |z_k − z_j| are the other edge lengths; z stored already mirrored (Im z_k < 0) exactly on
//! the faces with flags bit 1 and a clockwise UV triangle; flags bit 0 exactly on the faces
//! with mask bit 3; w_origin = uv_i; M_t maps z_j, z_k to uv − w_origin and has det 1; log
//! slot e is non-zero exactly where mask bit e (edge ij, jk, ki) says a neighbour exists.

use std::path::{Path, PathBuf};

use num_complex::Complex64 as C;
use reparam::vectors::{read_manifest, Array};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors/bpm")
}

/// The array `kernel.name.npy` as f64.
fn load(kernel: &str, name: &str) -> (Vec<f64>, Vec<usize>) {
    let a = Array::load(&dir().join(format!("{kernel}.{name}.npy"))).unwrap();
    (a.to_f64(), a.shape.clone())
}

#[test]
fn the_bpm_manifest_says_what_the_data_are() {
    let manifest = read_manifest(&dir()).unwrap();
    let eval = manifest
        .kernels
        .iter()
        .find(|k| k.name == "bpm_eval")
        .unwrap();
    let maps_meaning = &eval
        .inputs
        .iter()
        .find(|i| i.file.ends_with("maps.npy"))
        .unwrap()
        .meaning;
    // The words this test checks are the manifest's.
    for claim in [
        "z_i = 0 and z_j on the positive real axis (|z_j| = |p_j − p_i|)",
        "already mirrored",
        "w_origin.re, w_origin.im = uv_i",
        "e = 0: ij (corners i→j), 1: jk, 2: ki",
        "det 1; maps z to w − w_origin",
    ] {
        assert!(
            maps_meaning.contains(claim),
            "manifest no longer says: {claim}"
        );
    }

    let (maps, shape) = load("bpm_eval", "maps");
    let (flags, _) = load("bpm_eval", "flags");
    let (star_p, _) = load("bpm_precompute", "star_p");
    let (star_w, _) = load("bpm_precompute", "star_w");
    let (mask, _) = load("bpm_precompute", "mask");
    let faces = shape[0];
    assert_eq!(shape[1], 44);
    let (mut mirrored, mut fallback, mut inner) = (0, 0, 0);
    for f in 0..faces {
        let row = &maps[44 * f..44 * (f + 1)];
        let c = |k: usize| C::new(row[k], row[k + 1]);
        let p = |n: usize| {
            let q = &star_p[18 * f + 3 * n..18 * f + 3 * n + 3];
            nalgebra::Vector3::new(q[0], q[1], q[2])
        };
        let w = |n: usize| C::new(star_w[12 * f + 2 * n], star_w[12 * f + 2 * n + 1]);
        let (flag, m) = (flags[f] as u32, mask[f] as u32);
        // Bit 0 of the flags is mask bit 3 (the degenerate face's linear fallback).
        assert_eq!(
            flag & 1 != 0,
            m & 8 != 0,
            "face {f}: fallback flag and mask"
        );
        // The corner UVs are the star's.
        for (k, n) in [(4, 0), (6, 1), (8, 2)] {
            assert_eq!(c(k), w(n), "face {f}: uv of corner {n}");
        }
        if flag & 1 != 0 {
            fallback += 1;
            continue;
        }
        let (zj, zk) = (c(0), c(2));
        let l = |a: usize, b: usize| (p(b) - p(a)).norm();
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-5 * y.max(1e-3);
        assert!(
            zj.im == 0.0 && zj.re > 0.0,
            "face {f}: z_j on the positive real axis"
        );
        assert!(close(zj.norm(), l(0, 1)), "face {f}: |z_j| = |p_j − p_i|");
        assert!(close(zk.norm(), l(0, 2)), "face {f}: |z_k| = |p_k − p_i|");
        assert!(
            close((zk - zj).norm(), l(1, 2)),
            "face {f}: |z_k − z_j| = |p_k − p_j|"
        );
        // Stored already mirrored: Im z_k < 0 exactly where bit 1 is set, and that is where
        // the UV triangle is clockwise.
        let clockwise = ((w(1) - w(0)).conj() * (w(2) - w(0))).im < 0.0;
        assert_eq!(
            flag & 2 != 0,
            zk.im < 0.0,
            "face {f}: mirrored flag and z_k"
        );
        assert_eq!(
            flag & 2 != 0,
            clockwise,
            "face {f}: mirrored flag and UV orientation"
        );
        mirrored += usize::from(flag & 2 != 0);
        // w_origin = uv_i.
        assert_eq!(c(10), c(4), "face {f}: w_origin = uv_i");
        // M_t: det 1, z_i = 0 ↦ 0, z_j ↦ uv_j − w_origin, z_k ↦ uv_k − w_origin.
        let [a, b, cc, d] = [c(12), c(14), c(16), c(18)];
        let m_t = |z: C| (a * z + b) / (cc * z + d);
        assert!((a * d - b * cc - 1.0).norm() < 1e-4, "face {f}: det M_t");
        let size = (c(6) - c(4)).norm().max((c(8) - c(4)).norm());
        for (z, uv) in [(C::new(0.0, 0.0), c(4)), (zj, c(6)), (zk, c(8))] {
            assert!(
                (m_t(z) - (uv - c(10))).norm() <= 1e-4 * size,
                "face {f}: M_t maps z to w − w_origin"
            );
        }
        // Slot e (edge ij, jk, ki) holds a log exactly where mask bit e says a neighbour
        // shares edge e; its last two values are 0.
        for e in 0..3 {
            let slot = &row[20 + 8 * e..28 + 8 * e];
            assert_eq!(slot[6..], [0.0, 0.0], "face {f} slot {e}");
            let nonzero = slot.iter().any(|&x| x != 0.0);
            assert_eq!(
                nonzero,
                m & (1 << e) != 0,
                "face {f}: slot {e} and mask bit {e}"
            );
            inner += usize::from(nonzero);
        }
    }
    // The canonical mesh exercises each convention (the manifest's `covers`).
    assert!(mirrored > 0 && fallback > 0 && inner > 0 && inner < 3 * (faces - fallback));
}
