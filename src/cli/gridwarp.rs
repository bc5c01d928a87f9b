//! `reparam gridwarp --scene <bump|saddle|worm|plane>`: solve a built-in scene frame by frame,
//! write pictures, the grid lines of every frame (JSON) and the statistics.

use std::path::{Path, PathBuf};

use clap::Args;
use nalgebra::Vector3;
use reparam::gridwarp::merit::{rigid_stretch, RigidStretch};
use reparam::gridwarp::picture::{
    atlas_texture, detail_texture, grid_overlay, remap_mesh_uvs, render_textured, surface_mesh,
};
use reparam::gridwarp::rasterize::{frames_fields, rigidity_from_image, Roi};
use reparam::gridwarp::scene::{analytic_scene, AnalyticScene, SCENES};
use reparam::gridwarp::{grid_from_rigidity, solve_sequence, Grid, SolveOptions};
use reparam::gridwarp::{DeformedFields, Field, RestFields};
use reparam::lm::{LmOptions, StopCode};
use reparam::mesh::{load_gltf, load_obj, TriMesh};
use reparam::report::sig;
use reparam::texture::{save_png, side_by_side};
use reparam::{Error, Result};
use serde::Serialize;

#[derive(Args, Clone)]
pub struct GridwarpArgs {
    /// Built-in scene (ignored with --gltf or --obj).
    #[arg(long, default_value = "bump", value_parser = clap::builder::PossibleValuesParser::new(SCENES))]
    pub scene: String,
    /// A skinned glTF/GLB: the rest pose and `--frames` poses of `--animation` at uniform times.
    #[arg(long)]
    pub gltf: Option<PathBuf>,
    /// Animation of --gltf (default: the first).
    #[arg(long)]
    pub animation: Option<String>,
    /// OBJ frames with the same connectivity and UVs; the first is the rest pose.
    #[arg(long, num_args = 2..)]
    pub obj: Vec<PathBuf>,
    /// Texture-space region of interest u0,u1,v0,v1 (with --gltf / --obj).
    #[arg(long, default_value = "0,1,0,1")]
    pub roi: String,
    /// Rigidity map (PNG 8/16-bit or EXR, values in [0, 1]) over the ROI; default: R ≡ 1.
    #[arg(long)]
    pub rigidity: Option<PathBuf>,
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
    parse_grid_spec(spec)
}

/// `MxN` → a uniform grid of M × N lines.
fn parse_grid_spec(spec: &str) -> Result<Grid> {
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

/// Solve the scene (or the mesh input) and write its pictures; shared by the command and the demo.
pub fn solve_scene(args: &GridwarpArgs) -> Result<GridwarpResult> {
    if args.gltf.is_some() || !args.obj.is_empty() {
        return solve_meshes(args);
    }
    let scene = analytic_scene(&args.scene, args.frames)
        .ok_or_else(|| Error::InvalidArgument(format!("unknown scene '{}'", args.scene)))?;
    if args.size < 2 || args.samples == 0 {
        return Err(Error::InvalidArgument(
            "--size must be ≥ 2 and --samples ≥ 1".into(),
        ));
    }
    let fields = scene.fields(args.size);
    let rest_grid = parse_grid(&args.grid, &scene, args.epsilon)?;
    let (frames, grids) = solve_and_measure(args, &fields.rest, &rest_grid, &fields.frames)?;
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

/// Solve every frame (warm-started) and measure it: per-frame statistics and grids.
fn solve_and_measure(
    args: &GridwarpArgs,
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &[DeformedFields],
) -> Result<(Vec<FrameStats>, Vec<Grid>)> {
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
    let solutions = solve_sequence(rest, rest_grid, deformed, &options)?;
    let frames = solutions
        .iter()
        .zip(deformed)
        .enumerate()
        .map(|(k, (s, deformed))| FrameStats {
            frame: k,
            rigid_stretch_before: rigid_stretch(rest, deformed, rest_grid, rest_grid, 256),
            rigid_stretch_after: rigid_stretch(rest, deformed, rest_grid, &s.grid, 256),
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
    Ok((frames, grids))
}

fn parse_roi(spec: &str) -> Result<Roi> {
    let bad = || Error::InvalidArgument(format!("--roi must be u0,u1,v0,v1, got '{spec}'"));
    let v: Vec<f64> = spec
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| bad())?;
    match v[..] {
        [u0, u1, v0, v1] => Roi::new(u0, u1, v0, v1),
        _ => Err(bad()),
    }
}

/// The rest mesh and the deformed frames from --gltf (poses at uniform times) or --obj.
fn load_frames(args: &GridwarpArgs) -> Result<(TriMesh, Vec<TriMesh>, String)> {
    if let Some(path) = &args.gltf {
        let skinned = load_gltf(path)?;
        let animation = match &args.animation {
            Some(name) => skinned.animation_index(name).ok_or_else(|| {
                Error::InvalidArgument(format!(
                    "{}: no animation '{name}' (has: {})",
                    path.display(),
                    skinned.animation_names().join(", ")
                ))
            })?,
            None if skinned.animations.is_empty() => {
                return Err(Error::InvalidArgument(format!(
                    "{}: the file has no animation",
                    path.display()
                )))
            }
            None => 0,
        };
        let duration = skinned.duration(animation)?;
        let count = args.frames.max(1);
        let frames = (0..count)
            .map(|k| skinned.posed_mesh(animation, duration * k as f64 / count as f64))
            .collect::<Result<Vec<_>>>()?;
        let stem = path
            .file_stem()
            .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
        return Ok((skinned.mesh, frames, stem));
    }
    let meshes = args
        .obj
        .iter()
        .map(|p| load_obj(p))
        .collect::<Result<Vec<_>>>()?;
    let stem = args.obj[0]
        .file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
    Ok((meshes[0].clone(), meshes[1..].to_vec(), stem))
}

/// gridwarp on real meshes: fields rasterised over the ROI in texture space, then as for scenes.
fn solve_meshes(args: &GridwarpArgs) -> Result<GridwarpResult> {
    let roi = parse_roi(&args.roi)?;
    let (rest_mesh, frame_meshes, stem) = load_frames(args)?;
    let size = (args.size, args.size);
    let fields = frames_fields(&rest_mesh, &frame_meshes, &roi, size)?;
    let rigidity = match &args.rigidity {
        Some(path) => rigidity_from_image(path, None, size)?,
        None => Field::constant(1.0),
    };
    let rest = fields.rest_fields(rigidity.clone());
    let rest_grid = match args.grid.as_str() {
        "auto" => grid_from_rigidity(&rigidity, args.epsilon),
        spec => parse_grid_spec(spec)?,
    };
    let (frames, grids) = solve_and_measure(args, &rest, &rest_grid, &fields.frames)?;
    let warped = grids.last().unwrap_or(&rest_grid);
    let overlay = args.out.join(format!("gridwarp_{stem}_grid.png"));
    save_png(
        &grid_overlay(&detail_texture(&rigidity, 512), &rest_grid, warped),
        &overlay,
    )?;
    let texture = atlas_texture(&roi, &rigidity, 1024);
    let last = frame_meshes.last().unwrap_or(&rest_mesh);
    let view = Vector3::new(-1.0, 0.3, 0.2);
    let original = render_textured(last, &texture, view, 480);
    let remapped = render_textured(
        &remap_mesh_uvs(last, &roi, &rest_grid, warped),
        &texture,
        view,
        480,
    );
    let render = args.out.join(format!("gridwarp_{stem}_render.png"));
    save_png(&side_by_side(&[&original, &remapped], 8), &render)?;
    Ok(GridwarpResult {
        scene: stem,
        unknowns: rest_grid.unknowns(),
        rest_grid,
        frames,
        grids,
        pictures: vec![overlay, render],
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
    let lines = args
        .out
        .join(format!("gridwarp_{}_lines.json", result.scene));
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
    let header: Vec<String> = FRAME_HEADER.iter().map(|h| h.to_string()).collect();
    super::text_table(&header, &frame_rows(frames))
}
