//! `bpm_render`'s bound ([`reparam::crosscheck::render_bound`]) against its twin
//! (`src/twin/bpm_render.rs`):
//! - it accepts every conforming render the twin can draw: exact fixed-function stages, the
//!   8-bit stages of most desktop GPUs, and Vulkan's minimum (4-bit snapping and filter weights,
//!   every quantisation truncated), each under the `nearest` and the `worst` arithmetic;
//! - it rejects porting mistakes built from the twin's pieces: the texture's v not flipped,
//!   the barycentrics rotated, u and v swapped, the linear interpolant drawn for BPM's, a
//!   sampler with nearest filtering.
#![cfg(feature = "gpu")]

use nalgebra::Vector3;
use reparam::bpm::gpu::stars;
use reparam::bpm::render::{render_cpu, RenderOptions};
use reparam::bpm::{precompute, Bpm, BpmOptions, Interp};
use reparam::crosscheck::bpm::round_mesh_to_f32;
use reparam::crosscheck::bpm_bound::ball_star;
use reparam::crosscheck::bpm_models::f32_star;
use reparam::crosscheck::render_bound::{channel_errors, render_bound};
use reparam::mesh::{procedural, TriMesh};
use reparam::texture::{checker, uv_grid_texture, Image, Rgba8};
use reparam::twin::bpm_common::{TriangleMaps, INTERP_LINEAR};
use reparam::twin::bpm_precompute::{triangle_maps, FIT_LOCAL};
use reparam::twin::bpm_render::{
    bpm_render_fragment, render_twin, render_twin_with, FixedFunction, FragmentStage,
};
use reparam::twin::{with_model, Model, Real, F, V2, V3};

/// Small pictures: the bound is per pixel, and these tests run in debug builds.
const SIZE: u32 = 128;

struct Case {
    mesh: TriMesh,
    reference: Bpm,
    texture: Image<Rgba8>,
    options: RenderOptions,
}

/// A cone fan (one chart, a BPM interpolant far from linear) under a checkerboard magnified 4
/// texels per pixel, a torus (seams, a silhouette and hidden faces) under the UV grid, and the
/// cone fan under a 32-texel checkerboard (a quarter texel per pixel, where the filter
/// weights' quantisation outweighs the snapping: without the bound's q term the Vulkan-minimum
/// render goes 105 channels over).
fn cases(interp: Interp) -> Vec<Case> {
    [
        (
            procedural::cone_fan(8, 0.8),
            checker(512, 16),
            Vector3::new(0.0, -0.35, 1.0),
        ),
        (
            procedural::torus(16, 8, 1.0, 0.35),
            uv_grid_texture(1024),
            Vector3::new(0.3, 0.6, 1.0),
        ),
        (
            procedural::cone_fan(8, 0.8),
            checker(32, 4),
            Vector3::new(0.0, -0.35, 1.0),
        ),
    ]
    .into_iter()
    .map(|(mesh, texture, view_dir)| {
        let mesh = round_mesh_to_f32(&mesh);
        let reference = precompute(&mesh, BpmOptions::default()).unwrap();
        let options = RenderOptions {
            width: SIZE,
            height: SIZE,
            view_dir,
            interp,
            ..Default::default()
        };
        Case {
            mesh,
            reference,
            texture,
            options,
        }
    })
    .collect()
}

/// The per-triangle data as the `bpm_precompute` twin computes it under `model`.
fn twin_maps(mesh: &TriMesh, model: Model) -> Vec<TriangleMaps<F>> {
    stars(mesh)
        .unwrap()
        .iter()
        .map(|s| {
            let star = f32_star(&ball_star(s));
            with_model(model, || triangle_maps(&star, FIT_LOCAL))
        })
        .collect()
}

/// Elements (pixel channels) over the bound, the worst ratio, and the contested pixels.
fn judge(case: &Case, picture: &Image<Rgba8>) -> (usize, f64, usize) {
    let bound = render_bound(&case.mesh, &case.reference, &case.texture, &case.options).unwrap();
    let reference = render_cpu(&case.mesh, &case.reference, &case.texture, &case.options);
    let (over, worst) = bound.judge(&channel_errors(&reference, picture).unwrap());
    (over, worst, bound.contested)
}

#[test]
fn every_conforming_render_is_within_the_bound() {
    for interp in [Interp::Bpm, Interp::Linear] {
        for case in cases(interp) {
            for model in [Model::Nearest, Model::Worst(1)] {
                let maps = twin_maps(&case.mesh, model);
                for fixed in [
                    FixedFunction::EXACT,
                    FixedFunction::TYPICAL,
                    FixedFunction::SPEC_MINIMUM,
                ] {
                    let picture = render_twin(
                        &case.mesh,
                        &maps,
                        &case.texture,
                        &case.options,
                        model,
                        fixed,
                    );
                    let (over, worst, contested) = judge(&case, &picture);
                    eprintln!(
                        "{} {interp:?} {} {fixed:?}: worst {worst:.3}, {over} over, {contested} contested",
                        case.mesh.name,
                        model.name()
                    );
                    assert_eq!(
                        over,
                        0,
                        "{} {interp:?} {} {fixed:?}",
                        case.mesh.name,
                        model.name()
                    );
                    // Contested pixels are a thin band along edges, not the picture.
                    assert!(
                        contested < (SIZE * SIZE / 10) as usize,
                        "{contested} contested"
                    );
                }
            }
        }
    }
}

/// The v of the texture coordinate not flipped (the OBJ origin taken as top-left).
fn v_not_flipped(maps: &[TriangleMaps<F>], face: u32, b: V3<F>, interp: u32) -> Option<V2<F>> {
    let st = bpm_render_fragment(maps, face, b, interp)?;
    Some(V2::new(st.x, F::lit(1.0) - st.y))
}

/// Corner weights rotated (b_j, b_k, b_i): a slot mistake.
fn rotated_barycentrics(
    maps: &[TriangleMaps<F>],
    face: u32,
    b: V3<F>,
    interp: u32,
) -> Option<V2<F>> {
    bpm_render_fragment(maps, face, V3::new(b.y, b.z, b.x), interp)
}

/// The linear interpolant whatever the mode asks.
fn always_linear(maps: &[TriangleMaps<F>], face: u32, b: V3<F>, _: u32) -> Option<V2<F>> {
    bpm_render_fragment(maps, face, b, INTERP_LINEAR)
}

/// u and v swapped.
fn swapped_uv(maps: &[TriangleMaps<F>], face: u32, b: V3<F>, interp: u32) -> Option<V2<F>> {
    let st = bpm_render_fragment(maps, face, b, interp)?;
    Some(V2::new(F::lit(1.0) - st.y, F::lit(1.0) - st.x))
}

#[test]
fn porting_mistakes_are_rejected() {
    let fixed = FixedFunction::TYPICAL;
    let model = Model::Nearest;
    let mutants: [(&str, FragmentStage); 4] = [
        ("v not flipped", &v_not_flipped),
        ("u and v swapped", &swapped_uv),
        ("rotated barycentrics", &rotated_barycentrics),
        ("always linear", &always_linear),
    ];
    // The sampler created with nearest filtering: weights of 0 bits, rounded to nearest.
    let nearest_filter = FixedFunction {
        subtexel_bits: Some(0),
        ..fixed
    };
    // Elements over the bound, per mistake, summed over the cases: each must be rejected by
    // the pair. (One case alone may not see a mistake: on the cone fan, whose UVs and
    // checkerboard are symmetric about u = v, swapping u and v draws the same picture.)
    let mut rejected = std::collections::BTreeMap::<&str, usize>::new();
    for case in cases(Interp::Bpm) {
        let maps = twin_maps(&case.mesh, model);
        let run = |name: &str, fragment: FragmentStage, fixed: FixedFunction| {
            let picture = render_twin_with(
                &case.mesh,
                &maps,
                &case.texture,
                &case.options,
                model,
                fixed,
                fragment,
            );
            let (over, worst, _) = judge(&case, &picture);
            eprintln!("{} {name}: {over} over, worst {worst:.2}", case.mesh.name);
            over
        };
        for (name, fragment) in mutants {
            *rejected.entry(name).or_default() += run(name, fragment, fixed);
        }
        *rejected.entry("nearest filtering").or_default() += run(
            "nearest filtering",
            &bpm_render_fragment::<F>,
            nearest_filter,
        );
    }
    for (name, over) in rejected {
        assert!(over > 0, "{name}: accepted");
    }
}
