//! BPM cross-check: the f32 kernels `bpm_precompute` and `bpm_eval` against the f64 reference,
//! in texels of a 4096² texture.
//!
//! Three comparisons, all from the same f32-rounded mesh and the same f32 sample points:
//! - **eval kernel**: `bpm_eval` on the reference's per-triangle data rounded to f32, against
//!   the reference evaluation (isolates the evaluation's arithmetic; tight tolerance);
//! - **local pipeline**: `bpm_precompute` (local-frame fit) then `bpm_eval`, all on the GPU;
//! - **determinant pipeline**: the same with the seed's determinant fit (the "speckling").

use num_complex::Complex64 as C;
use rayon::prelude::*;
use reparam_gpu::Gpu;
use serde::Serialize;

use super::timing::{time_cpu, time_gpu_warm};
use super::{to_f32_precision, Bounds, ErrorSummary, Row, Timing};
use crate::bpm::gpu::{eval_gpu, maps_to_gpu, precompute_gpu, samples_to_gpu, stars};
use crate::bpm::render::{render_cpu, RenderOptions};
use crate::bpm::{precompute, Bpm, BpmOptions, Fit, Interp, Unfold};
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::report::sig;
use reparam_gpu::bpm::GpuTriangleMaps;

/// BPM's UV errors are measured in texels of a texture this wide (4096²): written once, in
/// [`super::bpm_bound`].
pub use super::bpm_bound::TEXTURE_SIZE;
/// Unit string of the summaries.
pub const UNIT: &str = "texels of a 4096² texture";

/// The bounds of the eval kernel and of the local-fit pipeline are per sample, derived from the
/// WGSL accuracy table by the kernels' f32 twins (over balls for the eval, to first order on a
/// tape for the pipeline): [`super::bpm_bound`].
pub use super::bpm_bound::{crosscheck_samples, eval_bounds, pipeline_bounds};
pub use super::render_bound::{channel_errors, render_bound, RENDER_BOUND_FORMULA};

/// What the eval rows' bound says (one line for the table and the manifests).
pub const EVAL_BOUND_FORMULA: &str = "per sample: the bpm_eval twin over balls (WGSL table, \
    f32 inputs) · 4096 (crosscheck::bpm_bound)";
/// What the pipeline row's bound says.
pub const PIPELINE_BOUND_FORMULA: &str = "per sample: 2 × the first-order bound of the \
    bpm_precompute → bpm_eval twins on a tape (WGSL table) · 4096 (crosscheck::bpm_bound)";

/// Threshold of a visible error: one texel. The determinant pipeline's summary uses it as its
/// tolerance, so its `over_tolerance` is the number of speckled samples.
pub const SPECKLE_THRESHOLD: f64 = 1.0;

/// The three comparisons on one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct BpmCrosscheck {
    pub mesh: String,
    pub faces: usize,
    pub adapter: String,
    /// `bpm_eval` alone (BPM interpolation) on the reference's data.
    pub eval_kernel: ErrorSummary,
    /// `bpm_eval` in linear mode on the same data.
    pub linear_kernel: ErrorSummary,
    /// GPU precompute (local fit) + GPU eval.
    pub local: ErrorSummary,
    /// GPU precompute (determinant fit) + GPU eval.
    pub det: ErrorSummary,
    /// Fraction of samples off by more than one texel, per fit.
    pub speckle_local: f64,
    pub speckle_det: f64,
}

/// The mesh as the GPU sees it: positions and UVs rounded to f32 (stored back as f64).
pub fn round_mesh_to_f32(mesh: &TriMesh) -> TriMesh {
    let mut m = mesh.clone();
    for p in &mut m.positions {
        *p = p.map(to_f32_precision);
    }
    for t in &mut m.uvs {
        *t = t.map(to_f32_precision);
    }
    m
}

/// Errors |gpu − cpu| in texels and the reference magnitudes |cpu| in texels.
fn texel_errors(cpu: &[C], gpu: &[C]) -> (Vec<f64>, Vec<f64>) {
    cpu.par_iter()
        .zip(gpu)
        .map(|(c, g)| ((g - c).norm() * TEXTURE_SIZE, c.norm() * TEXTURE_SIZE))
        .unzip()
}

fn summary(cpu: &[C], gpu: &[C], tolerance: f64) -> (ErrorSummary, f64) {
    let (errors, magnitudes) = texel_errors(cpu, gpu);
    let s = ErrorSummary::from_errors(UNIT, &errors, &magnitudes, tolerance);
    (s, ErrorSummary::fraction_over(&errors, SPECKLE_THRESHOLD))
}

/// Run the three comparisons on `mesh` (needs UVs).
pub fn crosscheck_bpm(gpu: &Gpu, mesh: &TriMesh) -> Result<BpmCrosscheck> {
    let mesh = round_mesh_to_f32(mesh);
    let reference: Bpm = precompute(&mesh, BpmOptions::default())?;
    let samples = crosscheck_samples(mesh.face_count());
    let gpu_samples = samples_to_gpu(&samples);
    let cpu_bpm = reference.eval_many(&samples, Interp::Bpm);
    let cpu_linear = reference.eval_many(&samples, Interp::Linear);
    let largest = |b: Vec<f64>| b.into_iter().fold(0.0, f64::max);
    let eval_bound = largest(eval_bounds(&reference, &samples, Interp::Bpm, &cpu_bpm));
    let linear_bound = largest(eval_bounds(
        &reference,
        &samples,
        Interp::Linear,
        &cpu_linear,
    ));
    let pipeline_bound = largest(pipeline_bounds(&stars(&mesh)?, &samples, &cpu_bpm));

    let rounded = maps_to_gpu(&reference);
    let (eval_kernel, _) = summary(
        &cpu_bpm,
        &eval_gpu(gpu, &rounded, &gpu_samples, Interp::Bpm)?,
        eval_bound,
    );
    let (linear_kernel, _) = summary(
        &cpu_linear,
        &eval_gpu(gpu, &rounded, &gpu_samples, Interp::Linear)?,
        linear_bound,
    );

    let pipeline = |fit: Fit, tolerance: f64| -> Result<(ErrorSummary, f64)> {
        let maps = precompute_gpu(gpu, &mesh, fit)?;
        Ok(summary(
            &cpu_bpm,
            &eval_gpu(gpu, &maps, &gpu_samples, Interp::Bpm)?,
            tolerance,
        ))
    };
    let (local, speckle_local) = pipeline(Fit::Local, pipeline_bound)?;
    let (det, speckle_det) = pipeline(Fit::Determinant, SPECKLE_THRESHOLD)?;
    Ok(BpmCrosscheck {
        mesh: mesh.name.clone(),
        faces: mesh.face_count(),
        adapter: gpu.adapter_summary(),
        eval_kernel,
        linear_kernel,
        local,
        det,
        speckle_local,
        speckle_det,
    })
}

/// The rows of `reparam crosscheck bpm` for one mesh: the eval kernel alone (BPM and linear),
/// the precompute kernel with each fit followed by the eval kernel, and the render pipeline
/// against the CPU renderer (`texture` on `mesh`'s UVs).
pub fn bpm_rows(
    gpu: &Gpu,
    mesh: &TriMesh,
    texture: &crate::texture::Image<[u8; 4]>,
) -> Result<Vec<Row>> {
    bpm_rows_with(gpu, mesh, texture, false)
}

/// [`bpm_rows`], with `perturb` (tests of the harness itself): the eval kernel is fed the
/// reference's maps with every coefficient × (1 + 1e-3), an input error far above the f32
/// roundoff the bound allows, so its rows must fail.
pub fn bpm_rows_with(
    gpu: &Gpu,
    mesh: &TriMesh,
    texture: &crate::texture::Image<[u8; 4]>,
    perturb: bool,
) -> Result<Vec<Row>> {
    bpm_rows_with_options(gpu, mesh, texture, perturb, BpmOptions::default())
}

/// [`bpm_rows_with`] with the reference precomputed under `options`. With
/// [`Unfold::Authors`] only the eval kernel's rows are produced (on the reference's maps, laid
/// out as the authors' code does): the GPU precompute kernel, and the render pipeline built on
/// it, implement only the correct unfolding, so their rows are left out and the first row says so.
pub fn bpm_rows_with_options(
    gpu: &Gpu,
    mesh: &TriMesh,
    texture: &crate::texture::Image<[u8; 4]>,
    perturb: bool,
    options: BpmOptions,
) -> Result<Vec<Row>> {
    let algorithm = "bpm";
    let name = mesh.name.clone();
    let mesh = round_mesh_to_f32(mesh);
    let (reference, precompute_cpu) = time_cpu(|| precompute(&mesh, options));
    let reference = reference?;
    let samples = crosscheck_samples(mesh.face_count());
    let gpu_samples = samples_to_gpu(&samples);
    let (cpu_bpm, eval_cpu) = time_cpu(|| reference.eval_many(&samples, Interp::Bpm));
    let cpu_linear = reference.eval_many(&samples, Interp::Linear);
    let bpm_bounds = eval_bounds(&reference, &samples, Interp::Bpm, &cpu_bpm);
    let linear_bounds = eval_bounds(&reference, &samples, Interp::Linear, &cpu_linear);
    let compare = |kernel: &str, cpu: &[C], gpu: &[C], bounds: Bounds, formula: &str| {
        let (errors, magnitudes) = texel_errors(cpu, gpu);
        Row::compare(
            algorithm,
            kernel,
            &name,
            UNIT,
            &errors,
            &magnitudes,
            bounds,
            formula,
        )
    };
    let mut rounded = maps_to_gpu(&reference);
    if perturb {
        perturb_maps(&mut rounded);
    }
    let (gpu_bpm, eval_gpu_t) =
        time_gpu_warm(gpu, || eval_gpu(gpu, &rounded, &gpu_samples, Interp::Bpm))?;
    let gpu_linear = eval_gpu(gpu, &rounded, &gpu_samples, Interp::Linear)?;
    let mut rows = vec![
        compare(
            "bpm_eval: BPM uv",
            &cpu_bpm,
            &gpu_bpm,
            Bounds::PerElement(bpm_bounds.clone()),
            EVAL_BOUND_FORMULA,
        )
        .with_note(&match options.unfold {
            Unfold::Correct => format!(
                "{} faces, {} samples{}",
                mesh.face_count(),
                samples.len(),
                unbounded_note(&bpm_bounds)
            ),
            Unfold::Authors => format!(
                "{} faces, {} samples{}; --unfold authors: maps laid out as the authors' code does \
                 ({} neighbours folded past 90°); bpm_precompute and bpm_render rows left out \
                 (the GPU precompute implements only the correct unfolding)",
                mesh.face_count(),
                samples.len(),
                unbounded_note(&bpm_bounds),
                reference.report.neighbours_folded_past_90
            ),
        })
        .with_timing(Timing {
            cpu_ms: Some(eval_cpu),
            ..eval_gpu_t
        }),
        compare(
            "bpm_eval: linear uv",
            &cpu_linear,
            &gpu_linear,
            Bounds::PerElement(linear_bounds),
            EVAL_BOUND_FORMULA,
        ),
    ];
    if options.unfold == Unfold::Authors {
        return Ok(rows);
    }
    let local_bounds = pipeline_bounds(&stars(&mesh)?, &samples, &cpu_bpm);
    for fit in [Fit::Local, Fit::Determinant] {
        let (maps, t) = time_gpu_warm(gpu, || precompute_gpu(gpu, &mesh, fit))?;
        let uv = eval_gpu(gpu, &maps, &gpu_samples, Interp::Bpm)?;
        let timing = Timing {
            cpu_ms: Some(precompute_cpu),
            ..t
        };
        rows.push(match fit {
            Fit::Local => compare(
                "bpm_precompute (local fit) → bpm_eval: uv",
                &cpu_bpm,
                &uv,
                Bounds::PerElement(local_bounds.clone()),
                PIPELINE_BOUND_FORMULA,
            )
            .with_note(unbounded_note(&local_bounds).trim_start_matches("; "))
            .with_timing(timing),
            Fit::Determinant => {
                let (errors, _) = texel_errors(&cpu_bpm, &uv);
                let speckled = ErrorSummary::fraction_over(&errors, SPECKLE_THRESHOLD);
                compare(
                    "bpm_precompute (determinant fit) → bpm_eval: uv",
                    &cpu_bpm,
                    &uv,
                    Bounds::Uniform(SPECKLE_THRESHOLD),
                    "1 texel (a visible speckle)",
                )
                .informative(&format!(
                    "the seed's determinant fit, shown for comparison: {}% of samples off by > 1 texel",
                    sig(100.0 * speckled, 2)
                ))
                .with_timing(timing)
            }
        });
    }
    rows.push(render_row(gpu, &mesh, &reference, texture, &name)?);
    Ok(rows)
}

/// `bpm_render` against `render_cpu` at 256 × 256 (BPM interpolation, the default view).
fn render_row(
    gpu: &Gpu,
    mesh: &TriMesh,
    reference: &Bpm,
    texture: &crate::texture::Image<[u8; 4]>,
    name: &str,
) -> Result<Row> {
    let options = RenderOptions {
        width: 256,
        height: 256,
        ..Default::default()
    };
    let (cpu, cpu_ms) = time_cpu(|| render_cpu(mesh, reference, texture, &options));
    let (picture, t) = time_gpu_warm(gpu, || {
        crate::bpm::gpu::render_gpu(gpu, mesh, reference.options.fit, texture, &options)
    })?;
    let bound = render_bound(mesh, reference, texture, &options)?;
    let errors = channel_errors(&cpu, &picture)?;
    let psnr = crate::raster::image_diff(&cpu, &picture)?.psnr_db;
    let pixels = errors.len() / 3;
    Ok(Row::compare(
        "bpm",
        "bpm_render: colour",
        name,
        "units of 1/255 per RGB channel",
        &errors,
        &[],
        Bounds::PerElement(bound.bounds),
        RENDER_BOUND_FORMULA,
    )
    .with_note(&format!(
        "256 × 256; {} of {pixels} pixels with contested coverage (unbounded){}; PSNR {} dB",
        bound.contested,
        match bound.unbounded_uv {
            0 => String::new(),
            n => format!(", {n} with no UV bound"),
        },
        sig(psnr, 3)
    ))
    .with_timing(Timing {
        cpu_ms: Some(cpu_ms),
        ..t
    }))
}

/// "; n samples without a bound from the WGSL table" when there are any.
fn unbounded_note(bounds: &[f64]) -> String {
    match super::bpm_bound::unbounded(bounds) {
        0 => String::new(),
        n => format!("; {n} samples without a bound from the WGSL table (a pole or a branch within rounding)"),
    }
}

/// The UV coefficients of `maps` × (1 + 1e-3) (see [`bpm_rows_with`]): uv_i, uv_j, uv_k and
/// w_origin, ≈ 1e-3 of the UVs' size, ≈ 4 texels, a hundred times the eval bound.
fn perturb_maps(maps: &mut [GpuTriangleMaps]) {
    for m in maps {
        for v in m.uv_ij.iter_mut().chain(m.uv_k_origin.iter_mut()) {
            *v *= 1.0 + 1e-3;
        }
    }
}
