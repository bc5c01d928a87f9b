//! The bound of `maps_inverse`'s positions, per query, derived from the kernel's f32 twin
//! ([`crate::twin::maps_inverse`]) evaluated over [`Lin`](crate::twin::Lin) (issue #34: no constant bounds).
//!
//! For a query, the kernel's output differs from the reference's Π⁻¹ (f64 on the f64 charts)
//! by two parts:
//!
//! - the inputs: the kernel reads the charts and positions rounded to f32. The twin over
//!   [`Lin`](crate::twin::Lin) evaluates Π⁻¹ in f64 on exactly those inputs; its distance to the reference is
//!   computed, not estimated: d_in = ‖Π⁻¹_f64(rounded tables) − Π⁻¹_f64(charts)‖;
//! - the arithmetic: every operation of the walk (to_plane's 3-term sums, each orient2d, the
//!   barycentric quotient, the clamp's renormalisation, the final interpolation) may err as the
//!   WGSL table allows. [`first_order_bound`](crate::twin::lin::first_order_bound) sums |∂p/∂eᵢ| aᵢ over them, along the walk the
//!   reference takes, per coordinate; the bound is [`SECOND_ORDER`](crate::twin::lin::SECOND_ORDER) times that (the
//!   [`crate::twin::lin`] module docs: why 2 covers the neglected terms).
//!
//! The choice of a star face near its edges is not a branch between formulas: the faces' maps
//! agree on the shared edge, so a GPU that takes the neighbour lands on the same point to first
//! order. Where a barycentric quotient's divisor is not trusted to first order (a star face of
//! almost no area in its chart), the bound is [`UNBOUNDED`](crate::crosscheck::bpm_bound::UNBOUNDED).
//!
//! bound = d_in + 2 ‖(b_x, b_y, b_z)‖₂, b_c the first-order bound of coordinate c.

use reparam_gpu::maps::{BaseQuery, InverseTables};

use super::bpm_bound::UNBOUNDED;
use crate::twin::lin::{first_order_bound, record, SECOND_ORDER};
use crate::twin::maps_inverse::{inverse, Tables};
use crate::twin::{Lin, Real, V3};

/// The kernel's tables as flat arrays (the layout of the conformance vectors' inputs).
#[derive(Clone, Debug, Default)]
pub struct FlatTables {
    pub positions: Vec<f32>,
    pub corners: Vec<u32>,
    pub created_by: Vec<u32>,
    pub charts: Vec<f32>,
    pub removals: Vec<u32>,
    pub old_faces: Vec<u32>,
    pub base_to_face: Vec<u32>,
}

impl FlatTables {
    /// Flatten the GPU's tables.
    pub fn of(t: &InverseTables) -> FlatTables {
        FlatTables {
            positions: t.positions.iter().flatten().copied().collect(),
            corners: t.faces.iter().flat_map(|d| d.corners).collect(),
            created_by: t.faces.iter().map(|d| d.created_by).collect(),
            charts: t
                .charts
                .iter()
                .flat_map(|c| c.created.iter().chain(&c.removed).flatten().copied())
                .collect(),
            removals: t.removals.iter().flatten().copied().collect(),
            old_faces: t.old_faces.clone(),
            base_to_face: t.base_to_face.clone(),
        }
    }

    /// The twin's view.
    pub fn tables(&self) -> Tables<'_> {
        Tables {
            positions: &self.positions,
            corners: &self.corners,
            created_by: &self.created_by,
            charts: &self.charts,
            removals: &self.removals,
            old_faces: &self.old_faces,
            base_to_face: &self.base_to_face,
        }
    }
}

/// The bound of query `q`'s position (module docs), `expected` the reference's Π⁻¹ in the
/// frame of `tables`' positions.
pub fn inverse_position_bound(tables: &Tables, q: &BaseQuery, expected: [f64; 3]) -> f64 {
    let (out, ambiguous) = record(|| {
        // On the fresh tape: values made before `record` would point into the old one.
        let bary = V3::new(
            Lin::lit(q.bary[0] as f64),
            Lin::lit(q.bary[1] as f64),
            Lin::lit(q.bary[2] as f64),
        );
        let p = inverse(tables, q.face, bary).position;
        let b = [p.x, p.y, p.z].map(first_order_bound);
        (p, b)
    });
    let (p, b) = out;
    let d_in = [p.x.value(), p.y.value(), p.z.value()]
        .iter()
        .zip(expected)
        .map(|(a, e)| (a - e) * (a - e))
        .sum::<f64>()
        .sqrt();
    let arithmetic = SECOND_ORDER * b.iter().map(|x| x * x).sum::<f64>().sqrt();
    let bound = d_in + arithmetic;
    if ambiguous || !bound.is_finite() {
        UNBOUNDED
    } else {
        bound
    }
}
