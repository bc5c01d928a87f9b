//! `reparam skinsimp <model.glb> --target-ratio 0.1 [--max-weights 4] [--poses clip:all|N]
//! [--method full|mohr|rest] -o out.glb [--json]`: simplify a skinned glTF model with optimised
//! skin weights, write the result as a skinned GLB, print the error on training and held-out
//! poses. `--frames f0.obj f1.obj …` simplifies a frame sequence with shared connectivity
//! instead (writes `<out>_<k>.obj` per frame). `--compare` runs all three methods at equal
//! vertex counts. Next to the GLB it writes `<out stem>_poses.png` (original vs simplified in 4
//! poses, [`crate::skinsimp::picture::pose_strip`]); `--plot <png>` adds the held-out error
//! against vertex count of the three methods
//! ([`crate::skinsimp::picture::error_plot`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::mesh::{load_gltf, load_obj, write_obj, SkinnedMesh};
use crate::report::sig;
use crate::skinsimp::evaluate::{compare, pose_set_error, MethodQuality};
use crate::skinsimp::glb::{level_model, write_glb};
use crate::skinsimp::picture::{
    error_plot, level_counts, pose_strip, spread_poses, ErrorSeries, PlotAxes, PoseStripOptions,
};
use crate::skinsimp::poses::{frames_input, select_poses, skinned_input, PoseSelection, PoseSets};
use crate::skinsimp::{
    simplify, simplify_with_progress, Hierarchy, Input, Level, Method, Options, Schedule,
};
use crate::texture::save_png;
use crate::{Error, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
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
    /// Collapse order: greedy (always the cheapest valid edge; the paper's order) or passes
    /// (meshoptimizer-style: cost and sort every edge, collapse in order skipping edges next to
    /// a merge of the same pass, repeat; faster on large meshes, not the greedy order).
    #[arg(long, default_value = "greedy", value_parser = ["greedy", "passes"])]
    pub schedule: String,
    /// Also run the other two methods and report all three at equal vertex counts.
    #[arg(long)]
    pub compare: bool,
    /// Output GLB (or, with --frames, the prefix of the OBJ files). A glTF model's run also
    /// writes `<out stem>_poses.png` beside it: original (top) vs simplified (bottom) in 4 poses.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Also write a PNG plot of the held-out mean RMS against vertex count (log–log) for the
    /// three methods (rest red, mohr orange, full blue), each simplified to the target and cut
    /// at 8 vertex counts; the numbers are printed (and in the --json summary). glTF input only.
    #[arg(long, value_name = "PNG")]
    pub plot: Option<PathBuf>,
    /// Print a JSON summary instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Summary {
    input: String,
    output: String,
    method: String,
    /// The collapse order (`greedy` or `passes`).
    schedule: String,
    training_poses: usize,
    held_out_poses: usize,
    input_vertices: usize,
    input_faces: usize,
    results: Vec<MethodQuality>,
    /// Pictures written: the pose strip, and the error plot with --plot.
    pictures: Vec<String>,
    /// With --plot: the plotted points per method and the axes' ranges.
    #[serde(skip_serializing_if = "Option::is_none")]
    error_plot: Option<PlotSummary>,
    /// What the glTF loader repaired or ignored (renormalised weights, welded soups, …).
    loader_report: Vec<String>,
}

#[derive(Serialize)]
struct PlotSummary {
    axes: PlotAxes,
    series: Vec<ErrorSeries>,
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
        (None, false) if args.plot.is_some() => Err(Error::InvalidArgument(
            "--plot needs a skinned glTF model (not --frames)".into(),
        )),
        (None, false) => run_frames(&args, method),
        _ => Err(Error::InvalidArgument(
            "give either a glTF model or --frames f0.obj f1.obj …".into(),
        )),
    }
}

/// `--poses` as a [`PoseSelection`].
pub(super) fn parse_poses(text: &str) -> Result<PoseSelection> {
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
    options.schedule = match args.schedule.as_str() {
        "passes" => Schedule::Passes,
        _ => Schedule::Greedy,
    };
    options
}

/// [`simplify_with_progress`] behind a progress bar (hidden with `--json`); returns the
/// hierarchy and the seconds it took.
fn simplify_timed(input: &Input, options: &Options, json: bool) -> Result<(Hierarchy, f64)> {
    let bar = progress_bar(json);
    let start = Instant::now();
    let hierarchy = simplify_with_progress(input, options, &mut |done, wanted| {
        bar.set_length(wanted as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    Ok((hierarchy, start.elapsed().as_secs_f64()))
}

fn run_gltf(args: &SkinsimpArgs, path: &Path, method: Method) -> Result<()> {
    let model = load_gltf(path)?;
    let sets = select_poses(&model, &parse_poses(&args.poses)?)?;
    let input = skinned_input(&model, &sets.training)?;
    let options = options(args, method, model.mesh.positions.len());
    let (hierarchy, seconds) = simplify_timed(&input, &options, args.json)?;
    let level = hierarchy.level(hierarchy.records.len());
    write_glb(&args.out, &level_model(&model, &level))?;
    let mut pictures = vec![write_pose_strip(args, &model, &sets, &level)?];
    let error_plot = match &args.plot {
        Some(path) => {
            let plot = write_error_plot(&model, &sets, &options, hierarchy, path)?;
            pictures.push(path.display().to_string());
            Some(plot)
        }
        None => None,
    };
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
        schedule: args.schedule.clone(),
        training_poses: sets.training.len(),
        held_out_poses: sets.held_out.len(),
        input_vertices: model.mesh.positions.len(),
        input_faces: model.mesh.faces.len(),
        results,
        pictures,
        error_plot,
        loader_report: model
            .report
            .to_string()
            .lines()
            .map(str::to_string)
            .collect(),
    };
    print_summary(&summary, args.json, &model)
}

/// `<out stem>_poses.png` beside the output: the original and `level` in 4 poses spread over
/// the clips of the training poses.
fn write_pose_strip(
    args: &SkinsimpArgs,
    model: &SkinnedMesh,
    sets: &PoseSets,
    level: &Level,
) -> Result<String> {
    let mut clips: Vec<usize> = Vec::new();
    for p in sets.training.iter().chain(&sets.held_out) {
        if !clips.contains(&p.animation) {
            clips.push(p.animation);
        }
    }
    let poses = spread_poses(model, &clips, 4)?;
    let strip = pose_strip(model, level, &poses, &PoseStripOptions::default())?;
    let stem = args
        .out
        .file_stem()
        .map_or_else(|| "skinsimp".into(), |s| s.to_string_lossy().into_owned());
    let path = args.out.with_file_name(format!("{stem}_poses.png"));
    save_png(&strip, &path)?;
    Ok(path.display().to_string())
}

/// The three methods simplified to the same target (`hierarchy` is the chosen one's), cut at 8
/// counts from the input down to the coarsest count all reach, evaluated on the held-out poses
/// (the training poses when none is held out), plotted to `path`.
fn write_error_plot(
    model: &SkinnedMesh,
    sets: &PoseSets,
    options: &Options,
    hierarchy: Hierarchy,
    path: &Path,
) -> Result<PlotSummary> {
    let input = skinned_input(model, &sets.training)?;
    let mut chosen = Some(hierarchy);
    let mut hierarchies = Vec::new();
    for m in Method::ALL {
        if let Some(h) = chosen.take_if(|h| h.method == m) {
            hierarchies.push(h);
        } else {
            hierarchies.push(simplify(
                &input,
                &Options {
                    method: m,
                    ..*options
                },
            )?);
        }
    }
    let n = model.mesh.positions.len();
    let reached = hierarchies
        .iter()
        .map(|h| h.input_vertices() - h.records.len())
        .max()
        .unwrap_or(n);
    if reached >= n {
        return Err(Error::InvalidArgument(format!(
            "--plot: {}: some method made no collapse, nothing to plot",
            model.mesh.name
        )));
    }
    let counts = level_counts(n, reached, 8)?;
    let poses = if sets.held_out.is_empty() {
        &sets.training
    } else {
        &sets.held_out
    };
    let refs: Vec<&Hierarchy> = hierarchies.iter().collect();
    let plot = error_plot(model, &refs, poses, &counts, 640, 400)?;
    save_png(&plot.image, path)?;
    Ok(PlotSummary {
        axes: plot.axes,
        series: plot.series,
    })
}

fn print_summary(summary: &Summary, json: bool, model: &SkinnedMesh) -> Result<()> {
    if json {
        return super::print_json(summary);
    }
    out!("{}", model.report);
    outln!(
        "{}: {} vertices, {} faces; {} training and {} held-out poses; wrote {}",
        summary.input,
        summary.input_vertices,
        summary.input_faces,
        summary.training_poses,
        summary.held_out_poses,
        summary.output
    );
    outln!("{}", quality_table(&summary.results));
    if let Some(plot) = &summary.error_plot {
        let (header, rows) = crate::skinsimp::picture::table_of(&plot.series);
        outln!("error plot ({}):", plot.axes.caption());
        outln!("{}", super::text_table(&header, &rows));
    }
    outln!("pictures: {}", summary.pictures.join(", "));
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
    let (hierarchy, seconds) = simplify_timed(&input, &options, args.json)?;
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
    outln!(
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
