//! Per-triangle precomputation (seed steps 2–5): the star layout in t's frame, the orientation
//! fix, the Möbius maps of t and its three neighbours, and the log Möbius ratios.
//!
//! The WGSL twin is `gpu/shaders/bpm_precompute.wgsl` (`star_layout`, `place_apex`,
//! `triangle_maps`), reading the same [`Star`] gathered here; it implements the correct
//! unfolding only ([`Unfold::Correct`]), not the authors' ([`place_apex_authors`]).

use nalgebra::{Point3, Vector3};
use num_complex::Complex64 as C;
use rayon::prelude::*;

use super::moebius::{
    c_abs, fit_mobius_det, fit_mobius_local, log_with, mobius_inverse, mobius_mul, ExpLog, Mobius,
    Sl2,
};
use crate::error::Result;
use crate::mesh::{Adjacency, EdgeKind, TriMesh, EDGE_CORNERS};

/// How the Möbius map through three points is fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum Fit {
    /// [`fit_mobius_local`]: relative to t's first corner, in UV and in the layout. Default.
    #[default]
    Local,
    /// [`fit_mobius_det`]: the seed's 3×3 determinants on absolute UVs.
    Determinant,
}

/// Multiplication order of the blended map (seed 004 §3.1, SPEC.md § 9).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum Order {
    /// M_z = M_t exp(½ Σ γ_e log(M_t⁻¹ M_e)): the seed's final form. Default.
    #[default]
    Right,
    /// M_z = exp(½ Σ γ_e log(M_e M_t⁻¹)) M_t: mathematically identical (the ratios are
    /// conjugate by M_t), kept as an option to show it.
    Left,
}

/// How a neighbour's apex is laid out in t's plane (seed step 2(c), SPEC.md § 2).
///
/// With φ ∈ [0, π] the fold angle between t and the neighbour across edge a→b (0: coplanar),
/// `along`, `perp` the apex's distance along and from the edge line, and dir the unit vector of
/// z_b − z_a, the apex goes to
///
/// ```text
///   z = z_a + dir · (along − i · perp · cos ρ),   ρ = 0 (Correct),  ρ = max(0, 2φ − π) (Authors)
/// ```
///
/// The authors' MATLAB code (shirrorbe/BPM, `IsometricEmbeddingFStar`) rotates the neighbour
/// about the edge by θ = atan2(‖v₁ × v₂‖, v₁·v₂) − π/2 (v₁ = edge × ẑ, v₂ the neighbour's normal)
/// and keeps x and y. ‖v₁ × v₂‖ drops the sign of cos φ, so for φ > 90° it turns the neighbour
/// back by only π − φ instead of φ: the neighbour stays 2φ − π out of the plane, its projection
/// is shortened, and past 135° its apex lands on t's side of the edge. The default is right because only the
/// hinge rotation by the full fold angle is an isometry of the neighbour (seed step 2(c), "rotate
/// so they lie in t's plane"; SPEC.md § 2): M_e must be fitted to the neighbour's true shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum Unfold {
    /// Hinge rotation by the full fold angle (ρ = 0): the isometric unfolding. Default.
    #[default]
    Correct,
    /// The authors' code (ρ = max(0, 2φ − π)), to reproduce the published figures. Their code
    /// also lays out a face whose UV triangle is clockwise without mirroring it (no orientation
    /// fix: its Möbius map takes the counter-clockwise layout to the clockwise UV triangle, seed
    /// §1.2's "infinite amount of texture"), and so does this option. Differs from `Correct`
    /// only for neighbours folded past 90° and for faces with clockwise UVs.
    Authors,
}

/// Options of the BPM precomputation and evaluation. `Default` is the reference setting.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize)]
pub struct BpmOptions {
    /// Möbius fit through three points (default: local frame).
    pub fit: Fit,
    /// exp/log implementation (default: entire series / closed forms).
    #[serde(skip)]
    pub exp_log: ExpLog,
    /// Multiplication order (default: right, the seed's).
    pub order: Order,
    /// Layout of the neighbours' apices (default: the correct, isometric unfolding; the GPU
    /// precompute kernel implements only that one).
    pub unfold: Unfold,
}

/// One triangle's star as both the CPU and the GPU precompute read it: six points (t's corners
/// i, j, k, then the apex across edges ij, jk, ki) with their UVs, and which neighbours exist.
#[derive(Clone, Copy, Debug)]
pub struct Star {
    /// 3D positions of i, j, k, apex(ij), apex(jk), apex(ki).
    pub p: [Point3<f64>; 6],
    /// UVs at the same six points (the apex UVs as the neighbour face sees them).
    pub w: [C; 6],
    /// `neighbour[e]`: an interior, non-degenerate neighbour exists across edge e.
    pub neighbour: [bool; 3],
    /// t itself is degenerate: fall back to linear interpolation.
    pub degenerate: bool,
}

/// Everything the evaluation needs about one triangle t = (i, j, k).
#[derive(Clone, Copy, Debug)]
pub struct TriangleMaps {
    /// Layout of the corners in t's frame: z\[0\] = 0, z\[1\] on the positive real axis, z\[2\]
    /// above it (or below, when the star is mirrored).
    pub z: [C; 3],
    /// The corners' UVs.
    pub uv: [C; 3],
    /// UV origin of the fit: f(z) = w_origin + M_t(z) (w_i for the local fit, 0 otherwise).
    pub w_origin: C,
    /// M_t in SL(2,C), mapping the layout z to w − w_origin.
    pub m_t: Mobius,
    /// Log Möbius ratios of the edges ij, jk, ki (zero on boundary and seam edges).
    pub logs: [Sl2; 3],
    /// Degenerate face (zero 3D or UV area): evaluated by linear interpolation.
    pub fallback_linear: bool,
    /// The star's layout was mirrored because t's UV triangle is clockwise (never under
    /// [`Unfold::Authors`]).
    pub mirrored: bool,
}

/// Counts of the special cases met while precomputing, reported to the user.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PrecomputeReport {
    pub faces: usize,
    /// Faces with zero 3D or UV area (linear fallback), first few ids listed below.
    pub degenerate_faces: usize,
    pub degenerate_examples: Vec<usize>,
    /// Faces whose UV triangle is clockwise (mirrored layout under [`Unfold::Correct`]; the
    /// authors' code, [`Unfold::Authors`], does not mirror them).
    pub mirrored_faces: usize,
    pub boundary_edges: usize,
    pub seam_edges: usize,
    /// Edges shared by three or more faces: treated as boundary.
    pub non_manifold_edges: usize,
    /// Edges whose two faces disagree on orientation: treated as boundary.
    pub misoriented_edges: usize,
    /// Neighbours folded by more than 90° against their face (one count per face and edge, so
    /// an interior edge counts twice; degenerate faces left out): the neighbours whose layout
    /// [`Unfold::Authors`] changes, whichever unfolding was used.
    pub neighbours_folded_past_90: usize,
    /// Of those, neighbours folded by more than 135°, which [`Unfold::Authors`] lays out on t's
    /// side of the shared edge (folded back over t).
    pub neighbours_folded_past_135: usize,
}

/// The precomputed BPM interpolant of a mesh.
#[derive(Clone, Debug)]
pub struct Bpm {
    pub maps: Vec<TriangleMaps>,
    pub options: BpmOptions,
    pub report: PrecomputeReport,
}

/// Relative area below which a triangle counts as degenerate: |cross| ≤ 1e-12 · (longest edge)²,
/// i.e. an angle of about 1e-12 rad, where the layout and the fits lose all significance.
const DEGENERATE_RELATIVE_AREA: f64 = 1e-12;

/// Precompute the BPM interpolant of `mesh` (seed steps 2–5), in parallel over triangles.
///
/// Requires UVs. Degenerate faces fall back to linear interpolation; boundary, seam,
/// non-manifold and misoriented edges get a zero log ratio. All are counted in the report.
pub fn precompute(mesh: &TriMesh, options: BpmOptions) -> Result<Bpm> {
    mesh.validate_with_uvs()?;
    let adjacency = Adjacency::new(mesh);
    let stars = gather_stars(mesh, &adjacency);
    let maps: Vec<TriangleMaps> = stars
        .par_iter()
        .map(|star| triangle_maps(star, options))
        .collect();
    let folds: Vec<[f64; 3]> = stars.par_iter().map(fold_cosines).collect();
    let folded_past = |cos_max: f64| {
        folds
            .iter()
            .flatten()
            .filter(|&&cos_phi| cos_phi < cos_max)
            .count()
    };
    let degenerate_ids: Vec<usize> = (0..stars.len()).filter(|&f| stars[f].degenerate).collect();
    let report = PrecomputeReport {
        faces: mesh.face_count(),
        degenerate_faces: degenerate_ids.len(),
        degenerate_examples: degenerate_ids.into_iter().take(10).collect(),
        mirrored_faces: stars
            .iter()
            .filter(|star| uv_clockwise([star.w[0], star.w[1], star.w[2]]))
            .count(),
        boundary_edges: adjacency.boundary_edges,
        seam_edges: adjacency.seam_edges,
        non_manifold_edges: adjacency.non_manifold_edges,
        misoriented_edges: adjacency.misoriented_edges,
        // φ > 90° ⟺ cos φ < 0; φ > 135° ⟺ cos φ < −1/√2.
        neighbours_folded_past_90: folded_past(0.0),
        neighbours_folded_past_135: folded_past(-std::f64::consts::FRAC_1_SQRT_2),
    };
    Ok(Bpm {
        maps,
        options,
        report,
    })
}

/// Every face's [`Star`] (the input of both the CPU and the GPU precompute), in parallel. The
/// mesh must be valid ([`TriMesh::validate_with_uvs`]).
pub fn gather_stars(mesh: &TriMesh, adjacency: &Adjacency) -> Vec<Star> {
    let degenerate: Vec<bool> = (0..mesh.face_count())
        .into_par_iter()
        .map(|f| is_degenerate(mesh, f))
        .collect();
    (0..mesh.face_count())
        .into_par_iter()
        .map(|f| gather_star(mesh, adjacency, &degenerate, f))
        .collect()
}

/// Collect face `f`'s star: its corners, the apex of each interior neighbour, their UVs.
pub fn gather_star(mesh: &TriMesh, adjacency: &Adjacency, degenerate: &[bool], f: usize) -> Star {
    let corners = mesh.faces[f];
    let uv_corners = mesh.uv_faces[f];
    let uv = |i: u32| {
        let t = mesh.uvs[i as usize];
        C::new(t.x, t.y)
    };
    let mut p = [mesh.positions[corners[0] as usize]; 6];
    let mut w = [uv(uv_corners[0]); 6];
    for c in 0..3 {
        p[c] = mesh.positions[corners[c] as usize];
        w[c] = uv(uv_corners[c]);
    }
    let mut neighbour = [false; 3];
    for e in 0..3 {
        if let EdgeKind::Interior { face, edge } = adjacency.edges[f][e] {
            let g = face as usize;
            if degenerate[g] {
                continue;
            }
            // The neighbour's apex is the corner opposite its shared edge.
            let apex = (edge as usize + 2) % 3;
            p[3 + e] = mesh.positions[mesh.faces[g][apex] as usize];
            w[3 + e] = uv(mesh.uv_faces[g][apex]);
            neighbour[e] = true;
        }
    }
    Star {
        p,
        w,
        neighbour,
        degenerate: degenerate[f],
    }
}

/// Whether face `f` has (relatively) zero area in 3D or in UV, or a repeated corner.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a > b)` is meant: NaN areas are degenerate
pub fn is_degenerate(mesh: &TriMesh, f: usize) -> bool {
    let [a, b, c] = mesh.face_positions(f);
    let area3 = (b - a).cross(&(c - a)).norm();
    let longest3 = (b - a).norm().max((c - b).norm()).max((a - c).norm());
    let [ta, tb, tc] = mesh.face_uvs(f);
    let (e1, e2) = (tb - ta, tc - ta);
    let area2 = (e1.x * e2.y - e1.y * e2.x).abs();
    let longest2 = e1.norm().max(e2.norm()).max((tc - tb).norm());
    !(area3 > DEGENERATE_RELATIVE_AREA * longest3 * longest3)
        || !(area2 > DEGENERATE_RELATIVE_AREA * longest2 * longest2)
}

/// Whether a UV triangle is clockwise (negative [`signed_area2`]).
pub fn uv_clockwise(w: [C; 3]) -> bool {
    signed_area2(w[0], w[1], w[2]) < 0.0
}

/// Signed area (×2) of a triangle of complex points: Im((b − a) · conj(c − a)) with the sign
/// flipped so that counter-clockwise is positive.
pub fn signed_area2(a: C, b: C, c: C) -> f64 {
    let (u, v) = (b - a, c - a);
    u.re * v.im - u.im * v.re
}

/// Lay out the star in t's own frame (seed step 2, SPEC.md §§ 2–3).
///
/// z_i = 0, z_j = |p_j − p_i| on the real axis, z_k = ((p_k − p_i)·e₁) + i |e₁ × (p_k − p_i)|;
/// each neighbour's apex is unfolded across its edge by [`place_apex`] ([`Unfold::Correct`]) or
/// [`place_apex_authors`] ([`Unfold::Authors`]). If t's UV triangle is clockwise, the whole star
/// is mirrored (z ↦ z̄) so the layout and UV orientations agree; otherwise "each triangle maps
/// to an infinite amount of texture" (seed §1.2). The authors' code does not mirror, and
/// neither does [`Unfold::Authors`]. Returns the six layout points and whether the star was
/// mirrored.
pub fn star_layout(p: &[Point3<f64>; 6], w_t: [C; 3], unfold: Unfold) -> ([C; 6], bool) {
    let ej = p[1] - p[0];
    let length = ej.norm();
    let e1 = ej / length;
    let pk = p[2] - p[0];
    let mut z = [C::new(0.0, 0.0); 6];
    z[1] = C::new(length, 0.0);
    z[2] = C::new(pk.dot(&e1), e1.cross(&pk).norm());
    let normal = triangle_normal(p);
    for e in 0..3 {
        let [a, b] = EDGE_CORNERS[e];
        z[3 + e] = match unfold {
            Unfold::Correct => place_apex(z[a], z[b], &p[a], &p[b], &p[3 + e]),
            Unfold::Authors => place_apex_authors(z[a], z[b], &p[a], &p[b], &normal, &p[3 + e]),
        };
    }
    // The authors' code has no orientation fix (see `Unfold::Authors`).
    let mirrored = unfold == Unfold::Correct && uv_clockwise(w_t);
    if mirrored {
        for zn in &mut z {
            *zn = zn.conj();
        }
    }
    (z, mirrored)
}

/// Unit normal n = (p_j − p_i) × (p_k − p_i) / |…| of t (the first three points of a star);
/// zero for a degenerate t.
fn triangle_normal(p: &[Point3<f64>; 6]) -> Vector3<f64> {
    let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
    let length = n.norm();
    if length > 0.0 {
        n / length
    } else {
        Vector3::zeros()
    }
}

/// Unfold a neighbour's apex across the edge a→b of t (an isometric hinge rotation).
///
/// With u = (p_b − p_a)/|p_b − p_a|: along = (p_apex − p_a)·u, perp = |u × (p_apex − p_a)|; in the
/// layout the apex goes to z_a + dir·(along − i·perp), dir = (z_b − z_a)/|z_b − z_a|, i.e. to the
/// right of a→b, opposite t's interior.
pub fn place_apex(z_a: C, z_b: C, p_a: &Point3<f64>, p_b: &Point3<f64>, p_apex: &Point3<f64>) -> C {
    let (along, perp) = hinge_coordinates(p_a, p_b, p_apex);
    let dir = (z_b - z_a) / c_abs(z_b - z_a);
    z_a + dir * C::new(along, -perp)
}

/// (along, perp) = ((p_apex − p_a)·u, |u × (p_apex − p_a)|), u = (p_b − p_a)/|p_b − p_a|: the
/// apex's distance along the edge line and from it.
fn hinge_coordinates(p_a: &Point3<f64>, p_b: &Point3<f64>, p_apex: &Point3<f64>) -> (f64, f64) {
    let u: Vector3<f64> = (p_b - p_a).normalize();
    let r = p_apex - p_a;
    (r.dot(&u), u.cross(&r).norm())
}

/// Cosine of the fold angle φ ∈ [0, π] of the neighbour across edge a→b of t; `normal` is t's
/// unit normal (zero for a degenerate t, which gives cos φ = 0: not counted as folded past 90°).
///
/// cos φ = (r⊥ · o)/|r⊥|, r⊥ = r − (r·u)u the apex's offset from the edge line (r = p_apex − p_a,
/// u the edge's unit vector) and o = u × n the in-plane direction away from t: 1 when the
/// neighbour is coplanar with t, 0 at a right angle, −1 when folded flat onto t.
pub fn fold_cosine(
    p_a: &Point3<f64>,
    p_b: &Point3<f64>,
    normal: &Vector3<f64>,
    p_apex: &Point3<f64>,
) -> f64 {
    let u: Vector3<f64> = (p_b - p_a).normalize();
    let r = p_apex - p_a;
    let perp = u.cross(&r).norm();
    let cos_phi = r.dot(&u.cross(normal)) / perp;
    if cos_phi.is_finite() {
        cos_phi.clamp(-1.0, 1.0)
    } else {
        1.0
    }
}

/// The fold cosines ([`fold_cosine`]) of a star's three neighbours; 1 (coplanar) where there is
/// no neighbour or t is degenerate.
pub fn fold_cosines(star: &Star) -> [f64; 3] {
    let normal = triangle_normal(&star.p);
    std::array::from_fn(|e| {
        let [a, b] = EDGE_CORNERS[e];
        match star.neighbour[e] && !star.degenerate {
            true => fold_cosine(&star.p[a], &star.p[b], &normal, &star.p[3 + e]),
            false => 1.0,
        }
    })
}

/// The authors' layout of a neighbour's apex ([`Unfold::Authors`]): their rotation about the
/// edge by θ = atan2(‖v₁ × v₂‖, v₁·v₂) − π/2, then x and y in t's frame.
///
/// z_a + dir·(along − i·perp·cos ρ), ρ = max(0, 2φ − π), with along, perp, dir as in
/// [`place_apex`] and φ the fold angle ([`fold_cosine`]). For φ ≤ 90° this is [`place_apex`]
/// exactly (same operations); for φ > 90°, cos ρ = cos(2φ − π) = 1 − 2 cos²φ, negative (apex on
/// t's side) past 135°.
pub fn place_apex_authors(
    z_a: C,
    z_b: C,
    p_a: &Point3<f64>,
    p_b: &Point3<f64>,
    normal: &Vector3<f64>,
    p_apex: &Point3<f64>,
) -> C {
    let cos_phi = fold_cosine(p_a, p_b, normal, p_apex);
    let cos_rho = match cos_phi >= 0.0 {
        true => 1.0,
        false => 1.0 - 2.0 * cos_phi * cos_phi,
    };
    let (along, perp) = hinge_coordinates(p_a, p_b, p_apex);
    let dir = (z_b - z_a) / c_abs(z_b - z_a);
    z_a + dir * C::new(along, -perp * cos_rho)
}

/// All per-triangle data of one star (seed steps 2–4).
///
/// M_t = fit(z_i, z_j, z_k → W_i, W_j, W_k) with W = w − w_origin; for each neighbour e across
/// edge (a, b): M_e = fit(z_a, z_b, z_apex → W_a, W_b, W_apex), δ_e = M_t⁻¹ M_e (right order)
/// or M_e M_t⁻¹ (left order), l_e = log δ_e after the sign fix; l_e = 0 without a neighbour.
///
/// **Departure, stated:** for a missing neighbour (a boundary edge, a UV seam, a degenerate
/// neighbour) the seed takes the identity, M_e = M_t, so δ_e = I; this code writes l_e = 0
/// directly. The two are the same map, since log I = 0 and exp 0 = I, so the blend is
/// unchanged and f = M_t on that edge (the seed's boundary property); writing 0 skips a fit and
/// a log whose f32 rounding would make l_e only close to 0.
#[allow(clippy::needless_range_loop)] // e names the edge in every per-edge array
pub fn triangle_maps(star: &Star, options: BpmOptions) -> TriangleMaps {
    let uv = [star.w[0], star.w[1], star.w[2]];
    let (z, mirrored) = star_layout(&star.p, uv, options.unfold);
    let mut maps = TriangleMaps {
        z: [z[0], z[1], z[2]],
        uv,
        w_origin: C::new(0.0, 0.0),
        m_t: Mobius::IDENTITY,
        logs: [Sl2::ZERO; 3],
        fallback_linear: true,
        mirrored,
    };
    if star.degenerate {
        return maps;
    }
    let w_origin = match options.fit {
        Fit::Local => star.w[0],
        Fit::Determinant => C::new(0.0, 0.0),
    };
    let big_w = star.w.map(|w| w - w_origin);
    let fit = |a: usize, b: usize, c: usize| match options.fit {
        Fit::Local => fit_mobius_local([z[a], z[b], z[c]], [big_w[a], big_w[b], big_w[c]]),
        Fit::Determinant => fit_mobius_det([z[a], z[b], z[c]], [big_w[a], big_w[b], big_w[c]]),
    };
    let m_t = fit(0, 1, 2);
    if !is_finite(&m_t) {
        return maps;
    }
    let m_t_inv = mobius_inverse(&m_t);
    for e in 0..3 {
        if !star.neighbour[e] {
            continue;
        }
        let [a, b] = EDGE_CORNERS[e];
        let m_e = fit(a, b, 3 + e);
        let ratio = match options.order {
            Order::Right => mobius_mul(&m_t_inv, &m_e),
            Order::Left => mobius_mul(&m_e, &m_t_inv),
        };
        let log = log_with(&ratio, options.exp_log);
        // A non-finite ratio (a neighbour whose fit blew up) is treated like a boundary edge.
        if log.is_finite() {
            maps.logs[e] = log;
        }
    }
    maps.w_origin = w_origin;
    maps.m_t = m_t;
    maps.fallback_linear = false;
    maps
}

fn is_finite(m: &Mobius) -> bool {
    [m.a, m.b, m.c, m.d]
        .iter()
        .all(|x| x.re.is_finite() && x.im.is_finite())
}
