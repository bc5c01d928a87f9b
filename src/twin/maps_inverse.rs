//! Twin of `gpu/shaders/maps_inverse.wgsl`, function for function: Π⁻¹ of a base point (MAPS
//! §3.3; seed 002 "Parameterization (1/3)–(3/3)", "Remeshing (1/5)";
//! `maps::param::Param::inverse`). From the base face, replay backwards every removal that
//! created the face the point is in:
//!
//! - u = Σ_c b_c μ_c, the point in the removal's plane ([`to_plane`]);
//! - the old star face containing u: the first (in the removal's order) with all barycentrics
//!   ≥ 0, else the one with the largest smallest barycentric ([`locate_in_star`]);
//! - its barycentrics clamped to ≥ 0 and renormalised ([`clamp_bary`]);
//!
//! and, down at an input face, interpolate its corners ([`inverse`]).
//!
//! The choice of a star face is a choice between two maps that agree on the faces' shared
//! edge: continuous in u, it is made on the values (a GPU that picks the neighbouring face near
//! an edge lands on the same surface point), not by [`Real::decides_lt`].

use super::coverage::{branches, hit, Branch};
use super::real::{Real, V2, V3};

/// `maps_inverse`'s branches ([`super::coverage`]).
pub const BRANCHES: &[Branch] = branches![
    "maps_inverse.walk.input_face" => "the walk reached an input face (created_by = NONE) and stops",
    "maps_inverse.walk.step" => "one removal replayed: the face was created by a removal",
    "maps_inverse.walk.exhausted" => "the walk stopped after face_count steps without reaching an input face",
    "maps_inverse.locate.inside" => "the first old star face with every λ ≥ 0 taken",
    "maps_inverse.locate.nearest" => "outside every old star face: the one with the largest smallest λ",
    "maps_inverse.locate.improved" => "a later star face with a larger smallest λ replaced the best so far",
    "maps_inverse.barycentric.area_norm" => "the three orientations sum to 0: divided by o(a, b, c) instead",
    "maps_inverse.clamp.negative" => "a λ < 0 clamped to 0 before the renormalisation",
];

/// `NONE`: no removal created the face (an input face).
pub const NONE: u32 = u32::MAX;

/// The buffers the kernel reads (bindings 1–6), as the vectors store them.
#[derive(Clone, Copy, Debug)]
pub struct Tables<'a> {
    /// `positions`: 4 per input vertex (x, y, z, 0).
    pub positions: &'a [f32],
    /// `faces[f].corners`: 3 per decimation face.
    pub corners: &'a [u32],
    /// `faces[f].created_by`: the removal that created face f, [`NONE`] for an input face.
    pub created_by: &'a [u32],
    /// `charts[f]`: 12 per face, μ of its corners (x, y each) in the plane of the removal that
    /// created it (`created`), then of the one that removed it (`removed`).
    pub charts: &'a [f32],
    /// `removals[r]`: first index into `old_faces`, count.
    pub removals: &'a [u32],
    pub old_faces: &'a [u32],
    pub base_to_face: &'a [u32],
}

impl Tables<'_> {
    /// `params.face_count`: the number of decimation faces.
    pub fn face_count(&self) -> u32 {
        self.created_by.len() as u32
    }
}

/// `InverseResult`.
#[derive(Clone, Copy, Debug)]
pub struct InverseResult<R> {
    pub position: V3<R>,
    /// The input face.
    pub face: u32,
    /// Barycentrics in the input face (clamped, sum 1).
    pub bary: V3<R>,
    /// The smallest barycentric met on the way, before clamping.
    pub min_bary: R,
}

fn read<R: Real>(x: f32) -> R {
    R::lit(x as f64)
}

/// `orient2d(a, b, c)` = (b.x − a.x)(c.y − a.y) − (b.y − a.y)(c.x − a.x).
pub fn orient2d<R: Real>(a: V2<R>, b: V2<R>, c: V2<R>) -> R {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// `barycentric(u, a, b, c)`: λ = (o(u, b, c), o(a, u, c), o(a, b, u)) / s, s the sum of the
/// three, or o(a, b, c) if that sum is 0.
pub fn barycentric<R: Real>(u: V2<R>, a: V2<R>, b: V2<R>, c: V2<R>) -> V3<R> {
    let area = orient2d(a, b, c);
    let l = V3::new(orient2d(u, b, c), orient2d(a, u, c), orient2d(a, b, u));
    let mut norm = l.x + l.y + l.z;
    if norm.value() == 0.0 {
        hit("maps_inverse.barycentric.area_norm");
        norm = area;
    }
    l / norm
}

/// `min3`.
pub fn min3<R: Real>(l: V3<R>) -> R {
    l.x.min(l.y.min(l.z))
}

/// Corner c of a chart: `which` 0 for `created`, 1 for `removed`.
pub fn chart_corner<R: Real>(tables: &Tables, face: u32, which: usize, c: usize) -> V2<R> {
    let o = 12 * face as usize + 6 * which + 2 * c;
    V2::new(read(tables.charts[o]), read(tables.charts[o + 1]))
}

/// `to_plane`: u = Σ_c b_c μ(corner_c) in the plane of the removal that created `face`.
pub fn to_plane<R: Real>(tables: &Tables, face: u32, b: V3<R>) -> V2<R> {
    let m = |c| chart_corner::<R>(tables, face, 0, c);
    m(0) * b.x + m(1) * b.y + m(2) * b.z
}

/// `Located`.
#[derive(Clone, Copy, Debug)]
pub struct Located<R> {
    pub face: u32,
    pub bary: V3<R>,
}

/// `locate_in_star`: the old star face of removal `r` (its `first`, `count`) containing u, else
/// the one with the largest smallest barycentric (the first on ties).
pub fn locate_in_star<R: Real>(tables: &Tables, r: [u32; 2], u: V2<R>) -> Located<R> {
    let mut best = Located {
        face: tables.old_faces[r[0] as usize],
        bary: V3::splat(R::lit(0.0)),
    };
    let mut best_min = f64::from(-f32::MAX);
    for m in 0..r[1] {
        let f = tables.old_faces[(r[0] + m) as usize];
        let c = |k| chart_corner::<R>(tables, f, 1, k);
        let l = barycentric(u, c(0), c(1), c(2));
        let lowest = min3(l).value();
        if lowest >= 0.0 {
            hit("maps_inverse.locate.inside");
            return Located { face: f, bary: l };
        }
        if lowest > best_min {
            if m > 0 {
                hit("maps_inverse.locate.improved");
            }
            best_min = lowest;
            best = Located { face: f, bary: l };
        }
    }
    hit("maps_inverse.locate.nearest");
    best
}

/// `clamp_bary`: max(λ, 0) / Σ max(λ, 0).
pub fn clamp_bary<R: Real>(l: V3<R>) -> V3<R> {
    let zero = R::lit(0.0);
    if min3(l).value() < 0.0 {
        hit("maps_inverse.clamp.negative");
    }
    let c = V3::new(l.x.max(zero), l.y.max(zero), l.z.max(zero));
    c / (c.x + c.y + c.z)
}

/// Removal r's range in `old_faces`.
pub fn removal(tables: &Tables, r: u32) -> [u32; 2] {
    [
        tables.removals[2 * r as usize],
        tables.removals[2 * r as usize + 1],
    ]
}

/// Input vertex v's position.
pub fn position<R: Real>(tables: &Tables, v: u32) -> V3<R> {
    let o = 4 * v as usize;
    let p = tables.positions;
    V3::new(read(p[o]), read(p[o + 1]), read(p[o + 2]))
}

/// `inverse` (`Param::inverse`): Π⁻¹ of the base point (base face `base`, barycentrics `b`).
pub fn inverse<R: Real>(tables: &Tables, base: u32, b: V3<R>) -> InverseResult<R> {
    let mut face = tables.base_to_face[base as usize];
    let mut bary = b;
    let mut min_bary = min3(bary);
    let mut reached = false;
    for _ in 0..tables.face_count() {
        let created_by = tables.created_by[face as usize];
        if created_by == NONE {
            reached = true;
            break;
        }
        hit("maps_inverse.walk.step");
        let u = to_plane(tables, face, bary);
        let found = locate_in_star(tables, removal(tables, created_by), u);
        min_bary = min_bary.min(min3(found.bary));
        face = found.face;
        bary = clamp_bary(found.bary);
    }
    // The loop's bound is face_count, reached only by a table whose walk never ends.
    reached = reached || tables.created_by[face as usize] == NONE;
    hit(if reached {
        "maps_inverse.walk.input_face"
    } else {
        "maps_inverse.walk.exhausted"
    });
    let t = &tables.corners[3 * face as usize..3 * face as usize + 3];
    let position = V3::sum(&[
        position(tables, t[0]) * bary.x,
        position(tables, t[1]) * bary.y,
        position(tables, t[2]) * bary.z,
    ]);
    InverseResult {
        position,
        face,
        bary,
        min_bary,
    }
}
