//! `reparam gridwarp --scene <bump|saddle|worm|plane>`: solve a built-in scene frame by frame,
//! write pictures, the grid lines of every frame (JSON) and the statistics.

use std::path::{Path, PathBuf};

use clap::Args;
use nalgebra::Vector3;
use reparam::gridwarp::merit::{rigid_stretch, RigidStretch};
use reparam::gridwarp::picture::{detail_texture, grid_overlay, render_textured, surface_mesh};
use reparam::gridwarp::scene::{analytic_scene, AnalyticScene, SCENES};
use reparam::gridwarp::{grid_from_rigidity, solve_sequence, Grid, SolveOptions};
use reparam::lm::{LmOptions, StopCode};
use reparam::report::sig;
use reparam::texture::{save_png, side_by_side};
use reparam::{Error, Result};
use serde::Serialize;

#[derive(Args, Clone)]
pub struct GridwarpArgs {
    /// Built-in scene.
    #[arg(long, default_value = "bump", value_parser = clap::builder::PossibleValuesParser::new(SCENES))]
    pub scene: String,
    /// Number of frames (the deformation grows to its full amount over them).
    #[arg(long, default_value_t = 6)]
    pub frames: usize,
    /// Field resolution (texels per side of the ROI).
    #[arg(long, default_value_t = 128)]
    pub size: usize,
    /// Starting grid: `auto` (Algorithm 1 from the rigidity map) or `MxN` uniform lines.
    #[arg(long, default_value = "auto")]
    pub grid: String,
    /// Threshold ε of Algorithm 1.
    #[arg(long, default_value_t = 0.5)]
    pub epsilon: f64,
    /// Midpoint samples per cell and axis (K = L).
    #[arg(long, default_value_t = 8)]
    pub samples: usize,
    /// Maximum line movement between frames (smoothness bound o).
    #[arg(long)]
    pub smoothness: Option<f64>,
    /// The paper's LM settings (all tolerances 0, 100 iterations) instead of the practical ones.
    #[arg(long)]
    pub paper: bool,
    /// Output folder.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Print machine-readable results.
    #[arg(long)]
    pub json: bool,
}

/// Per-frame figures.
#[derive(Clone, Debug, Serialize)]
pub struct FrameStats {
    pub frame: usize,
    pub rigid_stretch_before: RigidStretch,
    pub rigid_stretch_after: RigidStretch,
    pub energy_before: f64,
    pub energy_after: f64,
    pub seconds: f64,
    pub iterations: usize,
    pub energy_evaluations: usize,
    pub jacobian_evaluations: usize,
    pub stop: StopCode,
}

/// Everything `reparam gridwarp --json` prints.
#[derive(Clone, Debug, Serialize)]
pub struct GridwarpResult {
    pub scene: String,
    pub unknowns: usize,
    pub rest_grid: Grid,
    pub frames: Vec<FrameStats>,
    pub grids: Vec<Grid>,
    pub pictures: Vec<PathBuf>,
}

fn parse_grid(spec: &str, scene: &AnalyticScene, epsilon: f64) -> Result<Grid> {
    if spec == "auto" {
        return Ok(grid_from_rigidity(&scene.rigidity, epsilon));
    }
    let bad = || {
        Error::InvalidArgument(format!(
            "--grid must be `auto` or MxN with M, N ≥ 2, got '{spec}'"
        ))
    };
    let (m, n) = spec.split_once('x').ok_or_else(bad)?;
    let (m, n): (usize, usize) = (m.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
    if m < 2 || n < 2 {
        return Err(bad());
    }
    Ok(Grid::uniform(m, n))
}

/// Solve the scene and write its pictures; shared by the command and the demo.
pub fn solve_scene(args: &GridwarpArgs) -> Result<GridwarpResult> {
    let scene = analytic_scene(&args.scene, args.frames)
        .ok_or_else(|| Error::InvalidArgument(format!("unknown scene '{}'", args.scene)))?;
    if args.size < 2 || args.samples == 0 {
        return Err(Error::InvalidArgument(
            "--size must be ≥ 2 and --samples ≥ 1".into(),
        ));
    }
    let fields = scene.fields(args.size);
    let rest_grid = parse_grid(&args.grid, &scene, args.epsilon)?;
    let options = SolveOptions {
        samples: (args.samples, args.samples),
        lm: if args.paper {
            LmOptions::paper()
        } else {
            LmOptions::default()
        },
        smoothness: args.smoothness,
        looping: false,
    };
    let solutions = solve_sequence(&fields.rest, &rest_grid, &fields.frames, &options)?;
    let frames = solutions
        .iter()
        .zip(&fields.frames)
        .enumerate()
        .map(|(k, (s, deformed))| FrameStats {
            frame: k,
            rigid_stretch_before: rigid_stretch(
                &fields.rest,
                deformed,
                &rest_grid,
                &rest_grid,
                256,
            ),
            rigid_stretch_after: rigid_stretch(&fields.rest, deformed, &rest_grid, &s.grid, 256),
            energy_before: s.rest_energy,
            energy_after: s.lm.energy,
            seconds: s.seconds,
            iterations: s.lm.iterations,
            energy_evaluations: s.lm.energy_evaluations,
            jacobian_evaluations: s.lm.jacobian_evaluations,
            stop: s.lm.stop,
        })
        .collect();
    let grids: Vec<Grid> = solutions.iter().map(|s| s.grid.clone()).collect();
    let pictures = write_pictures(
        &args.out,
        &scene,
        &rest_grid,
        grids.last().unwrap_or(&rest_grid),
    )?;
    Ok(GridwarpResult {
        scene: args.scene.clone(),
        unknowns: rest_grid.unknowns(),
        rest_grid,
        frames,
        grids,
        pictures,
    })
}

/// The texture with both grids, and the last frame rendered with the original | warped UVs.
fn write_pictures(
    out: &Path,
    scene: &AnalyticScene,
    rest: &Grid,
    warped: &Grid,
) -> Result<Vec<PathBuf>> {
    let texture = detail_texture(&scene.rigidity, 512);
    let overlay = out.join(format!("gridwarp_{}_grid.png", scene.name));
    save_png(&grid_overlay(&texture, rest, warped), &overlay)?;
    let surface = scene.frames.last().map_or(&scene.rest, |f| f);
    let view = match scene.name {
        "worm" => Vector3::new(0.2, -0.3, 1.0),
        _ => Vector3::new(0.25, -0.6, 1.0),
    };
    let original = render_textured(&surface_mesh(&**surface, 160, None), &texture, view, 480);
    let remapped = render_textured(
        &surface_mesh(&**surface, 160, Some((rest, warped))),
        &texture,
        view,
        480,
    );
    let render = out.join(format!("gridwarp_{}_render.png", scene.name));
    save_png(&side_by_side(&[&original, &remapped], 8), &render)?;
    Ok(vec![overlay, render])
}

pub fn run(args: GridwarpArgs) -> Result<()> {
    let result = solve_scene(&args)?;
    let lines = args.out.join(format!("gridwarp_{}_lines.json", args.scene));
    let text = serde_json::to_string_pretty(&result.grids)
        .map_err(|e| Error::InvalidArgument(e.to_string()))?;
    std::fs::write(&lines, text).map_err(|e| Error::io(&lines, e))?;
    if args.json {
        return super::print_json(&result);
    }
    println!(
        "scene {}: {} unknowns (rest grid {}×{} lines), {} frames",
        result.scene,
        result.unknowns,
        result.rest_grid.s.len(),
        result.rest_grid.t.len(),
        result.frames.len()
    );
    println!("{}", frame_table(&result.frames));
    for p in result.pictures.iter().chain([&lines]) {
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// One row per frame: rigid stretch before → after, energy, time, iterations, evaluations, stop.
pub fn frame_rows(frames: &[FrameStats]) -> Vec<Vec<String>> {
    frames
        .iter()
        .map(|f| {
            vec![
                f.frame.to_string(),
                format!(
                    "{} → {}",
                    sig(f.rigid_stretch_before.mean, 3),
                    sig(f.rigid_stretch_after.mean, 3)
                ),
                format!(
                    "{} → {}",
                    sig(f.rigid_stretch_before.max, 3),
                    sig(f.rigid_stretch_after.max, 3)
                ),
                format!("{} → {}", sig(f.energy_before, 3), sig(f.energy_after, 3)),
                sig(f.seconds * 1e3, 3),
                f.iterations.to_string(),
                format!("{} + {}", f.energy_evaluations, f.jacobian_evaluations),
                format!("{}", f.stop.code()),
            ]
        })
        .collect()
}

/// Column names of [`frame_rows`].
pub const FRAME_HEADER: [&str; 8] = [
    "frame",
    "rigid stretch mean",
    "rigid stretch max",
    "energy",
    "ms",
    "iterations",
    "evaluations (E + J)",
    "stop",
];

fn frame_table(frames: &[FrameStats]) -> String {
    let rows = frame_rows(frames);
    let widths: Vec<usize> = (0..FRAME_HEADER.len())
        .map(|c| {
            rows.iter()
                .map(|r| r[c].chars().count())
                .chain([FRAME_HEADER[c].len()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |cells: Vec<String>| {
        cells
            .iter()
            .zip(&widths)
            .map(|(c, w)| format!("{c:>w$}"))
            .collect::<Vec<_>>()
            .join("  ")
    };
    let mut s = line(FRAME_HEADER.iter().map(|h| h.to_string()).collect());
    for r in rows {
        s += "\n";
        s += &line(r);
    }
    s
}
