//! Properties of the BPM kernels on lavapipe (or any adapter): each test builds plain f32
//! inputs, runs a kernel and checks a property that holds exactly in exact arithmetic, with a
//! tolerance derived from f32 rounding. Skipped (printing `skipped: no GPU adapter`) without an
//! adapter unless REPARAM_REQUIRE_GPU=1.

mod support;

use reparam_gpu::bpm::{
    bpm_eval, bpm_precompute, bpm_render, Fit, Interp, RenderInput, Sample, TriangleMaps,
    BPM_COMMON_WGSL, FLAG_LINEAR_FALLBACK, MASK_DEGENERATE,
};
use reparam_gpu::compute::DISPATCH_WGSL;
use reparam_gpu::{gpu_or_skip, Gpu, GpuError};
use support::{
    barycentric_grid, eval_f64, expm_taylor, max_distance, planar_star, Mesh, Mobius, C, U32,
};

// ---------------------------------------------------------------------------------------------
// Helpers

/// A Möbius map with its pole at −d/c ≈ −3.4 − 1.4i, more than 2 away from the star.
const G: Mobius = Mobius {
    a: C(1.0, 0.2),
    b: C(0.3, 0.0),
    c: C(0.25, -0.1),
    d: C(1.0, 0.0),
};

/// The planar star with UVs G(x + iy), or their mirror image conj(G(x + iy)) (clockwise UV
/// triangles), and the plane coordinates of its vertices.
fn mobius_star(mirror: bool) -> (Mesh, Vec<C>) {
    let (positions, faces, xy) = planar_star(1.0);
    let uvs = faces
        .iter()
        .map(|f| {
            f.map(|v| {
                if mirror {
                    G.apply(xy[v]).conj()
                } else {
                    G.apply(xy[v])
                }
            })
        })
        .collect();
    (
        Mesh {
            positions,
            faces,
            uvs,
        },
        xy,
    )
}

/// The planar star with the non-conformal UVs (x + 0.3 y + 0.2 x², 0.5 y): BPM is not exact
/// here, so the logs are far from 0.
fn shear_star() -> Mesh {
    let (positions, faces, xy) = planar_star(1.0);
    let uvs = faces
        .iter()
        .map(|f| {
            f.map(|v| {
                C(
                    xy[v].0 + 0.3 * xy[v].1 + 0.2 * xy[v].0 * xy[v].0,
                    0.5 * xy[v].1,
                )
            })
        })
        .collect();
    Mesh {
        positions,
        faces,
        uvs,
    }
}

/// Samples at the barycentric grid of every face, with the f64 barycentrics the GPU evaluates
/// (b_j, b_k rounded to f32, b_i = 1 − b_j − b_k).
fn grid_samples(faces: usize, n: usize) -> Vec<(Sample, [f64; 3])> {
    (0..faces)
        .flat_map(|f| {
            barycentric_grid(n).into_iter().map(move |b| {
                let s = Sample::new(f as u32, b[1] as f32, b[2] as f32);
                let (bj, bk) = (s.b[0] as f64, s.b[1] as f64);
                (s, [1.0 - bj - bk, bj, bk])
            })
        })
        .collect()
}

fn eval(
    gpu: &Gpu,
    maps: &[TriangleMaps],
    samples: &[(Sample, [f64; 3])],
    interp: Interp,
) -> Vec<[f32; 2]> {
    let s: Vec<Sample> = samples.iter().map(|(s, _)| *s).collect();
    bpm_eval::run(gpu, maps, &s, interp).expect("bpm_eval")
}

/// The point of face f with barycentrics b in plane coordinates.
fn plane_point(faces: &[[usize; 3]], xy: &[C], f: usize, b: [f64; 3]) -> C {
    let [i, j, k] = faces[f];
    xy[i]
        .scale(b[0])
        .add(xy[j].scale(b[1]))
        .add(xy[k].scale(b[2]))
}

/// Tolerance for reproducing a well-conditioned map on the unit-sized star (|uv| ≤ 1.5).
///
/// Derivation (first order, u = 2⁻²⁴): inputs rounded to f32 contribute ≈ 2u relative. The
/// precompute chains ≈ 10 dependent operations of layout and ≈ 30 of fit, whose differences
/// of inverses 1/w'₁ − 1/w'₂ amplify relative errors by κ = max|1/w'| / |1/w'₁ − 1/w'₂| ≲ 3
/// on these well-shaped triangles; ratio and log add ≈ 20; the evaluation ≈ 60 (weights,
/// blend, 6-term exp, two Möbius applications, each well conditioned here). Summing:
/// (2 + 10 + 3·30 + 20 + 60) u ≈ 180 u relative, × |uv| ≤ 1.5 ≈ 270 u; we allow 300 u ≈ 1.8e-5
/// (0.07 texel of a 4096² atlas). Measured on lavapipe: ≈ 3 u.
const MAP_TOLERANCE: f64 = 300.0 * U32;

// ---------------------------------------------------------------------------------------------
// Data layout

#[test]
fn struct_sizes_match_the_wgsl_layouts() {
    use std::mem::{offset_of, size_of};
    assert_eq!(size_of::<reparam_gpu::bpm::StarInput>(), 160);
    assert_eq!(offset_of!(reparam_gpu::bpm::StarInput, w), 96);
    assert_eq!(offset_of!(reparam_gpu::bpm::StarInput, mask), 144);
    assert_eq!(size_of::<TriangleMaps>(), 192);
    assert_eq!(offset_of!(TriangleMaps, m), 48);
    assert_eq!(offset_of!(TriangleMaps, logs), 80);
    assert_eq!(offset_of!(TriangleMaps, flags), 176);
    assert_eq!(size_of::<Sample>(), 16);
    assert_eq!(offset_of!(Sample, b), 8);
}

// ---------------------------------------------------------------------------------------------
// Precompute + eval

/// A global Möbius map is reproduced exactly by BPM: every δ_e = ±I, so every log is 0 and
/// f = G everywhere. Also for the mirrored chart (clockwise UVs), where the layout is mirrored.
#[test]
fn global_mobius_map_is_reproduced() {
    let Some(gpu) = gpu_or_skip() else { return };
    for mirror in [false, true] {
        let (mesh, xy) = mobius_star(mirror);
        let maps = bpm_precompute::run(&gpu, &mesh.stars(), Fit::Local).unwrap();
        for (f, t) in maps.iter().enumerate() {
            assert_eq!(t.is_mirrored(), mirror, "face {f}");
            assert!(!t.is_linear_fallback(), "face {f}");
            // logs = asinhc(q)·X with X = ratio − I entries: the same error budget as the map.
            assert!(
                t.max_abs_log() < MAP_TOLERANCE as f32,
                "face {f}: log {}",
                t.max_abs_log()
            );
        }
        let samples = grid_samples(mesh.faces.len(), 8);
        let uv = eval(&gpu, &maps, &samples, Interp::Bpm);
        let expected: Vec<C> = samples
            .iter()
            .map(|(s, b)| {
                let g = G.apply(plane_point(&mesh.faces, &xy, s.face as usize, *b));
                if mirror {
                    g.conj()
                } else {
                    g
                }
            })
            .collect();
        let error = max_distance(&uv, &expected);
        println!("mirror {mirror}: max |f − G| = {error:.2e} (tolerance {MAP_TOLERANCE:.1e})");
        assert!(error < MAP_TOLERANCE, "mirror {mirror}: {error:e}");
    }
}

/// The determinant fit reproduces the Möbius map near the origin too, but loses it when the
/// same star is small and far from the UV origin, where the local fit keeps f32 accuracy (the
/// seed's "speckling").
#[test]
fn determinant_fit_fails_far_from_the_origin_where_local_fit_does_not() {
    let Some(gpu) = gpu_or_skip() else { return };
    let (positions, faces, xy) = planar_star(0.01);
    let far = C(100.0, 60.0);
    let uv_of = |z: C| G.apply(z.scale(100.0)).scale(0.01).add(far);
    let uvs = faces.iter().map(|f| f.map(|v| uv_of(xy[v]))).collect();
    let mesh = Mesh {
        positions,
        faces,
        uvs,
    };
    let samples = grid_samples(mesh.faces.len(), 6);
    let expected: Vec<C> = samples
        .iter()
        .map(|(s, b)| uv_of(plane_point(&mesh.faces, &xy, s.face as usize, *b)))
        .collect();
    let error = |fit| {
        let maps = bpm_precompute::run(&gpu, &mesh.stars(), fit).unwrap();
        max_distance(&eval(&gpu, &maps, &samples, Interp::Bpm), &expected)
    };
    let (local, det) = (error(Fit::Local), error(Fit::Determinant));
    println!("UVs near {far:?}: max error local {local:.2e}, determinant {det:.2e}");
    // The UVs themselves are only known to ½ulp(117) ≈ 4e-6; the local fit works on
    // differences of size 0.01 and adds the MAP_TOLERANCE budget relative to those.
    assert!(
        local < 8.0 * 117.0 * U32 + MAP_TOLERANCE * 0.01,
        "local fit: {local:e}"
    );
    assert!(
        det > 10.0 * local,
        "determinant fit unexpectedly accurate: {det:e} vs {local:e}"
    );
}

/// f(z_v) = w_v at every corner, for UVs that are not a Möbius image (non-zero logs), and BPM
/// differs from linear inside (it does not reproduce non-conformal affine maps).
#[test]
fn corners_interpolate_their_uvs() {
    let Some(gpu) = gpu_or_skip() else { return };
    let mesh = shear_star();
    let maps = bpm_precompute::run(&gpu, &mesh.stars(), Fit::Local).unwrap();
    assert!(
        maps[0].max_abs_log() > 0.01,
        "logs too small for a meaningful test"
    );
    let corners: Vec<(Sample, [f64; 3])> = (0..mesh.faces.len())
        .flat_map(|f| {
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
                .map(|b| (Sample::new(f as u32, b[1] as f32, b[2] as f32), b))
        })
        .collect();
    let uv = eval(&gpu, &maps, &corners, Interp::Bpm);
    let expected: Vec<C> = corners
        .iter()
        .map(|(s, b)| mesh.uvs[s.face as usize][b.iter().position(|&x| x == 1.0).unwrap()])
        .collect();
    let error = max_distance(&uv, &expected);
    println!("max |f(z_v) − w_v| = {error:.2e}");
    assert!(error < MAP_TOLERANCE, "{error:e}");

    let centroid = [(Sample::new(0, 1.0 / 3.0, 1.0 / 3.0), [1.0 / 3.0; 3])];
    let bpm = C::from_f32x2(eval(&gpu, &maps, &centroid, Interp::Bpm)[0]);
    let linear = C::from_f32x2(eval(&gpu, &maps, &centroid, Interp::Linear)[0]);
    assert!(
        bpm.sub(linear).abs() > 1e-3,
        "BPM = linear at the centroid: {bpm:?}"
    );
}

/// Both faces of an interior edge give the same UV on it (the geodesic midpoint of their maps).
#[test]
fn interior_edges_are_continuous() {
    let Some(gpu) = gpu_or_skip() else { return };
    let mesh = shear_star();
    let maps = bpm_precompute::run(&gpu, &mesh.stars(), Fit::Local).unwrap();
    // Face 0 = (0, 1, 2) and face 1 = (1, 0, 3) share the edge 0–1.
    let steps = 16;
    let (mut inside, mut outside) = (Vec::new(), Vec::new());
    for n in 0..=steps {
        let s = n as f32 / steps as f32;
        inside.push((Sample::new(0, s, 0.0), [0.0; 3]));
        outside.push((Sample::new(1, 1.0 - s, 0.0), [0.0; 3]));
    }
    let a = eval(&gpu, &maps, &inside, Interp::Bpm);
    let b: Vec<C> = eval(&gpu, &maps, &outside, Interp::Bpm)
        .into_iter()
        .map(C::from_f32x2)
        .collect();
    let jump = max_distance(&a, &b);
    println!("max jump across the edge = {jump:.2e}");
    // (1 − s) in f32 is exact for these s, so both sides evaluate the same point.
    assert!(jump < 2.0 * MAP_TOLERANCE, "{jump:e}");
}

/// The eval kernel against an f64 evaluation of the same (GPU-precomputed, non-trivial) maps:
/// f = w_origin + M_t(exp(½ Σ γ_e l_e)(z)), γ in product form, exp by Taylor series. Pins what
/// the interpolation and continuity properties cannot: the edge weights and the blend.
#[test]
fn eval_kernel_matches_an_f64_evaluation_of_its_maps() {
    let Some(gpu) = gpu_or_skip() else { return };
    let mesh = shear_star();
    let maps = bpm_precompute::run(&gpu, &mesh.stars(), Fit::Local).unwrap();
    let samples = grid_samples(mesh.faces.len(), 7);
    let uv = eval(&gpu, &maps, &samples, Interp::Bpm);
    let expected: Vec<C> = samples
        .iter()
        .map(|(s, b)| eval_f64(&maps[s.face as usize], *b))
        .collect();
    let error = max_distance(&uv, &expected);
    // The evaluation alone: ≈ 60 dependent operations (weights, blend, 6-term exp, two Möbius
    // applications) on data exact in f32, |uv| ≤ 1.5, well conditioned: 60 u · 1.5 ≈ 90 u; we
    // allow 128 u ≈ 7.6e-6.
    println!("max |f_gpu − f_f64| = {error:.2e}");
    assert!(error < 128.0 * U32, "{error:e}");
}

/// Linear mode is b_i uv_i + b_j uv_j + b_k uv_k (a few roundings of |uv| ≤ 1.5).
#[test]
fn linear_mode_interpolates_barycentrically() {
    let Some(gpu) = gpu_or_skip() else { return };
    let mesh = shear_star();
    let maps = bpm_precompute::run(&gpu, &mesh.stars(), Fit::Local).unwrap();
    let samples = grid_samples(mesh.faces.len(), 5);
    let uv = eval(&gpu, &maps, &samples, Interp::Linear);
    let expected: Vec<C> = samples
        .iter()
        .map(|(s, b)| {
            let w = mesh.uvs[s.face as usize];
            w[0].scale(b[0]).add(w[1].scale(b[1])).add(w[2].scale(b[2]))
        })
        .collect();
    let error = max_distance(&uv, &expected);
    assert!(error < 10.0 * 1.5 * U32, "{error:e}");
}

/// A degenerate face (mask bit 3) gets the linear fallback: identity map, zero logs, flag bit
/// 0, and BPM evaluation equal to linear on it.
#[test]
fn degenerate_faces_fall_back_to_linear() {
    let Some(gpu) = gpu_or_skip() else { return };
    let mesh = shear_star();
    let mut stars = mesh.stars();
    stars[0].mask |= MASK_DEGENERATE;
    let maps = bpm_precompute::run(&gpu, &stars, Fit::Local).unwrap();
    assert_eq!(maps[0].flags & FLAG_LINEAR_FALLBACK, FLAG_LINEAR_FALLBACK);
    assert_eq!(maps[0].m, [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]]);
    assert_eq!(maps[0].max_abs_log(), 0.0);
    assert!(!maps[1].is_linear_fallback());
    let samples: Vec<(Sample, [f64; 3])> = grid_samples(1, 4);
    assert_eq!(
        eval(&gpu, &maps, &samples, Interp::Bpm),
        eval(&gpu, &maps, &samples, Interp::Linear)
    );
}

/// Chunked runs (several dispatches, several windows of faces) give bit-identical results to
/// single dispatches.
#[test]
fn chunking_does_not_change_results() {
    let Some(gpu) = gpu_or_skip() else { return };
    let mesh = shear_star();
    let stars = mesh.stars();
    let maps = bpm_precompute::run(&gpu, &stars, Fit::Local).unwrap();
    assert_eq!(
        bpm_precompute::run_chunked(&gpu, &stars, Fit::Local, 3).unwrap(),
        maps
    );
    let samples: Vec<Sample> = grid_samples(mesh.faces.len(), 6)
        .into_iter()
        .map(|(s, _)| s)
        .collect();
    assert_eq!(
        bpm_eval::run_chunked(&gpu, &maps, &samples, Interp::Bpm, 7, 3).unwrap(),
        bpm_eval::run(&gpu, &maps, &samples, Interp::Bpm).unwrap()
    );
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let Some(gpu) = gpu_or_skip() else { return };
    let maps = bpm_precompute::run(&gpu, &shear_star().stars(), Fit::Local).unwrap();
    let outside = [Sample::new(maps.len() as u32, 0.2, 0.2)];
    assert!(matches!(
        bpm_eval::run(&gpu, &maps, &outside, Interp::Bpm),
        Err(GpuError::Input(_))
    ));
    assert_eq!(
        bpm_eval::run(&gpu, &maps, &[], Interp::Bpm).unwrap(),
        Vec::<[f32; 2]>::new()
    );
    assert_eq!(
        bpm_precompute::run(&gpu, &[], Fit::Local).unwrap(),
        Vec::new()
    );
}

// ---------------------------------------------------------------------------------------------
// exp / log on sl(2,C), through a test kernel over bpm_common.wgsl

/// A complex number as the kernels store it.
type Cf32 = [f32; 2];

/// exp_sl2(Y) and log_sl2(exp_sl2(Y)) for each Y (three complex entries a, b, c), computed by
/// a test kernel that calls the shared WGSL functions.
fn exp_and_log(gpu: &Gpu, ys: &[[Cf32; 3]]) -> Vec<([Cf32; 4], [Cf32; 3])> {
    const KERNEL: &str = r#"
struct Params { count: u32, _pad0: u32, _pad1: u32, _pad2: u32 }
struct Y { a: vec2<f32>, b: vec2<f32>, c: vec2<f32> }
struct Out { e: Mobius, l: Y }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> ys: array<Y>;
@group(0) @binding(2) var<storage, read_write> outs: array<Out>;
@compute @workgroup_size(WORKGROUP_SIZE)
fn test_exp_log(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_index(gid, nwg);
    if i >= params.count { return; }
    let e = exp_sl2(Sl2(ys[i].a, ys[i].b, ys[i].c));
    let l = log_sl2_roots(e);
    outs[i] = Out(e, Y(l.a, l.b, l.c));
}
"#;
    let source = [DISPATCH_WGSL, BPM_COMMON_WGSL, KERNEL].join("\n");
    let kernel = gpu
        .compute_kernel("test_exp_log", &source, "test_exp_log")
        .unwrap();
    let out: Vec<[Cf32; 7]> = gpu
        .run_per_item(&kernel, |n| [n, 0, 0, 0], &[], ys, ys.len())
        .unwrap();
    out.into_iter()
        .map(|o| ([o[0], o[1], o[2], o[3]], [o[4], o[5], o[6]]))
        .collect()
}

/// exp_sl2 against an f64 Taylor series of the matrix exponential, and log_sl2_roots ∘ exp_sl2 = id,
/// on cases chosen to exercise every branch, including near each series' radius where a wrong
/// coefficient would show: p = a² + bc decides exp (series for |p| < 1), q = sinh²√p decides
/// log (series for |q| < 0.1). All eigenvalues have |Im| < π/2, so the principal log of exp Y
/// is Y.
#[test]
fn exp_and_log_on_sl2() {
    let Some(gpu) = gpu_or_skip() else { return };
    let r = |x: f64| C(x, 0.0);
    let z = C(0.0, 0.0);
    let (s09, th) = (0.9f64.sqrt(), 1.3);
    // (Y, whether exp leaves its series for cosh/sinh, whether log leaves it for ln/atan2)
    let cases: Vec<([C; 3], bool, bool)> = vec![
        ([z, r(0.7), z], false, false),                   // nilpotent, p = 0
        ([r(0.3), z, z], false, false),                   // p = 0.09, q = 0.093 (log series edge)
        ([z, r(3.0), r(0.0307)], false, false),           // p = 0.092, q = 0.095, large entries
        ([C(0.0, 0.2), z, z], false, false),              // p = −0.04, complex
        ([r(s09), z, z], false, true),                    // p = 0.9 (exp series edge), q = 1.2
        ([z, r(s09), r(-s09)], false, true),              // p = −0.9 (rotation), q = −0.66
        ([r(th), z, z], true, true),                      // p = 1.69: cosh/sinh branch
        ([z, r(th), r(-th)], true, true), // p = −1.69: cosh/sinh of an imaginary root
        ([C(0.6, 0.8), r(0.5), C(0.0, 0.3)], true, true), // p = −0.28 + 1.11i
    ];
    let ys: Vec<[Cf32; 3]> = cases.iter().map(|(y, ..)| y.map(C::f32x2)).collect();
    let out = exp_and_log(&gpu, &ys);
    for ((y, exp_closed, log_closed), (e, l)) in cases.iter().zip(&out) {
        let expected = expm_taylor(*y);
        // Series branches: ≈ 20 dependent operations (6- or 8-term Horner, then the products),
        // each within u of values bounded by `scale`: 64 u · scale. The cosh/sinh/ln/atan2
        // branches add the transcendentals' own error: lavapipe's atan2 is within ≈ 20 ulp; we
        // allow 512 u (WGSL's worst-case bounds are looser still). The log is of the GPU's own
        // exp, so its tolerance adds the exp's.
        let scale = expected
            .iter()
            .chain(y)
            .map(|x| x.abs())
            .fold(1.0, f64::max);
        let branch = |closed: bool| if closed { 512.0 } else { 64.0 } * U32 * scale;
        let (e_tolerance, l_tolerance) = (
            branch(*exp_closed),
            branch(*exp_closed) + branch(*log_closed),
        );
        let e_error = max_distance(e, &expected);
        let l_error = max_distance(l, y);
        println!("Y = {y:?}: |exp − expected| = {e_error:.1e} (< {e_tolerance:.1e}), |log exp Y − Y| = {l_error:.1e} (< {l_tolerance:.1e})");
        assert!(e_error < e_tolerance, "exp {y:?}: {e:?} vs {expected:?}");
        assert!(l_error < l_tolerance, "log exp {y:?}: {l:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Compute plumbing

#[test]
fn invalid_wgsl_is_a_validation_error() {
    let Some(gpu) = gpu_or_skip() else { return };
    let result = gpu.compute_kernel("broken", "fn main( {", "main");
    assert!(matches!(result, Err(GpuError::Validation(_))), "{result:?}");
    println!("{}", result.unwrap_err());
}

/// More workgroups than one grid row holds: the dispatch wraps into rows and every item is
/// visited once (`linear_index`).
#[test]
fn dispatch_beyond_one_row_of_workgroups() {
    let Some(gpu) = gpu_or_skip() else { return };
    let per_row = gpu.limits().max_compute_workgroups_per_dimension as usize;
    let count = (per_row + 1) * 64 + 5;
    if count > 1 << 24 {
        println!(
            "max_compute_workgroups_per_dimension = {per_row}: too large to test rows cheaply"
        );
        return;
    }
    const KERNEL: &str = r#"
struct Params { count: u32, _pad0: u32, _pad1: u32, _pad2: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> input: array<u32>;
@group(0) @binding(2) var<storage, read_write> output: array<u32>;
@compute @workgroup_size(WORKGROUP_SIZE)
fn plus_one(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_index(gid, nwg);
    if i >= params.count { return; }
    output[i] = input[i] + 1u;
}
"#;
    let kernel = gpu
        .compute_kernel("plus_one", &[DISPATCH_WGSL, KERNEL].join("\n"), "plus_one")
        .unwrap();
    let input: Vec<u32> = (0..count as u32).map(|i| 3 * i).collect();
    let output: Vec<u32> = gpu
        .run_per_item(&kernel, |n| [n, 0, 0, 0], &[], &input, count)
        .unwrap();
    assert!(output.iter().zip(&input).all(|(o, i)| *o == i + 1));
}

#[test]
fn adapter_summary_names_the_adapter() {
    let Some(gpu) = gpu_or_skip() else { return };
    let summary = gpu.adapter_summary();
    println!("{summary}");
    assert!(summary.contains(&gpu.adapter_info().name));
}

// ---------------------------------------------------------------------------------------------
// Render

/// An RGBA texture whose texel (x, y) is (20x + 5, 20y + 9, 7(x + y) + 1, 255).
fn ramp_texture(w: u32, h: u32) -> Vec<u8> {
    (0..h)
        .flat_map(|y| {
            (0..w).flat_map(move |x| {
                [
                    (20 * x + 5) as u8,
                    (20 * y + 9) as u8,
                    (7 * (x + y) + 1) as u8,
                    255,
                ]
            })
        })
        .collect()
}

const IDENTITY: [f32; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

/// A quad [x0, x1] × [y0, y1] at depth z as two faces, with UV = affine image of (x, y): the
/// mesh, and its corners for the renderer.
fn quad(x: [f64; 2], y: [f64; 2], z: f64, uv: impl Fn(f64, f64) -> C) -> (Mesh, Vec<[f32; 4]>) {
    let positions = vec![
        [x[0], y[0], z],
        [x[1], y[0], z],
        [x[1], y[1], z],
        [x[0], y[1], z],
    ];
    let faces = vec![[0, 1, 2], [0, 2, 3]];
    let mesh = Mesh::with_uv_map(positions, faces, |p| uv(p[0], p[1]));
    let corners = corners_of(&mesh);
    (mesh, corners)
}

fn corners_of(mesh: &Mesh) -> Vec<[f32; 4]> {
    mesh.faces
        .iter()
        .flat_map(|f| {
            f.map(|v| {
                let p = mesh.positions[v];
                [p[0] as f32, p[1] as f32, p[2] as f32, 1.0]
            })
        })
        .collect()
}

fn render(
    gpu: &Gpu,
    mesh: &Mesh,
    view_proj: [f32; 16],
    size: [u32; 2],
    texture: (&[u8], u32, u32),
) -> Vec<u8> {
    render_windowed(gpu, mesh, view_proj, size, texture, None)
}

/// [`bpm_render::run`], or [`bpm_render::run_windowed`] with `Some(faces_per_window)`.
fn render_windowed(
    gpu: &Gpu,
    mesh: &Mesh,
    view_proj: [f32; 16],
    size: [u32; 2],
    texture: (&[u8], u32, u32),
    faces_per_window: Option<usize>,
) -> Vec<u8> {
    let maps = bpm_precompute::run(gpu, &mesh.stars(), Fit::Local).unwrap();
    let corners = corners_of(mesh);
    let input = RenderInput {
        width: size[0],
        height: size[1],
        view_proj,
        corners: &corners,
        maps: &maps,
        texture_width: texture.1,
        texture_height: texture.2,
        texture: texture.0,
        interp: Interp::Bpm,
        background: [10, 20, 30, 255],
    };
    match faces_per_window {
        Some(window) => bpm_render::run_windowed(gpu, &input, window),
        None => bpm_render::run(gpu, &input),
    }
    .unwrap()
}

/// A full-screen quad with uv = ((x + 1)/2, (y + 1)/2) on a texture the size of the picture:
/// pixel (px, py) samples texture coordinate ((px + ½)/W, (py + ½)/H), a texel centre, so the
/// picture is the texture itself (checks the v flip, top-row-first order and texel centres).
#[test]
fn full_screen_quad_shows_the_texture_texel_for_texel() {
    let Some(gpu) = gpu_or_skip() else { return };
    let (w, h) = (8, 6);
    let texture = ramp_texture(w, h);
    let (mesh, _) = quad([-1.0, 1.0], [-1.0, 1.0], 0.5, |x, y| {
        C((x + 1.0) / 2.0, (y + 1.0) / 2.0)
    });
    let picture = render(&gpu, &mesh, IDENTITY, [w, h], (&texture, w, h));
    let worst = picture
        .iter()
        .zip(&texture)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!(
        worst <= 1,
        "picture differs from the texture by up to {worst}: {picture:?}"
    );
}

/// No faces: the whole picture is the background. A texture of the wrong size is an error.
#[test]
fn empty_mesh_and_bad_texture() {
    let Some(gpu) = gpu_or_skip() else { return };
    let empty = Mesh {
        positions: vec![],
        faces: vec![],
        uvs: vec![],
    };
    let texture = ramp_texture(2, 2);
    let picture = render(&gpu, &empty, IDENTITY, [5, 3], (&texture, 2, 2));
    assert_eq!(picture, [10, 20, 30, 255].repeat(15));
    let input = RenderInput {
        width: 4,
        height: 4,
        view_proj: IDENTITY,
        corners: &[],
        maps: &[],
        texture_width: 3,
        texture_height: 2,
        texture: &texture,
        interp: Interp::Bpm,
        background: [0; 4],
    };
    assert!(matches!(
        bpm_render::run(&gpu, &input),
        Err(GpuError::Input(_))
    ));
}

/// Background where nothing is drawn; the nearer of two overlapping quads wins whatever the
/// drawing order (Less depth test), also across draw calls; uv outside [0, 1] wraps (REPEAT).
#[test]
fn depth_test_background_and_repeat() {
    let Some(gpu) = gpu_or_skip() else { return };
    // Texture 8×1: texels 0–3 red, 4–7 blue; bilinear is pure red for u mod 1 in
    // [1/16, 7/16] and pure blue in [9/16, 15/16].
    let texture: Vec<u8> = (0..8)
        .flat_map(|x| {
            if x < 4 {
                [255, 0, 0, 255]
            } else {
                [0, 0, 255, 255]
            }
        })
        .collect();
    // Near quad (z = 0.2) on the left half, u = 1.25 + 0.1 x ∈ [1.15, 1.25] (red after
    // wrapping); far quad (z = 0.7) over the whole width, u = 0.75 + 0.1 x (blue), drawn last.
    let (near, _) = quad([-1.0, 0.0], [-1.0, 0.5], 0.2, |x, y| {
        C(1.25 + 0.1 * x, 0.5 + 0.1 * y)
    });
    let (far, _) = quad([-1.0, 1.0], [-1.0, 0.5], 0.7, |x, y| {
        C(0.75 + 0.1 * x, 0.5 + 0.1 * y)
    });
    let mut mesh = near.clone();
    let offset = mesh.positions.len();
    mesh.positions.extend(&far.positions);
    mesh.faces
        .extend(far.faces.iter().map(|f| f.map(|v| v + offset)));
    mesh.uvs.extend(&far.uvs);
    let (w, h) = (16, 16);
    let picture = render(&gpu, &mesh, IDENTITY, [w, h], (&texture, 8, 1));
    let pixel = |x: u32, y: u32| -> [u8; 4] {
        let i = 4 * (y * w + x) as usize;
        picture[i..i + 4].try_into().unwrap()
    };
    assert_eq!(pixel(3, 1), [10, 20, 30, 255], "background (top rows)");
    assert_eq!(pixel(3, 12), [255, 0, 0, 255], "near quad (left)");
    assert_eq!(pixel(12, 12), [0, 0, 255, 255], "far quad (right)");
    // One face per draw call: the z-buffer is shared across draws, the picture is the same.
    let windowed = render_windowed(&gpu, &mesh, IDENTITY, [w, h], (&texture, 8, 1), Some(1));
    assert!(
        windowed == picture,
        "one face per window changes the picture"
    );
}

/// A quad tilted in depth under a perspective projection: the colour is a linear ramp in u, so
/// the picture shows u itself, which must be the perspective-correct u (screen-linear
/// interpolation would be off by up to ≈ 0.1 here).
#[test]
fn perspective_correct_interpolation() {
    let Some(gpu) = gpu_or_skip() else { return };
    // Projection with f = 1, near 0.1, far 10 (wgpu depth), camera at the origin looking down −z.
    let (n, f) = (0.1f64, 10.0f64);
    #[rustfmt::skip]
    let proj: [f64; 16] = [
        1.0, 0.0, 0.0, 0.0,
        0.0, 1.0, 0.0, 0.0,
        0.0, 0.0, f / (n - f), -1.0,
        0.0, 0.0, n * f / (n - f), 0.0,
    ]; // column-major
       // Quad from (−1, −0.5, −1.2) to (1, 0.5, −3.5): x spans the screen, depth grows with x.
    let positions = vec![
        [-1.0, -0.5, -1.2],
        [1.0, -0.5, -3.5],
        [1.0, 0.5, -3.5],
        [-1.0, 0.5, -1.2],
    ];
    let faces = vec![[0, 1, 2], [0, 2, 3]];
    // The quad is an L × 1 rectangle, L = |(2, 0, −2.3)|. UV = a similarity of it: scale
    // s = 0.5/L, so u = 0.5 + 0.25 X runs from 0.25 to 0.75 and v = 0.5 + s Y.
    let s = 0.5 / (2.0f64.powi(2) + 2.3f64.powi(2)).sqrt();
    let mesh = Mesh::with_uv_map(positions, faces, |p| C(0.5 + 0.25 * p[0], 0.5 + s * p[1]));
    // Texture: 256 texels wide, red = x (a ramp), so bilinear red = 256 u − 0.5.
    let tw = 256u32;
    let texture: Vec<u8> = (0..tw).flat_map(|x| [x as u8, 0, 0, 255]).collect();
    let (w, h) = (32u32, 8u32);
    let picture = render(
        &gpu,
        &mesh,
        proj.map(|x| x as f32),
        [w, h],
        (&texture, tw, 1),
    );
    // Expected u at the centre row: intersect the pixel ray with the quad's plane.
    let y = h / 2;
    let mut checked = 0;
    for x in 0..w {
        let ndc_x = (x as f64 + 0.5) / w as f64 * 2.0 - 1.0;
        // Ray direction (ndc_x, ·, −1) (f = 1); the quad's centre line z = −1.2 − 1.15 (X + 1).
        // Solve X = ndc_x · t, Z = −t with −t = −1.2 − 1.15 (ndc_x t + 1): t = 2.35 / (1 − 1.15 ndc_x).
        let t = 2.35 / (1.0 - 1.15 * ndc_x);
        let x_world = ndc_x * t;
        if !(-1.0..=1.0).contains(&x_world) {
            continue;
        }
        let u = 0.5 + 0.25 * x_world;
        let expected_red = 256.0 * u - 0.5;
        let red = picture[4 * (y * w + x) as usize] as f64;
        assert!(
            (red - expected_red).abs() <= 1.5,
            "pixel {x}: red {red}, expected {expected_red:.1}"
        );
        checked += 1;
    }
    assert!(
        checked > w / 2,
        "quad covers only {checked} pixels of the row"
    );
}
