//! `reparam skinsimp <model.glb> --target-ratio 0.1 [--max-weights 4] [--poses clip:all|N]
//! [--method full|mohr|rest] -o out.glb [--json]`: simplify a skinned glTF model with optimised
//! skin weights, write the result as a skinned GLB, print the error on training and held-out
//! poses. `--frames f0.obj f1.obj …` simplifies a frame sequence with shared connectivity
//! instead (writes `<out>_<k>.obj` per frame). `--compare` runs all three methods at equal
//! vertex counts.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use reparam::mesh::{load_gltf, load_obj, write_obj, SkinnedMesh};
use reparam::report::sig;
use reparam::skinsimp::evaluate::{compare, pose_set_error, MethodQuality};
use reparam::skinsimp::glb::{level_model, write_glb};
use reparam::skinsimp::poses::{frames_input, select_poses, skinned_input, PoseSelection};
use reparam::skinsimp::{simplify_with_progress, Method, Options};
use reparam::{Error, Result};
use serde::Serialize;

#[derive(Args, Clone)]
pub struct SkinsimpArgs {
    /// Skinned glTF model (.glb / .gltf). Omit with --frames.
    pub input: Option<PathBuf>,
    /// OBJ frames with shared connectivity (no weights: pure per-pose quadrics).
    #[arg(long, num_args = 1..)]
    pub frames: Vec<PathBuf>,
    /// Fraction of the input vertices to keep.
    #[arg(long, default_value_t = 0.1)]
    pub target_ratio: f64,
    /// Most skin weights per vertex, W_max (≤ 4: one JOINTS/WEIGHTS set; up to 8).
    #[arg(long, default_value_t = 4)]
    pub max_weights: usize,
    /// Example poses: `clip:all` (every keyframe of every clip), `clip:NAME[,NAME…]`, or N
    /// (2N uniform times per clip). Even keys train, odd keys are held out.
    #[arg(long, default_value = "clip:all")]
    pub poses: String,
    /// Collapse cost: full (optimised weights), mohr (summed pose quadrics, endpoint weights),
    /// rest (rest-pose quadrics, endpoint weights).
    #[arg(long, default_value = "full", value_parser = ["full", "mohr", "rest"])]
    pub method: String,
    /// Also run the other two methods and report all three at equal vertex counts.
    #[arg(long)]
    pub compare: bool,
    /// Output GLB (or, with --frames, the prefix of the OBJ files).
    #[arg(short, long)]
    pub out: PathBuf,
    /// Print a JSON summary instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Summary {
    input: String,
    output: String,
    method: String,
    training_poses: usize,
    held_out_poses: usize,
    input_vertices: usize,
    input_faces: usize,
    results: Vec<MethodQuality>,
    /// What the glTF loader repaired or ignored (renormalised weights, welded soups, …).
    loader_report: Vec<String>,
}

pub fn run(args: SkinsimpArgs) -> Result<()> {
    if !(args.target_ratio > 0.0 && args.target_ratio <= 1.0) {
        return Err(Error::InvalidArgument(format!(
            "--target-ratio {} must be in (0, 1]",
            args.target_ratio
        )));
    }
    let method = match args.method.as_str() {
        "rest" => Method::Rest,
        "mohr" => Method::Mohr,
        _ => Method::Full,
    };
    match (&args.input, args.frames.is_empty()) {
        (Some(path), true) => run_gltf(&args, path, method),
        (None, false) => run_frames(&args, method),
        _ => Err(Error::InvalidArgument(
            "give either a glTF model or --frames f0.obj f1.obj …".into(),
        )),
    }
}

/// `--poses` as a [`PoseSelection`].
fn parse_poses(text: &str) -> Result<PoseSelection> {
    if text == "clip:all" {
        return Ok(PoseSelection::Keyframes(None));
    }
    if let Some(names) = text.strip_prefix("clip:") {
        return Ok(PoseSelection::Keyframes(Some(
            names.split(',').map(str::to_string).collect(),
        )));
    }
    text.parse::<usize>()
        .map(PoseSelection::Uniform)
        .map_err(|_| {
            Error::InvalidArgument(format!(
                "--poses {text:?}: expected clip:all, clip:NAME or a number"
            ))
        })
}

fn progress_bar(hidden: bool) -> ProgressBar {
    if hidden {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(0);
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} collapses {elapsed}") {
        bar.set_style(style);
    }
    bar
}

fn options(args: &SkinsimpArgs, method: Method, vertices: usize) -> Options {
    let mut options = Options {
        method,
        target_vertices: ((vertices as f64 * args.target_ratio).round() as usize).max(4),
        ..Options::default()
    };
    options.cost.max_weights = args.max_weights;
    options
}

fn run_gltf(args: &SkinsimpArgs, path: &Path, method: Method) -> Result<()> {
    let model = load_gltf(path)?;
    let sets = select_poses(&model, &parse_poses(&args.poses)?)?;
    let input = skinned_input(&model, &sets.training)?;
    let options = options(args, method, model.mesh.positions.len());
    let bar = progress_bar(args.json);
    let start = Instant::now();
    let hierarchy = simplify_with_progress(&input, &options, &mut |done, wanted| {
        bar.set_length(wanted as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let level = hierarchy.level(hierarchy.records.len());
    write_glb(&args.out, &level_model(&model, &level))?;
    let results = if args.compare {
        compare(&model, &sets, &Method::ALL, &options)?
    } else {
        vec![MethodQuality {
            method: method.name(),
            vertices: level.mesh.positions.len(),
            faces: level.mesh.faces.len(),
            training: pose_set_error(&model, &level, &sets.training)?,
            held_out: pose_set_error(&model, &level, &sets.held_out)?,
            seconds,
        }]
    };
    let summary = Summary {
        input: path.display().to_string(),
        output: args.out.display().to_string(),
        method: method.name().to_string(),
        training_poses: sets.training.len(),
        held_out_poses: sets.held_out.len(),
        input_vertices: model.mesh.positions.len(),
        input_faces: model.mesh.faces.len(),
        results,
        loader_report: model
            .report
            .to_string()
            .lines()
            .map(str::to_string)
            .collect(),
    };
    print_summary(&summary, args.json, &model)
}

fn print_summary(summary: &Summary, json: bool, model: &SkinnedMesh) -> Result<()> {
    if json {
        return super::print_json(summary);
    }
    print!("{}", model.report);
    println!(
        "{}: {} vertices, {} faces; {} training and {} held-out poses; wrote {}",
        summary.input,
        summary.input_vertices,
        summary.input_faces,
        summary.training_poses,
        summary.held_out_poses,
        summary.output
    );
    println!("{}", quality_table(&summary.results));
    Ok(())
}

/// The quality table: per method, vertex count, mean/max RMS and max Hausdorff on training and
/// held-out poses, seconds.
pub fn quality_table(results: &[MethodQuality]) -> String {
    let header: Vec<String> = [
        "method",
        "vertices",
        "faces",
        "train RMS mean",
        "train Hausdorff",
        "held-out RMS mean",
        "held-out RMS max",
        "held-out Hausdorff",
        "seconds",
    ]
    .map(String::from)
    .to_vec();
    let rows: Vec<Vec<String>> = results
        .iter()
        .map(|q| {
            vec![
                q.method.to_string(),
                q.vertices.to_string(),
                q.faces.to_string(),
                sig(q.training.rms_mean, 3),
                sig(q.training.hausdorff_max, 3),
                sig(q.held_out.rms_mean, 3),
                sig(q.held_out.rms_max, 3),
                sig(q.held_out.hausdorff_max, 3),
                sig(q.seconds, 3),
            ]
        })
        .collect();
    super::text_table(&header, &rows)
}

#[derive(Serialize)]
struct FramesSummary {
    frames: usize,
    input_vertices: usize,
    output_vertices: usize,
    output_faces: usize,
    seconds: f64,
    written: Vec<String>,
}

fn run_frames(args: &SkinsimpArgs, method: Method) -> Result<()> {
    let meshes = args
        .frames
        .iter()
        .map(|p| load_obj(p))
        .collect::<Result<Vec<_>>>()?;
    let input = frames_input(&meshes)?;
    let options = options(args, method, meshes[0].positions.len());
    let bar = progress_bar(args.json);
    let start = Instant::now();
    let hierarchy = simplify_with_progress(&input, &options, &mut |done, wanted| {
        bar.set_length(wanted as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let level = hierarchy.level(hierarchy.records.len());
    let mut written = Vec::new();
    for (k, frame) in level.frames.iter().enumerate() {
        let mut mesh = level.mesh.clone();
        mesh.positions = frame.clone();
        let path = PathBuf::from(format!("{}_{k}.obj", args.out.display()));
        write_obj(&mesh, &path)?;
        written.push(path.display().to_string());
    }
    let summary = FramesSummary {
        frames: meshes.len(),
        input_vertices: meshes[0].positions.len(),
        output_vertices: level.mesh.positions.len(),
        output_faces: level.mesh.faces.len(),
        seconds,
        written,
    };
    if args.json {
        return super::print_json(&summary);
    }
    println!(
        "{} frames: {} → {} vertices ({} faces) in {} s; wrote {}",
        summary.frames,
        summary.input_vertices,
        summary.output_vertices,
        summary.output_faces,
        sig(seconds, 3),
        summary.written.join(", ")
    );
    Ok(())
}
