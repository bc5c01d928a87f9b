//! `reparam bpm render|qc`.

use std::path::PathBuf;
use std::time::Instant;

use crate::bpm::conformality::{
    conformality, conformality_report, Conformality, ConformalityOptions, ConformalityReport,
    FaceMeans,
};
use crate::bpm::quality::check_qc_size;
use crate::bpm::render::{render_cpu, s_picture, RenderOptions, SView};
use crate::bpm::{
    authors_vertex_owners, precompute, qc_protocol_faces, Bpm, BpmOptions, FaceQc, Fit, Interp,
    PrecomputeReport, QcStats, Unfold, VertexRule,
};
use crate::mesh::{Adjacency, TriMesh};
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

/// `--s-view`: where the s picture looks at the mesh from ([`SView`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum SViewArg {
    /// The 3D surface, from --view.
    #[default]
    Surface,
    /// The UV layout.
    Uv,
}

impl From<SViewArg> for SView {
    fn from(a: SViewArg) -> SView {
        match a {
            SViewArg::Surface => SView::Surface,
            SViewArg::Uv => SView::Uv,
        }
    }
}

/// The conformality picture's options, shared by `render` and `qc`.
#[derive(Args)]
pub struct SPictureArgs {
    /// Also write a PNG colouring every face by its cross-ratio mismatch s (the input map's
    /// distance from conformal, BPM's assumption), with a legend of the area shares.
    #[arg(long, value_name = "PNG")]
    pub s_picture: Option<PathBuf>,
    /// View of the s picture: the 3D surface (from --view) or the UV layout.
    #[arg(long, value_enum, default_value = "surface")]
    pub s_view: SViewArg,
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
    #[command(flatten)]
    pub s_picture: SPictureArgs,
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
    /// Neighbour layout: `authors` reproduces the authors' code and the published figures
    /// (their rotation, and their rule that each shared sub-vertex is evaluated once, by the
    /// face of its last occurrence in their subdivided face list).
    #[arg(long, value_enum, default_value = "correct")]
    pub unfold: UnfoldArg,
    /// Write the per-face figures as a NumPy .npy array, faces × 8 float64 columns: 0 BPM mean
    /// QC, 1 BPM max QC, 2 linear mean QC, 3 linear max QC (area-weighted over the face's
    /// sub-triangles; NaN for a degenerate face), 4 s (cross-ratio mismatch; NaN for a
    /// degenerate face), 5 3D area, 6 BPM folded sub-triangles, 7 linear folded sub-triangles.
    #[arg(long, value_name = "NPY")]
    pub per_face: Option<PathBuf>,
    /// With --json: include the per-face figures (`faces`: face, s, area, bpm and linear mean,
    /// max, folded).
    #[arg(long, requires = "json")]
    pub json_faces: bool,
    #[command(flatten)]
    pub s_picture: SPictureArgs,
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
    conformality: ConformalityReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    s_picture: Option<PathBuf>,
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
    check_extension(args.s_picture.s_picture.as_deref(), "png", "--s-picture")?;
    let mesh = load_mesh(&args.mesh)?;
    let bpm_options = BpmOptions {
        fit: args.fit.into(),
        unfold: args.unfold.into(),
        ..Default::default()
    };
    let bpm = precompute(&mesh, bpm_options)?;
    let texture = resolve_texture(&mesh, args.texture.as_deref())?;
    let measured = conformality(&mesh)?;
    let conformality = render_conformality_report(&mesh, &bpm, &measured)?;
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
    let s_picture_path = write_s_picture(
        &mesh,
        &measured,
        &args.s_picture,
        args.view,
        args.size,
        &conformality,
    )?;
    let result = RenderResult {
        mesh: mesh.name.clone(),
        output: args.output.clone(),
        backend: format!("{:?}", args.backend).to_lowercase(),
        interp: options.interp,
        unfold: bpm.options.unfold,
        width: options.width,
        height: options.height,
        precompute: bpm.report.clone(),
        conformality,
        s_picture: s_picture_path,
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
    print_conformality(&result.conformality, result.s_picture.as_deref());
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
    /// Which face evaluates a sub-vertex shared by several faces (BPM; linear is per face).
    vertex_rule: VertexRule,
    precompute: PrecomputeReport,
    linear: QcStats,
    bpm: QcStats,
    conformality: ConformalityReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    per_face: Option<PathBuf>,
    #[serde(skip_serializing_if = "Option::is_none")]
    s_picture: Option<PathBuf>,
    #[serde(skip_serializing_if = "Option::is_none")]
    faces: Option<Vec<FaceRow>>,
    seconds: f64,
}

/// One face in `--json-faces` (figures that do not exist, for a degenerate face, are absent).
#[derive(Serialize)]
struct FaceRow {
    face: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    s: Option<f64>,
    /// Absent when it overflows f64.
    #[serde(skip_serializing_if = "Option::is_none")]
    area: Option<f64>,
    bpm: FaceFigures,
    linear: FaceFigures,
}

#[derive(Serialize)]
struct FaceFigures {
    #[serde(skip_serializing_if = "Option::is_none")]
    mean: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    max: Option<f64>,
    folded: u32,
}

impl From<&FaceQc> for FaceFigures {
    fn from(q: &FaceQc) -> FaceFigures {
        FaceFigures {
            mean: q.mean.is_finite().then_some(q.mean),
            max: q.max.is_finite().then_some(q.max),
            folded: q.folded,
        }
    }
}

/// The protocol's figures for both interpolants, overall and per face.
struct QcRun {
    linear: QcStats,
    bpm: QcStats,
    linear_faces: Vec<FaceQc>,
    bpm_faces: Vec<FaceQc>,
    vertex_rule: VertexRule,
}

/// Run the QC protocol for linear interpolation and BPM; under the authors' unfolding BPM's
/// shared sub-vertices follow their vertex rule too ([`crate::bpm::vertex_rule`]).
fn run_qc(mesh: &TriMesh, bpm: &Bpm, subdiv: u32) -> QcRun {
    let vertex_rule = match bpm.options.unfold {
        Unfold::Correct => VertexRule::PerFace,
        Unfold::Authors => VertexRule::Authors,
    };
    let owners = match vertex_rule {
        VertexRule::PerFace => None,
        VertexRule::Authors => Some(authors_vertex_owners(mesh, &Adjacency::new(mesh), subdiv)),
    };
    let (linear, linear_faces) = qc_protocol_faces(bpm, Interp::Linear, subdiv, None);
    let (bpm_stats, bpm_faces) = qc_protocol_faces(bpm, Interp::Bpm, subdiv, owners.as_ref());
    QcRun {
        linear,
        bpm: bpm_stats,
        linear_faces,
        bpm_faces,
        vertex_rule,
    }
}

fn qc(args: QcArgs) -> Result<()> {
    check_extension(args.per_face.as_deref(), "npy", "--per-face")?;
    check_extension(args.s_picture.s_picture.as_deref(), "png", "--s-picture")?;
    let mesh = load_mesh(&args.mesh)?;
    check_qc_size(&mesh.name, mesh.faces.len(), args.subdiv)?;
    let start = Instant::now();
    let bpm = precompute(
        &mesh,
        BpmOptions {
            fit: args.fit.into(),
            unfold: args.unfold.into(),
            ..Default::default()
        },
    )?;
    let run = run_qc(&mesh, &bpm, args.subdiv);
    for stats in [&run.linear, &run.bpm] {
        check_measured(&mesh.name, &bpm.report, stats)?;
    }
    let measured = conformality(&mesh)?;
    let report = conformality_report(
        &measured,
        Some(FaceMeans {
            bpm: &run.bpm_faces,
            linear: &run.linear_faces,
        }),
        &ConformalityOptions::default(),
    );
    if let Some(path) = &args.per_face {
        save_npy_f64(
            path,
            mesh.face_count(),
            8,
            &per_face_values(&run, &measured),
        )?;
    }
    let default_view = RenderOptions::default().view_dir;
    let s_picture_path = write_s_picture(
        &mesh,
        &measured,
        &args.s_picture,
        default_view,
        (768, 768),
        &report,
    )?;
    let result = QcResult {
        mesh: mesh.name.clone(),
        subdiv: args.subdiv,
        unfold: bpm.options.unfold,
        vertex_rule: run.vertex_rule,
        precompute: bpm.report.clone(),
        faces: args.json_faces.then(|| face_rows(&run, &measured)),
        linear: run.linear,
        bpm: run.bpm,
        conformality: report,
        per_face: args.per_face.clone(),
        s_picture: s_picture_path,
        seconds: start.elapsed().as_secs_f64(),
    };
    if args.json {
        return super::print_json(&result);
    }
    print_precompute_report(&bpm.report);
    outln!(
        "QC = σmax/σmin over {} sub-triangles ({} subdivisions per face, {:?} unfolding, {:?} \
         vertex rule), area-weighted:",
        result.bpm.sub_triangles,
        args.subdiv,
        result.unfold,
        result.vertex_rule
    );
    outln!("{}", qc_table(&[&result.linear, &result.bpm]));
    print_conformality(&result.conformality, result.s_picture.as_deref());
    if let Some(path) = &result.per_face {
        outln!(
            "wrote the per-face figures to {} (faces × 8, see --help)",
            path.display()
        );
    }
    outln!("({} s)", sig(result.seconds, 3));
    Ok(())
}

/// `--per-face`: faces × 8 float64 (columns in [`QcArgs::per_face`]'s help), row-major.
fn per_face_values(run: &QcRun, measured: &Conformality) -> Vec<f64> {
    let faces = run.bpm_faces.len();
    let mut values = Vec::with_capacity(8 * faces);
    for f in 0..faces {
        let (b, l) = (&run.bpm_faces[f], &run.linear_faces[f]);
        values.extend([
            b.mean,
            b.max,
            l.mean,
            l.max,
            measured.face_s[f],
            measured.face_area[f],
            b.folded as f64,
            l.folded as f64,
        ]);
    }
    values
}

/// Write `values` as a little-endian float64 C-order `.npy` array of shape `rows × columns`.
fn save_npy_f64(path: &std::path::Path, rows: usize, columns: usize, values: &[f64]) -> Result<()> {
    use npyz::WriterBuilder;
    let io = |e: std::io::Error| crate::Error::io(path, e);
    let mut bytes = Vec::new();
    let mut writer = npyz::WriteOptions::<f64>::new()
        .default_dtype()
        .shape(&[rows as u64, columns as u64])
        .writer(&mut bytes)
        .begin_nd()
        .map_err(io)?;
    writer.extend(values.iter().copied()).map_err(io)?;
    writer.finish().map_err(io)?;
    std::fs::write(path, bytes).map_err(io)
}

fn face_rows(run: &QcRun, measured: &Conformality) -> Vec<FaceRow> {
    (0..run.bpm_faces.len())
        .map(|f| FaceRow {
            face: f,
            s: Some(measured.face_s[f]).filter(|s| s.is_finite()),
            area: Some(measured.face_area[f]).filter(|a| a.is_finite()),
            bpm: (&run.bpm_faces[f]).into(),
            linear: (&run.linear_faces[f]).into(),
        })
        .collect()
}

/// `render`'s conformality report: the s distribution, and when it warns, BPM's and linear's
/// QC where s ≥ 1 from the protocol at its default 4 subdivisions (left out, with a pointer
/// to `bpm qc`, when the mesh is too large for it).
fn render_conformality_report(
    mesh: &TriMesh,
    bpm: &Bpm,
    measured: &Conformality,
) -> Result<ConformalityReport> {
    let options = ConformalityOptions::default();
    let warn = crate::bpm::conformality::needs_warning(measured, &options);
    if !warn || check_qc_size(&mesh.name, mesh.faces.len(), RENDER_QC_SUBDIV).is_err() {
        return Ok(conformality_report(measured, None, &options));
    }
    let run = run_qc(mesh, bpm, RENDER_QC_SUBDIV);
    Ok(conformality_report(
        measured,
        Some(FaceMeans {
            bpm: &run.bpm_faces,
            linear: &run.linear_faces,
        }),
        &options,
    ))
}

/// Subdivisions of the QC `render` runs for its conformality warning (the `qc` default).
const RENDER_QC_SUBDIV: u32 = 4;

/// Write the s picture when asked; returns its path.
fn write_s_picture(
    mesh: &TriMesh,
    measured: &Conformality,
    args: &SPictureArgs,
    view_dir: nalgebra::Vector3<f64>,
    size: (u32, u32),
    report: &ConformalityReport,
) -> Result<Option<PathBuf>> {
    let Some(path) = &args.s_picture else {
        return Ok(None);
    };
    let options = RenderOptions {
        width: size.0,
        height: size.1,
        view_dir,
        ..Default::default()
    };
    save_png(
        &s_picture(mesh, measured, args.s_view.into(), &options, &report.by_bin)?,
        path,
    )?;
    Ok(Some(path.clone()))
}

/// [`crate::Error::InvalidArgument`] unless `path` (when given) ends in `.extension`.
fn check_extension(path: Option<&std::path::Path>, extension: &str, flag: &str) -> Result<()> {
    match path {
        Some(p) if p.extension().and_then(|e| e.to_str()) != Some(extension) => {
            Err(crate::Error::InvalidArgument(format!(
                "{flag} {}: the file name must end in .{extension}",
                p.display()
            )))
        }
        _ => Ok(()),
    }
}

/// The conformality report in text: the s distribution (with each bin's QC when measured) and
/// the warning, if any.
fn print_conformality(report: &ConformalityReport, picture: Option<&std::path::Path>) {
    let d = &report.distribution;
    outln!(
        "input map conformality: s = max over a face's edges of |log(cr_uv / cr_3d)| (0 for a \
         discrete conformal map); area-weighted mean {}, max {}{}",
        sig(d.mean, 3),
        sig(d.max, 3),
        match d.unmeasured_faces {
            0 => String::new(),
            k => format!(", {k} degenerate faces left out"),
        }
    );
    outln!("{}", s_table(report));
    if let Some(path) = picture {
        outln!("wrote the s picture to {}", path.display());
    }
    if let Some(w) = &report.warning {
        outln!("warning: {}", w.message);
    }
}

/// One row per s bin: area share, faces, and (when measured) BPM's and linear's mean QC.
fn s_table(report: &ConformalityReport) -> String {
    let d = &report.distribution;
    let figure = |x: Option<f64>| x.map_or("-".to_string(), |v| sig(v, 4));
    let mut s = format!(
        "{:<12} {:>8} {:>7} {:>9} {:>9}\n",
        "s", "area %", "faces", "bpm QC", "linear QC"
    );
    for bin in 0..5 {
        let (bpm, linear) = match report.by_bin.get(bin) {
            Some(b) => (b.bpm_mean, b.linear_mean),
            None => (None, None),
        };
        s += &format!(
            "{:<12} {:>8} {:>7} {:>9} {:>9}\n",
            crate::bpm::conformality::S_BIN_LABELS[bin],
            sig(100.0 * d.area_share[bin], 3),
            d.faces[bin],
            figure(bpm),
            figure(linear)
        );
    }
    s
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
