//! The BPM kernels' f32 twins (`src/twin/bpm_*.rs`) against the reference and the bounds:
//! - over balls the twins compute the reference's values (to the f32 formulation's own
//!   departure, series terms), so the bounds they derive are about the same function;
//! - the f64 reference's two forms of exp and log agree (the kernel uses scaling and squaring);
//! - under every arithmetic model a conforming GPU may use (correctly rounded, fused,
//!   reordered, at the edge of the WGSL table) the twins stay within the derived bounds, on the
//!   canonical vectors and on other built-in meshes;
//! - the closed form of exp (cos, sin, cosh) at the edge of the table does not: why the kernel
//!   squares instead;
//! - reparam's own WGSL kernels agree with the twin under the `nearest` model.
#![cfg(feature = "gpu")]

mod common;

use num_complex::Complex64 as C;
use reparam::bpm::gpu::stars;
use reparam::bpm::moebius::{
    cosh_sinhc, cosh_sinhc_squaring, exp_sl2, log_sl2, log_sl2_roots, Mobius, Sl2,
};
use reparam::bpm::{precompute, BpmOptions, Interp};
use reparam::crosscheck::bpm::{crosscheck_samples, round_mesh_to_f32, TEXTURE_SIZE};
use reparam::crosscheck::bpm_bound::{
    ball_maps, ball_star, complex, eval_bounds, pipeline_bounds, UNBOUNDED,
};
use reparam::crosscheck::bpm_models::{bpm_model_ratios, f32_maps, f32_sample, f32_star};
use reparam::mesh::{procedural, TriMesh};
use reparam::twin::ball::evaluate;
use reparam::twin::bpm_common::{self as common_twin, Complex, CoshSinhc};
use reparam::twin::bpm_eval::{bpm_eval, Sample};
use reparam::twin::bpm_precompute::{triangle_maps, FIT_LOCAL};
use reparam::twin::{with_model, Model, Real, F, V2};

use common::Rng;

/// The meshes the bounds are checked on: the canonical one and the stress cases.
fn meshes() -> Vec<TriMesh> {
    vec![
        procedural::bpm_conformance(),
        procedural::cone_fan(16, 1.0),
        procedural::torus(12, 6, 1.0, 0.35),
        procedural::tiny_far_uv(6),
        procedural::two_charts_mirrored(3),
        procedural::mobius_mesh(4, procedural::default_mobius()),
    ]
}

#[test]
fn the_f64_reference_forms_of_exp_and_log_agree() {
    let mut rng = Rng(7);
    for _ in 0..2000 {
        let r = rng.uniform(0.0, 6.0).powi(2);
        let p = rng.complex(1.0) * r;
        let (c, s) = cosh_sinhc(p);
        let (c2, s2) = cosh_sinhc_squaring(p);
        let scale = c.norm().max(s.norm()).max(1.0);
        assert!((c - c2).norm() <= 1e-12 * scale, "C at {p}");
        assert!((s - s2).norm() <= 1e-12 * scale, "S at {p}");
        let y = Sl2 {
            a: rng.complex(2.0),
            b: rng.complex(2.0),
            c: rng.complex(2.0),
        };
        let m: Mobius = exp_sl2(&y);
        let (l, l2) = (log_sl2(&m), log_sl2_roots(&m));
        let d = (l.a - l2.a).norm() + (l.b - l2.b).norm() + (l.c - l2.c).norm();
        assert!(d <= 1e-10 * (1.0 + l.max_abs()), "log of exp of {y:?}: {d}");
    }
}

#[test]
fn over_balls_the_twins_compute_the_reference() {
    for mesh in meshes() {
        let mesh = round_mesh_to_f32(&mesh);
        let reference = precompute(&mesh, BpmOptions::default()).unwrap();
        let samples = crosscheck_samples(mesh.face_count());
        let expected = reference.eval_many(&samples, Interp::Bpm);
        let stars = stars(&mesh).unwrap();
        for (s, f) in samples.iter().zip(&expected) {
            let maps = [ball_maps(&reference.maps[s.face as usize])];
            let ball_s = Sample {
                face: 0,
                b: [
                    reparam::twin::Ball::exact(s.bary[1]),
                    reparam::twin::Ball::exact(s.bary[2]),
                ],
            };
            let (uv, _) = evaluate(|| bpm_eval(&maps, &ball_s, 0).unwrap());
            // Six series terms instead of ten: 2e-9 relative at most.
            let scale = 1.0 + f.norm();
            assert!(
                (complex(uv) - f).norm() <= 1e-8 * scale,
                "{}: eval {s:?}",
                mesh.name
            );
            let (twin_maps, _) =
                evaluate(|| triangle_maps(&ball_star(&stars[s.face as usize]), FIT_LOCAL));
            let (uv, _) = evaluate(|| bpm_eval(&[twin_maps], &ball_s, 0).unwrap());
            assert!(
                (complex(uv) - f).norm() <= 1e-8 * scale,
                "{}: precompute {s:?}",
                mesh.name
            );
        }
    }
}

#[test]
fn every_conforming_model_stays_within_the_derived_bounds() {
    let mut table = String::new();
    let mut over_total = 0;
    for mesh in meshes() {
        for model in Model::CHECKED {
            let r = bpm_model_ratios(&mesh, model).unwrap();
            table += &format!(
                "{:32} {:16} eval {:.2e} linear {:.2e} pipeline {:.2e} over {}\n",
                mesh.name,
                model.name(),
                r.eval_bpm,
                r.eval_linear,
                r.pipeline,
                r.over
            );
            over_total += r.over;
        }
    }
    println!("{table}");
    assert_eq!(over_total, 0, "{table}");
}

#[test]
fn the_bounds_are_finite_on_the_canonical_mesh() {
    let mesh = round_mesh_to_f32(&procedural::bpm_conformance());
    let reference = precompute(&mesh, BpmOptions::default()).unwrap();
    let samples = crosscheck_samples(mesh.face_count());
    let expected = reference.eval_many(&samples, Interp::Bpm);
    let eval = eval_bounds(&reference, &samples, Interp::Bpm, &expected);
    let pipeline = pipeline_bounds(&stars(&mesh).unwrap(), &samples, &expected);
    for (n, b) in eval.iter().enumerate() {
        assert!(
            *b < UNBOUNDED && *b > 0.0,
            "eval sample {n}: {:?}",
            samples[n]
        );
    }
    for (n, b) in pipeline.iter().enumerate() {
        assert!(
            *b < UNBOUNDED && *b > 0.0,
            "pipeline sample {n}: {:?} {b}",
            samples[n]
        );
    }
    // A bound that could be met by any sloppy port is no bound: the largest stays below a
    // tenth of a texel of 4096².
    let largest = pipeline.iter().copied().fold(0.0, f64::max);
    assert!(largest < 0.1, "largest pipeline bound {largest} texels");
}

/// The closed form C = cosh √p, S = sinh √p / √p with WGSL's cosh, sinh (via exp), cos, sin:
/// what the kernel computed before `cosh_sinhc_squaring` replaced it.
fn cosh_sinhc_closed<R: Real>(p: Complex<R>) -> CoshSinhc<R> {
    use reparam::twin::real::{cos, cosh, sin, sinh};
    let r = common_twin::c_sqrt(p);
    let ch = V2::new(cosh(r.x) * cos(r.y), sinh(r.x) * sin(r.y));
    let sh = V2::new(sinh(r.x) * cos(r.y), cosh(r.x) * sin(r.y));
    CoshSinhc {
        c: ch,
        s: common_twin::c_div(sh, r),
    }
}

#[test]
fn the_closed_form_of_exp_at_the_edge_of_the_table_is_why_the_kernel_squares() {
    // exp of Y with p = a² + b c of modulus ≈ 4–9: the closed form's absolute 2⁻¹¹ in cos and
    // sin puts C and S ≈ 5e-4 off; squaring keeps them within a few f32 roundings.
    let mut rng = Rng(11);
    let (mut closed, mut squared) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let p = rng.complex(3.0) + C::new(4.0, 0.0);
        let (c, _) = cosh_sinhc(p);
        let pf = V2::new(F::new(p.re as f32), F::new(p.im as f32));
        let model = Model::EdgeOfSpec(1);
        let a = with_model(model, || cosh_sinhc_closed(pf));
        let b = with_model(model, || common_twin::cosh_sinhc_squaring(pf));
        closed = closed.max((complex(a.c) - c).norm() / c.norm());
        squared = squared.max((complex(b.c) - c).norm() / c.norm());
    }
    assert!(closed > 1e-4, "closed form at the edge: {closed}");
    assert!(squared < 1e-5, "squaring at the edge: {squared}");
}

#[test]
fn the_wgsl_kernels_agree_with_the_twin_under_the_nearest_model() {
    let Some(gpu) = reparam_gpu::gpu_or_skip() else {
        return;
    };
    use reparam::bpm::gpu::{eval_gpu, maps_to_gpu, precompute_gpu, samples_to_gpu};
    for mesh in meshes() {
        let mesh = round_mesh_to_f32(&mesh);
        let reference = precompute(&mesh, BpmOptions::default()).unwrap();
        let samples = crosscheck_samples(mesh.face_count());
        let gpu_samples = samples_to_gpu(&samples);
        let gpu_uv = eval_gpu(&gpu, &maps_to_gpu(&reference), &gpu_samples, Interp::Bpm).unwrap();
        let expected = reference.eval_many(&samples, Interp::Bpm);
        let bounds = eval_bounds(&reference, &samples, Interp::Bpm, &expected);
        // Both conform, so each is within the bound of the exact value and they differ by at
        // most twice it; a formula that differs would differ by about a mutant's error, which
        // is ≫ the bound (tests/mutants_bpm.rs).
        for (n, s) in samples.iter().enumerate() {
            let maps = [f32_maps(&ball_maps(&reference.maps[s.face as usize]))];
            let uv = with_model(Model::Nearest, || bpm_eval(&maps, &f32_sample(s), 0)).unwrap();
            let d = (complex(uv) - gpu_uv[n]).norm() * TEXTURE_SIZE;
            assert!(
                d <= 2.0 * bounds[n],
                "{} sample {n}: {d} vs {}",
                mesh.name,
                bounds[n]
            );
        }
        let gpu_maps = precompute_gpu(&gpu, &mesh, reparam::bpm::Fit::Local).unwrap();
        let stars = stars(&mesh).unwrap();
        let pipeline = pipeline_bounds(&stars, &samples, &expected);
        let gpu_uv = eval_gpu(&gpu, &gpu_maps, &gpu_samples, Interp::Bpm).unwrap();
        for (n, s) in samples.iter().enumerate() {
            let star = f32_star(&ball_star(&stars[s.face as usize]));
            let t = with_model(Model::Nearest, || triangle_maps(&star, FIT_LOCAL));
            let uv = with_model(Model::Nearest, || bpm_eval(&[t], &f32_sample(s), 0)).unwrap();
            let d = (complex(uv) - gpu_uv[n]).norm() * TEXTURE_SIZE;
            assert!(
                d <= 2.0 * pipeline[n],
                "{} pipeline sample {n}: {d}",
                mesh.name
            );
        }
    }
}
