//! Mutation tests of the canonical BPM vectors (`reference_data/vectors/bpm`): each mutant is a
//! mistake a porter makes, built from the kernels' f32 twins (`src/twin/bpm_*.rs`); `verify`
//! must reject every one (a fail verdict), and accept the twins themselves under every
//! arithmetic model a conforming GPU may use. The table printed by each test is the conformance
//! guide's (`src/vectors/README.md`).
#![cfg(feature = "gpu")]

mod common;

use common::mutation::MutationTable;
use reparam::twin::bpm_common::{
    blended_log, c_mul, c_zero, edge_weights, eval, eval_bpm, eval_linear, exp_sl2, fit_mobius_det,
    fit_mobius_local, log_sl2_roots, maps_logs, maps_m_t, maps_uv, maps_w_origin, maps_z,
    mobius_apply, mobius_identity, mobius_inverse, mobius_is_finite, mobius_mul,
    pack_triangle_maps, sl2_add, sl2_max_abs, sl2_scale, sl2_zero, Complex, Mobius, Sl2,
    TriangleMaps, FLAG_LINEAR_FALLBACK, FLAG_MIRRORED, INTERP_BPM, INTERP_LINEAR,
};
use reparam::twin::bpm_eval::bpm_eval;
use reparam::twin::bpm_precompute::{
    edge_corners, star_layout, StarInput, StarLayout, MASK_DEGENERATE,
};
use reparam::twin::candidate::bpm::{self as candidate, EvalFn, PrecomputeFn};
use reparam::twin::real::{cross, dot, is_finite, length, select, sum};
use reparam::twin::{Model, Real, F, V2, V3};
use reparam::vectors::bpm::twin_io;
use reparam::vectors::verify::{verify_array, VerifyReport};
use reparam::vectors::{Array, KernelVectors};

/// The canonical vectors' folder.
fn dir() -> std::path::PathBuf {
    common::canonical::dir("bpm")
}

/// Kernel `name`'s manifest entry.
fn kernel(name: &str) -> KernelVectors {
    common::canonical::kernel("bpm", name)
}

/// Kernel `k`'s input array called `name`.
fn input(k: &KernelVectors, name: &str) -> Array {
    common::canonical::input("bpm", k, name)
}

fn judge(k: &KernelVectors, candidate: &Array, name: &str) -> VerifyReport {
    verify_array(&dir(), k, candidate, name).unwrap()
}

// ---------------------------------------------------------------------------------------------
// bpm_eval

/// The eval kernel's candidate on the canonical inputs with `body` in place of `eval`.
fn eval_candidate(k: &KernelVectors, body: EvalFn, model: Model) -> Array {
    candidate::eval_with(&dir(), k, model, body).unwrap()
}

fn correct_eval(t: &TriangleMaps<F>, b: V3<F>) -> Complex<F> {
    eval(t, b, INTERP_BPM)
}

/// exp(½ ℓ) of a face at b (the twin's steps, for the mutants that change what follows).
fn half_exp(t: &TriangleMaps<F>, b: V3<F>, logs: [Sl2<F>; 3], half: f64) -> Mobius<F> {
    let gamma = edge_weights(b, maps_z(t)).to_array();
    let mut l = sl2_zero();
    for e in 0..3 {
        l = sl2_add(l, sl2_scale(logs[e], V2::new(gamma[e], F::lit(0.0))));
    }
    exp_sl2(sl2_scale(l, V2::new(F::lit(half), F::lit(0.0))))
}

fn z_at(t: &TriangleMaps<F>, b: V3<F>) -> Complex<F> {
    let z = maps_z(t);
    V2::sum(&[z[0] * b.x, z[1] * b.y, z[2] * b.z])
}

/// The BPM branch only, for a face that is not a fallback.
fn unless_fallback(t: &TriangleMaps<F>, b: V3<F>, f: impl Fn() -> Complex<F>) -> Complex<F> {
    if t.flags & FLAG_LINEAR_FALLBACK != 0 {
        return eval_linear(t, b);
    }
    f()
}

const EVAL_MUTANTS: [(&str, &str, EvalFn); 10] = [
    (
        "linear",
        "plain linear interpolation of the corner UVs",
        |t, b| eval_linear(t, b),
    ),
    (
        "m_t_alone",
        "M_t alone: no blending (w_origin + M_t(z))",
        |t, b| {
            unless_fallback(t, b, || {
                maps_w_origin(t) + mobius_apply(maps_m_t(t), z_at(t, b))
            })
        },
    ),
    (
        "wrong_order",
        "exp(Y)·M_t: the blend applied after M_t",
        |t, b| {
            unless_fallback(t, b, || {
                let e = half_exp(t, b, maps_logs(t), 0.5);
                maps_w_origin(t) + mobius_apply(e, mobius_apply(maps_m_t(t), z_at(t, b)))
            })
        },
    ),
    (
        "slots_opposite_corners",
        "log slot e read as the edge opposite corner e (jk, ki, ij)",
        |t, b| {
            unless_fallback(t, b, || {
                let l = maps_logs(t);
                let e = half_exp(t, b, [l[2], l[0], l[1]], 0.5);
                maps_w_origin(t) + mobius_apply(maps_m_t(t), mobius_apply(e, z_at(t, b)))
            })
        },
    ),
    ("full_log", "exp(ℓ) instead of exp(½ ℓ)", |t, b| {
        unless_fallback(t, b, || {
            let e = half_exp(t, b, maps_logs(t), 1.0);
            maps_w_origin(t) + mobius_apply(maps_m_t(t), mobius_apply(e, z_at(t, b)))
        })
    }),
    ("no_w_origin", "w_origin not added back", |t, b| {
        unless_fallback(t, b, || eval_bpm(t, b) - maps_w_origin(t))
    }),
    (
        "mirrored_again",
        "z conjugated again where flags bit 1 is set",
        |t, b| {
            let mut t = *t;
            if t.flags & FLAG_MIRRORED != 0 {
                t.z = reparam::twin::V4::new(t.z.x, -t.z.y, t.z.z, -t.z.w);
            }
            eval(&t, b, INTERP_BPM)
        },
    ),
    (
        "fallback_ignored",
        "flags bit 0 ignored: BPM on a fallback face",
        |t, b| eval_bpm(t, b),
    ),
    (
        "weights_without_lengths",
        "γ ∝ b_i b_j without the edge lengths",
        |t, b| {
            unless_fallback(t, b, || {
                let g = [b.x * b.y, b.y * b.z, b.z * b.x];
                let s = sum(&g);
                let gamma = g.map(|x| x / s);
                let mut l = sl2_zero();
                for (e, log) in maps_logs(t).into_iter().enumerate() {
                    l = sl2_add(l, sl2_scale(log, V2::new(gamma[e], F::lit(0.0))));
                }
                let e = exp_sl2(sl2_scale(l, V2::new(F::lit(0.5), F::lit(0.0))));
                maps_w_origin(t) + mobius_apply(maps_m_t(t), mobius_apply(e, z_at(t, b)))
            })
        },
    ),
    (
        "taylor_3",
        "exp by the seed's first three Taylor terms I + Y + Y²/2",
        |t, b| {
            unless_fallback(t, b, || {
                let gamma = edge_weights(b, maps_z(t));
                let y = sl2_scale(blended_log(t, gamma), V2::new(F::lit(0.5), F::lit(0.0)));
                let ym = Mobius {
                    a: y.a,
                    b: y.b,
                    c: y.c,
                    d: -y.a,
                };
                let y2 = mobius_mul(ym, ym);
                let half = V2::new(F::lit(0.5), F::lit(0.0));
                let e = Mobius {
                    a: mobius_identity::<F>().a + ym.a + c_mul(y2.a, half),
                    b: ym.b + c_mul(y2.b, half),
                    c: ym.c + c_mul(y2.c, half),
                    d: mobius_identity::<F>().d + ym.d + c_mul(y2.d, half),
                };
                maps_w_origin(t) + mobius_apply(maps_m_t(t), mobius_apply(e, z_at(t, b)))
            })
        },
    ),
];

/// The eval kernel `name`'s canonical vectors judge `correct` under every model (it must pass)
/// and each of `mutants` (each must fail).
fn judge_eval_mutants(name: &str, correct: EvalFn, mutants: &[(&str, &str, EvalFn)]) {
    let k = kernel(name);
    let mut table = MutationTable::default();
    for model in Model::CHECKED {
        let r = judge(&k, &eval_candidate(&k, correct, model), "twin");
        table.twin(&model.name(), &r);
    }
    for &(mutant, mistake, body) in mutants {
        let r = judge(&k, &eval_candidate(&k, body, Model::Nearest), mutant);
        table.mutant(mutant, mistake, &r);
    }
    table.finish();
}

#[test]
fn the_canonical_eval_vectors_reject_every_mutant_and_accept_the_twin() {
    judge_eval_mutants("bpm_eval", correct_eval, &EVAL_MUTANTS);
}

// ---------------------------------------------------------------------------------------------
// bpm_precompute

/// The precompute kernel's candidate with `body` (the twin's `triangle_maps` or a mutant of
/// it) per star.
fn precompute_candidate(k: &KernelVectors, body: PrecomputeFn, model: Model) -> Array {
    candidate::precompute_with(&dir(), k, model, body).unwrap()
}

/// A star layout step: the six points and t's UVs → the layout.
type LayoutFn = fn([V3<F>; 6], [Complex<F>; 3]) -> StarLayout<F>;
/// A fit step: three layout points → three UVs.
type FitFn = fn([Complex<F>; 3], [Complex<F>; 3]) -> Mobius<F>;

/// The twin's `triangle_maps` with its steps open to change: `layout` lays the star out, `fit`
/// fits three points, `ratio` makes δ_e from M_t and M_e, `log` takes its log, `origin` says
/// whether W = w − w_i, `use_mask` whether boundary edges and degenerate faces are skipped,
/// `slot` where edge e's log is stored.
#[allow(clippy::too_many_arguments)]
fn precompute_with(
    star: &StarInput<F>,
    layout: LayoutFn,
    fit: FitFn,
    ratio: fn(Mobius<F>, Mobius<F>) -> Mobius<F>,
    log: fn(Mobius<F>) -> Sl2<F>,
    origin: bool,
    use_mask: bool,
    slot: fn(usize) -> usize,
) -> TriangleMaps<F> {
    let uv = [star.w[0], star.w[1], star.w[2]];
    let star_z = layout(star.p, uv);
    let z = star_z.z;
    let z_t = [z[0], z[1], z[2]];
    let mirrored = select(0, FLAG_MIRRORED, star_z.mirrored);
    let mut logs = [sl2_zero(), sl2_zero(), sl2_zero()];
    let fallback = pack_triangle_maps(
        z_t,
        uv,
        c_zero(),
        mobius_identity(),
        logs,
        FLAG_LINEAR_FALLBACK | mirrored,
    );
    if use_mask && (star.mask & MASK_DEGENERATE) != 0 {
        return fallback;
    }
    let w_origin = select(c_zero(), star.w[0], origin);
    let big_w: [Complex<F>; 6] = std::array::from_fn(|n| star.w[n] - w_origin);
    let m_t = fit([z[0], z[1], z[2]], [big_w[0], big_w[1], big_w[2]]);
    if !mobius_is_finite(m_t) {
        return fallback;
    }
    for e in 0..3 {
        if use_mask && (star.mask & (1 << e)) == 0 {
            continue;
        }
        let [a, b] = edge_corners(e);
        let m_e = fit([z[a], z[b], z[3 + e]], [big_w[a], big_w[b], big_w[3 + e]]);
        let l_e = log(ratio(m_t, m_e));
        if is_finite(sl2_max_abs(l_e)) {
            logs[slot(e)] = l_e;
        }
    }
    // A face whose origin was not subtracted keeps w_origin = uv_i in its data, as the manifest
    // says (the mistake is in the fit, not in the layout of the row).
    pack_triangle_maps(z_t, uv, star.w[0], m_t, logs, mirrored)
}

fn right_ratio(m_t: Mobius<F>, m_e: Mobius<F>) -> Mobius<F> {
    mobius_mul(mobius_inverse(m_t), m_e)
}

fn same_slot(e: usize) -> usize {
    e
}

/// The star laid out without the mirroring (z as if every UV triangle were counter-clockwise).
fn layout_unmirrored(p: [V3<F>; 6], w: [Complex<F>; 3]) -> StarLayout<F> {
    let l = star_layout(p, w);
    let z = if l.mirrored {
        l.z.map(|z| V2::new(z.x, -z.y))
    } else {
        l.z
    };
    StarLayout { z, mirrored: false }
}

/// The apexes unfolded to the left of each edge (into t instead of away from it).
fn layout_apex_left(p: [V3<F>; 6], w: [Complex<F>; 3]) -> StarLayout<F> {
    let mut l = star_layout(p, w);
    for e in 0..3 {
        let [a, b] = edge_corners(e);
        let (za, zb) = (l.z[a], l.z[b]);
        let u = (p[b] - p[a]) / length((p[b] - p[a]).to_array());
        let r = p[3 + e] - p[a];
        let along = dot(r.to_array(), u.to_array());
        let perp = length(cross(u, r).to_array());
        let dir = (zb - za) / length((zb - za).to_array());
        let perp = if l.mirrored { -perp } else { perp };
        l.z[3 + e] = za + c_mul(dir, V2::new(along, perp));
    }
    l
}

/// log without the sign fix: asinhc(q) X of A as it comes. X and q of −A are −X and q, so
/// where Re Tr A < 0 this is the fixed log negated.
fn log_unsigned(m: Mobius<F>) -> Sl2<F> {
    let flipped = if m.a.x.value() + m.d.x.value() < 0.0 {
        Mobius {
            a: -m.a,
            b: -m.b,
            c: -m.c,
            d: -m.d,
        }
    } else {
        m
    };
    let l = log_sl2_roots(flipped);
    if flipped == m {
        l
    } else {
        sl2_scale(l, V2::new(F::lit(-1.0), F::lit(0.0)))
    }
}

const PRECOMPUTE_MUTANTS: [(&str, &str, PrecomputeFn); 9] = [
    (
        "determinant_fit",
        "the seed's 3×3 determinant fit in plain f32 (no local frame)",
        |s| {
            precompute_with(
                s,
                star_layout,
                fit_mobius_det,
                right_ratio,
                log_sl2_roots,
                false,
                true,
                same_slot,
            )
        },
    ),
    ("no_mirroring", "clockwise UV triangles not mirrored", |s| {
        precompute_with(
            s,
            layout_unmirrored,
            fit_mobius_local,
            right_ratio,
            log_sl2_roots,
            true,
            true,
            same_slot,
        )
    }),
    (
        "apex_left",
        "neighbour apexes unfolded onto t's side of the edge",
        |s| {
            precompute_with(
                s,
                layout_apex_left,
                fit_mobius_local,
                right_ratio,
                log_sl2_roots,
                true,
                true,
                same_slot,
            )
        },
    ),
    (
        "mask_ignored",
        "boundary, seam and degenerate bits ignored",
        |s| {
            precompute_with(
                s,
                star_layout,
                fit_mobius_local,
                right_ratio,
                log_sl2_roots,
                true,
                false,
                same_slot,
            )
        },
    ),
    (
        "no_sign_fix",
        "log taken without the sign fix Re Tr δ ≥ 0",
        |s| {
            precompute_with(
                s,
                star_layout,
                fit_mobius_local,
                right_ratio,
                log_unsigned,
                true,
                true,
                same_slot,
            )
        },
    ),
    (
        "left_ratio",
        "δ_e = M_e M_t⁻¹ (left form) with the right-order evaluation",
        |s| {
            precompute_with(
                s,
                star_layout,
                fit_mobius_local,
                |m_t, m_e| mobius_mul(m_e, mobius_inverse(m_t)),
                log_sl2_roots,
                true,
                true,
                same_slot,
            )
        },
    ),
    (
        "inverse_ratio",
        "δ_e = M_e⁻¹ M_t (the ratio inverted)",
        |s| {
            precompute_with(
                s,
                star_layout,
                fit_mobius_local,
                |m_t, m_e| mobius_mul(mobius_inverse(m_e), m_t),
                log_sl2_roots,
                true,
                true,
                same_slot,
            )
        },
    ),
    (
        "no_origin_shift",
        "M_t fitted to w, not w − w_i, while w_origin = uv_i is stored",
        |s| {
            precompute_with(
                s,
                star_layout,
                fit_mobius_local,
                right_ratio,
                log_sl2_roots,
                false,
                true,
                same_slot,
            )
        },
    ),
    (
        "slots_opposite_corners",
        "edge e's log stored in the slot of the corner opposite it",
        |s| {
            precompute_with(
                s,
                star_layout,
                fit_mobius_local,
                right_ratio,
                log_sl2_roots,
                true,
                true,
                |e| (e + 2) % 3,
            )
        },
    ),
];

#[test]
fn the_canonical_precompute_vectors_reject_every_mutant_and_accept_the_twin() {
    let k = kernel("bpm_precompute");
    let mut table = MutationTable::default();
    for model in Model::CHECKED {
        let r = judge(
            &k,
            &candidate::bpm_precompute(&dir(), &k, model).unwrap(),
            "twin",
        );
        table.twin(&model.name(), &r);
    }
    // The identity of the mutant harness: with nothing changed it is the twin, and passes.
    let same = |s: &StarInput<F>| {
        precompute_with(
            s,
            star_layout,
            fit_mobius_local,
            right_ratio,
            log_sl2_roots,
            true,
            true,
            same_slot,
        )
    };
    let stars = twin_io::stars(
        &input(&k, "star_p"),
        &input(&k, "star_w"),
        &input(&k, "mask"),
    )
    .unwrap();
    let maps: Vec<TriangleMaps<F>> = stars.iter().map(same).collect();
    assert!(judge(&k, &twin_io::maps_candidate(&maps), "harness").pass);
    for (name, mistake, body) in PRECOMPUTE_MUTANTS {
        let r = judge(&k, &precompute_candidate(&k, body, Model::Nearest), name);
        table.mutant(name, mistake, &r);
    }
    table.finish();
}

/// The twin's `bpm_eval` entry point agrees with the body the eval mutants wrap.
#[test]
fn the_eval_harness_is_the_kernel() {
    let k = kernel("bpm_eval");
    let maps = twin_io::maps(&input(&k, "maps"), &input(&k, "flags")).unwrap();
    let samples = twin_io::samples(&input(&k, "face"), &input(&k, "bary")).unwrap();
    let direct: Vec<Option<Complex<F>>> = samples
        .iter()
        .map(|s| bpm_eval(&maps, s, INTERP_BPM))
        .collect();
    assert_eq!(
        twin_io::uv_candidate(&direct),
        eval_candidate(&k, correct_eval, Model::Nearest)
    );
}

// ---------------------------------------------------------------------------------------------
// bpm_eval_linear

fn correct_linear(t: &TriangleMaps<F>, b: V3<F>) -> Complex<F> {
    eval(t, b, INTERP_LINEAR)
}

/// Σ b_c uv_c with the corners' UVs taken in the order `order`.
fn linear_with(t: &TriangleMaps<F>, w: [F; 3], order: [usize; 3]) -> Complex<F> {
    let uv = maps_uv(t);
    V2::sum(&[
        uv[order[0]] * w[0],
        uv[order[1]] * w[1],
        uv[order[2]] * w[2],
    ])
}

const LINEAR_MUTANTS: [(&str, &str, EvalFn); 6] = [
    (
        "uv_jk_swapped",
        "b_j with uv_k and b_k with uv_j",
        |t, b| linear_with(t, [b.x, b.y, b.z], [0, 2, 1]),
    ),
    (
        "bary_rotated",
        "(b_i, b_j, b_k) read as (b_j, b_k, b_i)",
        |t, b| linear_with(t, [b.y, b.z, b.x], [0, 1, 2]),
    ),
    (
        "b_i_dropped",
        "b_i taken as 0 (only the stored b_j, b_k used)",
        |t, b| linear_with(t, [F::lit(0.0), b.y, b.z], [0, 1, 2]),
    ),
    (
        "w_origin_added",
        "w_origin added to the linear interpolant as to BPM's",
        |t, b| eval(t, b, INTERP_LINEAR) + maps_w_origin(t),
    ),
    (
        "layout_not_uv",
        "the layout z interpolated instead of the UVs",
        |t, b| {
            let z = maps_z(t);
            V2::sum(&[z[0] * b.x, z[1] * b.y, z[2] * b.z])
        },
    ),
    (
        "bpm_instead",
        "the BPM interpolant where linear was asked",
        |t, b| eval(t, b, INTERP_BPM),
    ),
];

#[test]
fn the_canonical_linear_vectors_reject_every_mutant_and_accept_the_twin() {
    judge_eval_mutants("bpm_eval_linear", correct_linear, &LINEAR_MUTANTS);
}
