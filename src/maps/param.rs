//! Π and Π⁻¹ between the input surface and the base domain (notes "Parameter bookkeeping",
//! "Smoothing and remeshing"; seed "Parameterization (1/3)–(3/3)", "Remeshing (1/5)").
//!
//! Π is the composition of the level maps: each committed removal maps its star faces onto
//! its new faces through the flattened hole μ (old and new faces tile the same planar polygon,
//! each linearly), so Π of a point (face, barycentrics) is found by replaying, from the input
//! face, every removal that deleted the face it is in: u = Σ b_c μ(corner_c), located in the new
//! faces with robust orientations. Π⁻¹ replays the same maps backwards, from a base face through
//! the removals that created each face, locating u in the old star (the fan (0, μ_m, μ_{m+1})).
//! Both directions use the same planar maps, so Π⁻¹(Π(p)) = p up to rounding and every base
//! point has exactly one preimage — Π is a bijection by construction, not by a search among
//! charts (straight triangles in different charts would leave slivers uncovered where charts
//! bend across base edges).

use nalgebra::Point3;

use super::hierarchy::{Location, Removal};
use super::retriangulate::{barycentric, orient2d};

/// A point of the base domain: base face and barycentric coordinates in its corner order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BasePoint {
    /// Base face index.
    pub face: u32,
    /// Barycentric coordinates (sum 1).
    pub bary: [f64; 3],
}

/// A point of the input surface found by Π⁻¹.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Input face index.
    pub face: u32,
    /// Barycentric coordinates in the input face (sum 1, each ≥ 0).
    pub bary: [f64; 3],
    /// Σ bary_c p_c.
    pub position: Point3<f64>,
    /// The smallest barycentric coordinate met on the way before clamping: ≥ 0 when every
    /// step found a containing triangle, a tiny negative number when rounding put the point a
    /// hair outside (then the nearest triangle is used).
    pub min_bary: f64,
}

/// Π and Π⁻¹ of a MAPS hierarchy.
#[derive(Clone, Debug)]
pub struct Param {
    positions: Vec<Point3<f64>>,
    /// Every face of the decimation (input faces first, then faces created by removals).
    faces: Vec<[u32; 3]>,
    created_by: Vec<u32>,
    removed_by: Vec<u32>,
    records: Vec<Removal>,
    /// Base face index → decimation face id, and back (`u32::MAX` for dead faces).
    base_to_face: Vec<u32>,
    face_to_base: Vec<u32>,
    input_faces: usize,
    location: Vec<Location>,
}

impl Param {
    /// Assemble from the decimation's faces and records (see the module docs).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        positions: &[Point3<f64>],
        faces: Vec<[u32; 3]>,
        created_by: Vec<u32>,
        removed_by: Vec<u32>,
        records: Vec<Removal>,
        base_to_face: Vec<u32>,
        input_faces: usize,
        location: Vec<Location>,
    ) -> Param {
        let mut face_to_base = vec![u32::MAX; faces.len()];
        for (b, &f) in base_to_face.iter().enumerate() {
            face_to_base[f as usize] = b as u32;
        }
        Param {
            positions: positions.to_vec(),
            faces,
            created_by,
            removed_by,
            records,
            base_to_face,
            face_to_base,
            input_faces,
            location,
        }
    }

    /// Π of input vertex `v` (the hierarchy's bookkeeping), or `None` for a vertex no face uses.
    pub fn vertex(&self, v: u32) -> Option<BasePoint> {
        let (face, bary) = self.location[v as usize];
        (face != u32::MAX).then_some(BasePoint { face, bary })
    }

    /// Π of the point with barycentrics `b` in input face `f`: replay the removals that deleted
    /// the faces it passes through (module docs). `None` if `f` is not an input face.
    pub fn forward(&self, f: u32, b: [f64; 3]) -> Option<BasePoint> {
        if f as usize >= self.input_faces {
            return None;
        }
        let (face, bary) = self.forward_until(f, b, usize::MAX)?;
        Some(BasePoint {
            face: self.face_to_base[face as usize],
            bary,
        })
    }

    /// Π_l of the point with barycentrics `b` in decimation face `f`: replay only the removals
    /// with commit index below `limit` (the first `limit` records), from `f` onwards. With
    /// `limit` the number of removals committed by the end of level l this is the map from the
    /// input to the mesh after level l (issue #23's per-level distortion); it continues from
    /// any face of an earlier level, so levels can be stepped one after another. Returns a
    /// decimation face id (see [`Param::face`]) and barycentrics; `None` for a face id out of
    /// range.
    pub fn forward_until(&self, f: u32, b: [f64; 3], limit: usize) -> Option<(u32, [f64; 3])> {
        let (mut face, mut bary) = (f, b);
        loop {
            let r = *self.removed_by.get(face as usize)?;
            if r == u32::MAX || r as usize >= limit {
                return Some((face, bary));
            }
            let r = &self.records[r as usize];
            let u = self.to_plane(r, face, bary);
            let new: Vec<[usize; 3]> = (0..r.new_count)
                .map(|n| {
                    let t = self.faces[(r.new_first + n) as usize];
                    t.map(|v| ring_index(r, v).expect("new faces join ring vertices"))
                })
                .collect();
            let (n, l) = super::retriangulate::locate(u, &r.mu, &new);
            face = r.new_first + n as u32;
            bary = clamp(l);
        }
    }

    /// Π⁻¹ of a base point: replay backwards the removals that created the faces it passes
    /// through, locating u in each removal's old star (the fan (0, μ_m, μ_{m+1})), down to an
    /// input face; the 3D point interpolates that face's corners. `None` for a face index out of
    /// range.
    pub fn inverse(&self, p: &BasePoint) -> Option<SurfacePoint> {
        let mut face = *self.base_to_face.get(p.face as usize)?;
        let mut bary = p.bary;
        let mut min_bary = bary.iter().copied().fold(f64::INFINITY, f64::min);
        while self.created_by[face as usize] != u32::MAX {
            let r = &self.records[self.created_by[face as usize] as usize];
            let u = self.to_plane(r, face, bary);
            let (old, l) = self.locate_in_star(r, u);
            min_bary = min_bary.min(l.iter().copied().fold(f64::INFINITY, f64::min));
            face = old;
            bary = clamp(l);
        }
        let tri = self.faces[face as usize];
        let mut position = Point3::origin();
        for c in 0..3 {
            position += self.positions[tri[c] as usize].coords * bary[c];
        }
        Some(SurfacePoint {
            face,
            bary,
            position,
            min_bary,
        })
    }

    /// u = Σ b_c μ(corner_c) in the plane of removal `r` (μ of the removed vertex is 0).
    fn to_plane(&self, r: &Removal, face: u32, b: [f64; 3]) -> [f64; 2] {
        let t = self.faces[face as usize];
        let mut u = [0.0; 2];
        for c in 0..3 {
            if let Some(m) = ring_index(r, t[c]) {
                u[0] += b[c] * r.mu[m][0];
                u[1] += b[c] * r.mu[m][1];
            }
        }
        u
    }

    /// The old star face of `r` containing u (robust orientations; the nearest one when
    /// rounding put u a hair outside), with barycentrics in that face's corner order.
    fn locate_in_star(&self, r: &Removal, u: [f64; 2]) -> (u32, [f64; 3]) {
        let mut best: Option<(f64, u32, [f64; 3])> = None;
        for &f in &r.old_faces {
            let t = self.faces[f as usize];
            let m = t.map(|v| ring_index(r, v).map(|k| r.mu[k]).unwrap_or([0.0, 0.0]));
            let l = barycentric(u, m[0], m[1], m[2]);
            let min = smallest(&l);
            if min >= 0.0 {
                return (f, l);
            }
            if best.as_ref().is_none_or(|b| min > b.0) {
                best = Some((min, f, l));
            }
        }
        let (_, f, l) = best.expect("a star has faces");
        (f, l)
    }

    /// The decimation face id of base face `b` (see [`Param::face`]); `None` out of range.
    pub fn decimation_face(&self, b: u32) -> Option<u32> {
        self.base_to_face.get(b as usize).copied()
    }

    /// The committed removals in order (each level's map; for tests and pictures).
    pub fn removals(&self) -> &[Removal] {
        &self.records
    }

    /// The decimation face `f` (input faces are `0 .. input_faces`). Panics when `f` is out of
    /// range (ids come from this `Param`).
    pub fn face(&self, f: u32) -> [u32; 3] {
        self.faces[f as usize]
    }

    /// Whether every removal's planar maps are orientation preserving: each old fan triangle
    /// (0, μ_m, μ_{m+1}) and each new triangle is strictly counter-clockwise (robust). Returns
    /// the number of triangles that are not (0 for a valid hierarchy).
    pub fn count_flipped(&self) -> usize {
        let mut bad = 0;
        for r in &self.records {
            let k = r.ring.len();
            for (m, &f) in r.old_faces.iter().enumerate() {
                let _ = f;
                if orient2d([0.0, 0.0], r.mu[m], r.mu[(m + 1) % k]) <= 0.0 {
                    bad += 1;
                }
            }
            for n in 0..r.new_count {
                let t = self.faces[(r.new_first + n) as usize];
                let m = t.map(|v| r.mu[ring_index(r, v).expect("ring vertex")]);
                if orient2d(m[0], m[1], m[2]) <= 0.0 {
                    bad += 1;
                }
            }
        }
        bad
    }
}

/// Position of vertex `v` in the ring of removal `r` (`None` for the removed vertex itself).
fn ring_index(r: &Removal, v: u32) -> Option<usize> {
    r.ring.iter().position(|&w| w == v)
}

/// Barycentrics clamped to ≥ 0 and renormalised (removes the ~1e-17 excursions of points that
/// rounding put a hair outside their triangle). Barycentrics that say nothing (NaN, from a
/// triangle flattened to a point or a segment, or all ≤ 0) become the centroid's, so that Π⁻¹
/// stays a point of the face: a spiked grid over a 2-face base domain gave a NaN remesh vertex
/// and an infinite Hausdorff distance (found by the command fuzzer, issue #35).
pub(crate) fn clamp(l: [f64; 3]) -> [f64; 3] {
    let c = l.map(|x| x.max(0.0));
    let s = c[0] + c[1] + c[2];
    if !(s > 0.0 && s.is_finite()) {
        return [1.0 / 3.0; 3];
    }
    c.map(|x| x / s)
}

/// The smallest of three barycentrics, −∞ when one is NaN: the ranking of [`Param`]'s star
/// faces, in which a face with meaningful barycentrics must beat a degenerate one (`f64::min`
/// skips a NaN, and a NaN compares false, so a degenerate first face used to stay the best).
fn smallest(l: &[f64; 3]) -> f64 {
    if l.iter().any(|x| x.is_nan()) {
        return f64::NEG_INFINITY;
    }
    l[0].min(l[1]).min(l[2])
}
