//! The ring batch of the `maps_priority` and `maps_flatten` vectors (`positions`, `neighbours`,
//! `rings`: the kernels' buffers, `maps_rings.wgsl`'s `RingHeader`) read into the twins'
//! [`Ring`]s.

use std::path::Path;

use crate::error::{Error, Result};
use crate::twin::maps_priority::Ring;
use crate::twin::{F, V3};
use crate::vectors::KernelVectors;

/// The rings of kernel `k`'s inputs in `dir`, positions as the f32 the kernel reads: per ring
/// (centre, first, count, kind, s, t, 0, 0) of `rings`, its ring vertices
/// `neighbours[first .. first + count]`, each a row (x, y, z, 0) of `positions`.
pub fn rings(dir: &Path, k: &KernelVectors) -> Result<Vec<Ring<F>>> {
    let positions = k.load_input(dir, "positions")?.to_f64();
    let neighbours = k.load_input(dir, "neighbours")?.to_f64();
    let headers = k.load_input(dir, "rings")?.to_f64();
    let bad = |what: String| Error::Vectors {
        file: dir.display().to_string(),
        reason: format!("{}: {what}", k.name),
    };
    let vertices = positions.len() / 4;
    let point = |v: f64| -> Result<V3<F>> {
        let v = v as usize;
        if v >= vertices {
            return Err(bad(format!("vertex {v} of {vertices}")));
        }
        let p = &positions[4 * v..4 * v + 3];
        Ok(V3::new(
            F::new(p[0] as f32),
            F::new(p[1] as f32),
            F::new(p[2] as f32),
        ))
    };
    headers
        .chunks(8)
        .map(|h| {
            let (first, count) = (h[1] as usize, h[2] as usize);
            let slots = neighbours
                .get(first..first + count)
                .ok_or_else(|| bad(format!("ring slots {first}..{}", first + count)))?;
            Ok(Ring {
                centre: point(h[0])?,
                points: slots.iter().map(|&v| point(v)).collect::<Result<_>>()?,
                kind: h[3] as u32,
                s: h[4] as usize,
                t: h[5] as usize,
            })
        })
        .collect()
}
