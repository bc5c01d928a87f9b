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
//! `gridwarp_naa_frame_newton`). The paper uses ALGLIB's Jacobian-only protocol, so this model is an option, not the default; LM
//! needs no change for it: a trial whose damped model is not positive definite fails its box QP
//! or predicts no decrease, and both count as a rejected trial (λ grows).
//!
//! # Formula (one sample, one axis; module docs of [`super`] for q, W, φ_c)
//! Slot a = (c, k) is coordinate k of corner c; φ'_c = ∂φ_c/∂s for the s residual (∂φ_c/∂t for
//! the t residual); D_k is column k of J_D, G_k = (∂_k J_D) W, u = q/‖q‖. Then
//!   Q_a = ∂q/∂x_a = φ'_c D_k + φ_c G_k,      d_a = ∂r/∂x_a = σ uᵀQ_a,
//!   ∂²q/∂x_a∂x_b = φ'_c φ_c' ∂_l D_k + φ_c φ'_c' ∂_k D_l + φ_c φ_c' (∂_l∂_k J_D) W,
//!   r∇²r_ab = σr [Q_aᵀ(I − uuᵀ)Q_b/‖q‖ + uᵀ ∂²q/∂x_a∂x_b].
//! With κ = (‖q‖ − o)/‖q‖ (= r/(σ‖q‖)), ρ = σ²κ, A_kl = D_k·D_l, B_kl = D_k·G_l,
//! C_kl = G_k·G_l and H_kl = ρ B_kl + σr u·∂_l D_k this is
//!   r∇²r_ab = φ'_c φ'_c' ρA_kl + φ'_c φ_c' H_kl + φ_c φ'_c' H_lk + φ_c φ_c' ρC_kl − κ d_a d_b.
//! (σr uᵀ(uuᵀ)… gives the last term: ρ (uᵀQ_a)(uᵀQ_b) = κ d_a d_b.) Left out: the term
//! φ_c φ_c' σr uᵀ(∂_s∂_t J_D)W of the fields' mixed derivative, the only second derivative of a
//! bilinear texel patch (a constant per texel): S is exact where J_D is affine across the
//! cell's texels, and a model of the curvature elsewhere (LM's gain ratio absorbs the rest).
//! At q = 0 (u undefined) the sample adds nothing, as in the Jacobian.

use super::{dot, image, lanes, norm, CellWarp, JacobianAt, NaaEnergy, LANES};
use crate::gridwarp::energy::{axes_total, LaneResiduals, UPPER_8};

/// Per axis and lane, the running sums of the 36 upper-triangle entries of a cell's S.
pub(super) type CurvatureSums = [[[f64; LANES]; 36]; 2];

/// The per-sample 2×2 coefficient blocks of r∇²r (module docs), one value per lane:
/// ρA_kl, ρC_kl, H_kl (indexed [k][l]) and κ.
struct LaneCoefficients {
    rho_a: [[[f64; LANES]; 2]; 2],
    rho_c: [[[f64; LANES]; 2]; 2],
    h: [[[f64; LANES]; 2]; 2],
    kappa: [f64; LANES],
}

/// [f(0), …, f(LANES − 1)] by a plain loop, always inlined (so that it is compiled with its
/// caller's AVX-512, unlike an outlined `std::array::from_fn`).
#[inline(always)]
fn lanewise(f: impl Fn(usize) -> f64) -> [f64; LANES] {
    let mut out = [0.0; LANES];
    for (lane, v) in out.iter_mut().enumerate() {
        *v = f(lane);
    }
    out
}

impl NaaEnergy<'_> {
    /// Add the r∇²r of the LANES samples from `at` on (both axes) to `sums`, given their
    /// residuals and derivatives `chunk` ([`NaaEnergy::chunk_residuals`]): first the per-sample
    /// coefficients ([`NaaEnergy::chunk_coefficients`]), then every entry
    ///   S_ab += φ'_c φ'_c' ρA_kl + φ'_c φ_c' H_kl + φ_c φ'_c' H_lk + φ_c φ_c' ρC_kl − κ d_a d_b,
    /// a = 2c + k, b = 2c' + l, lane by lane.
    #[inline(always)]
    pub(super) fn add_chunk_curvature(
        &self,
        jac: &impl JacobianAt,
        warp: &CellWarp,
        at: usize,
        chunk: &LaneResiduals<8>,
        sums: &mut CurvatureSums,
    ) {
        let s = &self.lanes;
        let (alpha, beta) = (lanes(&s.alpha, at), lanes(&s.beta, at));
        let [bs, bt, as_, at_] = s.slopes.each_ref().map(|v| lanes(v, at));
        // φ_c and φ'_c per lane (the same weights as the Jacobian's): corners 00, 10, 01, 11.
        let phi: [[f64; LANES]; 4] = [
            lanewise(|l| (1.0 - alpha[l]) * (1.0 - beta[l])),
            lanewise(|l| alpha[l] * (1.0 - beta[l])),
            lanewise(|l| (1.0 - alpha[l]) * beta[l]),
            lanewise(|l| alpha[l] * beta[l]),
        ];
        let dphi_ds: [[f64; LANES]; 4] = [lanewise(|l| -bs[l]), *bs, lanewise(|l| -bt[l]), *bt];
        let dphi_dt: [[f64; LANES]; 4] = [lanewise(|l| -as_[l]), lanewise(|l| -at_[l]), *as_, *at_];
        let coefficients = self.chunk_coefficients(jac, warp, at);
        for (axis, (k, dphi)) in coefficients.iter().zip([dphi_ds, dphi_dt]).enumerate() {
            let d = &chunk.d[axis];
            // The factors of φ'_c and φ_c in S_ab (module docs), per corner c' of b and (k, l):
            //   U_c'kl = φ'_c' ρA_kl + φ_c' H_kl,  V_c'kl = φ'_c' H_lk + φ_c' ρC_kl,
            // so that S_ab = φ'_c U_c'kl + φ_c V_c'kl − κ d_a d_b.
            let mut u = [[[[0.0; LANES]; 2]; 2]; 4];
            let mut v = [[[[0.0; LANES]; 2]; 2]; 4];
            for c2 in 0..4 {
                for k_a in 0..2 {
                    for l_b in 0..2 {
                        for lane in 0..LANES {
                            u[c2][k_a][l_b][lane] = dphi[c2][lane] * k.rho_a[k_a][l_b][lane]
                                + phi[c2][lane] * k.h[k_a][l_b][lane];
                            v[c2][k_a][l_b][lane] = dphi[c2][lane] * k.h[l_b][k_a][lane]
                                + phi[c2][lane] * k.rho_c[k_a][l_b][lane];
                        }
                    }
                }
            }
            let mut kappa_d = [[0.0; LANES]; 8];
            for (kappa_d, d) in kappa_d.iter_mut().zip(d) {
                *kappa_d = lanewise(|lane| k.kappa[lane] * d[lane]);
            }
            // Entry e = (a, b), a ≤ b, in the order of UPPER_8 (row by row).
            let mut e = 0;
            for (a, kappa_d_a) in kappa_d.iter().enumerate() {
                let (c, k_a) = (a / 2, a % 2);
                for b in a..8 {
                    let (u, v) = (&u[b / 2][k_a][b % 2], &v[b / 2][k_a][b % 2]);
                    let sum = &mut sums[axis][e];
                    for lane in 0..LANES {
                        sum[lane] += dphi[c][lane] * u[lane] + phi[c][lane] * v[lane]
                            - kappa_d_a[lane] * d[b][lane];
                    }
                    e += 1;
                }
            }
        }
    }

    /// The coefficients of r∇²r of the LANES samples from `at` on, per axis (module docs):
    /// κ = (‖q‖ − o)/‖q‖, ρ = σ²κ, ρA_kl = ρ D_k·D_l, ρC_kl = ρ G_k·G_l and
    /// H_kl = ρ D_k·G_l + σr u·∂_l D_k (all 0 where q = 0 or σ = 0).
    #[inline(always)]
    fn chunk_coefficients(
        &self,
        jac: &impl JacobianAt,
        warp: &CellWarp,
        at: usize,
    ) -> [LaneCoefficients; 2] {
        let s = &self.lanes;
        let (alpha, beta, sigma) = (lanes(&s.alpha, at), lanes(&s.beta, at), lanes(&s.sigma, at));
        let (o_s, o_t) = (lanes(&s.o_s, at), lanes(&s.o_t, at));
        let zero = || LaneCoefficients {
            rho_a: [[[0.0; LANES]; 2]; 2],
            rho_c: [[[0.0; LANES]; 2]; 2],
            h: [[[0.0; LANES]; 2]; 2],
            kappa: [0.0; LANES],
        };
        let mut out = [zero(), zero()];
        // One simple loop over the lanes (selects, no branches): vector registers.
        for lane in 0..LANES {
            let w = warp.at(alpha[lane], beta[lane]);
            let (ds, dt) = jac.at(w.pos);
            // D_k, column k of J_D, and ∂_l D_k, its derivative along coordinate l: along[l][k].
            let columns = [ds.value, dt.value];
            let along = [[ds.ds, dt.ds], [ds.dt, dt.dt]];
            let sg = sigma[lane];
            for (out, (w, o)) in out.iter_mut().zip([(w.w_s, o_s[lane]), (w.w_t, o_t[lane])]) {
                let q = image(&ds.value, &dt.value, w);
                let length = norm(q);
                // 1/‖q‖, or 0 at q = 0: then κ = ρ = 0 and u = 0, so the sample adds nothing.
                let inverse = if length > 0.0 { 1.0 / length } else { 0.0 };
                let kappa = (length - o) * inverse;
                let rho = sg * sg * kappa;
                let sigma_r = sg * sg * (length - o);
                let u = q.map(|v| v * inverse);
                // G_k = (∂_k J_D) W.
                let g = [image(&ds.ds, &dt.ds, w), image(&ds.dt, &dt.dt, w)];
                out.kappa[lane] = kappa;
                for k in 0..2 {
                    for l in 0..2 {
                        out.rho_a[k][l][lane] = rho * dot(columns[k], columns[l]);
                        out.rho_c[k][l][lane] = rho * dot(g[k], g[l]);
                        out.h[k][l][lane] =
                            rho * dot(columns[k], g[l]) + sigma_r * dot(u, along[l][k]);
                    }
                }
            }
        }
        out
    }

    /// S of cell `cell` (8×8 over its slots, [`NaaEnergy::cell_unknowns`]) from its chunks'
    /// residuals `chunks` (in order): per axis and lane sums over the chunks, then each entry
    /// [`axes_total`] (a fixed order: the same for any number of threads). Inlined into the
    /// callers' AVX-512 variants ([`NaaEnergy::fill_blocks`]).
    #[inline(always)]
    pub(super) fn cell_curvature(
        &self,
        jac: &impl JacobianAt,
        warp: &CellWarp,
        first: usize,
        chunks: &[LaneResiduals<8>],
    ) -> [[f64; 8]; 8] {
        let mut sums: CurvatureSums = [[[0.0; LANES]; 36]; 2];
        for (n, chunk) in chunks.iter().enumerate() {
            self.add_chunk_curvature(jac, warp, first + n * LANES, chunk, &mut sums);
        }
        let mut s = [[0.0; 8]; 8];
        for (e, &(a, b)) in UPPER_8.iter().enumerate() {
            s[a][b] = axes_total(&[sums[0][e], sums[1][e]]);
            s[b][a] = s[a][b];
        }
        s
    }
}
