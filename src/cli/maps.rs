//! `reparam maps`: build the MAPS hierarchy of a mesh (OBJ, PLY, OFF or built-in), optionally
//! remesh it, write the base domain, remeshes and pictures, print a summary (or `--json`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::maps::distortion::{distortion, Distortion};
use crate::maps::distortion::{map_distortion, DistortionStats};
use crate::maps::equalise::{
    equalise, uniform_equalised, uniform_equalised_relaxed, EqualiseOptions, EqualiseReport,
    Equalised, Stage,
};
use crate::maps::quality::{AngleStats, WrongFacing};
use crate::maps::relax::{uniform_relaxed, RelaxOptions, RelaxStats};
use crate::maps::remesh::{adaptive, uniform, AdaptiveOptions, Remesh};
use crate::maps::smooth::{uniform_smoothed_with, SmoothOptions, SmoothStats};
use crate::maps::{
    build_with_progress, detect_features, load_features, picture, FeatureOptions, Features,
    HierarchyStop, LevelReport, Maps, MapsOptions, RejectCounts, StopReason, Timings,
};
use crate::mesh::{write_obj, TriMesh};
use crate::report::sig;
use crate::texture::{save_png, side_by_side};
use crate::{Error, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use super::inputs::builtin_mesh;

#[derive(Args, Clone, Debug)]
pub struct MapsArgs {
    /// The mesh: an .obj, .ply or .off file, or `procedural:<name>` (e.g. procedural:torus;
    /// also the hard models genus2, genus3, horned, pedestal, and the unevenly sampled
    /// genus2_uneven, head_uneven, skull_uneven, genus2_uneven9, genus2_uneven_100k).
    pub mesh: String,
    /// Stop when the base domain has at most this many triangles (0: as coarse as possible).
    #[arg(long, default_value_t = 0)]
    pub base_size: usize,
    /// λ of the priority w(λ, i) = λ a/max a + (1 − λ) κ/max κ.
    #[arg(long, default_value_t = 0.5)]
    pub lambda: f64,
    /// Beyond the paper: normalise the priority's terms by this quantile over the candidates
    /// instead of their maximum (1: the paper's maximum).
    #[arg(long, default_value_t = 1.0)]
    pub priority_quantile: f64,
    /// Beyond the paper: visit each level's candidates in a pseudo-random order from this seed
    /// instead of the priority (the order public ports use).
    #[arg(long)]
    pub shuffle_seed: Option<u64>,
    /// Beyond the paper: the priority's second term is the collapse error (how far the input
    /// points a removal re-stores lie from its ring's plane) instead of the curvature.
    #[arg(long)]
    pub priority_error: bool,
    /// The paper's removal order at every level: no shape rule on the coarse levels (by
    /// default, beyond the paper, the levels near the base size remove first the vertices whose
    /// retriangulated star keeps the re-stored input points closest, `maps::shape`).
    #[arg(long)]
    pub paper_removal: bool,
    /// The shape rule's deferral: a selected vertex whose shape error is above this quantile of
    /// the level's candidates' waits for a later level (1: the order alone).
    #[arg(long, default_value_t = crate::maps::shape::ShapeRule::default().quantile)]
    pub shape_quantile: f64,
    /// The shape rule orders the levels that start with at most this many times `--base-size`
    /// faces.
    #[arg(long, default_value_t = crate::maps::shape::ShapeRule::default().coarse_factor)]
    pub shape_levels: f64,
    /// How a removed vertex's ring is flattened: the paper's conformal z^a (|μ| = r^a), or,
    /// beyond the paper, the polar map that keeps the radii (|μ| = r, angles scaled by a).
    #[arg(long, value_enum, default_value_t = FlatteningArg::Conformal)]
    pub flattening: FlatteningArg,
    /// Vertices of higher degree are not removed.
    #[arg(long, default_value_t = 12)]
    pub max_degree: usize,
    /// Beyond the paper: when neither the CDT nor a fan of a hole passes the checks, try the
    /// best valid triangulation of the flattened hole (dynamic programming) before rejecting.
    #[arg(long)]
    pub best_triangulation: bool,
    /// The paper's stopping rule: stop at the first level that removes nothing, even before
    /// the base size is reached (by default the candidates next to the rejected vertices get
    /// another level).
    #[arg(long)]
    pub no_retry_rejected: bool,
    /// Features: `auto` (detect by dihedral angle and curvature) or a sidecar file with lines
    /// `v I` (corner vertex, 0-based) and `e I J` (feature edge). None by default.
    #[arg(long)]
    pub features: Option<String>,
    /// Corner vertices to keep, as a list of 0-based indices: `3,17,42` (added to --features).
    #[arg(long, value_name = "I,J,…")]
    pub feature_vertices: Option<String>,
    /// Feature edges, as a list of 0-based index pairs: `3-17,17-42` (added to --features).
    #[arg(long, value_name = "I-J,…")]
    pub feature_edges: Option<String>,
    /// Also make the Loop-smoothed version of every `uniform:J` remesh (parameters smoothed in
    /// the parameter domain, same connectivity), with its own OBJ and Hausdorff distance.
    #[arg(long)]
    pub smooth: bool,
    /// Also make, for every `uniform:J`, the remesh whose parameters are relaxed by N sweeps
    /// towards the surface's area (`maps::relax`, beyond the paper; same connectivity).
    /// `--relax` alone: 15 sweeps (`RelaxOptions::default`).
    #[arg(long, value_name = "N", num_args = 0..=1, default_missing_value = RELAX_SWEEPS)]
    pub relax: Option<usize>,
    /// Also make, for every `uniform:J`, the remesh of Π' = Φ ∘ Π: Φ maps each base face onto
    /// itself, piecewise linearly on a lattice of 4^K triangles per face, minimising Sander et
    /// al.'s L² stretch plus 5× the Dirichlet energy over the whole base domain
    /// (`maps::equalise`, beyond the paper; same connectivity). `--equalise` alone: K = 5.
    /// With `--relax`, Π''s remesh is relaxed too.
    #[arg(long, value_name = "K", num_args = 0..=1, default_missing_value = EQUALISE_DEPTH)]
    pub equalise: Option<u32>,
    /// With `--equalise`: K_E, the depth of the edge-flap stage Φ_E solved after Φ
    /// (`maps::flaps`, beyond the paper), Π' = Φ_E ∘ Φ ∘ Π for one round: each base edge's two
    /// half-faces,
    /// unfolded, mapped onto themselves with the lattice points on the edge free, so that area
    /// moves across base edges; 4^K_E lattice triangles per third of a face. 0: no edge stage.
    #[arg(long, value_name = "K_E", default_value = EDGE_FLAPS_DEPTH)]
    pub edge_flaps: u32,
    /// With `--equalise` and an edge stage: solve the per-face stage once more after it, on the map
    /// the two leave (Π' = Φ₂ ∘ Φ_E ∘ Φ ∘ Π).
    #[arg(long)]
    pub refine_faces: bool,
    /// With `--equalise` and an edge stage: how many edge stages, each after a per-face stage
    /// (2, the default: Π' = Φ_E ∘ Φ ∘ Φ_E ∘ Φ ∘ Π), so that area travels further than one
    /// flap.
    #[arg(long, value_name = "N", default_value_t = crate::maps::equalise::DEFAULT_EDGE_ROUNDS, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub edge_rounds: u32,
    /// Remeshes to make: `uniform:J` (quadrisect J times) or `adaptive:EPS` (EPS relative to
    /// the longest bounding-box side). May be repeated.
    #[arg(long)]
    pub remesh: Vec<String>,
    /// Output folder for the base domain, remeshes (OBJ) and pictures.
    #[arg(long, default_value = "out/maps")]
    pub out: PathBuf,
    /// Picture size in pixels (0: no pictures).
    #[arg(long, default_value_t = 512)]
    pub picture_size: usize,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `--relax` without a value: [`crate::maps::relax::DEFAULT_SWEEPS`] (a test checks they agree).
pub const RELAX_SWEEPS: &str = "15";

/// `--equalise` without a value: [`crate::maps::equalise::DEFAULT_DEPTH`] (a test checks they
/// agree).
pub const EQUALISE_DEPTH: &str = "5";

/// `--edge-flaps` by default: [`crate::maps::flaps::DEFAULT_DEPTH`] (a test checks they agree).
pub const EDGE_FLAPS_DEPTH: &str = "4";

/// One requested remesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RemeshSpec {
    Uniform(u32),
    Adaptive(f64),
}

/// Parse `uniform:J` or `adaptive:EPS`.
pub fn parse_remesh(s: &str) -> Result<RemeshSpec> {
    let bad =
        || Error::InvalidArgument(format!("--remesh {s}: expected uniform:J or adaptive:EPS"));
    match s.split_once(':') {
        Some(("uniform", j)) => j.parse().map(RemeshSpec::Uniform).map_err(|_| bad()),
        Some(("adaptive", e)) => e.parse().map(RemeshSpec::Adaptive).map_err(|_| bad()),
        _ => Err(bad()),
    }
}

/// `--flattening`: [`crate::maps::flatten::Flattening`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FlatteningArg {
    /// The paper's z^a.
    Conformal,
    /// |μ| = r, the angles scaled by a (beyond the paper).
    Polar,
}

/// Summary of one remesh.
#[derive(Clone, Debug, Serialize)]
pub struct RemeshSummary {
    pub kind: String,
    pub faces: usize,
    pub vertices: usize,
    /// Sampled Hausdorff distance remesh → input and input → remesh, and their max relative to
    /// the bounding-box diagonal.
    pub hausdorff_remesh_to_input: f64,
    pub hausdorff_input_to_remesh: f64,
    pub hausdorff_relative: f64,
    /// Area-weighted mean distance, the larger of the two directions, relative to the
    /// bounding-box diagonal.
    pub mean_distance_relative: f64,
    /// Fraction of the remesh's area whose normal opposes the nearest input triangle's.
    pub wrong_facing_area: f64,
    /// The faces that carry it: their count, the largest of their smallest angles, and their
    /// largest distance from the input relative to the diagonal.
    pub wrong_facing: WrongFacing,
    /// The remesh's smallest angles (degrees): min, mean, fraction under 10°, histogram by 10°.
    pub smallest_angles: AngleStats,
    /// p95 of |log(A_f / Ā)| over the remesh's faces: how unevenly it spends its triangles
    /// (compare `distortion.input_area_spread`).
    pub area_spread: f64,
    /// Whether it meets issue #23's targets (Hausdorff ≤ 1.5%, mean ≤ 0.1% of the diagonal,
    /// no wrong-facing area: `RemeshQuality::faithful`).
    pub faithful: bool,
    /// Wall-clock seconds of the remesh, and the part of them spent on the distance figures
    /// (Hausdorff, mean distance, wrong-facing area; one BVH per side).
    pub seconds: f64,
    pub hausdorff_seconds: f64,
    pub file: String,
    /// For a smoothed remesh: its stencil counts.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub smoothing: Option<SmoothStats>,
    /// For a relaxed remesh: its sweep counts.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relaxation: Option<RelaxStats>,
}

/// One stage of Π' after the first per-face one: `edges` (Φ_E) or `faces`, and its solve.
#[derive(Clone, Debug, Serialize)]
pub struct StageSummary {
    pub stage: &'static str,
    pub solve: EqualiseReport,
}

/// What `--equalise` did: the solve of the first per-face stage Φ ([`EqualiseReport`]), those
/// of the later stages, and the distortion of Π' = … Φ_E ∘ Φ ∘ Π, measured as
/// `distortion.final_map` is for Π.
#[derive(Clone, Debug, Serialize)]
pub struct EqualisedSummary {
    pub solve: EqualiseReport,
    /// The stages after Φ, in the order they apply (none with `--edge-flaps 0`).
    pub later: Vec<StageSummary>,
    pub distortion: DistortionStats,
    /// Wall-clock seconds of the solve (lattice and L-BFGS).
    pub seconds: f64,
}

/// The `--json` summary.
#[derive(Clone, Debug, Serialize)]
pub struct MapsSummary {
    pub mesh: String,
    pub input_faces: usize,
    pub input_vertices: usize,
    pub levels: usize,
    pub base_faces: usize,
    pub base_vertices: usize,
    pub feature_corners: usize,
    pub feature_edges: usize,
    pub rejected: RejectCounts,
    /// `--base-size` (0: as coarse as possible).
    pub base_size_asked: usize,
    /// Whether the base domain has at most `base_size_asked` faces (true when 0 was asked).
    pub base_size_reached: bool,
    /// Why the hierarchy stopped, and the state of the base domain's vertices.
    pub stop: HierarchyStop,
    pub per_level: Vec<LevelReport>,
    /// Distortion of Π per level and at the end, and the input's triangle-size spread.
    pub distortion: Distortion,
    /// The input's own folds (edges past 90°): the wrong-facing area a remesh cannot avoid.
    pub input_folds: crate::maps::quality::InputFolds,
    /// Seconds spent measuring the distortion.
    pub distortion_seconds: f64,
    /// With `--equalise`: the solve of every stage and the distortion of Π'.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub equalised: Option<EqualisedSummary>,
    /// Set when a remesh is not faithful to the input: what was measured and what to try.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
    pub timings: Timings,
    pub remeshes: Vec<RemeshSummary>,
    pub pictures: Vec<String>,
}

pub fn run(args: MapsArgs) -> Result<()> {
    let summary = maps(&args, !args.json)?;
    if args.json {
        super::print_json(&summary)
    } else {
        print_summary(&summary);
        Ok(())
    }
}

/// The hard test models of issue #23 (`procedural::genus_bumpy`, `horned`, `pedestal`), by
/// name: genus2, genus3, horned, pedestal (64 grid cubes along the longest side, 26k–34k
/// triangles), genus2_100k (110 cubes, ≈ 100k triangles); the unevenly sampled models of issue
/// #37 (one half 3× finer, `procedural::genus_uneven`, `head_uneven`): genus2_uneven,
/// head_uneven (64 cubes), genus2_uneven_100k (80 cubes), genus2_uneven9 (48 cubes, the fine
/// half 9× denser), skull_uneven (64 cubes, head_uneven with two thin arches, genus 2).
fn hard_model(name: &str) -> Option<TriMesh> {
    use crate::mesh::procedural::{
        genus_bumpy, genus_uneven, genus_uneven_steps, head_uneven, horned, many_limbed, pedestal,
        skull_uneven,
    };
    Some(match name {
        "genus2" => genus_bumpy(2, 64),
        "genus3" => genus_bumpy(3, 64),
        "genus2_100k" => genus_bumpy(2, 110),
        "genus2_uneven" => genus_uneven(2, 64),
        "genus2_uneven_100k" => genus_uneven(2, 80),
        "genus2_uneven9" => genus_uneven_steps(2, 48, 2),
        "head_uneven" => head_uneven(64),
        "skull_uneven" => skull_uneven(64),
        "horned" => horned(64),
        "pedestal" => pedestal(64),
        "many_limbed" => many_limbed(96),
        _ => return None,
    })
}

/// Load the mesh named on the command line: an OBJ, PLY or OFF file, or `procedural:<name>`
/// (the hard models or a built-in mesh).
pub fn load(spec: &str) -> Result<TriMesh> {
    match spec.strip_prefix("procedural:") {
        Some(name) => hard_model(name)
            .or_else(|| builtin_mesh(name))
            .map(|mut m| {
                m.uvs.clear();
                m.uv_faces.clear();
                m
            })
            .ok_or_else(|| Error::InvalidArgument(format!("unknown built-in mesh '{name}'"))),
        None => crate::mesh::load_mesh(Path::new(spec)),
    }
}

/// The features asked for: none, detected, or read from a sidecar file (`--features`), plus the
/// command-line lists (`--feature-vertices`, `--feature-edges`).
fn features_of(mesh: &TriMesh, args: &MapsArgs) -> Result<Features> {
    let mut features = match args.features.as_deref() {
        None => Features::default(),
        Some("auto") => detect_features(mesh, &FeatureOptions::default()),
        Some(path) => load_features(Path::new(path))?,
    };
    let listed = parse_feature_list(
        args.feature_vertices.as_deref(),
        args.feature_edges.as_deref(),
    )?;
    features.corners.extend(listed.corners);
    features.edges.extend(listed.edges);
    Ok(features)
}

/// Parse `--feature-vertices I,J,…` and `--feature-edges I-J,…` (0-based vertex indices,
/// commas between items, spaces allowed). Errors: [`Error::InvalidArgument`] naming the option
/// and the item for anything else (an edge with equal ends too). Whether the indices are
/// vertices and edges of the mesh is checked by [`Features::validate`] when the hierarchy is
/// built.
pub fn parse_feature_list(vertices: Option<&str>, edges: Option<&str>) -> Result<Features> {
    let items = |list: Option<&str>| -> Vec<String> {
        list.unwrap_or("")
            .split(',')
            .map(|w| w.trim().to_string())
            .filter(|w| !w.is_empty())
            .collect()
    };
    let index = |option: &str, item: &str, w: &str| -> Result<u32> {
        w.trim().parse::<u32>().map_err(|_| {
            Error::InvalidArgument(format!(
                "{option} `{item}`: `{}` is not a vertex index (0-based)",
                w.trim()
            ))
        })
    };
    let mut features = Features::default();
    for item in items(vertices) {
        features
            .corners
            .insert(index("--feature-vertices", &item, &item)?);
    }
    for item in items(edges) {
        let Some((a, b)) = item.split_once('-') else {
            return Err(Error::InvalidArgument(format!(
                "--feature-edges `{item}`: expected I-J"
            )));
        };
        let (a, b) = (
            index("--feature-edges", &item, a)?,
            index("--feature-edges", &item, b)?,
        );
        if a == b {
            return Err(Error::InvalidArgument(format!(
                "--feature-edges `{item}`: an edge needs two different vertices"
            )));
        }
        features.edges.insert((a.min(b), a.max(b)));
    }
    Ok(features)
}

/// Run the whole command; `progress` shows a bar per level on stderr.
pub fn maps(args: &MapsArgs, progress: bool) -> Result<MapsSummary> {
    let mesh = load(&args.mesh)?;
    let specs: Vec<RemeshSpec> = args
        .remesh
        .iter()
        .map(|s| parse_remesh(s))
        .collect::<Result<_>>()?;
    if !specs.is_empty() {
        crate::maps::quality::check_distance_range(&args.mesh, &mesh.positions)?;
    }
    let features = features_of(&mesh, args)?;
    let options = MapsOptions {
        lambda: args.lambda,
        base_size: args.base_size,
        max_degree: args.max_degree,
        priority_quantile: args.priority_quantile,
        shuffle_seed: args.shuffle_seed,
        priority_error: args.priority_error,
        flattening: match args.flattening {
            FlatteningArg::Conformal => crate::maps::flatten::Flattening::Conformal,
            FlatteningArg::Polar => crate::maps::flatten::Flattening::Polar,
        },
        best_triangulation: args.best_triangulation,
        retry_rejected: !args.no_retry_rejected,
        shape_rule: (!args.paper_removal).then_some(crate::maps::shape::ShapeRule {
            coarse_factor: args.shape_levels,
            quantile: args.shape_quantile,
        }),
        ..MapsOptions::default()
    };
    let bar = if progress {
        let bar = ProgressBar::new(mesh.faces.len() as u64);
        if let Ok(style) = ProgressStyle::with_template("{bar:40} level {msg}") {
            bar.set_style(style);
        }
        bar
    } else {
        ProgressBar::hidden()
    };
    let mut per_level = Vec::new();
    let maps = build_with_progress(&mesh, &features, &options, &mut |r: LevelReport| {
        bar.set_position((mesh.faces.len() - r.faces) as u64);
        bar.set_message(format!(
            "{}: {} faces, {} removed, {} rejected",
            r.level, r.faces, r.removed, r.rejected
        ));
        per_level.push(r);
    })?;
    bar.finish_and_clear();
    let base_size_reached = args.base_size == 0 || maps.base_faces.len() <= args.base_size;
    if !base_size_reached {
        eprintln!("{}", shortfall_message(&maps, args.base_size));
    }
    std::fs::create_dir_all(&args.out).map_err(|e| Error::io(&args.out, e))?;
    let stem = stem_of(&args.mesh);
    write_obj(
        &maps.base_mesh(),
        &args.out.join(format!("{stem}_base.obj")),
    )?;
    let mut remeshes = Vec::new();
    let mut made: Vec<Remesh> = Vec::new();
    let mut record = |r: Remesh, kind: String, seconds: f64, smoothing, relaxation| -> Result<()> {
        let file = args
            .out
            .join(format!("{stem}_{}.obj", kind.replace([':', ' '], "_")));
        write_obj(&r.mesh, &file)?;
        remeshes.push(RemeshSummary {
            kind,
            faces: r.mesh.faces.len(),
            vertices: r.mesh.positions.len(),
            hausdorff_remesh_to_input: r.hausdorff.a_to_b,
            hausdorff_input_to_remesh: r.hausdorff.b_to_a,
            hausdorff_relative: r.quality.hausdorff_relative,
            mean_distance_relative: r.quality.mean_relative,
            wrong_facing_area: r.quality.wrong_facing_area,
            wrong_facing: r.quality.wrong_facing,
            smallest_angles: r.quality.angles,
            area_spread: r.quality.area_spread,
            faithful: r.quality.faithful(),
            seconds,
            hausdorff_seconds: r.hausdorff_seconds,
            file: file.display().to_string(),
            smoothing,
            relaxation,
        });
        made.push(r);
        Ok(())
    };
    let relax = args.relax.map(|n| RelaxOptions {
        iterations: n,
        ..RelaxOptions::default()
    });
    let phi: Option<(Equalised, f64)> = match args.equalise {
        Some(depth) => {
            let t = Instant::now();
            let phi = equalise(
                &maps,
                &EqualiseOptions {
                    depth,
                    edge_depth: (args.edge_flaps > 0).then_some(args.edge_flaps),
                    refine: args.refine_faces,
                    edge_rounds: args.edge_rounds,
                    ..EqualiseOptions::default()
                },
            )?;
            Some((phi, t.elapsed().as_secs_f64()))
        }
        _ => None,
    };
    for spec in specs {
        let t = Instant::now();
        let (r, kind) = match spec {
            RemeshSpec::Uniform(j) => (uniform(&maps, j)?, format!("uniform:{j}")),
            RemeshSpec::Adaptive(eps) => (
                adaptive(
                    &maps,
                    &AdaptiveOptions {
                        epsilon: eps,
                        ..AdaptiveOptions::default()
                    },
                )?,
                format!("adaptive:{eps}"),
            ),
        };
        record(r, kind, t.elapsed().as_secs_f64(), None, None)?;
        if let (RemeshSpec::Uniform(j), true) = (spec, args.smooth) {
            let t = Instant::now();
            let s = uniform_smoothed_with(&maps, j, &SmoothOptions::default())?;
            let kind = format!("uniform:{j} smoothed");
            record(
                s.remesh,
                kind,
                t.elapsed().as_secs_f64(),
                Some(s.stats),
                None,
            )?;
        }
        if let (RemeshSpec::Uniform(j), Some(options)) = (spec, &relax) {
            let t = Instant::now();
            let s = uniform_relaxed(&maps, j, options)?;
            let kind = format!("uniform:{j} relaxed");
            record(
                s.remesh,
                kind,
                t.elapsed().as_secs_f64(),
                None,
                Some(s.stats),
            )?;
        }
        if let (RemeshSpec::Uniform(j), Some((phi, _))) = (spec, &phi) {
            let t = Instant::now();
            let r = uniform_equalised(&maps, j, phi)?;
            record(
                r,
                format!("uniform:{j} equalised"),
                t.elapsed().as_secs_f64(),
                None,
                None,
            )?;
            if let Some(options) = &relax {
                let t = Instant::now();
                let s = uniform_equalised_relaxed(&maps, j, phi, options)?;
                let kind = format!("uniform:{j} equalised relaxed");
                record(
                    s.remesh,
                    kind,
                    t.elapsed().as_secs_f64(),
                    None,
                    Some(s.stats),
                )?;
            }
        }
    }
    let equalised = phi.as_ref().map(|(phi, seconds)| {
        let (distortion, log_area_ratio) = map_distortion(&maps, &phi.vertex_parameters(&maps));
        (
            EqualisedSummary {
                solve: phi.report,
                later: phi
                    .later
                    .iter()
                    .map(|s| StageSummary {
                        stage: match s {
                            Stage::Edges(_) => "edges",
                            Stage::Faces(_) => "faces",
                        },
                        solve: s.report(),
                    })
                    .collect(),
                distortion,
                seconds: *seconds,
            },
            log_area_ratio,
        )
    });
    let t = Instant::now();
    let distortion = distortion(&maps);
    let distortion_seconds = t.elapsed().as_secs_f64();
    let input_folds = crate::maps::quality::input_folds(&maps.positions, &maps.input_faces);
    let warning = unfaithful_warning(
        &remeshes,
        &distortion,
        maps.base_faces.len(),
        &input_folds,
        equalised.is_some(),
    );
    if let Some(w) = &warning {
        eprintln!("{w}");
    }
    let pictures = if args.picture_size > 0 {
        write_pictures(
            &maps,
            &distortion,
            equalised.as_ref().map(|e| e.1.as_slice()),
            &made,
            &args.out,
            &stem,
            args.picture_size,
        )?
    } else {
        Vec::new()
    };
    let base_vertices = maps
        .base_faces
        .iter()
        .flatten()
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    Ok(MapsSummary {
        mesh: mesh.name.clone(),
        input_faces: mesh.faces.len(),
        input_vertices: mesh.positions.len(),
        levels: maps.level_count(),
        base_faces: maps.base_faces.len(),
        base_vertices,
        feature_corners: features.corners.len(),
        feature_edges: features.edges.len(),
        rejected: maps.rejects,
        base_size_asked: args.base_size,
        base_size_reached,
        stop: maps.stop,
        per_level,
        distortion,
        input_folds,
        distortion_seconds,
        equalised: equalised.map(|e| e.0),
        warning,
        timings: maps.timings,
        remeshes,
        pictures,
    })
}

/// The warning printed when the hierarchy stops above `--base-size`: the faces reached, why the
/// last level stopped, the rejections by cause, and what the final vertices are.
pub fn shortfall_message(maps: &Maps, asked: usize) -> String {
    let stop = &maps.stop;
    let why = match stop.reason {
        StopReason::BaseSize => "it reached the base size".to_string(),
        StopReason::MaxLevels => "the level limit was reached".to_string(),
        StopReason::NoCandidates => "no vertex was removable".to_string(),
        StopReason::AllRejected => format!(
            "every selected removal of the last level was rejected ({} by the flattening guard, \
             {} with every triangulation flipped in 3D, {} with every valid one duplicating an edge or face)",
            stop.last_level_rejects.flatten,
            stop.last_level_rejects.flipped,
            stop.last_level_rejects.duplicate
        ),
    };
    let r = &maps.rejects;
    format!(
        "warning: base domain has {} faces, {asked} were asked for: the hierarchy stopped because {why}. \
         Rejected removals over all levels: {} by the flattening guard, {} flipped in 3D, {} duplicate edge/face. \
         Of the {} base vertices: {} candidates, {} over the degree limit, {} corners, {} not a single fan.",
        maps.base_faces.len(),
        r.flatten,
        r.flipped,
        r.duplicate,
        stop.vertices,
        stop.candidates,
        stop.over_degree,
        stop.corners,
        stop.not_a_fan
    )
}

/// The warning printed when some remesh misses issue #23's targets: the base domain does not
/// represent the shape at this size. Names the worst remesh's figures and Π's distortion and
/// suggests a larger base or features.
pub fn unfaithful_warning(
    remeshes: &[RemeshSummary],
    distortion: &Distortion,
    base_faces: usize,
    folds: &crate::maps::quality::InputFolds,
    equalised: bool,
) -> Option<String> {
    let bad: Vec<&RemeshSummary> = remeshes.iter().filter(|r| !r.faithful).collect();
    let worst = bad
        .iter()
        .max_by(|a, b| a.hausdorff_relative.total_cmp(&b.hausdorff_relative))?;
    let d = &distortion.final_map;
    let only_folds = folds.edges > 0
        && bad.iter().all(|r| {
            r.hausdorff_relative <= crate::maps::quality::FAITHFUL_HAUSDORFF
                && r.mean_distance_relative <= crate::maps::quality::FAITHFUL_MEAN
                && r.wrong_facing_area <= folds.area_fraction
        });
    if only_folds {
        return Some(format!(
            "warning: {} of {} remeshes have area facing the wrong way (worst {}: {}%), no more \
             than the input's own folds: {} edges folded past 90°, {}% of its area on their \
             faces. The distance targets hold (Hausdorff {}%, mean {}% of the diagonal).",
            bad.len(),
            remeshes.len(),
            worst.kind,
            sig(100.0 * worst.wrong_facing_area, 3),
            folds.edges,
            sig(100.0 * folds.area_fraction, 3),
            sig(100.0 * worst.hausdorff_relative, 3),
            sig(100.0 * worst.mean_distance_relative, 3),
        ));
    }
    Some(
        format!(
        "warning: {} of {} remeshes miss the faithfulness targets (Hausdorff ≤ 1.5%, mean ≤ 0.1% \
         of the diagonal, no wrong-facing area); worst {}: Hausdorff {}%, mean {}%, wrong-facing \
         area {}%. The base domain of {base_faces} faces does not represent the shape there \
         (Π: area distortion p95 {} against the input's spread {}, σmax/σmin p95 {}, {} folded \
         images). Try {}{}a larger --base-size or --features auto; the picture \
         *_area_distortion.png shows where.{}",
        bad.len(),
        remeshes.len(),
        worst.kind,
        sig(100.0 * worst.hausdorff_relative, 3),
        sig(100.0 * worst.mean_distance_relative, 3),
        sig(100.0 * worst.wrong_facing_area, 3),
        sig(d.area_p95, 3),
        sig(distortion.input_area_spread, 3),
        sig(d.conformal_p95, 3),
        d.folded,
        relax_hint(remeshes, &bad),
        equalise_hint(distortion, equalised),
        wrong_facing_note(worst, folds)
    ) + &equalise_fold_note(
            &remeshes
                .iter()
                .map(|r| (r.kind.as_str(), r.wrong_facing_area))
                .collect::<Vec<_>>(),
        ),
    )
}

/// Issue #53: the note of [`unfaithful_warning`] when an equalised relaxed remesh (`kind`,
/// wrong-facing area) has more wrong-facing area than the relaxed remesh of the same depth:
/// Φ keeps Π's folded images where the base domain misses a part of the shape, and its
/// redistribution of area can turn more of the remesh over there (the MAPS guide's section on
/// the coarse levels' removal rule). Empty when none does.
fn equalise_fold_note(remeshes: &[(&str, f64)]) -> String {
    for &(kind, equalised) in remeshes {
        let Some(depth) = kind.strip_suffix(" equalised relaxed") else {
            continue;
        };
        let relaxed_kind = format!("{depth} relaxed");
        let Some(&(_, relaxed)) = remeshes.iter().find(|(k, _)| *k == relaxed_kind) else {
            continue;
        };
        if equalised > relaxed {
            return format!(
                " With --equalise, {kind} has more wrong-facing area than {relaxed_kind} ({}% \
                 against {}%): Φ keeps Π's folded images where the base domain misses a part \
                 of the shape, and moving area there turns more of the remesh over; prefer \
                 {relaxed_kind} there, or a larger --base-size.",
                sig(100.0 * equalised, 3),
                sig(100.0 * relaxed, 3)
            );
        }
    }
    String::new()
}

/// `--relax, ` when a uniform remesh misses the targets and none was relaxed.
fn relax_hint(remeshes: &[RemeshSummary], bad: &[&RemeshSummary]) -> &'static str {
    let relaxed = remeshes.iter().any(|r| r.relaxation.is_some());
    let uniform_missed = bad.iter().any(|r| r.kind.starts_with("uniform"));
    if uniform_missed && !relaxed {
        "--relax (the uniform remesh's parameters moved towards the surface's area, beyond the \
         paper), "
    } else {
        ""
    }
}

/// `--equalise, ` when Π's area distortion (p95) exceeds the input's own spread and Π was not
/// composed with the reparameterisation (issue #37).
fn equalise_hint(distortion: &Distortion, equalised: bool) -> &'static str {
    if !equalised && distortion.final_map.area_p95 > distortion.input_area_spread {
        "--equalise (Π composed with a stretch-minimising reparameterisation of the base domain, \
         within each base face and across its edges, so that its area follows the surface's; \
         beyond the paper), "
    } else {
        ""
    }
}

/// A table cell for a remesh's wrong-facing area: the fraction, and with some, its faces and
/// the largest of their smallest angles, e.g. `0.000446 (5 faces, ≤ 38.2°)`.
pub fn wrong_facing_cell(r: &RemeshSummary) -> String {
    if r.wrong_facing.faces == 0 {
        return sig(r.wrong_facing_area, 3);
    }
    format!(
        "{} ({} faces, ≤ {}°)",
        sig(r.wrong_facing_area, 3),
        r.wrong_facing.faces,
        sig(r.wrong_facing.largest_smallest_angle_deg, 3)
    )
}

/// The part of [`unfaithful_warning`] that says where a remesh's wrong-facing area is: its
/// faces, how thin and how far from the input; whether they are slivers on the surface (every
/// smallest angle under 10°, every distance within the Hausdorff target); and the input's own
/// folds when it has some.
fn wrong_facing_note(worst: &RemeshSummary, folds: &crate::maps::quality::InputFolds) -> String {
    if worst.wrong_facing_area == 0.0 {
        return String::new();
    }
    let w = &worst.wrong_facing;
    let slivers = w.largest_smallest_angle_deg < 10.0
        && w.largest_distance_relative <= crate::maps::quality::FAITHFUL_HAUSDORFF;
    let mut note = format!(
        " The wrong-facing area is on {} faces, smallest angles up to {}°, at most {}% of the \
         diagonal from the input{}",
        w.faces,
        sig(w.largest_smallest_angle_deg, 3),
        sig(100.0 * w.largest_distance_relative, 3),
        if slivers {
            ": slivers on the surface, folded over where Π⁻¹ stretches a small base-domain \
             triangle across a bend (σmax/σmin above)."
        } else {
            "."
        }
    );
    if folds.edges > 0 {
        note += &format!(
            " The input itself has {} edges folded past 90° ({}% of its area on their faces): \
             a remesh coarser than those folds faces them the wrong way.",
            folds.edges,
            sig(100.0 * folds.area_fraction, 3)
        );
    }
    note
}

/// A file-name stem for the mesh spec.
fn stem_of(spec: &str) -> String {
    match spec.strip_prefix("procedural:") {
        Some(name) => name.to_string(),
        None => Path::new(spec)
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("mesh")
            .to_string(),
    }
}

/// Levels side by side, the base domain with the input's points, iso-parameter lines of Π,
/// iso-parameter lines of the unsmoothed and the smoothed parameterisation side by side, the
/// input coloured by the area distortion of Π, and one picture per remesh. Returns the file
/// names.
pub fn write_pictures(
    maps: &Maps,
    distortion: &Distortion,
    equalised: Option<&[Option<f64>]>,
    remeshes: &[Remesh],
    out: &Path,
    stem: &str,
    size: usize,
) -> Result<Vec<String>> {
    let mut files = Vec::new();
    let mut save =
        |name: String, img: &crate::texture::Image<crate::texture::Rgba8>| -> Result<()> {
            save_png(img, &out.join(&name))?;
            files.push(name);
            Ok(())
        };
    let levels = picture::hierarchy_levels(maps, 4, size);
    let refs: Vec<_> = levels.iter().collect();
    save(format!("{stem}_levels.png"), &side_by_side(&refs, 4))?;
    save(
        format!("{stem}_base_points.png"),
        &picture::base_domain_points(maps, size),
    )?;
    save(
        format!("{stem}_iso_lines.png"),
        &picture::iso_lines(maps, 8, size),
    )?;
    save(
        format!("{stem}_iso_lines_smoothed.png"),
        &picture::iso_lines_smoothed(maps, 3, size)?,
    )?;
    save(
        format!("{stem}_area_distortion.png"),
        &picture::area_distortion(maps, &distortion.log_area_ratio, size),
    )?;
    if let Some(log_area_ratio) = equalised {
        save(
            format!("{stem}_equalised_area_distortion.png"),
            &picture::area_distortion(maps, log_area_ratio, size),
        )?;
    }
    for r in remeshes {
        let name = r
            .mesh
            .name
            .rsplit('(')
            .next()
            .unwrap_or("remesh")
            .trim_end_matches(')')
            .replace([' ', '=', ':'], "_");
        save(
            format!("{stem}_{name}.png"),
            &picture::remesh_picture(maps, &r.mesh, size),
        )?;
    }
    Ok(files)
}

fn print_summary(s: &MapsSummary) {
    outln!(
        "{}: {} faces, {} vertices → {} levels, base domain {} faces / {} vertices ({} corners, {} feature edges tagged)",
        s.mesh, s.input_faces, s.input_vertices, s.levels, s.base_faces, s.base_vertices, s.feature_corners, s.feature_edges
    );
    outln!(
        "rejected removals: {} by the flattening guard, {} by the triangulation checks ({} flipped in 3D, {} duplicate edge/face)",
        s.rejected.flatten, s.rejected.triangulation, s.rejected.flipped, s.rejected.duplicate
    );
    outln!(
        "time: check {} s, hierarchy {} s, Π/Π⁻¹ {} s",
        sig(s.timings.check, 3),
        sig(s.timings.hierarchy, 3),
        sig(s.timings.param, 3)
    );
    let d = &s.distortion.final_map;
    outln!(
        "distortion of Π: |log area ratio| mean {} p95 {} max {} (input's triangle-size spread {}), \
         σmax/σmin mean {} p95 {} max {}, {} folded of {} triangles; Π⁻¹(Π(v)) within {} of the \
         diagonal",
        sig(d.area_mean, 3),
        sig(d.area_p95, 3),
        sig(d.area_max, 3),
        sig(s.distortion.input_area_spread, 3),
        sig(d.conformal_mean, 3),
        sig(d.conformal_p95, 3),
        sig(d.conformal_max, 3),
        d.folded,
        d.triangles,
        sig(s.distortion.round_trip_max_relative, 2)
    );
    if let Some(e) = &s.equalised {
        let (d, r) = (&e.distortion, &e.solve);
        outln!(
            "distortion of Π' (--equalise, {} s in all; first the per-face stage Φ: lattice depth \
             {}, {} unknowns, L² stretch {} → {} in {} L-BFGS iterations): |log area ratio| mean \
             {} p95 {} max {}, σmax/σmin mean {} p95 {} max {}",
            sig(e.seconds, 3),
            r.depth,
            r.unknowns,
            sig(r.stretch_before, 4),
            sig(r.stretch_after, 4),
            r.solver.iterations,
            sig(d.area_mean, 3),
            sig(d.area_p95, 3),
            sig(d.area_max, 3),
            sig(d.conformal_mean, 3),
            sig(d.conformal_p95, 3),
            sig(d.conformal_max, 3),
        );
    }
    for later in s.equalised.iter().flat_map(|e| &e.later) {
        let r = &later.solve;
        outln!(
            "  then the {}: lattice depth {}, {} unknowns, L² stretch {} → {} in {} L-BFGS iterations",
            if later.stage == "edges" {
                "edge stage Φ_E"
            } else {
                "per-face stage Φ"
            },
            r.depth,
            r.unknowns,
            sig(r.stretch_before, 4),
            sig(r.stretch_after, 4),
            r.solver.iterations,
        );
    }
    if !s.remeshes.is_empty() {
        let header: Vec<String> = [
            "remesh",
            "faces",
            "vertices",
            "Hausdorff/diag",
            "mean dist/diag",
            "wrong-facing area (faces, largest smallest angle)",
            "angles < 10°",
            "seconds",
        ]
        .map(String::from)
        .to_vec();
        let rows: Vec<Vec<String>> = s
            .remeshes
            .iter()
            .map(|r| {
                vec![
                    r.kind.clone(),
                    r.faces.to_string(),
                    r.vertices.to_string(),
                    sig(r.hausdorff_relative, 3),
                    sig(r.mean_distance_relative, 3),
                    wrong_facing_cell(r),
                    sig(r.smallest_angles.below_10, 3),
                    sig(r.seconds, 3),
                ]
            })
            .collect();
        outln!("{}", super::text_table(&header, &rows));
    }
    for p in &s.pictures {
        outln!("wrote {p}");
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn relax_without_a_value_runs_the_default_sweeps() {
        assert_eq!(
            super::RELAX_SWEEPS.parse::<usize>(),
            Ok(crate::maps::relax::DEFAULT_SWEEPS)
        );
    }

    #[test]
    fn equalise_without_a_value_uses_the_default_depth() {
        assert_eq!(
            super::EQUALISE_DEPTH.parse::<u32>(),
            Ok(crate::maps::equalise::DEFAULT_DEPTH)
        );
    }

    /// The note appears only when an equalised relaxed remesh has more wrong-facing area than
    /// the relaxed one of its depth (the skull with the paper's order: 3.39% against 2.49%),
    /// names both, and is empty when it has as much or less, or has no relaxed partner.
    #[test]
    fn equalise_fold_note_only_when_equalise_raises_the_wrong_facing_area() {
        let note = super::equalise_fold_note(&[
            ("uniform:3", 0.04),
            ("uniform:3 relaxed", 0.0249),
            ("uniform:3 equalised", 0.032),
            ("uniform:3 equalised relaxed", 0.0339),
        ]);
        assert!(note.contains("uniform:3 equalised relaxed"), "{note}");
        assert!(note.contains("3.39% against 2.49%"), "{note}");
        for rel in [0.0339, 0.04] {
            let none = super::equalise_fold_note(&[
                ("uniform:3 relaxed", rel),
                ("uniform:3 equalised relaxed", 0.0339),
            ]);
            assert_eq!(none, "", "relaxed {rel}");
        }
        assert_eq!(
            super::equalise_fold_note(&[
                ("uniform:2 relaxed", 0.0),
                ("uniform:3 equalised relaxed", 0.1)
            ]),
            ""
        );
    }

    #[test]
    fn edge_flaps_default_is_the_library_default() {
        assert_eq!(
            super::EDGE_FLAPS_DEPTH.parse::<u32>(),
            Ok(crate::maps::flaps::DEFAULT_DEPTH)
        );
    }
}
