//! `reparam crosscheck <bpm|gridwarp|unwarp|maps|skinsimp|all>`: every f32 GPU kernel against
//! the f64 reference from identical inputs, on built-in data or the user's own, on one adapter
//! or on each; one row per kernel with its derived bound and verdict.
//!
//! Exit codes: 0 when every kernel is within its bound, 1 when any exceeds it (listed on
//! stderr), 2 on bad input or without an adapter.

use std::path::PathBuf;

use crate::{Error, Result};
use clap::{Args, Subcommand};

use super::gridwarp::GridwarpArgs;
use super::unwarp::UnwarpArgs;

#[derive(Args)]
#[command(args_conflicts_with_subcommands = false)]
pub struct CrosscheckArgs {
    #[command(subcommand)]
    pub algorithm: Option<Algorithm>,
    /// Print every adapter wgpu finds (name, backend, device type, driver) and exit.
    #[arg(long, global = true)]
    pub list_adapters: bool,
    /// The adapter to run on: its index in `--list-adapters` or a part of its name, backend or
    /// driver (case-insensitive), e.g. `gl`. Default: `REPARAM_ADAPTER`, else the best one.
    #[arg(long, global = true, conflicts_with = "all_adapters")]
    pub adapter: Option<String>,
    /// Run on every adapter and set the results side by side.
    #[arg(long, global = true)]
    pub all_adapters: bool,
    /// Folder for the `--sweep` plots.
    #[arg(long, global = true, default_value = "out/crosscheck")]
    pub plots: PathBuf,
}

impl CrosscheckArgs {
    /// Whether `--json` was given (to its algorithm).
    pub fn json(&self) -> bool {
        self.algorithm.as_ref().is_some_and(|a| a.common().json)
    }
}

#[derive(Subcommand)]
pub enum Algorithm {
    /// BPM: bpm_eval, bpm_precompute (local and determinant fit), bpm_render.
    Bpm(BpmInput),
    /// gridwarp: gridwarp_aa (cell energies, F, JᵀJ, Jᵀr) and whole LM solves; the input flags
    /// of `reparam gridwarp` (--scene, --gltf/--animation, --obj, --roi, --rigidity, …).
    Gridwarp(GridwarpInput),
    /// unwarp: unwarp_pass and whole runs; the input flags of `reparam unwarp`.
    Unwarp(UnwarpInput),
    /// maps: maps_priority, maps_flatten, maps_inverse on a MAPS hierarchy.
    Maps(MapsInput),
    /// skinsimp: skinsimp_lbs, skinsimp_quadrics, skinsimp_collapse_cost on a skinned glTF.
    Skinsimp(SkinsimpInput),
    /// All five on built-in data.
    All(Common),
}

/// Flags every algorithm takes.
#[derive(Args, Clone, Default)]
pub struct Common {
    /// Print machine-readable results (schema in `src/crosscheck/README.md`).
    #[arg(long)]
    pub json: bool,
    /// Also sweep the error against a conditioning parameter (table and log–log plot).
    #[arg(long)]
    pub sweep: bool,
    /// Test only: feed the GPU a perturbed input (BPM eval: every map coefficient × (1 + 1e-3)),
    /// so the cross-check must report it over its bound.
    #[arg(long, hide = true)]
    pub perturb_gpu_input: bool,
}

#[derive(Args, Clone, Default)]
pub struct BpmInput {
    /// Mesh (OBJ with `vt`, or `procedural:<name>`); repeat for several. Default: every small
    /// built-in mesh.
    #[arg(long)]
    pub mesh: Vec<String>,
    /// Neighbour layout of the reference. `authors` (the authors' code, see `bpm qc --unfold`)
    /// checks the eval kernel only: the GPU precompute implements the correct unfolding alone.
    /// The --sweep always uses the correct one.
    #[arg(long, value_enum, default_value = "correct")]
    pub unfold: super::bpm::UnfoldArg,
    #[command(flatten)]
    pub common: Common,
}

#[derive(Args, Clone)]
pub struct GridwarpInput {
    #[command(flatten)]
    pub args: GridwarpArgs,
    /// Also sweep the error against a conditioning parameter (table and log–log plot).
    #[arg(long)]
    pub sweep: bool,
}

#[derive(Args, Clone)]
pub struct UnwarpInput {
    #[command(flatten)]
    pub args: UnwarpArgs,
    /// Also sweep the error against a conditioning parameter (table and log–log plot).
    #[arg(long)]
    pub sweep: bool,
}

#[derive(Args, Clone)]
pub struct MapsInput {
    /// The mesh: .obj, .ply, .off or `procedural:<name>`. Default: the demo's torus.
    pub mesh: Option<String>,
    /// Stop the hierarchy at this many base triangles (0: as coarse as possible).
    #[arg(long, default_value_t = 0)]
    pub base_size: usize,
    /// λ of the priority.
    #[arg(long, default_value_t = 0.5)]
    pub lambda: f64,
    /// Features: `auto` or a sidecar file (`v I`, `e I J` lines).
    #[arg(long)]
    pub features: Option<String>,
    #[command(flatten)]
    pub common: Common,
}

#[derive(Args, Clone)]
pub struct SkinsimpInput {
    /// A skinned glTF/GLB. Default: the built-in skinned tube.
    pub model: Option<PathBuf>,
    /// Training poses: `clip:all`, `clip:NAME,…` or a number of uniform times per clip.
    #[arg(long, default_value = "clip:all")]
    pub poses: String,
    #[command(flatten)]
    pub common: Common,
}

/// Run the command; the exit code says whether every kernel passed (`main` gives an error
/// status 2).
#[cfg(not(feature = "gpu"))]
pub fn try_run(_: CrosscheckArgs) -> Result<u8> {
    Err(Error::Gpu(
        "this build has no GPU support (feature `gpu` is off)".into(),
    ))
}

/// Run the command; the exit code says whether every kernel passed (`main` gives an error
/// status 2).
#[cfg(feature = "gpu")]
pub fn try_run(args: CrosscheckArgs) -> Result<u8> {
    use crate::crosscheck::run::{AdapterRows, CrosscheckReport, SkippedAdapter};
    use reparam_gpu::Gpu;

    if args.list_adapters {
        return list_adapters();
    }
    let Some(algorithm) = args.algorithm else {
        return Err(Error::InvalidArgument(
            "name an algorithm: reparam crosscheck <bpm|gridwarp|unwarp|maps|skinsimp|all> \
             (or --list-adapters)"
                .into(),
        ));
    };
    let mut skipped = Vec::new();
    let gpus: Vec<Gpu> = if args.all_adapters {
        let all = Gpu::all_adapters();
        if all.is_empty() {
            return Err(Error::Gpu(reparam_gpu::GpuError::NoAdapter.to_string()));
        }
        let mut gpus = Vec::new();
        for (description, gpu) in all {
            match gpu {
                Ok(g) => gpus.push(g),
                Err(e) => {
                    eprintln!("adapter {} skipped: {e}", description.summary());
                    skipped.push(SkippedAdapter {
                        adapter: description.summary(),
                        reason: e.to_string(),
                    });
                }
            }
        }
        if gpus.is_empty() {
            return Err(Error::Gpu(format!(
                "no adapter could create a device, so nothing was checked: {}",
                skipped
                    .iter()
                    .map(|s| format!("{} ({})", s.adapter, s.reason))
                    .collect::<Vec<_>>()
                    .join("; ")
            )));
        }
        gpus
    } else {
        vec![match &args.adapter {
            Some(selector) => Gpu::with_adapter(selector),
            None => Gpu::new(),
        }
        .map_err(|e| Error::Gpu(e.to_string()))?]
    };
    let common = algorithm.common();
    let mut adapters = Vec::new();
    for gpu in &gpus {
        let rows = rows_for(gpu, &algorithm)?;
        adapters.push(AdapterRows {
            adapter: gpu.adapter_summary(),
            rows,
        });
    }
    let mut report = CrosscheckReport::new(adapters);
    report.skipped = skipped;
    if common.sweep {
        let (sweeps, plots) = sweeps(&gpus[0], &algorithm, &args.plots)?;
        report.sweeps = sweeps;
        report.plots = plots;
    }
    if common.json {
        super::print_json(&report)?;
    } else {
        print_report(&report)?;
    }
    for f in &report.failures {
        eprintln!("over its bound: {f}");
    }
    if super::stdout_gone() {
        eprintln!(
            "crosscheck: {} (stdout closed)",
            if report.exit_code == 0 {
                "pass"
            } else {
                "FAIL"
            }
        );
    }
    Ok(report.exit_code)
}

impl Algorithm {
    /// The flags every algorithm has.
    pub fn common(&self) -> Common {
        match self {
            Algorithm::Bpm(a) => a.common.clone(),
            Algorithm::Maps(a) => a.common.clone(),
            Algorithm::Skinsimp(a) => a.common.clone(),
            Algorithm::All(c) => c.clone(),
            Algorithm::Gridwarp(a) => Common {
                json: a.args.json,
                sweep: a.sweep,
                ..Default::default()
            },
            Algorithm::Unwarp(a) => Common {
                json: a.args.json,
                sweep: a.sweep,
                ..Default::default()
            },
        }
    }
}

#[cfg(feature = "gpu")]
fn list_adapters() -> Result<u8> {
    let adapters = reparam_gpu::list_adapters();
    if adapters.is_empty() {
        return Err(Error::Gpu(reparam_gpu::GpuError::NoAdapter.to_string()));
    }
    let header = [
        "index",
        "name",
        "backend",
        "device type",
        "driver",
        "driver info",
    ]
    .map(String::from)
    .to_vec();
    let rows: Vec<Vec<String>> = adapters
        .iter()
        .map(|a| {
            vec![
                a.index.to_string(),
                a.name.clone(),
                a.backend.clone(),
                a.device_type.clone(),
                a.driver.clone(),
                a.driver_info.clone(),
            ]
        })
        .collect();
    outln!("{}", super::text_table(&header, &rows));
    Ok(0)
}

#[cfg(feature = "gpu")]
fn print_report(report: &crate::crosscheck::run::CrosscheckReport) -> Result<()> {
    use crate::crosscheck::run::{side_by_side, text_table};
    for (k, a) in report.adapters.iter().enumerate() {
        outln!("[{k}] adapter: {}", a.adapter);
        outln!("f32 GPU against f64 CPU from identical (f32-rounded) inputs; ε = u = 2⁻²³ (one WGSL rounding, up or down)");
        let (header, rows, notes) = text_table(&a.rows);
        outln!("{}", super::text_table(&header, &rows));
        outln!("{}\n", notes.join("\n"));
    }
    if report.adapters.len() > 1 {
        let (header, rows) = side_by_side(&report.adapters)?;
        outln!("side by side (max error in each row's unit, worst error/bound):");
        outln!("{}", super::text_table(&header, &rows));
    }
    for (sweep, plot) in report.sweeps.iter().zip(&report.plots) {
        outln!("\nsweep: {} (first adapter; plot {plot})", sweep.title);
        let (header, rows) = sweep.table();
        outln!("{}", super::text_table(&header, &rows));
    }
    for s in &report.skipped {
        outln!("adapter {} skipped, not checked: {}", s.adapter, s.reason);
    }
    if report.failures.is_empty() {
        outln!("every kernel within its bound");
    }
    Ok(())
}

/// The sweeps of `algorithm` on `gpu`, their plots written to `dir` (640 × 420 PNGs).
#[cfg(feature = "gpu")]
pub fn sweeps(
    gpu: &reparam_gpu::Gpu,
    algorithm: &Algorithm,
    dir: &std::path::Path,
) -> Result<(Vec<crate::crosscheck::sweep::Sweep>, Vec<String>)> {
    use crate::crosscheck::sweep::sweeps_of;
    let names: &[&str] = match algorithm {
        Algorithm::Bpm(_) => &["bpm"],
        Algorithm::Gridwarp(_) => &["gridwarp"],
        Algorithm::Unwarp(_) => &["unwarp"],
        Algorithm::Maps(_) => &["maps"],
        Algorithm::Skinsimp(_) => &["skinsimp"],
        Algorithm::All(_) => &["bpm", "gridwarp", "unwarp", "maps", "skinsimp"],
    };
    std::fs::create_dir_all(dir).map_err(|e| Error::Io {
        path: dir.to_path_buf(),
        source: e,
    })?;
    let mut all = Vec::new();
    let mut plots = Vec::new();
    for name in names {
        for sweep in sweeps_of(gpu, name)? {
            let path = dir.join(format!("{}.png", sweep.name));
            crate::texture::save_png(&sweep.plot(640, 420)?, &path)?;
            plots.push(path.display().to_string());
            all.push(sweep);
        }
    }
    Ok((all, plots))
}

/// Every row of `algorithm` on `gpu`.
#[cfg(feature = "gpu")]
pub fn rows_for(
    gpu: &reparam_gpu::Gpu,
    algorithm: &Algorithm,
) -> Result<Vec<crate::crosscheck::Row>> {
    match algorithm {
        Algorithm::Bpm(a) => bpm_rows(gpu, a),
        Algorithm::Gridwarp(a) => gridwarp_rows(gpu, &a.args),
        Algorithm::Unwarp(a) => unwarp_rows(gpu, &a.args),
        Algorithm::Maps(a) => maps_rows(gpu, a),
        Algorithm::Skinsimp(a) => skinsimp_rows(gpu, a),
        Algorithm::All(c) => {
            let mut rows = bpm_rows(
                gpu,
                &BpmInput {
                    mesh: Vec::new(),
                    common: c.clone(),
                    ..Default::default()
                },
            )?;
            rows.extend(gridwarp_rows(gpu, &default_gridwarp_args()?)?);
            let mut naa = default_gridwarp_args()?;
            naa.variant = super::gridwarp::Variant::Naa;
            rows.extend(gridwarp_rows(gpu, &naa)?);
            rows.extend(unwarp_rows(gpu, &default_unwarp_args()?)?);
            rows.extend(maps_rows(gpu, &default_maps_input())?);
            rows.extend(skinsimp_rows(gpu, &default_skinsimp_input())?);
            Ok(rows)
        }
    }
}

/// The built-in meshes of `crosscheck bpm` without `--mesh`.
pub fn bpm_meshes(input: &BpmInput) -> Result<Vec<crate::mesh::TriMesh>> {
    if input.mesh.is_empty() {
        return Ok(crate::mesh::procedural::all_small());
    }
    input
        .mesh
        .iter()
        .map(|m| super::inputs::load_mesh(m))
        .collect()
}

#[cfg(feature = "gpu")]
fn bpm_rows(gpu: &reparam_gpu::Gpu, input: &BpmInput) -> Result<Vec<crate::crosscheck::Row>> {
    use crate::crosscheck::bpm::bpm_rows_with_options;
    let texture = crate::texture::checker(512, 16);
    let mut rows = Vec::new();
    for mesh in bpm_meshes(input)? {
        if mesh.uvs.is_empty() {
            return Err(Error::InvalidArgument(format!(
                "{}: the mesh has no texture coordinates (`vt` lines); BPM interpolates UVs",
                mesh.name
            )));
        }
        rows.extend(bpm_rows_with_options(
            gpu,
            &mesh,
            &texture,
            input.common.perturb_gpu_input,
            crate::bpm::BpmOptions {
                unfold: input.unfold.into(),
                ..Default::default()
            },
        )?);
    }
    Ok(rows)
}

#[cfg(feature = "gpu")]
fn gridwarp_rows(
    gpu: &reparam_gpu::Gpu,
    args: &GridwarpArgs,
) -> Result<Vec<crate::crosscheck::Row>> {
    use crate::crosscheck::gridwarp::crosscheck_gridwarp;
    use crate::crosscheck::gridwarp_naa::crosscheck_gridwarp_naa;
    let options = super::gridwarp::solve_options(args);
    let mut rows = Vec::new();
    for w in super::gridwarp::warp_inputs(args)? {
        rows.extend(match args.variant {
            super::gridwarp::Variant::Aa => {
                crosscheck_gridwarp(gpu, &w.name, &w.rest, &w.rest_grid, &w.frames, &options)?
            }
            super::gridwarp::Variant::Naa => crosscheck_gridwarp_naa(
                gpu,
                &w.name,
                &w.rest,
                &w.rest_grid,
                &w.jacobians,
                &options,
                args.sliding_border,
            )?,
        });
    }
    Ok(rows)
}

/// The clap defaults of an argument struct (what the command sees with no flag).
fn defaults<T: clap::Args + clap::FromArgMatches>() -> Result<T> {
    #[derive(clap::Parser)]
    struct Wrap<U: clap::Args> {
        #[command(flatten)]
        inner: U,
    }
    use clap::Parser;
    Wrap::<T>::try_parse_from(["reparam"])
        .map(|w| w.inner)
        .map_err(|e| Error::InvalidArgument(format!("default arguments: {e}")))
}

/// `reparam unwarp`'s defaults on the built-in `cones` map (64², s = 0.05), as the demo.
pub fn default_unwarp_args() -> Result<UnwarpArgs> {
    let mut args: UnwarpArgs = defaults()?;
    args.procedural = Some("cones".into());
    Ok(args)
}

/// `reparam gridwarp`'s defaults: the `bump` scene, 128² fields, 6 frames, 8 × 8 samples.
pub fn default_gridwarp_args() -> Result<GridwarpArgs> {
    defaults()
}

#[cfg(feature = "gpu")]
fn unwarp_rows(gpu: &reparam_gpu::Gpu, args: &UnwarpArgs) -> Result<Vec<crate::crosscheck::Row>> {
    let mut args = args.clone();
    if args.input.is_none() && args.procedural.is_none() {
        args.procedural = Some("cones".into());
    }
    let heights = super::unwarp::heights(&args)?;
    let options = super::unwarp::options(&args, &heights)?;
    let name = match (&args.input, &args.procedural) {
        (Some(p), _) => p.display().to_string(),
        (None, Some(n)) => format!("{n} {}²", args.size),
        _ => "height map".into(),
    };
    crate::crosscheck::unwarp::crosscheck_unwarp(gpu, &name, &heights, &options)
}

/// The demo's torus (48 × 24).
pub fn default_maps_input() -> MapsInput {
    MapsInput {
        mesh: None,
        base_size: 0,
        lambda: 0.5,
        features: None,
        common: Common::default(),
    }
}

#[cfg(feature = "gpu")]
fn maps_rows(gpu: &reparam_gpu::Gpu, input: &MapsInput) -> Result<Vec<crate::crosscheck::Row>> {
    use crate::maps::{build, detect_features, load_features, FeatureOptions, MapsOptions};
    let spec = input.mesh.as_deref().unwrap_or("procedural:torus");
    let mesh = super::maps::load(spec)?;
    crate::crosscheck::check_f32_range(&mesh.name, &mesh.positions)?;
    let features = match input.features.as_deref() {
        None => Default::default(),
        Some("auto") => detect_features(&mesh, &FeatureOptions::default()),
        Some(path) => load_features(std::path::Path::new(path))?,
    };
    let options = MapsOptions {
        lambda: input.lambda,
        base_size: input.base_size,
        ..Default::default()
    };
    let maps = build(&mesh, &features, &options)?;
    crate::crosscheck::maps::crosscheck_maps(gpu, &mesh.name, &maps, &options)
}

/// The built-in skinned tube (12 × 12), 4 uniform poses per clip.
pub fn default_skinsimp_input() -> SkinsimpInput {
    SkinsimpInput {
        model: None,
        poses: "4".into(),
        common: Common::default(),
    }
}

#[cfg(feature = "gpu")]
fn skinsimp_rows(
    gpu: &reparam_gpu::Gpu,
    input: &SkinsimpInput,
) -> Result<Vec<crate::crosscheck::Row>> {
    use crate::skinsimp::poses::{select_poses, skinned_input};
    let model = match &input.model {
        Some(path) => crate::mesh::load_gltf(path)?,
        None => crate::skinsimp::tube::skinned_tube(12, 12),
    };
    let sets = select_poses(&model, &super::skinsimp::parse_poses(&input.poses)?)?;
    let skinned = skinned_input(&model, &sets.training)?;
    let name = match &input.model {
        Some(p) => p.display().to_string(),
        None => model.mesh.name.clone(),
    };
    crate::crosscheck::skinsimp::crosscheck_skinsimp(gpu, &name, &skinned)
}

/// The demo report's cross-check section: per algorithm, its table on built-in data with the
/// adapter named, the bound formulas and notes, then every sweep's table and plot (written to
/// `out/crosscheck/`).
#[cfg(feature = "gpu")]
pub fn report_section(out: &std::path::Path, report: &mut crate::report::Report) -> Result<()> {
    use crate::crosscheck::run::text_table;
    report.section("Cross-check — every f32 GPU kernel against the f64 reference");
    let gpu = match reparam_gpu::Gpu::new() {
        Ok(gpu) => gpu,
        Err(e) => {
            outln!("crosscheck: no GPU adapter, section skipped ({e})");
            report.paragraph(&format!("Skipped: {e}"));
            return Ok(());
        }
    };
    outln!("crosscheck: every kernel on built-in data, and the sweeps");
    report.paragraph(&format!(
        "`reparam crosscheck all` on this machine. Adapter: **{}**. Each kernel runs on the GPU \
         and in f64 on the CPU from identical (f32-rounded) inputs; a row gives the count \
         compared, the error in the kernel's natural unit (max, p50, p99, RMS), the derived bound \
         (its value: the bound, or the median of per-element bounds, marked ~), how many \
         elements exceed it, the verdict, and the times: GPU dispatches alone, the whole GPU call \
         with uploads and readback, and the f64 reference on {} threads. ε = u = 2⁻²³ (one WGSL rounding, up or down).",
        gpu.adapter_summary(),
        rayon::current_num_threads()
    ));
    let algorithms = [
        ("BPM", Algorithm::Bpm(BpmInput::default())),
        (
            "gridwarp",
            Algorithm::Gridwarp(GridwarpInput {
                args: default_gridwarp_args()?,
                sweep: false,
            }),
        ),
        (
            "unwarp",
            Algorithm::Unwarp(UnwarpInput {
                args: default_unwarp_args()?,
                sweep: false,
            }),
        ),
        ("maps", Algorithm::Maps(default_maps_input())),
        ("skinsimp", Algorithm::Skinsimp(default_skinsimp_input())),
    ];
    for (title, algorithm) in &algorithms {
        let rows = rows_for(&gpu, algorithm)?;
        let rounded: Vec<_> = rows.iter().map(|r| r.rounded(3)).collect();
        let (header, body, notes) = text_table(&rounded);
        report.paragraph(&format!("**{title}** (adapter: {})", gpu.adapter_summary()));
        report.table(
            &header.iter().map(String::as_str).collect::<Vec<_>>(),
            &body,
        );
        report.paragraph(&notes.join("  \n"));
    }
    let (sweeps, plots) = sweeps(
        &gpu,
        &Algorithm::All(Common::default()),
        &out.join("crosscheck"),
    )?;
    report.paragraph(
        "Stability sweeps: the error against a conditioning parameter, with the derived bound \
         (dashed). Where a measured line crosses its bound, f32 is no longer enough.",
    );
    for (sweep, plot) in sweeps.iter().zip(&plots) {
        let (header, rows) = sweep.table();
        report.paragraph(&format!("**{}**", sweep.title));
        report.table(
            &header.iter().map(String::as_str).collect::<Vec<_>>(),
            &rows,
        );
        let relative = std::path::Path::new(plot)
            .strip_prefix(out)
            .map_or(plot.clone(), |p| p.display().to_string());
        report.image(&sweep.title, &relative);
    }
    Ok(())
}
