//! `reparam bpm render|qc`.

use std::path::PathBuf;
use std::time::Instant;

use crate::bpm::render::{render_cpu, RenderOptions};
use crate::bpm::{
    precompute, qc_protocol, BpmOptions, Fit, Interp, PrecomputeReport, QcStats, Unfold,
};
use crate::report::sig;
use crate::texture::save_png;
use crate::Result;
use clap::{Args, Subcommand, ValueEnum};
use serde::Serialize;

use crate::bpm::render::resolve_texture;

use super::inputs::{load_mesh, parse_direction, parse_size};

#[derive(Subcommand)]
pub enum BpmCommand {
    /// Render a mesh textured under BPM or linear UVs to a PNG.
    Render(RenderArgs),
    /// The authors' quality protocol: QC = σmax/σmin over 4ⁿ sub-triangles per face.
    Qc(QcArgs),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum InterpArg {
    Bpm,
    Linear,
}

impl From<InterpArg> for Interp {
    fn from(a: InterpArg) -> Interp {
        match a {
            InterpArg::Bpm => Interp::Bpm,
            InterpArg::Linear => Interp::Linear,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    Cpu,
    Gpu,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FitArg {
    Local,
    Det,
}

impl From<FitArg> for Fit {
    fn from(a: FitArg) -> Fit {
        match a {
            FitArg::Local => Fit::Local,
            FitArg::Det => Fit::Determinant,
        }
    }
}

/// `--unfold`: how the neighbours of each triangle are laid out in its plane ([`Unfold`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum UnfoldArg {
    /// The isometric hinge unfolding (reparam's reference figures).
    #[default]
    Correct,
    /// The authors' MATLAB code: neighbours folded past 90° are not rotated flat (reproduces
    /// the published figures).
    Authors,
}

impl From<UnfoldArg> for Unfold {
    fn from(a: UnfoldArg) -> Unfold {
        match a {
            UnfoldArg::Correct => Unfold::Correct,
            UnfoldArg::Authors => Unfold::Authors,
        }
    }
}

#[derive(Args)]
pub struct RenderArgs {
    /// OBJ file (with `vt` and optionally an MTL texture) or `procedural:<name>`.
    pub mesh: String,
    #[arg(long, value_enum, default_value = "bpm")]
    pub interp: InterpArg,
    #[arg(long, value_enum, default_value = "cpu")]
    pub backend: Backend,
    /// Möbius fit (the GPU backend's precompute uses it too).
    #[arg(long, value_enum, default_value = "local")]
    pub fit: FitArg,
    /// Neighbour layout: `authors` reproduces the authors' code (CPU backend only).
    #[arg(long, value_enum, default_value = "correct")]
    pub unfold: UnfoldArg,
    /// Texture image; default: the mesh's material texture, else a built-in UV grid.
    #[arg(long)]
    pub texture: Option<PathBuf>,
    /// Picture size WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size, default_value = "768x768")]
    pub size: (u32, u32),
    /// View direction x,y,z (from the mesh towards the eye).
    #[arg(long, value_parser = parse_direction, default_value = "0.4,0.3,1")]
    pub view: nalgebra::Vector3<f64>,
    /// With --backend gpu: also render on the CPU and report PSNR and differing pixels.
    #[arg(long)]
    pub compare: bool,
    /// Output PNG.
    #[arg(short, long, default_value = "out/bpm_render.png")]
    pub output: PathBuf,
    /// Print machine-readable results.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct QcArgs {
    /// OBJ file (with `vt`) or `procedural:<name>`.
    pub mesh: String,
    /// Number of 1→4 subdivisions per face (4 → 256 sub-triangles).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(0..=8))]
    pub subdiv: u32,
    #[arg(long, value_enum, default_value = "local")]
    pub fit: FitArg,
    /// Neighbour layout: `authors` reproduces the authors' code and the published figures.
    #[arg(long, value_enum, default_value = "correct")]
    pub unfold: UnfoldArg,
    /// Print machine-readable results.
    #[arg(long)]
    pub json: bool,
}

pub fn run(cmd: BpmCommand) -> Result<()> {
    match cmd {
        BpmCommand::Render(args) => render(args),
        BpmCommand::Qc(args) => qc(args),
    }
}

#[derive(Serialize)]
struct RenderResult {
    mesh: String,
    output: PathBuf,
    backend: String,
    interp: Interp,
    unfold: Unfold,
    width: u32,
    height: u32,
    precompute: PrecomputeReport,
    seconds: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    adapter: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    versus_cpu: Option<crate::raster::DiffStats>,
}

fn render(args: RenderArgs) -> Result<()> {
    if args.backend == Backend::Gpu && args.unfold == UnfoldArg::Authors {
        return Err(crate::Error::InvalidArgument(
            "--unfold authors needs --backend cpu: the GPU precompute kernel implements only the \
             correct unfolding"
                .into(),
        ));
    }
    let mesh = load_mesh(&args.mesh)?;
    let bpm_options = BpmOptions {
        fit: args.fit.into(),
        unfold: args.unfold.into(),
        ..Default::default()
    };
    let bpm = precompute(&mesh, bpm_options)?;
    let texture = resolve_texture(&mesh, args.texture.as_deref())?;
    let options = RenderOptions {
        width: args.size.0,
        height: args.size.1,
        view_dir: args.view,
        interp: args.interp.into(),
        ..Default::default()
    };
    let start = Instant::now();
    let (image, adapter, versus_cpu) = match args.backend {
        Backend::Cpu => (render_cpu(&mesh, &bpm, &texture, &options), None, None),
        Backend::Gpu => render_gpu(&mesh, &bpm, &texture, &options, args.compare)?,
    };
    let seconds = start.elapsed().as_secs_f64();
    save_png(&image, &args.output)?;
    let result = RenderResult {
        mesh: mesh.name.clone(),
        output: args.output.clone(),
        backend: format!("{:?}", args.backend).to_lowercase(),
        interp: options.interp,
        unfold: bpm.options.unfold,
        width: options.width,
        height: options.height,
        precompute: bpm.report.clone(),
        seconds,
        adapter,
        versus_cpu,
    };
    if args.json {
        return super::print_json(&result);
    }
    outln!(
        "wrote {} ({}×{}, {:?}, {} backend, {} s)",
        args.output.display(),
        options.width,
        options.height,
        options.interp,
        result.backend,
        sig(seconds, 3)
    );
    print_precompute_report(&bpm.report);
    if let Some(d) = &result.versus_cpu {
        outln!(
            "versus the CPU render: PSNR {} dB, {}% of pixels differ by more than 1/255, max {}",
            sig(d.psnr_db, 3),
            sig(100.0 * d.fraction_over_1_of_255, 2),
            d.max_abs
        );
    }
    Ok(())
}

#[cfg(feature = "gpu")]
type GpuRender = (
    crate::texture::Image<[u8; 4]>,
    Option<String>,
    Option<crate::raster::DiffStats>,
);

#[cfg(feature = "gpu")]
fn render_gpu(
    mesh: &crate::mesh::TriMesh,
    bpm: &crate::bpm::Bpm,
    texture: &crate::texture::Image<[u8; 4]>,
    options: &RenderOptions,
    compare: bool,
) -> Result<GpuRender> {
    let gpu = crate::bpm::gpu::context()?;
    let image = crate::bpm::gpu::render_gpu(&gpu, mesh, bpm.options.fit, texture, options)?;
    let diff = match compare {
        true => Some(crate::raster::image_diff(
            &image,
            &render_cpu(mesh, bpm, texture, options),
        )?),
        false => None,
    };
    Ok((image, Some(gpu.adapter_summary()), diff))
}

#[cfg(not(feature = "gpu"))]
fn render_gpu(
    _: &crate::mesh::TriMesh,
    _: &crate::bpm::Bpm,
    _: &crate::texture::Image<[u8; 4]>,
    _: &RenderOptions,
    _: bool,
) -> Result<(
    crate::texture::Image<[u8; 4]>,
    Option<String>,
    Option<crate::raster::DiffStats>,
)> {
    Err(crate::Error::Gpu(
        "this build has no GPU support (feature `gpu` is off)".into(),
    ))
}

pub fn print_precompute_report(r: &PrecomputeReport) {
    outln!(
        "{} faces; {} degenerate (linear fallback{}), {} mirrored; edges: {} boundary, {} UV seam, {} non-manifold, {} misoriented (all treated as boundary)",
        r.faces,
        r.degenerate_faces,
        if r.degenerate_examples.is_empty() { String::new() } else { format!(", e.g. faces {:?}", r.degenerate_examples) },
        r.mirrored_faces,
        r.boundary_edges,
        r.seam_edges,
        r.non_manifold_edges,
        r.misoriented_edges
    );
    outln!(
        "neighbours folded past 90° (laid out differently by --unfold authors): {}, of which past 135° (folded back over their face): {}",
        r.neighbours_folded_past_90, r.neighbours_folded_past_135
    );
}

#[derive(Serialize)]
struct QcResult {
    mesh: String,
    subdiv: u32,
    unfold: Unfold,
    precompute: PrecomputeReport,
    linear: QcStats,
    bpm: QcStats,
    seconds: f64,
}

fn qc(args: QcArgs) -> Result<()> {
    let mesh = load_mesh(&args.mesh)?;
    crate::bpm::quality::check_qc_size(&mesh.name, mesh.faces.len(), args.subdiv)?;
    let start = Instant::now();
    let bpm = precompute(
        &mesh,
        BpmOptions {
            fit: args.fit.into(),
            unfold: args.unfold.into(),
            ..Default::default()
        },
    )?;
    let linear = qc_protocol(&bpm, Interp::Linear, args.subdiv);
    let bpm_stats = qc_protocol(&bpm, Interp::Bpm, args.subdiv);
    for stats in [&linear, &bpm_stats] {
        check_measured(&mesh.name, &bpm.report, stats)?;
    }
    let result = QcResult {
        mesh: mesh.name.clone(),
        subdiv: args.subdiv,
        unfold: bpm.options.unfold,
        precompute: bpm.report.clone(),
        linear,
        bpm: bpm_stats,
        seconds: start.elapsed().as_secs_f64(),
    };
    if args.json {
        return super::print_json(&result);
    }
    print_precompute_report(&bpm.report);
    outln!(
        "QC = σmax/σmin over {} sub-triangles ({} subdivisions per face, {:?} unfolding), area-weighted:",
        result.bpm.sub_triangles, args.subdiv, result.unfold
    );
    outln!("{}", qc_table(&[&result.linear, &result.bpm]));
    outln!("({} s)", sig(result.seconds, 3));
    Ok(())
}

/// The QC figures exist: at least one sub-triangle has a finite QC. When every face is
/// degenerate (skipped) or every sub-triangle collapsed, the mean and the percentiles would be
/// NaN (`null` in `--json`) with exit 0; this is an error naming the mesh and a degenerate face.
fn check_measured(mesh: &str, report: &PrecomputeReport, stats: &QcStats) -> Result<()> {
    if stats.sub_triangles > stats.collapsed {
        return Ok(());
    }
    Err(crate::Error::DegenerateFace {
        mesh: mesh.to_string(),
        face: report.degenerate_examples.first().copied().unwrap_or(0),
        reason: format!(
            "no face can be measured ({} of {} faces degenerate, {} sub-triangles collapsed), \
             so the QC figures are undefined; give the mesh faces of non-zero area in 3D and UV",
            report.degenerate_faces, report.faces, stats.collapsed
        ),
    })
}

/// A plain-text table of QC statistics, one row per interpolant.
pub fn qc_table(rows: &[&QcStats]) -> String {
    let mut s = format!(
        "{:<8} {:>9} {:>9} {:>9} {:>9} {:>11} {:>8}\n",
        "interp", "mean", "p50", "p95", "p99", "max", "folded"
    );
    for q in rows {
        s += &format!(
            "{:<8} {:>9} {:>9} {:>9} {:>9} {:>11} {:>8}\n",
            format!("{:?}", q.interp).to_lowercase(),
            sig(q.mean, 4),
            sig(q.p50, 4),
            sig(q.p95, 4),
            sig(q.p99, 4),
            sig(q.max, 4),
            q.folded
        );
    }
    s
}
