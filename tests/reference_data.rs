//! reference_data/ still equals what reparam generates: the canonical meshes are exactly the
//! procedural ones, and the golden f64 BPM values are reproduced.

use std::path::Path;

use reparam::bpm::{precompute, BpmOptions, Interp};
use reparam::mesh::io::load_obj;
use reparam::reference_data::{bpm_cases, read_golden};

fn dir() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/reference_data/bpm"))
}

#[test]
fn canonical_meshes_equal_the_generators() {
    for (stem, mesh) in bpm_cases() {
        let loaded = load_obj(&dir().join(format!("{stem}.obj"))).unwrap();
        // OBJ numbers are written in shortest round-trip form: equality is exact.
        assert_eq!(loaded.positions, mesh.positions, "{stem}");
        assert_eq!(loaded.uvs, mesh.uvs, "{stem}");
        assert_eq!(loaded.faces, mesh.faces, "{stem}");
        assert_eq!(loaded.uv_faces, mesh.uv_faces, "{stem}");
    }
}

#[test]
fn golden_bpm_values_are_reproduced() {
    for (stem, _) in bpm_cases() {
        let mesh = load_obj(&dir().join(format!("{stem}.obj"))).unwrap();
        let golden = read_golden(&dir().join(format!("{stem}.golden.json"))).unwrap();
        let bpm = precompute(&mesh, BpmOptions::default()).unwrap();
        assert_eq!(golden.samples.len(), 4 * mesh.face_count());
        for s in &golden.samples {
            for (interp, expected) in [(Interp::Bpm, s.bpm), (Interp::Linear, s.linear)] {
                let w = bpm.eval(s.face as usize, s.bary, interp);
                // Bit-identical on the machine that wrote them; elsewhere libm's cosh/sinh/ln may
                // differ in the last ulp, amplified by the maps' conditioning (≲ 10² here).
                let err = (w.re - expected[0]).abs().max((w.im - expected[1]).abs());
                assert!(err < 1e-13, "{stem} face {} {interp:?}: {err:e}", s.face);
            }
        }
    }
}
