//! The canonical inputs and golden f64 outputs kept in `reference_data/`: small meshes written
//! by reparam itself from `mesh::procedural`, and the reference's results on them at fixed
//! points, in full precision (JSON numbers are written in shortest round-trip form).
//!
//! `reparam reference-data` regenerates the folder; `tests/reference_data.rs` checks that the
//! files still equal what the generators and the reference produce. Users comparing their own
//! implementation against reparam can read these files without building anything.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::bpm::{precompute, BpmOptions, Interp};
use crate::error::{Error, Result};
use crate::mesh::{io::write_obj, procedural, TriMesh};

/// The BPM cases: file stem and mesh.
pub fn bpm_cases() -> Vec<(&'static str, TriMesh)> {
    vec![
        ("cone_fan_8", procedural::cone_fan(8, 0.8)),
        ("torus_12x6", procedural::torus(12, 6, 1.0, 0.35)),
        ("two_charts_mirrored_3", procedural::two_charts_mirrored(3)),
    ]
}

/// One golden value: the interpolated UV at a point of a face.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoldenSample {
    pub face: u32,
    pub bary: [f64; 3],
    pub bpm: [f64; 2],
    pub linear: [f64; 2],
}

/// Golden BPM values on one mesh (default options: local fit, entire exp/log, right order).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoldenBpm {
    pub mesh: String,
    pub how: String,
    pub samples: Vec<GoldenSample>,
}

/// The fixed points of every face at which golden values are stored.
pub const GOLDEN_BARY: [[f64; 3]; 4] = [
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [0.6, 0.3, 0.1],
    [0.05, 0.5, 0.45],
    [0.5, 0.5, 0.0],
];

/// Evaluate the reference on `mesh` at [`GOLDEN_BARY`] of every face.
pub fn bpm_golden(mesh: &TriMesh) -> Result<GoldenBpm> {
    let bpm = precompute(mesh, BpmOptions::default())?;
    let mut samples = Vec::new();
    for face in 0..mesh.face_count() {
        for bary in GOLDEN_BARY {
            let [b, l] = [Interp::Bpm, Interp::Linear].map(|i| {
                let w = bpm.eval(face, bary, i);
                [w.re, w.im]
            });
            samples.push(GoldenSample {
                face: face as u32,
                bary,
                bpm: b,
                linear: l,
            });
        }
    }
    Ok(GoldenBpm {
        mesh: mesh.name.clone(),
        how: "reparam reference-data: bpm::precompute with BpmOptions::default(), Bpm::eval".into(),
        samples,
    })
}

/// Write every case to `dir/bpm/<stem>.obj` and `dir/bpm/<stem>.golden.json`.
pub fn write_all(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for (stem, mesh) in bpm_cases() {
        let obj = dir.join("bpm").join(format!("{stem}.obj"));
        write_obj(&mesh, &obj)?;
        let json = dir.join("bpm").join(format!("{stem}.golden.json"));
        let text = serde_json::to_string_pretty(&bpm_golden(&mesh)?)
            .map_err(|e| Error::InvalidArgument(format!("cannot serialise golden values: {e}")))?;
        std::fs::write(&json, text).map_err(|e| Error::io(&json, e))?;
        written.extend([obj, json]);
    }
    #[cfg(feature = "gpu")]
    written.extend(crate::vectors::write_canonical(&dir.join("vectors"))?);
    Ok(written)
}

/// Read a golden file.
pub fn read_golden(path: &Path) -> Result<GoldenBpm> {
    let text = crate::input::read_input_text(path)?;
    serde_json::from_str(&text).map_err(|e| Error::MeshParse {
        path: path.into(),
        message: e.to_string(),
    })
}
