//! Bridge between the f64 MAPS reference and the f32 kernels of `reparam-gpu`
//! (`gpu/src/maps/`, `shaders/maps_priority.wgsl`, `maps_flatten.wgsl`, `maps_inverse.wgsl`).
//!
//! | step | f64 reference | f32 kernel | here |
//! |---|---|---|---|
//! | priority terms a(i), κ(i) | [`super::priority::ring_area`], [`super::priority::curvature`] | `maps_priority` | [`priority_terms_cpu`], [`priority_terms_gpu`], [`crosscheck_priority`] |
//! | z^a flattening of every ring of a level | [`super::flatten::cumulative_angles`], [`super::flatten::flatten_ring`] | `maps_flatten` | [`flatten_cpu`], [`flatten_gpu`], [`crosscheck_flatten`] |
//! | Π⁻¹ of base points | [`super::Param::inverse`] | `maps_inverse` | [`inverse_tables`], [`inverse_gpu`], [`crosscheck_inverse`] |
//!
//! Combinatorial decisions stay on the CPU: which rings exist and their shape ([`level_rings`]),
//! the hierarchy's removals, planes μ and faces ([`inverse_tables`]). The kernels evaluate the
//! formulas.
//!
//! Inputs: positions are centred on the bounding box's centre and divided by its diagonal
//! ([`normalise`]), so lengths are fractions of the diagonal and f32 keeps its relative precision
//! whatever the model's units. For the priority terms and the flattening the reference runs on
//! the same f32-rounded normalised positions (identical inputs: the comparison measures the
//! kernel's f32 arithmetic only). Π⁻¹ is compared with [`super::Param::inverse`] itself: the
//! kernel gets the f64 hierarchy's μ rounded to f32 (barycentrics do not depend on a plane's
//! scale, so μ is not normalised) and the rounded normalised positions.

// `!(e <= bound)` is meant throughout: a NaN error counts as over any bound.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{Point3, Vector3};
use reparam_gpu::maps::inverse::{InverseKernel, NONE};
use reparam_gpu::maps::{
    flatten, priority, BaseQuery, DecimationFace, FaceCharts, FlatPoint, FlatRing, InverseResult,
    InverseTables, RingHeader, Rings, KIND_DISK, KIND_FEATURE_LINE, KIND_HALF_DISK, STATUS_OK,
};
use reparam_gpu::Gpu;

use super::features::Features;
use super::flatten::{cumulative_angles, flatten_ring, FlattenReject, RingShape};
use super::hierarchy::Work;
use super::param::BasePoint;
use super::priority::{curvature, ring_area, star_normal};
use super::Maps;
use crate::crosscheck::maps_bound::{flatten_bounds, flatten_reference, priority_bounds};
use crate::crosscheck::ErrorSummary;
use crate::error::{Error, Result};

fn gpu_error(e: reparam_gpu::GpuError) -> Error {
    Error::Gpu(e.to_string())
}

/// A GPU context ([`Error::Gpu`] when there is no adapter).
pub fn context() -> Result<Gpu> {
    Gpu::new().map_err(gpu_error)
}

/// Positions in the kernels' frame: p' = (p − centre)/diagonal (bounding box), rounded to f32.
#[derive(Clone, Debug)]
pub struct Normalised {
    /// The bounding box's centre.
    pub centre: Point3<f64>,
    /// The bounding box's diagonal.
    pub diagonal: f64,
    /// p' rounded to f32, w = 0 (what the kernels read).
    pub gpu: Vec<[f32; 4]>,
    /// The same rounded values in f64 (what the reference runs on for identical inputs).
    pub cpu: Vec<Point3<f64>>,
}

impl Normalised {
    /// p' = (p − centre)/diagonal in f64 (not rounded).
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        Point3::from((p - self.centre) / self.diagonal)
    }
}

/// [`Normalised`] positions. [`Error::InvalidArgument`] for no positions, a non-finite
/// coordinate or a zero diagonal.
pub fn normalise(positions: &[Point3<f64>]) -> Result<Normalised> {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in positions {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let diagonal = (hi - lo).norm();
    if positions.is_empty() || !diagonal.is_finite() || diagonal <= 0.0 {
        return Err(Error::InvalidArgument(format!(
            "cannot normalise {} positions (bounding box diagonal {diagonal})",
            positions.len()
        )));
    }
    let centre = Point3::from((lo + hi) / 2.0);
    let gpu: Vec<[f32; 4]> = positions
        .iter()
        .map(|p| {
            let q = (p - centre) / diagonal;
            [q.x as f32, q.y as f32, q.z as f32, 0.0]
        })
        .collect();
    let cpu = gpu
        .iter()
        .map(|q| Point3::new(q[0] as f64, q[1] as f64, q[2] as f64))
        .collect();
    Ok(Normalised {
        centre,
        diagonal,
        gpu,
        cpu,
    })
}

/// The flattenable 1-rings of a level: every vertex of `faces` whose star is one fan of 3 or more
/// ring vertices and which is not a corner, with the ring and shape the hierarchy would use
/// (`Work::ring`, `Work::shape`; any degree — the hierarchy's degree limit is not applied).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelRings {
    /// The centre vertices, increasing.
    pub vertices: Vec<u32>,
    /// Ring vertices j_0 … j_{K−1} of each (counter-clockwise).
    pub rings: Vec<Vec<u32>>,
    /// The star faces of each, in ring order.
    pub stars: Vec<Vec<[u32; 3]>>,
    /// The flattening's shape of each.
    pub shapes: Vec<RingShape>,
}

impl LevelRings {
    /// Total ring slots Σ K.
    pub fn slot_count(&self) -> usize {
        self.rings.iter().map(Vec::len).sum()
    }
}

/// The rings of the mesh (`positions`, `faces`) with `features` (tags) and the corner threshold
/// `corner_turn` ([`super::MapsOptions::corner_turn`]). For `faces` = [`super::Level::faces`] of a
/// level, these are that level's rings; the shapes use `features` as tagged on the input, which
/// is exact at level 0 and at every level of a mesh without tagged feature edges (the hierarchy
/// moves a removed feature vertex's tags onto its chord; the levels do not store the moved tags).
pub fn level_rings(
    positions: &[Point3<f64>],
    faces: &[[u32; 3]],
    features: &Features,
    corner_turn: f64,
) -> LevelRings {
    let work = Work::new(positions, faces, features, corner_turn);
    let mut out = LevelRings::default();
    for v in 0..positions.len() as u32 {
        if !work.vert_alive[v as usize] || work.corner[v as usize] {
            continue;
        }
        let Some(ring) = work.ring(v) else { continue };
        if ring.verts.len() < 3 {
            continue;
        }
        let Some(shape) = work.shape(v, &ring) else {
            continue;
        };
        out.vertices.push(v);
        out.stars
            .push(ring.faces.iter().map(|&f| work.faces[f as usize]).collect());
        out.rings.push(ring.verts);
        out.shapes.push(shape);
    }
    out
}

/// The kernels' batch of `rings` over the normalised positions `positions`.
pub fn rings_batch(positions: &[[f32; 4]], rings: &LevelRings) -> Rings {
    let mut batch = Rings {
        positions: positions.to_vec(),
        neighbours: Vec::with_capacity(rings.slot_count()),
        rings: Vec::with_capacity(rings.vertices.len()),
    };
    for ((&v, ring), shape) in rings.vertices.iter().zip(&rings.rings).zip(&rings.shapes) {
        let (kind, s, t) = match *shape {
            RingShape::Disk => (KIND_DISK, 0, 0),
            RingShape::HalfDisk => (KIND_HALF_DISK, 0, 0),
            RingShape::FeatureLine { s, t } => (KIND_FEATURE_LINE, s as u32, t as u32),
        };
        batch.rings.push(RingHeader {
            centre: v,
            first: batch.neighbours.len() as u32,
            count: ring.len() as u32,
            kind,
            s,
            t,
            _pad: [0; 2],
        });
        batch.neighbours.extend(ring);
    }
    batch
}

fn ring_points(positions: &[Point3<f64>], ring: &[u32]) -> Vec<Point3<f64>> {
    ring.iter().map(|&w| positions[w as usize]).collect()
}

/// The reference's priority terms [a(i), κ(i)] of every ring: `ring_area` of the star and
/// `curvature` with the `star_normal` (exactly the hierarchy's candidate computation).
pub fn priority_terms_cpu(positions: &[Point3<f64>], rings: &LevelRings) -> Vec<[f64; 2]> {
    rings
        .vertices
        .iter()
        .zip(&rings.rings)
        .zip(&rings.stars)
        .map(|((&v, ring), star)| {
            let pts = ring_points(positions, ring);
            [
                ring_area(positions, star),
                curvature(&positions[v as usize], &pts, &star_normal(positions, star)),
            ]
        })
        .collect()
}

/// The `maps_priority` kernel's [a(i), κ(i)] of every ring of `batch`.
pub fn priority_terms_gpu(gpu: &Gpu, batch: &Rings) -> Result<Vec<[f64; 2]>> {
    Ok(priority::run(gpu, batch)
        .map_err(gpu_error)?
        .iter()
        .map(|t| [t.area as f64, t.kappa as f64])
        .collect())
}

/// Priority terms on the GPU against the reference, from identical inputs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PriorityCrosscheck {
    /// Rings compared.
    pub rings: usize,
    /// |Δa|/a (tolerance: the largest relative area bound).
    pub area: ErrorSummary,
    /// |Δκ| in units of 1/diagonal (tolerance: the largest finite κ bound).
    pub kappa: ErrorSummary,
    /// Rings whose error exceeds their own bound ([`priority_bounds`]).
    pub area_over_bound: usize,
    pub kappa_over_bound: usize,
    /// max error/bound over the rings.
    pub area_worst_ratio: f64,
    pub kappa_worst_ratio: f64,
    /// Rings whose fit the WGSL table cannot bound (a singular or nearly singular fit, a
    /// cancelling normal: bound infinite; κ not compared).
    pub kappa_singular: usize,
}

/// Run `maps_priority` on `rings` over `positions` (normalised and rounded with [`normalise`])
/// and compare with [`priority_terms_cpu`] on the same values, ring by ring against its own
/// [`priority_bounds`] (the kernel's twin over the WGSL accuracy table).
pub fn crosscheck_priority(
    gpu: &Gpu,
    positions: &Normalised,
    rings: &LevelRings,
) -> Result<PriorityCrosscheck> {
    let gpu_terms = priority_terms_gpu(gpu, &rings_batch(&positions.gpu, rings))?;
    let cpu_terms = priority_terms_cpu(&positions.cpu, rings);
    let pos = &positions.cpu;
    let (mut area_err, mut area_mag, mut kappa_err, mut kappa_mag) =
        (vec![], vec![], vec![], vec![]);
    let (mut area_over, mut kappa_over, mut singular) = (0, 0, 0);
    let (mut area_ratio, mut kappa_ratio, mut area_tol, mut kappa_tol) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (r, (g, c)) in gpu_terms.iter().zip(&cpu_terms).enumerate() {
        let [ab, kb] =
            priority_bounds(pos, rings.vertices[r], &rings.rings[r], rings.shapes[r], *c);
        let da = (g[0] - c[0]).abs();
        area_err.push(da / c[0]);
        area_mag.push(1.0);
        area_tol = area_tol.max(ab / c[0]);
        area_ratio = area_ratio.max(da / ab);
        area_over += usize::from(!(da <= ab));
        if !kb.is_finite() {
            singular += 1;
            continue;
        }
        let dk = (g[1] - c[1]).abs();
        kappa_err.push(dk);
        kappa_mag.push(c[1]);
        kappa_tol = kappa_tol.max(kb);
        kappa_ratio = kappa_ratio.max(dk / kb);
        kappa_over += usize::from(!(dk <= kb));
    }
    Ok(PriorityCrosscheck {
        rings: rings.vertices.len(),
        area: ErrorSummary::from_errors("relative", &area_err, &area_mag, area_tol),
        kappa: ErrorSummary::from_errors("1/diagonal", &kappa_err, &kappa_mag, kappa_tol),
        area_over_bound: area_over,
        kappa_over_bound: kappa_over,
        area_worst_ratio: area_ratio,
        kappa_worst_ratio: kappa_ratio,
        kappa_singular: singular,
    })
}

/// The reference's flattening of one ring: θ ([`cumulative_angles`]: K + 1 entries closed, K
/// open) and μ ([`flatten_ring`], or its rejection).
pub type FlattenedRing = (Vec<f64>, std::result::Result<Vec<[f64; 2]>, FlattenReject>);

/// The reference's flattening of every ring ([`FlattenedRing`]).
pub fn flatten_cpu(positions: &[Point3<f64>], rings: &LevelRings) -> Vec<FlattenedRing> {
    rings
        .vertices
        .iter()
        .zip(&rings.rings)
        .zip(&rings.shapes)
        .map(|((&v, ring), &shape)| {
            let centre = positions[v as usize];
            let pts = ring_points(positions, ring);
            let closed = !matches!(shape, RingShape::HalfDisk);
            (
                cumulative_angles(&centre, &pts, closed),
                flatten_ring(&centre, &pts, shape),
            )
        })
        .collect()
}

/// The `maps_flatten` kernel's output for `batch`: per ring and per slot.
pub fn flatten_gpu(gpu: &Gpu, batch: &Rings) -> Result<(Vec<FlatRing>, Vec<FlatPoint>)> {
    flatten::run(gpu, batch).map_err(gpu_error)
}

/// Flattening on the GPU against the reference, from identical inputs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FlattenCrosscheck {
    /// Rings compared.
    pub rings: usize,
    /// |Δθ_k| in radians over every slot and total (tolerance: the largest bound).
    pub theta: ErrorSummary,
    /// |Δa|/a (a and a₂) over the rings both sides flattened (tolerance: the largest relative
    /// bound).
    pub a: ErrorSummary,
    /// |Δμ_k|/|μ_k| over the slots of rings both sides flattened (tolerance: the largest
    /// relative bound).
    pub mu: ErrorSummary,
    /// Slots whose θ or μ error, rings whose a or a₂ error, exceeds its own bound
    /// ([`flatten_bounds`]).
    pub theta_over_bound: usize,
    pub a_over_bound: usize,
    pub mu_over_bound: usize,
    /// max error/bound.
    pub theta_worst_ratio: f64,
    pub a_worst_ratio: f64,
    pub mu_worst_ratio: f64,
    /// Rings the reference rejected (degenerate, flipped fan).
    pub rejected: usize,
    /// Rings whose kernel status differs from the reference's decision.
    pub status_mismatches: usize,
    /// Rings not compared because the WGSL table gives no bound there ([`flatten_bounds`] is
    /// `None`: a sector decided within rounding of a·φ = π, a divisor within rounding of 0).
    pub unbounded: usize,
}

/// Run `maps_flatten` on `rings` over `positions` and compare with the reference on the same
/// values ([`flatten_reference`]), slot by slot and ring by ring against [`flatten_bounds`]
/// (the kernel's twin over the WGSL accuracy table).
pub fn crosscheck_flatten(
    gpu: &Gpu,
    positions: &Normalised,
    rings: &LevelRings,
) -> Result<FlattenCrosscheck> {
    let batch = rings_batch(&positions.gpu, rings);
    let (flat, points) = flatten_gpu(gpu, &batch)?;
    let pos = &positions.cpu;
    let (mut theta_err, mut theta_mag, mut a_err, mut a_mag, mut mu_err, mut mu_mag) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let (mut theta_over, mut mu_over, mut a_over, mut rejected, mut mismatches) = (0, 0, 0, 0, 0);
    let mut unbounded = 0;
    let (mut theta_ratio, mut a_ratio, mut mu_ratio) = (0.0f64, 0.0f64, 0.0f64);
    let (mut theta_tol, mut a_tol, mut mu_tol) = (0.0f64, 0.0f64, 0.0f64);
    for (r, h) in batch.rings.iter().enumerate() {
        let (v, ring, shape) = (rings.vertices[r], &rings.rings[r], rings.shapes[r]);
        let reference = flatten_reference(pos, v, ring, shape);
        let g = &flat[r];
        let slots = &points[h.first as usize..(h.first + h.count) as usize];
        let status = reference.ring[3] as u32;
        mismatches += usize::from(g.status != status);
        rejected += usize::from(status != STATUS_OK);
        let Some(bounds) = flatten_bounds(pos, v, ring, shape, &reference) else {
            unbounded += 1;
            continue;
        };
        // θ of every slot and the total.
        let mut thetas: Vec<(f64, f64, f64)> = slots
            .iter()
            .zip(&reference.points)
            .zip(&bounds.points)
            .map(|((p, e), b)| (p.theta as f64, e[2], b[2]))
            .collect();
        thetas.push((g.theta_total as f64, reference.ring[2], bounds.ring[2]));
        for (got, expected, bound) in thetas {
            let e = (got - expected).abs();
            theta_err.push(e);
            theta_mag.push(expected);
            theta_tol = theta_tol.max(bound);
            theta_ratio = theta_ratio.max(e / bound);
            theta_over += usize::from(!(e <= bound));
        }
        if status != STATUS_OK || g.status != STATUS_OK {
            continue;
        }
        for (i, got) in [g.a as f64, g.a2 as f64].into_iter().enumerate() {
            let expected = reference.ring[i];
            let e = (got - expected).abs();
            a_err.push(e / expected);
            a_mag.push(1.0);
            a_tol = a_tol.max(bounds.ring[i] / expected);
            a_ratio = a_ratio.max(e / bounds.ring[i]);
            a_over += usize::from(!(e <= bounds.ring[i]));
        }
        for ((p, e), bound) in slots.iter().zip(&reference.points).zip(&bounds.mu_norm) {
            let modulus = e[0].hypot(e[1]);
            let err = (p.mu[0] as f64 - e[0]).hypot(p.mu[1] as f64 - e[1]);
            mu_err.push(err / modulus);
            mu_mag.push(1.0);
            mu_tol = mu_tol.max(bound / modulus);
            mu_ratio = mu_ratio.max(err / bound);
            mu_over += usize::from(!(err <= *bound));
        }
    }
    Ok(FlattenCrosscheck {
        rings: rings.vertices.len(),
        theta: ErrorSummary::from_errors("radians", &theta_err, &theta_mag, theta_tol),
        a: ErrorSummary::from_errors("relative", &a_err, &a_mag, a_tol),
        mu: ErrorSummary::from_errors("relative to |μ_k|", &mu_err, &mu_mag, mu_tol),
        theta_over_bound: theta_over,
        a_over_bound: a_over,
        mu_over_bound: mu_over,
        theta_worst_ratio: theta_ratio,
        a_worst_ratio: a_ratio,
        mu_worst_ratio: mu_ratio,
        rejected,
        status_mismatches: mismatches,
        unbounded,
    })
}

/// The hierarchy of `maps` in the `maps_inverse` layout ([`InverseTables`]): every decimation
/// face (input faces, then the faces of each removal, [`super::Param::face`]) with the removal
/// that created it, per face μ of its corners in the planes of the removals that created and
/// deleted it (rounded to f32; the removed vertex at 0), per removal its old faces, the base
/// faces (the faces no removal deleted, in id order: [`Maps::base_faces`]'s order), and the
/// positions of `positions` ([`normalise`]).
pub fn inverse_tables(maps: &Maps, positions: &Normalised) -> InverseTables {
    let param = &maps.param;
    let records = param.removals();
    let total =
        maps.input_faces.len() + records.iter().map(|r| r.new_count as usize).sum::<usize>();
    let mut faces: Vec<DecimationFace> = (0..total as u32)
        .map(|f| DecimationFace {
            corners: param.face(f),
            created_by: NONE,
        })
        .collect();
    let mut charts = vec![FaceCharts::default(); total];
    let mut removed = vec![false; total];
    let mut removals = Vec::with_capacity(records.len());
    let mut old_faces = Vec::new();
    for (index, r) in records.iter().enumerate() {
        let mu_of = |v: u32| {
            r.ring
                .iter()
                .position(|&w| w == v)
                .map_or([0.0; 2], |m| r.mu[m].map(|x| x as f32))
        };
        removals.push([old_faces.len() as u32, r.old_faces.len() as u32]);
        for &g in &r.old_faces {
            old_faces.push(g);
            removed[g as usize] = true;
            charts[g as usize].removed = faces[g as usize].corners.map(mu_of);
        }
        for f in r.new_first..r.new_first + r.new_count {
            faces[f as usize].created_by = index as u32;
            charts[f as usize].created = faces[f as usize].corners.map(mu_of);
        }
    }
    InverseTables {
        positions: positions.gpu.clone(),
        faces,
        charts,
        removals,
        old_faces,
        base_to_face: (0..total as u32)
            .filter(|&f| !removed[f as usize])
            .collect(),
    }
}

/// The base points in the kernel's layout (barycentrics rounded to f32).
pub fn base_queries(points: &[BasePoint]) -> Vec<BaseQuery> {
    points
        .iter()
        .map(|p| BaseQuery {
            bary: p.bary.map(|x| x as f32),
            face: p.face,
        })
        .collect()
}

/// Π⁻¹ of `points` on the GPU over `tables` (positions in the tables' normalised frame).
pub fn inverse_gpu(
    gpu: &Gpu,
    tables: &InverseTables,
    points: &[BasePoint],
) -> Result<Vec<InverseResult>> {
    InverseKernel::new(gpu, tables)
        .and_then(|k| k.run(gpu, &base_queries(points)))
        .map_err(gpu_error)
}

/// The smallest altitude of triangle (p, q, r): 2·area / longest edge.
pub fn smallest_altitude(p: &Point3<f64>, q: &Point3<f64>, r: &Point3<f64>) -> f64 {
    let longest = (q - p).norm().max((r - q).norm()).max((p - r).norm());
    (q - p).cross(&(r - p)).norm() / longest
}

/// Π⁻¹ on the GPU against [`super::Param::inverse`] (the figures).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct InverseCrosscheck {
    /// Points compared.
    pub points: usize,
    /// |Δp| as a fraction of the bounding box diagonal (tolerance: the largest of
    /// `position_bounds`).
    pub position: ErrorSummary,
    /// Per point |Δp| …
    pub position_errors: Vec<f64>,
    /// … and its bound ([`crate::crosscheck::maps_inverse_bound::inverse_position_bound`]:
    /// from the kernel's twin over `Lin`; `f64::MAX` where the WGSL table gives none).
    pub position_bounds: Vec<f64>,
    /// max_c |Δb_c| over the points that reached the same input face, whose smallest altitude
    /// exceeds 1e-3 of the diagonal (its tolerance the largest of `bary_bounds`).
    pub bary: ErrorSummary,
    /// Per compared point (the order of `bary`'s errors): max_c |Δb_c| …
    pub bary_errors: Vec<f64>,
    /// … and its bound, the point's position bound / h with h the face's smallest altitude
    /// (fraction of the diagonal): |∇b_c| = 1/h_c, so a point moved by |Δp| in the face's
    /// plane moves each barycentric by at most |Δp|/h.
    pub bary_bounds: Vec<f64>,
    /// Points the kernel took to another input face than the reference.
    pub face_mismatches: usize,
    /// The largest reference barycentric distance to an edge, min_c b_c, among those points
    /// (small: a point changes face only next to an edge).
    pub mismatch_max_min_bary: f64,
    /// Points whose face's smallest altitude is below 1e-3 of the diagonal (bary not compared).
    pub thin: usize,
}

/// Run `maps_inverse` on `points` and compare with [`super::Param::inverse`] (module docs).
/// [`Error::InvalidArgument`] for a base point the reference cannot map (face out of range).
///
/// Each point's position is held to its own bound (`position_bounds`), from which its
/// barycentric bound follows (`bary_bounds`).
pub fn crosscheck_inverse(
    gpu: &Gpu,
    maps: &Maps,
    points: &[BasePoint],
) -> Result<InverseCrosscheck> {
    use crate::crosscheck::maps_inverse_bound::{inverse_position_bound, FlatTables};
    let norm = normalise(&maps.positions)?;
    let tables = inverse_tables(maps, &norm);
    let gpu_points = inverse_gpu(gpu, &tables, points)?;
    let flat = FlatTables::of(&tables);
    let queries = base_queries(points);
    let (mut pos_err, mut pos_mag, mut bary_err, mut bary_mag) = (vec![], vec![], vec![], vec![]);
    let (mut pos_bound, mut bary_bound) = (vec![], vec![]);
    let (mut mismatches, mut mismatch_min, mut thin) = (0, 0.0f64, 0);
    for ((p, g), q) in points.iter().zip(&gpu_points).zip(&queries) {
        let c = maps.param.inverse(p).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "base point in face {} of {}",
                p.face,
                maps.base_faces.len()
            ))
        })?;
        let expected = norm.apply(&c.position);
        let got = Point3::new(
            g.position[0] as f64,
            g.position[1] as f64,
            g.position[2] as f64,
        );
        pos_err.push((got - expected).norm());
        pos_mag.push(expected.coords.norm());
        let position_bound =
            inverse_position_bound(&flat.tables(), q, [expected.x, expected.y, expected.z]);
        pos_bound.push(position_bound);
        if g.face != c.face {
            mismatches += 1;
            mismatch_min = mismatch_min.max(c.bary.iter().copied().fold(f64::INFINITY, f64::min));
            continue;
        }
        let [a, b, d] =
            maps.input_faces[c.face as usize].map(|v| norm.apply(&maps.positions[v as usize]));
        let h = smallest_altitude(&a, &b, &d);
        if h <= 1e-3 {
            thin += 1;
            continue;
        }
        bary_bound.push(position_bound / h);
        let e = (0..3)
            .map(|k| (g.bary[k] as f64 - c.bary[k]).abs())
            .fold(0.0, f64::max);
        bary_err.push(e);
        bary_mag.push(1.0);
    }
    Ok(InverseCrosscheck {
        points: points.len(),
        position: ErrorSummary::from_errors(
            "fraction of the diagonal",
            &pos_err,
            &pos_mag,
            pos_bound.iter().copied().fold(0.0, f64::max),
        ),
        position_errors: pos_err,
        position_bounds: pos_bound,
        bary: ErrorSummary::from_errors(
            "barycentric",
            &bary_err,
            &bary_mag,
            bary_bound.iter().copied().fold(0.0, f64::max),
        ),
        bary_errors: bary_err,
        bary_bounds: bary_bound,
        face_mismatches: mismatches,
        mismatch_max_min_bary: mismatch_min,
        thin,
    })
}
