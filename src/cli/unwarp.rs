//! `reparam unwarp <height.png|exr> | --procedural NAME`: compute the per-texel offset map that
//! removes the texture stretch of displacement mapping, write it with its mip chain, the
//! pre-warped texture and the pictures, print the figures.

use std::path::PathBuf;
use std::time::Instant;

use crate::report::sig;
use crate::texture::{load_gray_f32, load_rgba8};
use crate::unwarp::height::PROCEDURAL;
use crate::unwarp::output::write_outputs;
use crate::unwarp::stats::{area_ratios, coefficient_of_variation, uniformity, Uniformity};
use crate::unwarp::{
    load_height_map, procedural, Border, Energy, HeightMap, Solution, UnwarpOptions,
};
use crate::{Error, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

#[derive(Args, Clone)]
pub struct UnwarpArgs {
    /// Height map: PNG (8- or 16-bit) or OpenEXR. Omit with --procedural.
    pub input: Option<PathBuf>,
    /// Colour texture to pre-warp and to render (default: a built-in UV grid).
    #[arg(long)]
    pub color: Option<PathBuf>,
    /// Built-in height map instead of a file.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(PROCEDURAL))]
    pub procedural: Option<String>,
    /// Size of the built-in map (texels per side).
    #[arg(long, default_value_t = 64)]
    pub size: usize,
    /// Displacement scale s in texture-width units.
    #[arg(long, default_value_t = 0.05)]
    pub scale: f64,
    /// Area exponent θ.
    #[arg(long, default_value_t = 5.0)]
    pub theta: f64,
    /// Height pinned fully.
    #[arg(long, default_value_t = 0.0)]
    pub h_fix: f64,
    /// Width of the pinned height band (≤ 0 disables height pinning).
    #[arg(long, default_value_t = 0.04)]
    pub delta: f64,
    /// Painted pin mask (grey PNG/EXR, 1 = pinned), the height map's size.
    #[arg(long)]
    pub pin: Option<PathBuf>,
    /// Border: periodic (tileable) or fixed (outer ring keeps offset 0).
    #[arg(long, default_value = "periodic", value_parser = ["periodic", "fixed"])]
    pub border: String,
    /// Sweeps (4 passes each) on the finest level; the most when --tolerance is given.
    #[arg(long, default_value_t = 60)]
    pub sweeps: usize,
    /// Stop a level when a sweep lowers the energy by less than this, relatively.
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Levels of coarse-to-fine (1 = single level).
    #[arg(long, default_value_t = 1)]
    pub levels: usize,
    /// Sweeps on each coarser level.
    #[arg(long, default_value_t = 30)]
    pub coarse_sweeps: usize,
    /// Scales of coarse moves after every sweep (r = 2, 4, …, 2^N; 0 = texel passes only, as
    /// in the paper). Run in f64 on the CPU, also with --gpu.
    #[arg(long, default_value_t = 0)]
    pub coarse_moves: usize,
    /// Run the passes on the GPU (f32 kernel `unwarp_pass`).
    #[arg(long)]
    pub gpu: bool,
    /// Output folder.
    #[arg(long, default_value = "out/unwarp")]
    pub out: PathBuf,
    /// Print machine-readable results.
    #[arg(long)]
    pub json: bool,
}

/// Everything `reparam unwarp --json` prints.
#[derive(Clone, Debug, Serialize)]
pub struct UnwarpSummary {
    pub input: String,
    pub width: usize,
    pub height: usize,
    pub backend: String,
    pub levels: Vec<[usize; 2]>,
    pub initial_energy: Energy,
    pub final_energy: Energy,
    pub initial_energy_ratio: f64,
    pub final_energy_ratio: f64,
    /// Energy ratio on the finest level before the first sweep and after every sweep (after
    /// its coarse moves, if any).
    pub energy_ratio_per_sweep: Vec<f64>,
    /// Texel passes and coarse passes on the finest level.
    pub fine_passes: usize,
    pub coarse_passes: usize,
    pub area_ratio_cv_before: f64,
    pub area_ratio_cv_after: f64,
    pub before: Uniformity,
    pub after: Uniformity,
    pub max_offset_texels: f64,
    pub seconds: f64,
    pub files: Vec<PathBuf>,
}

pub(super) fn options(args: &UnwarpArgs, heights: &HeightMap) -> Result<UnwarpOptions> {
    let mut options = UnwarpOptions {
        scale: args.scale,
        theta: args.theta,
        border: if args.border == "fixed" {
            Border::Fixed
        } else {
            Border::Periodic
        },
        sweeps: args.sweeps,
        tolerance: args.tolerance,
        levels: args.levels.max(1),
        coarse_sweeps: args.coarse_sweeps,
        coarse_moves: args.coarse_moves,
        ..Default::default()
    };
    options.fixation.h_fix = args.h_fix;
    options.fixation.delta = args.delta;
    if let Some(path) = &args.pin {
        let mask = load_gray_f32(path)?;
        if (mask.width, mask.height) != (heights.width, heights.height) {
            return Err(Error::HeightMapSize {
                map: path.display().to_string(),
                width: mask.width,
                height: mask.height,
                reason: format!(
                    "the pin mask must have the height map's size {}x{}",
                    heights.width, heights.height
                ),
            });
        }
        options.fixation.mask = Some(mask);
    }
    Ok(options)
}

pub(super) fn heights(args: &UnwarpArgs) -> Result<HeightMap> {
    match (&args.input, &args.procedural) {
        (Some(path), None) => load_height_map(path),
        (None, Some(name)) => procedural(name, args.size),
        _ => Err(Error::InvalidArgument(
            "give either a height map file or --procedural NAME".into(),
        )),
    }
}

/// Solve with the CPU reference or, with `gpu`, the f32 kernel.
fn run_solve(
    heights: &HeightMap,
    options: &UnwarpOptions,
    gpu: bool,
    progress: impl FnMut(&crate::unwarp::Progress),
) -> Result<(Solution, String)> {
    if gpu {
        #[cfg(feature = "gpu")]
        {
            let (solution, adapter) = crate::unwarp::gpu::solve_gpu(heights, options, progress)?;
            return Ok((solution, format!("gpu f32 ({adapter})")));
        }
        #[cfg(not(feature = "gpu"))]
        return Err(Error::Gpu(
            "reparam was built without the `gpu` feature".into(),
        ));
    }
    Ok((
        crate::unwarp::solve(heights, options, progress)?,
        "cpu f64".into(),
    ))
}

/// Solve, write the outputs, and return the summary; shared by the command and the demo.
pub fn unwarp(args: &UnwarpArgs, show_progress: bool) -> Result<UnwarpSummary> {
    let heights = heights(args)?;
    let options = options(args, &heights)?;
    let color = args.color.as_deref().map(load_rgba8).transpose()?;
    let bar = if show_progress {
        let total =
            (options.levels.saturating_sub(1) * options.coarse_sweeps + options.sweeps) as u64;
        let bar = ProgressBar::new(total);
        if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} sweeps {msg}") {
            bar.set_style(style);
        }
        bar
    } else {
        ProgressBar::hidden()
    };
    let start = Instant::now();
    let (solution, backend) = run_solve(&heights, &options, args.gpu, |p| {
        bar.inc(1);
        bar.set_message(format!(
            "level {} energy ratio {:.4}",
            p.level, p.energy_ratio
        ));
    })?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let files = write_outputs(&args.out, &solution, color.as_ref())?;
    Ok(summary(&heights, &solution, backend, seconds, files))
}

fn summary(
    heights: &HeightMap,
    solution: &Solution,
    backend: String,
    seconds: f64,
    files: Vec<PathBuf>,
) -> UnwarpSummary {
    let problem = &solution.problem;
    let theta = problem.theta;
    let zero = vec![[0.0; 2]; problem.mesh.node_count()];
    let (before, after) = (
        uniformity(problem, &zero),
        uniformity(problem, &solution.offsets),
    );
    let phases = problem.mesh.phase_count();
    UnwarpSummary {
        input: heights.name.clone(),
        width: heights.width,
        height: heights.height,
        backend,
        levels: solution
            .levels
            .iter()
            .map(|l| [l.width, l.height])
            .collect(),
        initial_energy: solution.initial,
        final_energy: solution.last,
        initial_energy_ratio: solution.initial.ratio(theta),
        final_energy_ratio: solution.last.ratio(theta),
        energy_ratio_per_sweep: solution
            .fine()
            .energy_per_sweep(phases)
            .iter()
            .map(|e| e.ratio(theta))
            .collect(),
        fine_passes: solution.fine().passes,
        coarse_passes: solution.fine().coarse_passes,
        area_ratio_cv_before: coefficient_of_variation(&area_ratios(problem, &zero)),
        area_ratio_cv_after: coefficient_of_variation(&area_ratios(problem, &solution.offsets)),
        before,
        after,
        max_offset_texels: after.max_offset_texels,
        seconds,
        files,
    }
}

/// The summary as (figure, value) rows.
pub fn summary_rows(s: &UnwarpSummary) -> Vec<Vec<String>> {
    let sweeps = s.energy_ratio_per_sweep.len().saturating_sub(1);
    vec![
        vec![
            "map".into(),
            format!("{} ({}x{})", s.input, s.width, s.height),
        ],
        vec!["backend".into(), s.backend.clone()],
        vec![
            "levels".into(),
            s.levels
                .iter()
                .map(|l| format!("{}x{}", l[0], l[1]))
                .collect::<Vec<_>>()
                .join(" → "),
        ],
        vec![
            "energy ratio before → after".into(),
            format!(
                "{} → {} ({sweeps} fine sweeps{})",
                sig(s.initial_energy_ratio, 4),
                sig(s.final_energy_ratio, 4),
                if s.coarse_passes > 0 {
                    format!(", {} coarse passes", s.coarse_passes)
                } else {
                    String::new()
                }
            ),
        ],
        vec![
            "area-ratio CV before → after".into(),
            format!(
                "{} → {}",
                sig(s.area_ratio_cv_before, 3),
                sig(s.area_ratio_cv_after, 3)
            ),
        ],
        vec![
            "max σ1/σ2 before → after".into(),
            format!(
                "{} → {}",
                sig(s.before.max_sigma_ratio, 3),
                sig(s.after.max_sigma_ratio, 3)
            ),
        ],
        vec!["max offset (texels)".into(), sig(s.max_offset_texels, 3)],
        vec!["time (s)".into(), sig(s.seconds, 3)],
    ]
}

pub fn run(args: UnwarpArgs) -> Result<()> {
    let summary = unwarp(&args, !args.json)?;
    if args.json {
        return super::print_json(&summary);
    }
    let header = ["figure".to_string(), "value".to_string()];
    outln!("{}", super::text_table(&header, &summary_rows(&summary)));
    for f in &summary.files {
        outln!("wrote {}", f.display());
    }
    Ok(())
}
