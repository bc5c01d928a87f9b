//! Turning command-line words into inputs: meshes (a file or `procedural:<name>`), textures,
//! sizes and directions.

use std::path::Path;

use crate::mesh::{io::load_obj, procedural, TriMesh};
use crate::{Error, Result};
use nalgebra::Vector3;

/// Load a mesh from an OBJ file, or build a built-in one from `procedural:<name>`.
pub fn load_mesh(spec: &str) -> Result<TriMesh> {
    match spec.strip_prefix("procedural:") {
        Some(name) => builtin_mesh(name).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "unknown built-in mesh '{name}'; known: {}",
                BUILTIN_MESHES.join(", ")
            ))
        }),
        None => load_obj(Path::new(spec)),
    }
}

/// Parse `WxH` (e.g. `1024x768`).
pub fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got '{s}'"))?;
    let parse = |x: &str| {
        x.trim()
            .parse::<u32>()
            .map_err(|_| format!("bad size '{s}'"))
    };
    let (w, h) = (parse(w)?, parse(h)?);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size '{s}' out of range (1..16384)"));
    }
    Ok((w, h))
}

/// Parse `x,y,z` into a non-zero direction.
pub fn parse_direction(s: &str) -> std::result::Result<Vector3<f64>, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .map_err(|_| format!("bad direction '{s}'"))
        })
        .collect::<std::result::Result<_, _>>()?;
    match v[..] {
        [x, y, z]
            if (x * x + y * y + z * z) > 0.0 && x.is_finite() && y.is_finite() && z.is_finite() =>
        {
            Ok(Vector3::new(x, y, z))
        }
        _ => Err(format!("expected a non-zero direction x,y,z, got '{s}'")),
    }
}

/// Names accepted after `procedural:`.
pub const BUILTIN_MESHES: [&str; 11] = [
    "star",
    "star_affine",
    "cone",
    "torus",
    "mobius",
    "mirrored",
    "tiny_far_uv",
    "wavy",
    "big_torus",
    "folded_star",
    "bpm_conformance",
];

/// The built-in mesh called `name` (see [`BUILTIN_MESHES`]), at the size the demo uses.
pub fn builtin_mesh(name: &str) -> Option<TriMesh> {
    Some(match name {
        "star" => procedural::flat_star(12),
        "star_affine" => procedural::flat_star_affine(12),
        "cone" => procedural::cone_fan(8, 0.8),
        "torus" => procedural::torus(48, 24, 1.0, 0.35),
        "mobius" => procedural::mobius_mesh(8, procedural::default_mobius()),
        "mirrored" => procedural::two_charts_mirrored(6),
        "tiny_far_uv" => procedural::tiny_far_uv(8),
        "wavy" => procedural::wavy_grid(16),
        "big_torus" => procedural::big_torus(),
        // One neighbour folded by 150°, past the 135° where the authors' unfolding flips it.
        "folded_star" => procedural::folded_star(150f64.to_radians()),
        "bpm_conformance" => procedural::bpm_conformance(),
        _ => return None,
    })
}
