//! skinsimp cross-check: the f32 kernels `skinsimp_lbs` (posed positions of V vertices in P
//! poses), `skinsimp_quadrics` (per-pose source and vertex quadrics) and
//! `skinsimp_collapse_cost` (the optimal position given the weights, and its cost) against the
//! f64 reference ([`crate::skinsimp::gpu::crosscheck`], on the unit-box normalised model).
//!
//! Every element is held to a first-order f32 bound derived here: skinning per coordinate
//! ([`lbs_bound`]), quadrics per entry ([`source_bound`], [`quadric_checks`]), the edge
//! quadric, position and cost of every candidate ([`cost_checks`]); positions and costs also to
//! the notes' tolerances where f32 is expected to meet them. `tests/gpu_skinsimp.rs` uses the
//! same functions.

use nalgebra::{Matrix4, Point3, Vector3};
use reparam_gpu::skinsimp::{EdgeItem, PlaneSource, SOURCE_FACE};
use reparam_gpu::Gpu;

use super::timing::{time_cpu, time_gpu_warm};
use super::{Bounds, Row, Timing};
use crate::crosscheck::F32_FLUSH;
use crate::error::{Error, Result};
use crate::skinsimp::gpu::{
    crosscheck, edge_cost_position, edge_cost_quadric, plane_quadrics_f64,
    position_given_weights_f64, skin_f64, vertex_quadrics_f64, CostData, CrossCheckData,
    ReferenceCost, SkinsimpKernels, COST_ABSOLUTE, COST_RELATIVE, POSITION_TOLERANCE,
    QUADRIC_TOLERANCE, SKIP_CONDITION,
};
use crate::skinsimp::{Deformation, Input, Options};

/// The size u of one rounding: [`super::WGSL_U`] = 2⁻²³ (WGSL rounds up or down).
pub const U32: f64 = super::WGSL_U;

/// Per vertex i, pose j and coordinate r, the bound on |Δp_r| of f32 skinning:
/// (M_k h)_r is a 4-term dot product, ≤ 4u Σ_c |M_rc h_c| (also with fused multiply-adds);
/// scaling by w_k and summing K terms adds ≤ K u Σ_k w_k |(M_k h)_r|, so
/// |Δp_r| ≤ (4 + K) u Σ_k |w_k| Σ_c |M_k,rc h_c| to first order (the reference on the same f32
/// inputs is exact to 1e-16), times 1 + 1e-6 for the second-order terms; plus, for subnormal
/// products and sums, 2⁻¹²⁶ per operation ([`crate::crosscheck::F32_FLUSH`]: 4 products, 3
/// additions, a scaling and an addition per influence, 9K in all). In the order of
/// `data.posed_ref` (vertex-major, then pose), three coordinates each.
pub fn lbs_bound(data: &CrossCheckData) -> Result<Vec<f64>> {
    lbs_bound_of(&data.input)
}

/// [`lbs_bound`] of any skinned `input`: per vertex i (outer), pose j and coordinate r.
pub fn lbs_bound_of(input: &Input) -> Result<Vec<f64>> {
    let Deformation::Skinned { influences, joints } = &input.deformation else {
        return Err(Error::InvalidArgument(
            "skinning bounds need a skinned input".into(),
        ));
    };
    let p = joints.len();
    let mut bounds = Vec::with_capacity(input.mesh.positions.len() * p * 3);
    for x in 0..input.mesh.positions.len() * p {
        let (i, j) = (x / p, x % p);
        let h = input.mesh.positions[i].to_homogeneous();
        let list = &influences[i];
        let k = list.len() as f64;
        for row in 0..3 {
            let size: f64 = list
                .iter()
                .map(|&(joint, w)| {
                    let m: &Matrix4<f64> = &joints[j][joint as usize];
                    w.abs() * (0..4).map(|c| (m[(row, c)] * h[c]).abs()).sum::<f64>()
                })
                .sum();
            bounds.push((4.0 + k) * U32 * size * (1.0 + 1e-6) + 9.0 * k * F32_FLUSH);
        }
    }
    Ok(bounds)
}

/// The per-coordinate skinning errors in the order of [`lbs_bound`].
pub fn lbs_errors(data: &CrossCheckData) -> Vec<f64> {
    data.posed_ref
        .iter()
        .zip(&data.posed_gpu)
        .flat_map(|(r, g)| (0..3).map(move |c| (r[c] - g[c]).abs()))
        .collect()
}

/// Absolute error bound of each entry of a source quadric `w q qᵀ` computed in f32 from the
/// same f32 corners (first order; entries in the order (r, c ≥ r) of the upper triangle):
///
/// - face: edges round once, each cross-product component is a 2-product difference: |Δc| ≤
///   4√3 u |e1||e2|; normalising gives n and the area with errors ≤ δ = 4√3 κ u + 3u,
///   κ = |e1||e2| / |e1 × e2|; d = −n·p0 adds (δ + 3u)|p0|₁;
/// - constraint of edge e in a face of normal n_f (error δ_f as above): m = e × n_f has
///   |m| = |e| (e ⊥ n_f) and |Δm| ≤ |e| (√3 δ_f + 4√3 u), so the plane normal errs by
///   δ_c = √3 δ_f + 4√3 u + 3u, d by (δ_c + 3u)|p0|₁, the weight W|e|² by 5u;
/// - an entry `w q_r q_c` (2 products) then errs by ≤ w (Δq_r |q_c| + |q_r| Δq_c +
///   Δq_r Δq_c + |q_r q_c| (δ_w + 2u)), with q the reference's plane (the product of the errors keeps
///   the bound above 0 where q_r = q_c = 0, which a fused multiply-add does not leave exact);
/// - a face that is degenerate in f64: ≤ 2√3 u |e1||e2| (1 + |p0|₁)² per entry (the area f32
///   may leave, times the largest entry of a unit plane through p0).
pub fn source_bound(s: &PlaneSource, corners: [Point3<f64>; 3], weight: f64) -> [f64; 10] {
    let e1 = corners[1] - corners[0];
    let e2 = corners[2] - corners[0];
    let cross = e1.cross(&e2);
    let twice = cross.norm();
    let mut out = [0.0; 10];
    if twice == 0.0 {
        // Degenerate in f64, but f32 (rounded or fused) may leave a cross product of up to
        // 4√3 u |e1||e2|: a plane of any direction with weight (area) ≤ 2√3 u |e1||e2|, whose
        // entries are ≤ that weight times (1 + |p0|₁)² (|n_r| ≤ 1, |d| ≤ |p0|₁).
        let reach = 1.0 + corners[0].coords.abs().sum();
        let w = 2.0 * 3f64.sqrt() * U32 * e1.norm() * e2.norm();
        return [w * reach * reach; 10];
    }
    let kappa = e1.norm() * e2.norm() / twice;
    let delta_face = (4.0 * 3f64.sqrt() * kappa + 3.0) * U32;
    let n_face = cross / twice;
    let (n, p0, w, dn, dw) = if s.kind == SOURCE_FACE {
        (n_face, corners[0], 0.5 * twice, delta_face, delta_face)
    } else {
        let [i, k] = crate::mesh::EDGE_CORNERS[s.kind as usize];
        let e = corners[k] - corners[i];
        let m = e.cross(&n_face);
        if m.norm() == 0.0 {
            return out;
        }
        let dc = 3f64.sqrt() * delta_face + (4.0 * 3f64.sqrt() + 3.0) * U32;
        (
            m / m.norm(),
            corners[i],
            weight * e.norm_squared(),
            dc,
            5.0 * U32,
        )
    };
    let p0_1 = p0.coords.abs().sum();
    let q = [n.x, n.y, n.z, -n.dot(&p0.coords)];
    let dq = [dn, dn, dn, (dn + 3.0 * U32) * p0_1];
    let mut k = 0;
    for r in 0..4 {
        for c in r..4 {
            // The product of the two errors, Δq_r Δq_c, is second order, but it is all there
            // is where q_r = q_c = 0 (an axis-aligned plane): a fused or reordered f32
            // computation leaves ≈ u-sized components there, never exactly 0.
            out[k] = w
                * (dq[r] * q[c].abs()
                    + q[r].abs() * dq[c]
                    + dq[r] * dq[c]
                    + (q[r] * q[c]).abs() * (dw + 2.0 * U32));
            k += 1;
        }
    }
    out
}

/// One compared element: where it is, its error and its bound (1e-6 relative slack for the
/// neglected second-order terms included).
#[derive(Clone, Debug, PartialEq)]
pub struct Checked {
    /// What the element is, for messages: e.g. `vertex 3 pose 1 entry 4`.
    pub what: String,
    pub error: f64,
    pub bound: f64,
}

impl Checked {
    fn new(what: String, error: f64, bound: f64) -> Checked {
        Checked {
            what,
            error,
            bound: bound * (1.0 + 1e-6),
        }
    }

    /// `!(error ≤ bound)` (a NaN is over).
    pub fn is_over(&self) -> bool {
        !(self.error <= self.bound)
    }

    /// error / bound (0 for an exact element).
    pub fn ratio(&self) -> f64 {
        if self.error == 0.0 {
            0.0
        } else {
            self.error / self.bound
        }
    }
}

/// Every entry of every source quadric ([`source_bound`]) and of every vertex quadric: a vertex
/// sum of n sources in f32 errs by Σ of the sources' bounds plus the summation's
/// (n − 1) u Σ|K_s| (recursive summation from zero).
pub fn quadric_checks(data: &CrossCheckData) -> (Vec<Checked>, Vec<Checked>) {
    let s = &data.sources;
    let p = s.pose_count as usize;
    let weight = s.boundary_weight as f64;
    let mut bounds: Vec<[f64; 10]> = Vec::with_capacity(s.sources.len() * p);
    let mut plane = Vec::new();
    for (x, (r, g)) in data.plane_ref.iter().zip(&data.plane_gpu).enumerate() {
        let (src, j) = (s.sources[x / p], x % p);
        let corners = src.corners.map(|c| data.posed_rounded[c as usize * p + j]);
        let b = source_bound(&src, corners, weight);
        for (k, bk) in b.iter().enumerate() {
            plane.push(Checked::new(
                format!("source {} pose {j} entry {k}", x / p),
                (r.0[k] - g.0[k]).abs(),
                *bk,
            ));
        }
        bounds.push(b);
    }
    let mut vertex = Vec::new();
    for (x, (r, g)) in data.vertex_ref.iter().zip(&data.vertex_gpu).enumerate() {
        let (i, j) = (x / p, x % p);
        let list =
            &s.vertex_sources[s.vertex_offsets[i] as usize..s.vertex_offsets[i + 1] as usize];
        let n = list.len() as f64;
        for (k, (rk, gk)) in r.0.iter().zip(&g.0).enumerate() {
            let terms: f64 = list
                .iter()
                .map(|&src| data.plane_ref[src as usize * p + j].0[k].abs())
                .sum();
            let own: f64 = list
                .iter()
                .map(|&src| bounds[src as usize * p + j][k])
                .sum();
            vertex.push(Checked::new(
                format!("vertex {i} pose {j} entry {k}"),
                (rk - gk).abs(),
                own + (n - 1.0).max(0.0) * U32 * terms,
            ));
        }
    }
    (plane, vertex)
}

/// `Σ_k α_k f(M_k^j)` over the candidate's joints: with f = |·| the magnitude Ā^j of `A^j` (last
/// row `(0, 0, 0, Σα)`), with f the identity `A^j` itself (exact in f64: f32 weights and
/// entries, at most 8 terms).
fn blend_of(
    mats: &[Matrix4<f64>],
    item: &EdgeItem,
    f: impl Fn(&Matrix4<f64>) -> Matrix4<f64>,
) -> Matrix4<f64> {
    let mut a = Matrix4::zeros();
    for k in 0..item.candidates as usize {
        a += f(&mats[item.joints[k] as usize]) * item.alpha[k] as f64;
    }
    a
}

/// What [`cost_checks`] found.
#[derive(Debug, Default)]
pub struct CostChecks {
    /// Entries of Q̃ (step 1).
    pub quadric: Vec<Checked>,
    /// Candidates where the GPU kept another point: the reference's values at the two points
    /// against twice the value error bound (a near tie).
    pub ties: Vec<Checked>,
    /// Positions and costs where both kept the same point (steps 2 and 3).
    pub positions: Vec<Checked>,
    pub costs: Vec<Checked>,
    pub skipped: usize,
    /// Candidates where the notes' tolerance is expected to hold, and how many exceed it.
    pub expected_positions: usize,
    pub over_notes_positions: usize,
    pub expected_costs: usize,
    pub over_notes_costs: usize,
    /// Candidates beyond the notes' tolerance where it was not expected to hold.
    pub unexpected_positions_over: usize,
    pub unexpected_costs_over: usize,
}

/// One pose j of a candidate, as the bounds of [`CostBound`] need it: the magnitudes
/// Ā^j = Σ α_k |M_k^j| and T^j = |Q_a^j| + |Q_b^j| (entrywise), and the signed A^j = Σ α_k M_k^j
/// and Q^j = Q_a^j + Q_b^j (exact in f64: sums of a few f32 products).
#[derive(Clone, Debug)]
pub struct PoseTerms {
    pub abar: Matrix4<f64>,
    pub t: Matrix4<f64>,
    pub blend: Matrix4<f64>,
    pub quadric: Matrix4<f64>,
}

/// The magnitudes of the f32 evaluations at a point h = (v, 1) that the kernel may have moved
/// by up to Δv per coordinate (|h| is taken as (|v| + Δv, 1)), summed over the poses, with
/// P_j = Ā^j |h| (≥ |A^j h|) and G_j = |Q^j A^j h| + T^j Ā^j (Δv, Δv, Δv, 0) (≥ the half
/// gradient |Q^j p| at the moved point).
#[derive(Clone, Copy, Debug, Default)]
pub struct PointMagnitudes {
    /// Σ_j P_jᵀ T^j P_j: what every rounding of an entry of Q^j or of Q^j p is relative to.
    pub squared: f64,
    /// Σ_j P_jᵀ G_j: what an error in p = A^j h is relative to (p ↦ pᵀQp has gradient 2Qp).
    pub gradient: f64,
    /// Σ_j |h|ᵀ |A^{jT} Q^j A^j| |h|: the pose terms that Q̃'s pose sum adds up.
    pub pose_terms: f64,
    /// |h|ᵀ |Q̃| |h|.
    pub total: f64,
}

/// γ_n = n u / (1 − n u): n roundings in a row, each ≤ u relative (Higham, *Accuracy and
/// Stability of Numerical Algorithms*, Lemma 3.1), with u = [`U32`].
pub fn gamma(n: f64) -> f64 {
    n * U32 / (1.0 - n * U32)
}

/// The bounds of one candidate's outputs, from the reference alone, with the per-pose terms
/// of [`PoseTerms`], T_Q = Σ_j Ā^{jT} T^j Ā^j, and the magnitudes P, G of [`PointMagnitudes`]:
///
/// 1. Q̃ entries: Q_a + Q_b rounds once; an entry of A^j is a K-term sum (≤ (K + 1) u, K ≤ 8);
///    (AᵀQA)_rc is two 4-term dot products deep (≤ 8u); P poses add ≤ P u. So
///    |ΔQ̃| ≤ η_Q T_Q, η_Q = (1 + 2·9 + 8 + P) u, rounded up to (30 + P) u ([`Self::quadric`]).
/// 2. The solve: perturbing B, b by ΔB, Δb (|ΔB| ≤ η_Q T_B) moves v by
///    Δv_B = (B + ΔB)⁻¹ (ΔB v + Δb), ≤ ‖B⁻¹‖_F ρ / (1 − κε), ρ = η_Q (‖T_B‖_F |v| + |T_b|),
///    κε = ‖B⁻¹‖_F η_Q ‖T_B‖_F (the relative size of the perturbation, amplified; ∞ from ½ on).
///    The adjugate solve itself (cofactors c_j × c_k: 3 roundings each; det = c0·(c1 × c2): 5
///    more; the quotient: 2) adds σ ≤ u (12 ‖B‖_F² |b| + 10 ‖B‖_F³ |v|) / |det B|
///    ([`Self::solve`]).
/// 3. A value v̂ᵀQ̃v̂ at a point, from the kernel's own Q̃: an error ΔA in A^j changes
///    hᵀA^{jT}Q^jA^jh by 2 (ΔA h)ᵀ(Q^j A^j h), ≤ 2·9u P_jᵀG_j; Q_a + Q_b, AᵀQ and (AᵀQ)A round
///    (1 + 4 + 4) u relative to P_jᵀT^jP_j; the pose sum, in any order, ≤ γ_{P−1} Σ_j
///    |h|ᵀ|A^{jT}Q^jA^j||h|; Q̃h and h·(Q̃h) ≤ γ_8 |h|ᵀ|Q̃||h| ([`Self::value`]).
/// 4. The cost at the GPU's own position ṽ: E is quadratic in v with zero gradient at the
///    reference's v, so E(ṽ) − E(v) = Δvᵀ B Δv: for the solution
///    ≤ (√‖B⁻¹‖_F ρ / (1 − κε) + √‖B‖_F σ)² (B's energy norm of step 2's two parts; for Δv_B,
///    ‖B^{½}(B + ΔB)⁻¹‖ ≤ √‖B⁻¹‖ / (1 − κε)), for a kept end or midpoint 2|g|Δv + ‖B‖_F Δv²
///    ([`Self::moved`]). Evaluating E = Σ_j p_jᵀQ^jp_j in f32 at ṽ: p = A^j ṽ carries
///    (9 + 4) u P_j, whose effect is first order in the gradient: 2·13u P_jᵀG_j; Q_a + Q_b and
///    Q^j p round (1 + 4) u P_jᵀT^jP_j; p·(Qp) rounds 4u P_jᵀ|Q^j p|; so per pose
///    ≤ 5u PᵀTP + 30u PᵀG + 300u² PᵀTP (the second-order terms, ΔpᵀQΔp and the rest). The pose
///    sum adds terms p_jᵀQ^jp_j ≥ 0, so its rounding is relative to E itself:
///    ≤ γ_{P−1} (E(v) + moved + the per-pose errors) ([`Self::cost`]). Only the roundings of
///    the entries of Q^j and of Q^j p meet the cancellation of a plane's n·p + d; the earlier
///    bound (25 + P) u Σ_j P_jᵀT^jP_j charged every rounding, the pose sum's included, to it,
///    and was 2000× the error on `Fox.glb`.
#[derive(Clone, Debug)]
pub struct CostBound {
    /// T_Q.
    pub t_q: Matrix4<f64>,
    /// Per pose, in order.
    pub poses: Vec<PoseTerms>,
    pub eta_q: f64,
    /// ‖B‖_F of the reference's B.
    pub b_norm: f64,
    /// ‖B⁻¹‖_F (∞ when B is singular).
    pub inverse_norm: f64,
    /// Step 2's parts: Δv_B's bound ‖B⁻¹‖_F ρ / (1 − κε), and the solve's own rounding σ.
    pub solve_perturbation: f64,
    pub solve_rounding: f64,
    /// How far the f32 solution may land from the reference's: the sum of the two parts
    /// (∞ when B is singular or κε ≥ ½).
    pub solve: f64,
    /// How far the f32 midpoint (a + b) · 0.5 may land from the exact one: a + b rounds once,
    /// up or down (one ULP: u relative per coordinate), the halving is exact: ≤ u |a + b| / 2.
    pub midpoint: f64,
    /// The reference's Q̃ (for the gradient of v̂ᵀQ̃v̂ at a moved point).
    pub quadric: Matrix4<f64>,
}

impl CostBound {
    /// The bounds of candidate `item` (the kernel's input) whose reference result is `r`.
    pub fn new(cd: &CostData, item: &EdgeItem, r: &ReferenceCost) -> CostBound {
        let p = cd.mats.len();
        let eta_q = (30.0 + p as f64) * U32;
        let (a, b) = (item.a as usize, item.b as usize);
        let poses: Vec<PoseTerms> = (0..p)
            .map(|j| {
                let (qa, qb) = (
                    cd.vertex_quadrics[a * p + j].matrix(),
                    cd.vertex_quadrics[b * p + j].matrix(),
                );
                PoseTerms {
                    abar: blend_of(&cd.mats[j], item, |m| m.abs()),
                    t: qa.abs() + qb.abs(),
                    blend: blend_of(&cd.mats[j], item, |m| *m),
                    quadric: qa + qb,
                }
            })
            .collect();
        let t_q = poses
            .iter()
            .map(|pose| pose.abar.transpose() * pose.t * pose.abar)
            .fold(Matrix4::zeros(), |acc, m| acc + m);
        let bm = r.quadric.fixed_view::<3, 3>(0, 0).into_owned();
        let bv = Vector3::new(r.quadric[(0, 3)], r.quadric[(1, 3)], r.quadric[(2, 3)]);
        let tb = t_q.fixed_view::<3, 3>(0, 0).into_owned();
        let tbv = Vector3::new(t_q[(0, 3)], t_q[(1, 3)], t_q[(2, 3)]);
        let v = r.position.coords.norm();
        let (inverse_norm, solve_perturbation, solve_rounding) = match bm.try_inverse() {
            Some(inv) => {
                let inverse_norm = inv.norm();
                let amplified = inverse_norm * eta_q * tb.norm();
                let rho = eta_q * (tb.norm() * v + tbv.norm());
                let perturbation = if amplified < 0.5 {
                    inverse_norm * rho / (1.0 - amplified)
                } else {
                    f64::INFINITY
                };
                let rounding = U32
                    * (12.0 * bm.norm_squared() * bv.norm() + 10.0 * bm.norm().powi(3) * v)
                    / bm.determinant().abs();
                (inverse_norm, perturbation, rounding)
            }
            None => (f64::INFINITY, f64::INFINITY, f64::INFINITY),
        };
        CostBound {
            t_q,
            poses,
            eta_q,
            b_norm: bm.norm(),
            inverse_norm,
            solve_perturbation,
            solve_rounding,
            solve: solve_perturbation + solve_rounding,
            midpoint: 0.5 * U32 * (cd.rest[a].coords + cd.rest[b].coords).norm(),
            quadric: r.quadric,
        }
    }

    /// Step 1: the bound of each entry of Q̃, upper triangle row by row.
    pub fn quadric(&self) -> [f64; 10] {
        let mut out = [0.0; 10];
        let mut k = 0;
        for r in 0..4 {
            for c in r..4 {
                out[k] = self.eta_q * self.t_q[(r, c)];
                k += 1;
            }
        }
        out
    }

    /// The [`PointMagnitudes`] at `v`, moved by up to `dv` per coordinate.
    pub fn magnitudes(&self, v: &Point3<f64>, dv: f64) -> PointMagnitudes {
        let h = v.to_homogeneous();
        let habs = h.abs() + nalgebra::Vector4::new(dv, dv, dv, 0.0);
        let shift = nalgebra::Vector4::new(dv, dv, dv, 0.0);
        let mut m = PointMagnitudes {
            total: habs.dot(&(self.quadric.abs() * habs)),
            ..PointMagnitudes::default()
        };
        for pose in &self.poses {
            let big_p = pose.abar * habs;
            let g = (pose.quadric * (pose.blend * h)).abs() + pose.t * (pose.abar * shift);
            m.squared += big_p.dot(&(pose.t * big_p));
            m.gradient += big_p.dot(&g);
            let x = pose.blend.transpose() * pose.quadric * pose.blend;
            m.pose_terms += habs.dot(&(x.abs() * habs));
        }
        m
    }

    /// Step 3: the bound of v̂ᵀQ̃v̂ evaluated in f32, from the kernel's Q̃, at the kernel's
    /// point, within `dv` per coordinate of `v`:
    /// 18u ΣPᵀG + 9u ΣPᵀTP + γ_{P−1} Σ|h|ᵀ|AᵀQA||h| + γ_8 |h|ᵀ|Q̃||h|, plus 300u² ΣPᵀTP for
    /// the second-order terms.
    pub fn value(&self, v: &Point3<f64>, dv: f64) -> f64 {
        let m = self.magnitudes(v, dv);
        let poses = self.poses.len() as f64;
        (18.0 * U32 * m.gradient
            + (9.0 * U32 + 300.0 * U32 * U32) * m.squared
            + gamma((poses - 1.0).max(0.0)) * m.pose_terms
            + gamma(8.0) * m.total)
            * (1.0 + 1e-6)
    }

    /// Steps 1–2: the bound of the kept position, when both sides keep the point `choice`:
    /// the solve's (0), the midpoint's rounding (3); the ends a, b (1, 2) are inputs, copied,
    /// where only a subnormal coordinate may be flushed (≤ 2⁻¹²⁶, [`F32_FLUSH`]), as in every
    /// case.
    pub fn position(&self, choice: u32) -> f64 {
        let computed = match choice {
            0 => self.solve * (1.0 + 1e-6),
            3 => self.midpoint * (1.0 + 1e-6),
            _ => 0.0,
        };
        computed + F32_FLUSH
    }

    /// How much v̂ᵀQ̃v̂ (or E, equal to it) may change when the kept point `choice`, at `v`,
    /// moves by Δv ≤ [`Self::position`] (step 4): 2 |g| Δv plus Δvᵀ B Δv, g = (Q̃ v̂)\[0:3\] the
    /// half gradient (0 at the solution, the minimum); for the solution
    /// Δvᵀ B Δv ≤ (√‖B⁻¹‖_F ρ/(1 − κε) + √‖B‖_F (σ + 2⁻¹²⁶))², elsewhere ‖B‖_F Δv².
    pub fn moved(&self, choice: u32, v: &Point3<f64>) -> f64 {
        let dv = self.position(choice);
        let g = (self.quadric * v.to_homogeneous()).xyz().norm();
        if !dv.is_finite() {
            return f64::INFINITY;
        }
        let energy = if choice == 0 {
            // ‖Δv_B‖_B ≤ √‖B⁻¹‖ ρ/(1 − κε) = solve_perturbation / √‖B⁻¹‖.
            let norm = self.solve_perturbation / self.inverse_norm.sqrt()
                + self.b_norm.sqrt() * (self.solve_rounding + F32_FLUSH);
            norm * norm * (1.0 + 1e-6)
        } else {
            self.b_norm * dv * dv
        };
        2.0 * g * dv + energy
    }

    /// Step 4: the bound of E(v̂, α) when both sides keep point `choice` of the reference's
    /// result `r`: (5u ΣPᵀTP + 30u ΣPᵀG + 300u² ΣPᵀTP) (1 + γ_{P−1}) + moved
    /// + γ_{P−1} (E + moved).
    pub fn cost(&self, r: &ReferenceCost) -> f64 {
        let m = self.magnitudes(&r.position, self.position(r.choice));
        let per_pose = (5.0 * U32 + 300.0 * U32 * U32) * m.squared + 30.0 * U32 * m.gradient;
        let moved = self.moved(r.choice, &r.position);
        let sum = gamma((self.poses.len() as f64 - 1.0).max(0.0));
        (per_pose * (1.0 + sum) + moved + sum * (r.cost.abs() + moved)) * (1.0 + 1e-6)
    }

    /// How far (relatively) an f32 cond_F(B) may be from the reference's `condition`: the
    /// perturbation ΔB (≤ η_Q T_B) moves ‖B‖_F by ≤ ε ‖B‖_F, ε = η_Q ‖T_B‖_F / ‖B‖_F, and
    /// ‖B⁻¹‖_F by ≤ cond ε ‖B⁻¹‖_F; the adjugate's cofactors, det and norms round ≤ 20u
    /// relative each, amplified by the cancellation in det up to cond. Doubled for the
    /// second-order terms: 2 ((1 + cond) ε + 20u (1 + cond)).
    pub fn condition_error(&self, condition: f64) -> f64 {
        let tb = self.t_q.fixed_view::<3, 3>(0, 0).norm();
        let epsilon = self.eta_q * tb / self.b_norm;
        2.0 * (1.0 + condition) * (epsilon + 20.0 * U32)
    }

    /// Whether every conforming f32 evaluation keeps the reference's point: the solve's
    /// `cond ≤ max_condition` is decided beyond [`Self::condition_error`], and the kept point's
    /// value v̂ᵀQ̃v̂ is apart from every other compared point's by more than both values' bounds
    /// ([`Self::value`]) plus, for the solution, [`Self::moved`].
    pub fn decided(
        &self,
        r: &ReferenceCost,
        fallbacks: &[Point3<f64>; 3],
        solution: Option<Point3<f64>>,
        max_condition: f64,
    ) -> bool {
        let rho = self.condition_error(r.condition);
        let cond_decided = r.condition.is_finite()
            && rho < 0.5
            && (r.condition * (1.0 + rho) < max_condition
                || r.condition * (1.0 - rho) > max_condition);
        if !cond_decided {
            return false;
        }
        let value = |v: &Point3<f64>| {
            let h = v.to_homogeneous();
            h.dot(&(r.quadric * h))
        };
        let points: Vec<(u32, Point3<f64>)> = solution
            .map(|s| (0, s))
            .into_iter()
            .chain((1..4).map(|k| (k, fallbacks[k as usize - 1])))
            .collect();
        let slack = |k: u32, v: &Point3<f64>| self.value(v, self.position(k)) + self.moved(k, v);
        let kept = slack(r.choice, &r.position);
        points
            .iter()
            .all(|(k, v)| *k == r.choice || (value(v) - r.value).abs() > kept + slack(*k, v))
    }
}

/// Per compared candidate (cond_F(B) ≤ [`SKIP_CONDITION`]) the checks of [`CostBound`]: Q̃'s
/// entries, then, when both sides kept the same point, its position and cost; when they kept
/// different points, a near tie: the reference's values at the two points differ by ≤ both
/// values' bounds plus, when one side kept the solution, ‖B‖_F Δv².
///
/// The notes' tolerances ([`POSITION_TOLERANCE`], max(1e-4|E|, 1e-7)) must hold where the
/// expected error, bound/√k (k = 30 + P or 25 + P roundings adding up like √k u), is below
/// them; elsewhere exceedances are counted only.
pub fn cost_checks(data: &CrossCheckData) -> Result<CostChecks> {
    let cd = &data.cost_data;
    let p = cd.mats.len();
    let items = cd.edge_items(&data.candidates)?;
    let mut out = CostChecks::default();
    for ((c, item), (r, g)) in data
        .candidates
        .iter()
        .zip(&items)
        .zip(data.costs_ref.iter().zip(&data.costs_gpu))
    {
        if !(r.condition <= SKIP_CONDITION) {
            out.skipped += 1;
            continue;
        }
        let (a, b) = (c.a as usize, c.b as usize);
        let what = format!("edge ({a}, {b}) endpoint {}", c.endpoint);
        let bound = CostBound::new(cd, item, r);
        let q_gpu = edge_cost_quadric(g);
        let mut k = 0;
        let entry_bounds = bound.quadric();
        for rr in 0..4 {
            for cc in rr..4 {
                out.quadric.push(Checked::new(
                    format!("{what} Q̃[{rr},{cc}]"),
                    (r.quadric[(rr, cc)] - q_gpu[(rr, cc)]).abs(),
                    entry_bounds[k],
                ));
                k += 1;
            }
        }
        let v_gpu = edge_cost_position(g);
        if r.choice != g.choice {
            let value = |v: &Point3<f64>| {
                let h = v.to_homogeneous();
                h.dot(&(r.quadric * h))
            };
            let moved = bound.moved(r.choice, &r.position) + bound.moved(g.choice, &v_gpu);
            out.ties.push(Checked::new(
                format!("{what}: choice {} vs {}", r.choice, g.choice),
                (value(&r.position) - value(&v_gpu)).abs(),
                bound.value(&r.position, bound.position(r.choice))
                    + bound.value(&v_gpu, 0.0)
                    + moved,
            ));
            continue;
        }
        let position_bound = bound.position(r.choice);
        let position_error = (r.position - v_gpu).norm();
        out.positions.push(Checked::new(
            format!("{what} (cond {:.1e})", r.condition),
            position_error,
            position_bound,
        ));
        let cost_bound = bound.cost(r);
        let cost_error = (r.cost - g.cost as f64).abs();
        out.costs.push(Checked::new(what, cost_error, cost_bound));
        let notes_cost = (COST_RELATIVE * r.cost.abs()).max(COST_ABSOLUTE);
        if position_bound / (30.0 + p as f64).sqrt() <= POSITION_TOLERANCE {
            out.expected_positions += 1;
            out.over_notes_positions += usize::from(position_error > POSITION_TOLERANCE);
        } else {
            out.unexpected_positions_over += usize::from(position_error > POSITION_TOLERANCE);
        }
        if cost_bound / (25.0 + p as f64).sqrt() <= notes_cost {
            out.expected_costs += 1;
            out.over_notes_costs += usize::from(cost_error > notes_cost);
        } else {
            out.unexpected_costs_over += usize::from(cost_error > notes_cost);
        }
    }
    Ok(out)
}

/// A row of per-element checks, errors relative to `scale(n)` when given.
fn checked_row(kernel: &str, input: &str, unit: &str, checks: &[Checked], formula: &str) -> Row {
    let errors: Vec<f64> = checks.iter().map(|c| c.error).collect();
    let bounds: Vec<f64> = checks.iter().map(|c| c.bound).collect();
    Row::compare(
        "skinsimp",
        kernel,
        input,
        unit,
        &errors,
        &[],
        Bounds::PerElement(bounds),
        formula,
    )
}

/// The full skinsimp table for one skinned input.
pub fn crosscheck_skinsimp(gpu: &Gpu, input_name: &str, input: &Input) -> Result<Vec<Row>> {
    let options = Options::default();
    let kernels = SkinsimpKernels::new(gpu.clone())?;
    let (summary, data) = crosscheck(
        &kernels,
        input,
        options.boundary_weight,
        options.cost.max_condition,
    )?;
    // Each side's time alone, on the cross-check's own inputs.
    let (_, lbs_gpu) = time_gpu_warm(gpu, || kernels.skin(&data.input))?;
    let (_, lbs_cpu) = time_cpu(|| skin_f64(&data.input));
    let (_, quadrics_gpu) =
        time_gpu_warm(gpu, || kernels.quadrics(&data.sources, &data.posed_rounded))?;
    let (_, quadrics_cpu) = time_cpu(|| {
        let weight = data.sources.boundary_weight as f64;
        let plane = plane_quadrics_f64(&data.posed_rounded, &data.sources, weight);
        vertex_quadrics_f64(&plane, &data.sources)
    });
    let (_, costs_gpu) = time_gpu_warm(gpu, || {
        kernels.costs(
            &data.cost_data,
            &data.candidates,
            options.cost.max_condition,
        )
    })?;
    let (_, costs_cpu) = time_cpu(|| {
        use rayon::prelude::*;
        data.candidates
            .par_iter()
            .map(|c| position_given_weights_f64(&data.cost_data, c, options.cost.max_condition))
            .collect::<Vec<_>>()
    });

    let algorithm = "skinsimp";
    let sizes: Vec<f64> = data
        .posed_ref
        .iter()
        .flat_map(|p| (0..3).map(move |c| p[c].abs()))
        .collect();
    let lbs = Row::compare(
        algorithm,
        "skinsimp_lbs: posed positions",
        input_name,
        "unit box (per coordinate)",
        &lbs_errors(&data),
        &sizes,
        Bounds::PerElement(lbs_bound(&data)?),
        "(4 + K) u Σ_k w_k Σ_c |M_k,rc h_c| per coordinate (K influences)",
    )
    .with_note(&format!(
        "{} vertices × {} poses",
        summary.vertices, summary.poses
    ))
    .with_timing(Timing {
        cpu_ms: Some(lbs_cpu),
        ..lbs_gpu
    });
    let (plane_checks, vertex_checks) = quadric_checks(&data);
    let plane = checked_row(
        "skinsimp_quadrics: source quadrics w q qᵀ",
        input_name,
        "unit box² (entries)",
        &plane_checks,
        "per entry: w(Δq_r|q_c| + |q_r|Δq_c + Δq_rΔq_c + |q_r q_c|(δ_w + 2u)), δ = 4√3κu + 3u (source_bound)",
    )
    .with_note(&format!(
        "{} sources × {} poses; relative to the largest entry: max {}, within the notes' {QUADRIC_TOLERANCE:e}: {}",
        data.sources.sources.len(),
        summary.poses,
        crate::report::sig(summary.plane_quadrics.max_abs, 2),
        summary.plane_quadrics.over_tolerance == 0
    ))
    .with_timing(Timing {
        cpu_ms: Some(quadrics_cpu),
        ..quadrics_gpu
    });
    let vertex = checked_row(
        "skinsimp_quadrics: vertex quadrics Σ Q",
        input_name,
        "unit box² (entries)",
        &vertex_checks,
        "per entry: Σ_s source_bound + (n − 1) u Σ_s |K_s| (n sources)",
    );
    let checks = cost_checks(&data)?;
    let quadric_q = checked_row(
        "skinsimp_collapse_cost: edge quadric Q̃",
        input_name,
        "unit box² (entries)",
        &checks.quadric,
        "(30 + P) u Σ_j Ā^jᵀ T^j Ā^j per entry",
    )
    .with_note(&format!(
        "{} candidates, {} with cond > {SKIP_CONDITION:e} skipped",
        summary.candidates, checks.skipped
    ))
    .with_timing(Timing {
        cpu_ms: Some(costs_cpu),
        ..costs_gpu
    });
    let ties = checked_row(
        "skinsimp_collapse_cost: near ties (other point kept)",
        input_name,
        "unit box² (value)",
        &checks.ties,
        "|v̂ᵀQ̃v̂ at the two points| ≤ both values' bounds (18u ΣPᵀG + 9u ΣPᵀTP + γ_{P−1} Σ|h|ᵀ|AᵀQA||h| + γ_8 |h|ᵀ|Q̃||h|) + Δvᵀ B Δv + 2|g|Δv (CostBound::value, moved)",
    )
    .with_note(
        "the error here is how close a tie the GPU's rounding decided the other way: at most \
         the two values' actual f32 errors, so its ratio follows the cost row's, lower",
    );
    let positions = checked_row(
        "skinsimp_collapse_cost: position v̂",
        input_name,
        "unit box",
        &checks.positions,
        "‖B⁻¹‖ η_Q(‖T_B‖|v| + |T_b|)/(1 − κε) + u(12‖B‖²|b| + 10‖B‖³|v|)/|det B|",
    )
    .with_note(&format!(
        "notes' 1e-5 expected for {} (over: {}), exceeded elsewhere by {}",
        checks.expected_positions, checks.over_notes_positions, checks.unexpected_positions_over
    ));
    let costs = checked_row(
        "skinsimp_collapse_cost: cost v̂ᵀQv̂",
        input_name,
        "unit box²",
        &checks.costs,
        "(5u ΣPᵀTP + 30u ΣPᵀG)(1 + γ_{P−1}) + γ_{P−1} E + Δvᵀ B Δv + 2|g|Δv, P = Ā|v̂|, G = |QAv̂| (CostBound::cost)",
    )
    .with_note(&format!(
        "notes' max(1e-4|E|, 1e-7) expected for {} (over: {}), exceeded elsewhere by {}",
        checks.expected_costs, checks.over_notes_costs, checks.unexpected_costs_over
    ));
    let mut rows = vec![lbs, plane, vertex, quadric_q, ties, positions, costs];
    // The notes' tolerances where f32 is expected to meet them are part of the verdict.
    for (row, over) in [
        (5, checks.over_notes_positions),
        (6, checks.over_notes_costs),
    ] {
        if over > 0 {
            rows[row].over += over;
            rows[row].verdict = super::Verdict::Fail;
        }
    }
    Ok(rows)
}
