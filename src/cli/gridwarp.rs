//! `reparam gridwarp`: solve a built-in scene or a mesh sequence (OBJ frames, skinned glTF) over
//! one or more texture-space ROIs, frame by frame, with the axis-aligned or the
//! non-axis-aligned variant; write pictures, every frame's grid (JSON) and the statistics.

use std::path::{Path, PathBuf};

use crate::gridwarp::energy_naa::DeformedJacobian;
use crate::gridwarp::merit::{rigid_stretch, rigid_stretch_naa, RigidStretch};
use crate::gridwarp::picture::{
    atlas_texture, detail_texture, grid_overlay, remap_mesh_uvs, render_remapped,
    render_remapped_framed, rigid_faces, roi_crop, stretch_map, surface_mesh,
};
use crate::gridwarp::rasterize::{
    frames_fields, rigidity_from_image, rigidity_from_image_of_size, texel_map, Roi,
};
use crate::gridwarp::remap::check_disjoint;
use crate::gridwarp::rigidity::{parse_discs, rigidity_from_texture, AutoRigidityOptions};
use crate::gridwarp::scene::{analytic_scene, disc_rigidity, partials_of, AnalyticScene, SCENES};
use crate::gridwarp::{
    grid_from_rigidity, solve_naa_sequence, solve_sequence, AtlasRemap, Grid, NaaModel, Remap,
    SolveOptions, VertexGrid, Warped,
};
use crate::gridwarp::{DeformedFields, Field, RestFields};
use crate::lm::{LmOptions, LmReport, StopCode};
use crate::mesh::{load_gltf, load_gltf_base_colour, load_obj, write_obj, TriMesh};
use crate::report::sig;
use crate::texture::{load_rgba8, save_png, side_by_side, Image};
use crate::{Error, Result};
use clap::{Args, ValueEnum};
use nalgebra::Vector3;
use serde::Serialize;

/// Which energy to minimise.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Variant {
    /// Axis-aligned lines (seed §5).
    #[default]
    Aa,
    /// Non-axis-aligned vertices, bilinear cells (seed §8).
    Naa,
}

/// LM's model Hessian for the non-axis-aligned variant ([`NaaModel`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Model {
    /// JᵀJ (Gauss–Newton), the paper's.
    #[default]
    GaussNewton,
    /// JᵀJ + Σ r∇²r: far fewer iterations on most scenes, more on some (the worm).
    Newton,
    /// The better predicting of the two, chosen per iteration (NL2SOL's rule).
    Adaptive,
}

impl From<Model> for NaaModel {
    fn from(model: Model) -> NaaModel {
        match model {
            Model::GaussNewton => NaaModel::GaussNewton,
            Model::Newton => NaaModel::Newton,
            Model::Adaptive => NaaModel::Adaptive,
        }
    }
}

/// Seed §10.2 boundary blending: `auto` = on for mesh inputs whose ROI is smaller than the
/// texture (the seam would show on the surface), off for the built-in scenes (their ROI is the
/// whole surface).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Blend {
    #[default]
    Auto,
    On,
    Off,
}

#[derive(Args, Clone)]
pub struct GridwarpArgs {
    /// Built-in scene (ignored with --gltf or --obj).
    #[arg(long, default_value = "bump", value_parser = clap::builder::PossibleValuesParser::new(SCENES))]
    pub scene: String,
    /// A skinned glTF/GLB: `--frames` poses of `--animation` at uniform times over its duration.
    #[arg(long)]
    pub gltf: Option<PathBuf>,
    /// Animation of --gltf (default: the first).
    #[arg(long)]
    pub animation: Option<String>,
    /// OBJ frames with the same connectivity and UVs; the first is the rest pose.
    #[arg(long, num_args = 2..)]
    pub obj: Vec<PathBuf>,
    /// Texture-space region of interest u0,u1,v0,v1 (with --gltf / --obj); repeat for several
    /// ROIs (they must not overlap). Default: the whole texture.
    #[arg(long)]
    pub roi: Vec<String>,
    /// Rigidity: a map (PNG 8/16-bit or EXR, values in [0, 1]), `auto` (from the model's
    /// base-colour texture, see `gridwarp::rigidity`), or `discs:s,t,r;…` (rigid discs in ROI
    /// coordinates). Give one per ROI, or one shared by all (a shared image covers the whole
    /// texture; a per-ROI image covers its ROI). Default: R ≡ 1 (with `--grid auto`, no
    /// interior line: nothing to warp).
    #[arg(long)]
    pub rigidity: Vec<String>,
    /// Axis-aligned lines or non-axis-aligned vertices.
    #[arg(long, value_enum, default_value_t = Variant::Aa)]
    pub variant: Variant,
    /// NAA: let the border vertices slide along the ROI's edges.
    #[arg(long)]
    pub sliding_border: bool,
    /// Boundary blending (seed §10.2) in the textures of the pictures.
    #[arg(long, value_enum, default_value_t = Blend::Auto)]
    pub boundary_blend: Blend,
    /// Number of frames (scenes: the deformation grows to its full amount over them).
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
    /// Non-axis-aligned variant only: LM's model Hessian, Gauss–Newton's JᵀJ (the paper's),
    /// JᵀJ + Σ r∇²r (the residuals' curvature too), or the better of the two per iteration.
    #[arg(long, value_enum, default_value_t = Model::GaussNewton)]
    pub naa_model: Model,
    /// Output folder.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Print machine-readable results.
    #[arg(long)]
    pub json: bool,
}

impl Default for GridwarpArgs {
    fn default() -> Self {
        GridwarpArgs {
            scene: "bump".into(),
            gltf: None,
            animation: None,
            obj: Vec::new(),
            roi: Vec::new(),
            rigidity: Vec::new(),
            variant: Variant::Aa,
            sliding_border: false,
            boundary_blend: Blend::Auto,
            frames: 6,
            size: 128,
            grid: "auto".into(),
            epsilon: 0.5,
            samples: 8,
            smoothness: None,
            paper: false,
            naa_model: Model::GaussNewton,
            out: PathBuf::from("out"),
            json: false,
        }
    }
}

/// Per-frame figures of one ROI.
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

/// One ROI's solve.
#[derive(Clone, Debug, Serialize)]
pub struct RoiResult {
    /// [u0, u1, v0, v1].
    pub roi: [f64; 4],
    pub unknowns: usize,
    pub rest_grid: Grid,
    pub frames: Vec<FrameStats>,
    /// AA: the lines of every frame.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub grids: Vec<Grid>,
    /// NAA: the vertices of every frame.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub vertices: Vec<VertexGrid>,
}

impl RoiResult {
    /// The warp of frame `k`.
    pub fn warped(&self, k: usize) -> Warped {
        match self.grids.get(k) {
            Some(g) => Warped::Lines(g.clone()),
            None => self
                .vertices
                .get(k)
                .map_or(Warped::Lines(self.rest_grid.clone()), |v| {
                    Warped::Vertices(v.clone())
                }),
        }
    }
}

/// Per-frame totals over all ROIs (the paper's "combined times", Table 1 aa-face49-all).
#[derive(Clone, Debug, Serialize)]
pub struct CombinedFrame {
    pub frame: usize,
    pub seconds: f64,
    pub iterations: usize,
    pub energy_evaluations: usize,
    pub jacobian_evaluations: usize,
}

/// Everything `reparam gridwarp --json` prints.
#[derive(Clone, Debug, Serialize)]
pub struct GridwarpResult {
    pub scene: String,
    pub variant: Variant,
    /// LM's model Hessian for the non-axis-aligned variant (`--naa-model`; the axis-aligned one
    /// always uses Gauss–Newton).
    pub naa_model: NaaModel,
    pub rois: Vec<RoiResult>,
    pub combined: Vec<CombinedFrame>,
    /// The frame the render pictures show (the most stretched one before the warp).
    pub pictured_frame: usize,
    pub pictures: Vec<PathBuf>,
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

/// The starting grid: Algorithm 1 on `rigidity` or the user's uniform grid.
fn starting_grid(args: &GridwarpArgs, rigidity: &Field) -> Result<Grid> {
    match args.grid.as_str() {
        "auto" => Ok(grid_from_rigidity(rigidity, args.epsilon)),
        spec => parse_grid_spec(spec),
    }
}

pub(super) fn solve_options(args: &GridwarpArgs) -> SolveOptions {
    SolveOptions {
        samples: (args.samples, args.samples),
        lm: if args.paper {
            LmOptions::paper()
        } else {
            LmOptions::default()
        },
        smoothness: args.smoothness,
        looping: false,
        naa_model: args.naa_model.into(),
    }
}

pub(super) fn check_sizes(args: &GridwarpArgs) -> Result<()> {
    if args.size < 2 || args.samples == 0 || args.frames == 0 {
        return Err(Error::InvalidArgument(
            "--size must be ≥ 2, --samples ≥ 1 and --frames ≥ 1".into(),
        ));
    }
    if args.naa_model != Model::GaussNewton && args.variant == Variant::Aa {
        return Err(Error::InvalidArgument(
            "--naa-model applies to the non-axis-aligned variant only (add --variant naa)".into(),
        ));
    }
    Ok(())
}

/// Solve the scene (or the mesh input) and write its pictures; shared by the command and the demo.
pub fn solve_scene(args: &GridwarpArgs) -> Result<GridwarpResult> {
    check_sizes(args)?;
    if args.gltf.is_some() || !args.obj.is_empty() {
        return solve_meshes(args);
    }
    if !args.roi.is_empty() || !args.rigidity.is_empty() {
        return Err(Error::InvalidArgument(
            "--roi and --rigidity apply to mesh inputs (--gltf, --obj); a built-in scene has its own"
                .into(),
        ));
    }
    let scene = analytic_scene(&args.scene, args.frames)
        .ok_or_else(|| Error::InvalidArgument(format!("unknown scene '{}'", args.scene)))?;
    let fields = scene.fields(args.size);
    let jacobians = scene_jacobians(args, &scene);
    let rest_grid = starting_grid(args, &scene.rigidity)?;
    let roi = solve_roi(
        args,
        Roi::full(),
        &fields.rest,
        rest_grid,
        &fields.frames,
        &jacobians,
    )?;
    let pictured = most_stretched_frame(std::slice::from_ref(&roi));
    let blend = args.boundary_blend == Blend::On;
    let remap = Remap::new(roi.rest_grid.clone(), roi.warped(pictured)).with_boundary_blend(blend);
    let pictures = write_scene_pictures(args, &scene, pictured, &remap)?;
    Ok(GridwarpResult {
        scene: args.scene.clone(),
        variant: args.variant,
        naa_model: solve_options(args).naa_model,
        combined: combine(std::slice::from_ref(&roi)),
        rois: vec![roi],
        pictured_frame: pictured,
        pictures,
    })
}

/// Solve one ROI's sequence with the chosen variant and measure every frame.
fn solve_roi(
    args: &GridwarpArgs,
    roi: Roi,
    rest: &RestFields,
    rest_grid: Grid,
    frames: &[DeformedFields],
    jacobians: &[DeformedJacobian],
) -> Result<RoiResult> {
    let options = solve_options(args);
    let lattice = 256;
    let stats = |k: usize, lm: &LmReport, rest_energy, seconds, before, after| FrameStats {
        frame: k,
        rigid_stretch_before: before,
        rigid_stretch_after: after,
        energy_before: rest_energy,
        energy_after: lm.energy,
        seconds,
        iterations: lm.iterations,
        energy_evaluations: lm.energy_evaluations,
        jacobian_evaluations: lm.jacobian_evaluations,
        stop: lm.stop,
    };
    let roi_box = [roi.u0, roi.u1, roi.v0, roi.v1];
    match args.variant {
        Variant::Aa => {
            let solutions = solve_sequence(rest, &rest_grid, frames, &options)?;
            let frames = solutions
                .iter()
                .zip(frames)
                .enumerate()
                .map(|(k, (s, d))| {
                    let before = rigid_stretch(rest, d, &rest_grid, &rest_grid, lattice);
                    let after = rigid_stretch(rest, d, &rest_grid, &s.grid, lattice);
                    stats(k, &s.lm, s.rest_energy, s.seconds, before, after)
                })
                .collect();
            Ok(RoiResult {
                roi: roi_box,
                unknowns: rest_grid.unknowns(),
                frames,
                grids: solutions.into_iter().map(|s| s.grid).collect(),
                vertices: Vec::new(),
                rest_grid,
            })
        }
        Variant::Naa => {
            let start = VertexGrid::from_grid(&rest_grid).with_sliding_border(args.sliding_border);
            let solutions = solve_naa_sequence(rest, &rest_grid, &start, jacobians, &options)?;
            let frames = solutions
                .iter()
                .zip(jacobians)
                .enumerate()
                .map(|(k, (s, d))| {
                    let before = rigid_stretch_naa(rest, d, &rest_grid, &start, lattice);
                    let after = rigid_stretch_naa(rest, d, &rest_grid, &s.vertices, lattice);
                    stats(k, &s.lm, s.rest_energy, s.seconds, before, after)
                })
                .collect();
            Ok(RoiResult {
                roi: roi_box,
                unknowns: start.unknowns(),
                frames,
                grids: Vec::new(),
                vertices: solutions.into_iter().map(|s| s.vertices).collect(),
                rest_grid,
            })
        }
    }
}

/// Sums over the ROIs, frame by frame.
fn combine(rois: &[RoiResult]) -> Vec<CombinedFrame> {
    let frames = rois.iter().map(|r| r.frames.len()).max().unwrap_or(0);
    (0..frames)
        .map(|k| {
            let of = |f: &dyn Fn(&FrameStats) -> f64| -> f64 {
                rois.iter().filter_map(|r| r.frames.get(k)).map(f).sum()
            };
            CombinedFrame {
                frame: k,
                seconds: of(&|f| f.seconds),
                iterations: of(&|f| f.iterations as f64) as usize,
                energy_evaluations: of(&|f| f.energy_evaluations as f64) as usize,
                jacobian_evaluations: of(&|f| f.jacobian_evaluations as f64) as usize,
            }
        })
        .collect()
}

/// The frame whose rigid content is most stretched without the warp (largest mean over ROIs).
fn most_stretched_frame(rois: &[RoiResult]) -> usize {
    let frames = rois.iter().map(|r| r.frames.len()).max().unwrap_or(0);
    (0..frames)
        .map(|k| {
            let total: f64 = rois
                .iter()
                .filter_map(|r| r.frames.get(k))
                .map(|f| f.rigid_stretch_before.mean)
                .sum();
            (k, total)
        })
        .fold(
            (0, f64::NEG_INFINITY),
            |best, x| {
                if x.1 > best.1 {
                    x
                } else {
                    best
                }
            },
        )
        .0
}

/// `u0,u1,v0,v1` → a checked [`Roi`].
pub fn parse_roi(spec: &str) -> Result<Roi> {
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

/// The rest mesh, the deformed frames, a name, and the model's colour texture if it has one.
type Frames = (TriMesh, Vec<TriMesh>, String, Option<Image<[u8; 4]>>);

/// The rest mesh and the deformed frames from --gltf (poses at uniform times) or --obj.
fn load_frames(args: &GridwarpArgs) -> Result<Frames> {
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
        let texture = load_gltf_base_colour(path)?;
        return Ok((skinned.mesh, frames, stem, texture));
    }
    let meshes = args
        .obj
        .iter()
        .map(|p| load_obj(p))
        .collect::<Result<Vec<_>>>()?;
    let stem = args.obj[0]
        .file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
    let texture = match &meshes[0].texture {
        Some(path) => Some(load_rgba8(path)?),
        None => None,
    };
    Ok((meshes[0].clone(), meshes[1..].to_vec(), stem, texture))
}

/// The rigidity map of ROI `k` of `rois` from the `--rigidity` words (see [`GridwarpArgs`]).
fn roi_rigidity(
    args: &GridwarpArgs,
    rois: &[Roi],
    k: usize,
    rest: &TriMesh,
    texture: Option<&Image<[u8; 4]>>,
) -> Result<Field> {
    let size = (args.size, args.size);
    let shared = args.rigidity.len() == 1 && rois.len() > 1;
    let spec = match args.rigidity.len() {
        0 => return Ok(Field::constant(1.0)),
        1 => &args.rigidity[0],
        n if n == rois.len() => &args.rigidity[k],
        n => {
            return Err(Error::InvalidArgument(format!(
                "{n} --rigidity values for {} ROIs: give one per ROI or one shared by all",
                rois.len()
            )))
        }
    };
    let roi = &rois[k];
    if spec == "auto" {
        let texture = texture.ok_or_else(|| {
            Error::InvalidArgument(
                "--rigidity auto needs the model's colour texture (glTF base colour or the OBJ's map_Kd)"
                    .into(),
            )
        })?;
        let map = texel_map(rest, roi, size)?;
        return rigidity_from_texture(
            texture,
            roi,
            size,
            Some(&map.covered),
            &AutoRigidityOptions::default(),
        );
    }
    if let Some(discs) = spec.strip_prefix("discs:") {
        return Ok(disc_rigidity(args.size, &parse_discs(discs)?, 0.1));
    }
    let path = Path::new(spec);
    // A shared image covers the whole texture, a per-ROI one its ROI; with a known texture its
    // size must match the region it covers (±1 pixel of rounding).
    let cover = if shared { Roi::full() } else { *roi };
    match texture {
        Some(t) => {
            let (du, dv) = cover.size();
            let expected = (
                (du * t.width as f64).round() as usize,
                (dv * t.height as f64).round() as usize,
            );
            rigidity_from_image_of_size(path, shared.then_some(roi), size, expected, 1)
        }
        None => rigidity_from_image(path, shared.then_some(roi), size),
    }
}

/// One axis-aligned warp problem: a ROI's (or a scene's) rest fields, starting grid and frames.
pub struct WarpInput {
    pub name: String,
    pub rest: RestFields,
    pub rest_grid: Grid,
    pub frames: Vec<DeformedFields>,
    /// The frames' D_s, D_t for the non-axis-aligned variant (empty for `--variant aa`).
    pub jacobians: Vec<DeformedJacobian>,
}

/// The scene's frames as D_s, D_t for `--variant naa` (empty for `--variant aa`).
fn scene_jacobians(args: &GridwarpArgs, scene: &AnalyticScene) -> Vec<DeformedJacobian> {
    match args.variant {
        Variant::Aa => Vec::new(),
        Variant::Naa => scene
            .frames
            .iter()
            .map(|x| DeformedJacobian::from_partials(args.size, |s, t| partials_of(&**x, s, t)))
            .collect(),
    }
}

/// The problems `args` describes, without solving them (what `crosscheck gridwarp` compares):
/// the built-in scene, or per ROI of a mesh input the rasterised fields, its rigidity and the
/// starting grid, exactly as `reparam gridwarp` builds them.
pub fn warp_inputs(args: &GridwarpArgs) -> Result<Vec<WarpInput>> {
    check_sizes(args)?;
    if args.gltf.is_none() && args.obj.is_empty() {
        let scene = analytic_scene(&args.scene, args.frames)
            .ok_or_else(|| Error::InvalidArgument(format!("unknown scene '{}'", args.scene)))?;
        let fields = scene.fields(args.size);
        return Ok(vec![WarpInput {
            name: args.scene.clone(),
            rest_grid: starting_grid(args, &scene.rigidity)?,
            rest: fields.rest,
            frames: fields.frames,
            jacobians: scene_jacobians(args, &scene),
        }]);
    }
    let rois = parse_rois(args)?;
    let (rest_mesh, frame_meshes, stem, texture) = load_frames(args)?;
    let size = (args.size, args.size);
    let mut inputs = Vec::new();
    for (k, roi) in rois.iter().enumerate() {
        let fields = frames_fields(&rest_mesh, &frame_meshes, roi, size)?;
        let rigidity = roi_rigidity(args, &rois, k, &rest_mesh, texture.as_ref())?;
        inputs.push(WarpInput {
            name: if rois.len() > 1 {
                format!("{stem} roi{k}")
            } else {
                stem.clone()
            },
            rest_grid: starting_grid(args, &rigidity)?,
            rest: fields.rest_fields(rigidity),
            frames: fields.frames,
            jacobians: match args.variant {
                Variant::Aa => Vec::new(),
                Variant::Naa => fields.jacobians,
            },
        });
    }
    Ok(inputs)
}

/// The ROIs of `--roi` (default: the whole texture), checked to be disjoint.
fn parse_rois(args: &GridwarpArgs) -> Result<Vec<Roi>> {
    let rois: Vec<Roi> = if args.roi.is_empty() {
        vec![Roi::full()]
    } else {
        args.roi
            .iter()
            .map(|s| parse_roi(s))
            .collect::<Result<_>>()?
    };
    check_disjoint(&rois)?;
    Ok(rois)
}

/// gridwarp on real meshes: fields rasterised over each ROI in texture space, each ROI solved
/// independently frame by frame; pictures of the most stretched frame.
fn solve_meshes(args: &GridwarpArgs) -> Result<GridwarpResult> {
    let rois = parse_rois(args)?;
    let (rest_mesh, frame_meshes, stem, texture) = load_frames(args)?;
    let size = (args.size, args.size);
    let mut results = Vec::new();
    let mut rigidities = Vec::new();
    let mut stretch_inputs = Vec::new();
    for (k, roi) in rois.iter().enumerate() {
        let fields = frames_fields(&rest_mesh, &frame_meshes, roi, size)?;
        let rigidity = roi_rigidity(args, &rois, k, &rest_mesh, texture.as_ref())?;
        let rest = fields.rest_fields(rigidity.clone());
        let rest_grid = starting_grid(args, &rigidity)?;
        results.push(solve_roi(
            args,
            *roi,
            &rest,
            rest_grid,
            &fields.frames,
            &fields.jacobians,
        )?);
        rigidities.push(rigidity);
        stretch_inputs.push((rest, fields.frames));
    }
    let pictured = most_stretched_frame(&results);
    let pstem = picture_stem(args, &stem);
    let mut stretch_pictures = Vec::new();
    for (k, (rest, frames)) in stretch_inputs.iter().enumerate() {
        let path = args.out.join(format!("{pstem}_roi{k}_stretch.png"));
        save_png(&stretch_map(rest, &frames[pictured], 1.0, 512), &path)?;
        stretch_pictures.push(path);
    }
    let blend = match args.boundary_blend {
        Blend::On => true,
        Blend::Off => false,
        Blend::Auto => rois.iter().any(|r| !r.is_full()),
    };
    let remaps: Vec<(Roi, Remap)> = rois
        .iter()
        .zip(&results)
        .map(|(roi, r)| {
            let remap =
                Remap::new(r.rest_grid.clone(), r.warped(pictured)).with_boundary_blend(blend);
            (*roi, remap)
        })
        .collect();
    let atlas = AtlasRemap::new(remaps)?;
    let mut pictures = write_mesh_pictures(
        args,
        &pstem,
        &frame_meshes[pictured.min(frame_meshes.len() - 1)],
        texture.as_ref(),
        &rigidities,
        &atlas,
    )?;
    pictures.extend(stretch_pictures);
    Ok(GridwarpResult {
        scene: stem,
        variant: args.variant,
        naa_model: solve_options(args).naa_model,
        combined: combine(&results),
        rois: results,
        pictured_frame: pictured,
        pictures,
    })
}

/// File name stem of the pictures: the input's name, `_naa` for the non-axis-aligned variant.
fn picture_stem(args: &GridwarpArgs, name: &str) -> String {
    match args.variant {
        Variant::Aa => format!("gridwarp_{name}"),
        Variant::Naa => format!("gridwarp_{name}_naa"),
    }
}

/// (`name` is the picture stem.) Per ROI the grids over the detail texture (and over the model's
/// texture when it has one); the pictured frame rendered with the original | warped texture
/// lookup, with the detail atlas and with the model's texture, the camera framing the faces
/// on rigid content ([`rigid_faces`]); that frame as an OBJ with its UVs remapped per vertex (`_warped.obj`).
fn write_mesh_pictures(
    args: &GridwarpArgs,
    name: &str,
    mesh: &TriMesh,
    texture: Option<&Image<[u8; 4]>>,
    rigidities: &[Field],
    atlas: &AtlasRemap,
) -> Result<Vec<PathBuf>> {
    let stem = name;
    let mut pictures = Vec::new();
    for (k, ((roi, remap), rigidity)) in atlas.rois.iter().zip(rigidities).enumerate() {
        let mut panels = vec![grid_overlay(&detail_texture(rigidity, 512), remap)];
        if let Some(t) = texture {
            panels.push(grid_overlay(&roi_crop(t, roi, 512, 512), remap));
        }
        let path = args.out.join(format!("{stem}_roi{k}_grid.png"));
        save_png(&side_by_side(&panels.iter().collect::<Vec<_>>(), 8), &path)?;
        pictures.push(path);
    }
    let view = Vector3::new(-1.0, 0.3, 0.2);
    let lookup = |uv: [f64; 2]| atlas.lookup_uv(uv);
    let pairs: Vec<(&str, Image<[u8; 4]>)> = {
        let roi_maps: Vec<(Roi, &Field)> = atlas
            .rois
            .iter()
            .zip(rigidities)
            .map(|((roi, _), r)| (*roi, r))
            .collect();
        let mut v = vec![("render", atlas_texture(&roi_maps, 1024))];
        if let Some(t) = texture {
            v.push(("texture_render", t.clone()));
        }
        v
    };
    // The pictured frame with its UVs remapped per vertex (for other renderers).
    let obj = args.out.join(format!("{stem}_warped.obj"));
    let mut warped_mesh = remap_mesh_uvs(mesh, atlas);
    warped_mesh.texture = None;
    write_obj(&warped_mesh, &obj)?;
    pictures.push(obj);
    let roi_maps: Vec<(Roi, &Field)> = atlas
        .rois
        .iter()
        .zip(rigidities)
        .map(|((roi, _), r)| (*roi, r))
        .collect();
    let zoom = rigid_faces(mesh, &roi_maps);
    for (suffix, tex) in pairs {
        let original = render_remapped_framed(mesh, &zoom, &tex, view, 640, &|uv| uv);
        let warped = render_remapped_framed(mesh, &zoom, &tex, view, 640, &lookup);
        let path = args.out.join(format!("{stem}_{suffix}.png"));
        save_png(&side_by_side(&[&original, &warped], 8), &path)?;
        pictures.push(path);
    }
    Ok(pictures)
}

/// The texture with both grids, and the pictured frame rendered with the original | warped
/// lookup.
fn write_scene_pictures(
    args: &GridwarpArgs,
    scene: &AnalyticScene,
    frame: usize,
    remap: &Remap,
) -> Result<Vec<PathBuf>> {
    let stem = picture_stem(args, scene.name);
    let texture = detail_texture(&scene.rigidity, 512);
    let overlay = args.out.join(format!("{stem}_grid.png"));
    save_png(&grid_overlay(&texture, remap), &overlay)?;
    let surface = scene.frames.get(frame).unwrap_or(&scene.rest);
    let view = match scene.name {
        "worm" => Vector3::new(0.2, -0.3, 1.0),
        _ => Vector3::new(0.25, -0.6, 1.0),
    };
    let mesh = surface_mesh(&**surface, 160);
    let original = render_remapped(&mesh, &texture, view, 480, &|uv| uv);
    let warped = render_remapped(&mesh, &texture, view, 480, &|uv| remap.lookup(uv));
    let render = args.out.join(format!("{stem}_render.png"));
    save_png(&side_by_side(&[&original, &warped], 8), &render)?;
    Ok(vec![overlay, render])
}

pub fn run(args: GridwarpArgs) -> Result<()> {
    std::fs::create_dir_all(&args.out).map_err(|e| Error::io(&args.out, e))?;
    let result = solve_scene(&args)?;
    let lines = args
        .out
        .join(format!("{}_lines.json", picture_stem(&args, &result.scene)));
    let grids: Vec<serde_json::Value> = result
        .rois
        .iter()
        .map(|r| {
            serde_json::json!({
                "roi": r.roi,
                "rest_grid": r.rest_grid,
                "grids": r.grids,
                "vertices": r.vertices,
            })
        })
        .collect();
    let text =
        serde_json::to_string_pretty(&grids).map_err(|e| Error::InvalidArgument(e.to_string()))?;
    std::fs::write(&lines, text).map_err(|e| Error::io(&lines, e))?;
    if args.json {
        return super::print_json(&result);
    }
    outln!(
        "{} ({}): {} ROI(s), {} frames",
        result.scene,
        match result.variant {
            Variant::Aa => "axis-aligned",
            Variant::Naa => "non-axis-aligned",
        },
        result.rois.len(),
        result.combined.len()
    );
    for (k, r) in result.rois.iter().enumerate() {
        outln!(
            "ROI {k} u [{}, {}] x v [{}, {}]: {} unknowns (rest grid {}×{} lines)",
            r.roi[0],
            r.roi[1],
            r.roi[2],
            r.roi[3],
            r.unknowns,
            r.rest_grid.s.len(),
            r.rest_grid.t.len()
        );
        if r.unknowns == 0 {
            outln!("{}", NOTHING_TO_WARP);
        }
        outln!("{}", frame_table(&r.frames));
    }
    if result.rois.len() > 1 {
        outln!("all ROIs combined:");
        let header: Vec<String> = ["frame", "ms", "iterations", "evaluations (E + J)"]
            .iter()
            .map(|h| h.to_string())
            .collect();
        let rows: Vec<Vec<String>> = result
            .combined
            .iter()
            .map(|c| {
                vec![
                    c.frame.to_string(),
                    sig(c.seconds * 1e3, 3),
                    c.iterations.to_string(),
                    format!("{} + {}", c.energy_evaluations, c.jacobian_evaluations),
                ]
            })
            .collect();
        outln!("{}", super::text_table(&header, &rows));
    }
    outln!("pictures show frame {}", result.pictured_frame);
    for p in result.pictures.iter().chain([&lines]) {
        outln!("wrote {}", p.display());
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

/// Printed under a ROI without unknowns (Algorithm 1 on a uniform rigidity map, the default
/// R ≡ 1, places no interior line).
const NOTHING_TO_WARP: &str =
    "  nothing to warp: the starting grid has no interior line (Algorithm 1 \
     finds no rigidity boundary in a uniform map, e.g. the default R ≡ 1); give --rigidity (a map, \
     `auto` or `discs:…`) or a uniform grid --grid MxN";

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
