//! The second-order term of the non-axis-aligned model Hessian, opt-in ([`super::NaaModel::Newton`]):
//! S = Σ_k r_k ∇²r_k, added to JᵀJ so that each LM step minimises the quadratic model
//! F + 2gᵀh + hᵀ(JᵀJ + S)h of F = Σ r² (exactly ½∇²F = JᵀJ + S), not the Gauss–Newton one.
//!
//! # Why
//! The NAA residual r = σ(‖q‖ − o), q = J_D(p) W, is a norm: its curvature (I − uuᵀ)/‖q‖ is
//! large wherever ‖q‖ is far from o, and Gauss–Newton (JᵀJ alone) drops it. On the saddle the
//! accepted steps then shrink the energy gap by a near-constant factor (linear convergence, tens
//! of iterations at 192 and 288 unknowns). With S the iteration counts fall on the saddle, bump
//! and plane, not on the worm ([`super::NaaModel::Newton`] lists them; bench
//! `gridwarp_naa_frame_newton`). The paper uses ALGLIB's Jacobian-only protocol, so this model is
//! an option, not the default; LM needs no change for it: a trial whose damped model is not
//! positive definite fails its box QP or predicts no decrease, and both count as a rejected
//! trial (λ grows).
//!
//! # Formula (one sample, one axis; module docs of [`super`] for q, W, φ_c)
//! Slot a = (c, k) is coordinate k of corner c; φ'_c = ∂φ_c/∂s for the s residual (∂φ_c/∂t for
//! the t residual); D_k is column k of J_D, G_k = (∂_k J_D) W, u = q/‖q‖, Π = I − uuᵀ. Then
//!   Q_a = ∂q/∂x_a = φ'_c D_k + φ_c G_k,      d_a = ∂r/∂x_a = σ uᵀQ_a,
//!   ∂²q/∂x_a∂x_b = φ'_c φ_c' ∂_l D_k + φ_c φ'_c' ∂_k D_l + φ_c φ_c' (∂_l∂_k J_D) W,
//!   r∇²r_ab = σr [Q_aᵀ Π Q_b/‖q‖ + uᵀ ∂²q/∂x_a∂x_b].
//! With ρ = σr/‖q‖ = σ²(‖q‖ − o)/‖q‖ this is
//!   r∇²r_ab = φ'_c φ'_c' P_kl + φ'_c φ_c' Q_kl + φ_c φ'_c' Q_lk + φ_c φ_c' T_kl,
//!   P_kl = ρ D_kᵀΠD_l,  Q_kl = ρ D_kᵀΠG_l + σr uᵀ∂_l D_k,  T_kl = ρ G_kᵀΠG_l,
//! with xᵀΠy = x·y − (u·x)(u·y). Left out: the term φ_c φ_c' σr uᵀ(∂_s∂_t J_D)W of the fields'
//! mixed derivative, the only second derivative of a bilinear texel patch (a constant per
//! texel): S is exact where J_D is affine across the cell's texels, and a model of the curvature
//! elsewhere (LM's gain ratio absorbs the rest). At q = 0 (u undefined) the sample adds nothing,
//! as in the Jacobian.
//!
//! # Moments: summing over a cell's samples
//! The corner weights are products of one weight per side: for the s residual, with A = (1−α, α)
//! along s and B = (1−β, β) across, corner c = (i, j) (i = 0, 1 its side along, j across) has
//!   φ_c = A_i B_j,   φ'_c = ε_i B_j / h   (ε_0 = −1, ε_1 = +1; h the rest cell's width);
//! the t residual is the same with the roles of α and β (and of i and j, and h → the cell's
//! height k) swapped. So each product of weights above is one of a few monomials in α, β, and
//! a cell's S needs only these sums over its samples (B_jj' = B_j B_j', pairs unordered):
//! ```text
//! m1[jj'][kl] = Σ B_jj' P_kl,  m2[jj'][i'][kl] = Σ B_jj' A_i' Q_kl,
//! m3[ii'][jj'][kl] = Σ A_ii' B_jj' T_kl    (3·3 + 3·2·4 + 3·3·3 = 60 sums per axis),
//! ```
//! from which, for a = (c, k), c = (i, j), and b = (c', l), c' = (i', j'),
//! ```text
//! S_ab = ε_i ε_i' m1[jj'][kl] / h² + ε_i m2[jj'][i'][kl] / h + ε_i' m2[jj'][i][lk] / h
//!        + m3[ii'][jj'][kl].
//! ```
//! Each sample thus costs 60 multiply-adds per axis instead of one sum per entry of the 8×8
//! block (36 entries of three products each); the result is the same sum, rounded differently.
//! JᵀJ has the same form (d_a d_b = σ²(uᵀQ_a)(uᵀQ_b): P, Q, T with the products (u·x)(u·y)
//! weighted σ²), so for [`super::NaaModel::Newton`] the same 60 sums give JᵀJ + S at once,
//! with λ = σ² − ρ in place of −ρ as the weight of those products.
//!
//! # Lanes
//! The residual pass (`NaaEnergy::chunk_residuals`) keeps J_D and W of its LANES samples
//! (`LaneJacobian`), so S reads no texels of its own; the coefficients are then computed as
//! whole-lane operations (`axis_coefficients`) and added to the moments
//! (`CellMoments::add_chunk`). (Written per sample inside one lane loop, the same formulas
//! were left scalar by the compiler: the loop over the two axes stayed a loop.)

use super::{lanes, SampleLanes, VectorSample, LANES};
use crate::gridwarp::lanes::{lane_total, UPPER_8};

/// One value per lane.
type Lanes = [f64; LANES];

/// The index of an unordered pair {x, y} of sides (or of coordinates) 0/1: 00 → 0, 01 and
/// 10 → 1, 11 → 2.
#[inline(always)]
fn pair(x: usize, y: usize) -> usize {
    x + y
}

/// The coefficients P_kl, Q_kl and T_kl of one axis's r∇²r (module docs) of LANES samples,
/// one value per lane: P and T (symmetric) at [`pair`]`(k, l)`, Q at 2k + l.
pub(super) struct LaneCoefficients {
    p: [Lanes; 3],
    q: [Lanes; 4],
    t: [Lanes; 3],
}

/// J_D = [D_s D_t] with its derivatives along s and t at the warped points of LANES samples,
/// and their slopes W_s, W_t, one value per lane: what the residual pass
/// ([`super::NaaEnergy::chunk_residuals`]) keeps for S, so that S needs no texel reads of its
/// own. Indexed [column k][component], W as [axis][coordinate].
pub(super) struct LaneJacobian {
    value: [[Lanes; 3]; 2],
    ds: [[Lanes; 3]; 2],
    dt: [[Lanes; 3]; 2],
    w: [[Lanes; 2]; 2],
}

impl LaneJacobian {
    pub(super) fn zeros() -> Self {
        LaneJacobian {
            value: [[[0.0; LANES]; 3]; 2],
            ds: [[[0.0; LANES]; 3]; 2],
            dt: [[[0.0; LANES]; 3]; 2],
            w: [[[0.0; LANES]; 2]; 2],
        }
    }

    /// Lane `lane` ← J_D's columns `d_s`, `d_t` and the slopes `w` = [W_s, W_t].
    #[inline(always)]
    pub(super) fn set(
        &mut self,
        lane: usize,
        d_s: &VectorSample,
        d_t: &VectorSample,
        w: [[f64; 2]; 2],
    ) {
        for c in 0..3 {
            self.value[0][c][lane] = d_s.value[c];
            self.ds[0][c][lane] = d_s.ds[c];
            self.dt[0][c][lane] = d_s.dt[c];
            self.value[1][c][lane] = d_t.value[c];
            self.ds[1][c][lane] = d_t.ds[c];
            self.dt[1][c][lane] = d_t.dt[c];
        }
        for (lanes, w) in self.w.iter_mut().zip(w) {
            lanes[0][lane] = w[0];
            lanes[1][lane] = w[1];
        }
    }
}

/// x·y per lane, for 3-vectors given by component.
#[inline(always)]
fn dot_lanes(x: &[Lanes; 3], y: &[Lanes; 3]) -> Lanes {
    lanewise(|n| x[0][n] * y[0][n] + x[1][n] * y[1][n] + x[2][n] * y[2][n])
}

/// a w₀ + b w₁ per lane (a J_D-like matrix [a b] applied to w), by component.
#[inline(always)]
fn image_lanes(a: &[Lanes; 3], b: &[Lanes; 3], w: &[Lanes; 2]) -> [Lanes; 3] {
    let component = |c: usize| lanewise(|n| a[c][n] * w[0][n] + b[c][n] * w[1][n]);
    [component(0), component(1), component(2)]
}

/// The coefficients of r∇²r of LANES samples on one axis (module docs):
///   P_kl = ρ D_kᵀΠD_l,  Q_kl = ρ D_kᵀΠG_l + σr uᵀ∂_l D_k,  T_kl = ρ G_kᵀΠG_l,
/// q = J_D w, u = q/‖q‖, G_k = (∂_k J_D) w, ρ = σ²(‖q‖ − o)/‖q‖, σr = σ²(‖q‖ − o); all 0 at
/// q = 0 (u undefined: the sample adds nothing, as in the Jacobian); P, T by [`pair`], Q at
/// 2k + l. `w` = W_s or W_t and `o` = o_s or o_t per lane. `with_jtj`: those of JᵀJ + S
/// instead (σ²(u·x)(u·y) added to each, module docs "Moments"). Written as whole-lane
/// operations (each a short loop over the lanes, one vector instruction each).
#[inline(always)]
fn axis_coefficients(
    kept: &LaneJacobian,
    w: &[Lanes; 2],
    sigma: &Lanes,
    o: &Lanes,
    with_jtj: bool,
) -> LaneCoefficients {
    let [d0, d1] = &kept.value;
    // ∂_s D_k = kept.ds[k], ∂_t D_k = kept.dt[k].
    let q = image_lanes(d0, d1, w);
    let length = lanewise(|n| dot_lanes(&q, &q)[n].sqrt());
    let inverse = lanewise(|n| {
        if length[n] > 0.0 {
            1.0 / length[n]
        } else {
            0.0
        }
    });
    let sigma_r = lanewise(|n| sigma[n] * sigma[n] * (length[n] - o[n]));
    let rho = lanewise(|n| sigma_r[n] * inverse[n]);
    // λ, the weight of the products (u·x)(u·y): −ρ (from the projector Π of S), plus σ² with
    // JᵀJ (its d_a d_b = σ²(uᵀQ_a)(uᵀQ_b)).
    let jtj = if with_jtj { 1.0 } else { 0.0 };
    let lambda = lanewise(|n| jtj * sigma[n] * sigma[n] - rho[n]);
    let unit = |c: usize| lanewise(|n| q[c][n] * inverse[n]);
    let u = [unit(0), unit(1), unit(2)];
    let g = [
        image_lanes(&kept.ds[0], &kept.ds[1], w),
        image_lanes(&kept.dt[0], &kept.dt[1], w),
    ];
    let d = [d0, d1];
    let u_d = [dot_lanes(&u, d0), dot_lanes(&u, d1)];
    let u_g = [dot_lanes(&u, &g[0]), dot_lanes(&u, &g[1])];
    // ∂_l D_k by [l][k].
    let along = [[&kept.ds[0], &kept.ds[1]], [&kept.dt[0], &kept.dt[1]]];
    // ρ xᵀΠy = ρ x·y − ρ(u·x)(u·y), with JᵀJ's σ²(u·x)(u·y) added if asked.
    let mut out = LaneCoefficients {
        p: [[0.0; LANES]; 3],
        q: [[0.0; LANES]; 4],
        t: [[0.0; LANES]; 3],
    };
    for (k, l) in [(0, 0), (0, 1), (1, 1)] {
        let (dd, gg) = (dot_lanes(d[k], d[l]), dot_lanes(&g[k], &g[l]));
        out.p[pair(k, l)] = lanewise(|n| rho[n] * dd[n] + lambda[n] * u_d[k][n] * u_d[l][n]);
        out.t[pair(k, l)] = lanewise(|n| rho[n] * gg[n] + lambda[n] * u_g[k][n] * u_g[l][n]);
    }
    for k in 0..2 {
        for l in 0..2 {
            let (dg, u_along) = (dot_lanes(d[k], &g[l]), dot_lanes(&u, along[l][k]));
            out.q[2 * k + l] = lanewise(|n| {
                rho[n] * dg[n] + lambda[n] * u_d[k][n] * u_g[l][n] + sigma_r[n] * u_along[n]
            });
        }
    }
    out
}

/// The coefficients of the LANES samples from `at` on, both axes, from their kept J_D (of
/// JᵀJ + S `with_jtj`, else of S).
#[inline(always)]
fn chunk_coefficients(
    samples: &SampleLanes,
    at: usize,
    kept: &LaneJacobian,
    with_jtj: bool,
) -> [LaneCoefficients; 2] {
    let sigma = lanes(&samples.sigma, at);
    [
        axis_coefficients(kept, &kept.w[0], sigma, lanes(&samples.o_s, at), with_jtj),
        axis_coefficients(kept, &kept.w[1], sigma, lanes(&samples.o_t, at), with_jtj),
    ]
}

/// One axis's moments of a cell (module docs, "Moments"), per lane: `m1[jj'][kl]`,
/// `m2[jj'][i'][kl]` (kl = 2k + l), `m3[ii'][jj'][kl]`, pairs by [`pair`].
pub(super) struct AxisMoments<T> {
    m1: [[T; 3]; 3],
    m2: [[[T; 4]; 2]; 3],
    m3: [[[T; 3]; 3]; 3],
}

/// [f(0), …, f(LANES − 1)] by a plain loop, always inlined (so that it is compiled with its
/// caller's AVX-512, unlike an outlined `std::array::from_fn`).
#[inline(always)]
fn lanewise(f: impl Fn(usize) -> f64) -> Lanes {
    let mut out = [0.0; LANES];
    for (lane, v) in out.iter_mut().enumerate() {
        *v = f(lane);
    }
    out
}

/// The three products of a side's two weights per lane: [w₀w₀, w₀w₁, w₁w₁] (by [`pair`]).
#[inline(always)]
fn pair_products(w: &[Lanes; 2]) -> [Lanes; 3] {
    [
        lanewise(|l| w[0][l] * w[0][l]),
        lanewise(|l| w[0][l] * w[1][l]),
        lanewise(|l| w[1][l] * w[1][l]),
    ]
}

/// `sum[lane] += weight[lane] · coefficient[lane]` for each coefficient.
#[inline(always)]
fn add_weighted<const N: usize>(sums: &mut [Lanes; N], weight: &Lanes, coefficients: &[Lanes; N]) {
    for (sum, c) in sums.iter_mut().zip(coefficients) {
        for lane in 0..LANES {
            sum[lane] += weight[lane] * c[lane];
        }
    }
}

/// Corner c = i + 2j of a cell (i its side along s, j along t) seen from `axis`: (its side
/// along the axis, its side across it).
#[inline(always)]
fn sides(axis: usize, c: usize) -> (usize, usize) {
    if axis == 0 {
        (c % 2, c / 2)
    } else {
        (c / 2, c % 2)
    }
}

/// ε_i: the sign of ∂φ_c/∂(along) for side i (−1 for the near side, +1 for the far one).
#[inline(always)]
fn sign(side: usize) -> f64 {
    if side == 0 {
        -1.0
    } else {
        1.0
    }
}

impl AxisMoments<f64> {
    /// Add this axis's part of S (module docs, "Moments") to the upper triangle of `s`, for a
    /// rest cell of extent `h` along the axis.
    fn add_to(&self, axis: usize, h: f64, s: &mut [[f64; 8]; 8]) {
        let (h1, h2) = (1.0 / h, 1.0 / (h * h));
        for &(a, b) in &UPPER_8 {
            let ((c, k), (c2, l)) = ((a / 2, a % 2), (b / 2, b % 2));
            let ((i, j), (i2, j2)) = (sides(axis, c), sides(axis, c2));
            let jj = pair(j, j2);
            s[a][b] += sign(i) * sign(i2) * self.m1[jj][pair(k, l)] * h2
                + sign(i) * self.m2[jj][i2][2 * k + l] * h1
                + sign(i2) * self.m2[jj][i][2 * l + k] * h1
                + self.m3[pair(i, i2)][jj][pair(k, l)];
        }
    }
}

impl AxisMoments<Lanes> {
    fn zero() -> Self {
        AxisMoments {
            m1: [[[0.0; LANES]; 3]; 3],
            m2: [[[[0.0; LANES]; 4]; 2]; 3],
            m3: [[[[0.0; LANES]; 3]; 3]; 3],
        }
    }

    /// Each moment's lanes added in lane order.
    fn totals(&self) -> AxisMoments<f64> {
        let mut out = AxisMoments {
            m1: [[0.0; 3]; 3],
            m2: [[[0.0; 4]; 2]; 3],
            m3: [[[0.0; 3]; 3]; 3],
        };
        for jj in 0..3 {
            for kl in 0..3 {
                out.m1[jj][kl] = lane_total(&self.m1[jj][kl]);
                for ii in 0..3 {
                    out.m3[ii][jj][kl] = lane_total(&self.m3[ii][jj][kl]);
                }
            }
            for i in 0..2 {
                for kl in 0..4 {
                    out.m2[jj][i][kl] = lane_total(&self.m2[jj][i][kl]);
                }
            }
        }
        out
    }

    /// Add one chunk's samples: weights `along` = A and `across` = B (module docs) and the
    /// coefficients `k`, lane by lane.
    #[inline(always)]
    fn add(&mut self, along: &[Lanes; 2], across: &[Lanes; 2], k: &LaneCoefficients) {
        let (along2, across2) = (pair_products(along), pair_products(across));
        for (jj, b) in across2.iter().enumerate() {
            add_weighted(&mut self.m1[jj], b, &k.p);
            for (i, a) in along.iter().enumerate() {
                add_weighted(&mut self.m2[jj][i], &lanewise(|l| b[l] * a[l]), &k.q);
            }
            for (ii, a) in along2.iter().enumerate() {
                add_weighted(&mut self.m3[ii][jj], &lanewise(|l| a[l] * b[l]), &k.t);
            }
        }
    }
}

/// The moments of one cell's samples, axes s and t, summed per lane as the chunks come
/// ([`CellMoments::add_chunk`]); [`CellMoments::matrix`] turns them into the cell's S (or
/// JᵀJ + S).
pub(super) struct CellMoments([AxisMoments<Lanes>; 2]);

impl CellMoments {
    pub(super) fn zeros() -> Self {
        CellMoments([AxisMoments::zero(), AxisMoments::zero()])
    }

    /// Add the LANES samples from `at` on, given their J_D `kept` by the residual pass: their
    /// coefficients (axes s, t), weighted by A = (1−α, α) along s and B = (1−β, β) across for
    /// axis s, the roles swapped for axis t (module docs, "Moments").
    #[inline(always)]
    pub(super) fn add_chunk(
        &mut self,
        samples: &SampleLanes,
        at: usize,
        kept: &LaneJacobian,
        with_jtj: bool,
    ) {
        let coefficients = chunk_coefficients(samples, at, kept, with_jtj);
        let (alpha, beta) = (lanes(&samples.alpha, at), lanes(&samples.beta, at));
        let a = [lanewise(|l| 1.0 - alpha[l]), *alpha];
        let b = [lanewise(|l| 1.0 - beta[l]), *beta];
        self.0[0].add(&a, &b, &coefficients[0]);
        self.0[1].add(&b, &a, &coefficients[1]);
    }

    /// The cell's S, or JᵀJ + S if the chunks were added `with_jtj` (8×8 over its slots,
    /// [`super::NaaEnergy::cell_unknowns`]), for a rest cell of size h × k: each moment's lanes added in lane order, then the entries (module docs,
    /// "Moments"), axis s then t: a fixed order, the same for any number of threads.
    pub(super) fn matrix(&self, h: f64, k: f64) -> [[f64; 8]; 8] {
        let mut s = [[0.0; 8]; 8];
        for (axis, (moments, extent)) in self.0.iter().zip([h, k]).enumerate() {
            moments.totals().add_to(axis, extent, &mut s);
        }
        for &(a, b) in &UPPER_8 {
            s[b][a] = s[a][b];
        }
        s
    }
}
