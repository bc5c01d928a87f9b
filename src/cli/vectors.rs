//! `reparam vectors`: conformance vectors (`.npy` + `manifest.json`) of every kernel of an
//! algorithm, from built-in data or the user's own; `reparam verify`: judge a candidate's
//! outputs against them (exit 0 pass, 1 over a bound or NaN, 2 bad input).

use std::path::PathBuf;

use crate::vectors::{write_vectors, Array, KernelData};
use crate::{Error, Result};
use clap::{Args, Subcommand};

#[derive(Args)]
pub struct VectorsArgs {
    #[command(subcommand)]
    pub algorithm: VectorsAlgorithm,
    /// Folder for the vectors (created).
    #[arg(long, global = true, default_value = "out/vectors")]
    pub out: PathBuf,
    /// Also write reparam's own f32 GPU outputs there, one `<kernel>.npy` per kernel: a
    /// candidate that `reparam verify` should pass.
    #[arg(long, global = true)]
    pub gpu_candidate: Option<PathBuf>,
    /// Also run each kernel's f32 twin under the 7 arithmetic models a conforming GPU may use
    /// (nearest, FMA, reordered, the edge of the WGSL table, all at once) against the written
    /// vectors and print the worst error / bound per kernel and model: whether the bounds hold
    /// for every conforming GPU on this input. Exit 1 if one does not.
    #[arg(long, global = true)]
    pub twins: bool,
}

#[derive(Subcommand)]
pub enum VectorsAlgorithm {
    /// bpm_eval (BPM and linear): per-triangle data, samples, f64 UVs.
    Bpm {
        /// Mesh (OBJ with `vt`, or `procedural:<name>`). Default: procedural:bpm_conformance.
        #[arg(long, default_value = "procedural:bpm_conformance")]
        mesh: String,
    },
    /// gridwarp_aa: cell energies, F, JᵀJ, Jᵀr at one grid of the scene's last frame.
    Gridwarp {
        /// Built-in scene.
        #[arg(long, default_value = "bump")]
        scene: String,
        /// A skinned glTF/GLB instead (first ROI, last frame).
        #[arg(long)]
        gltf: Option<PathBuf>,
        #[arg(long)]
        animation: Option<String>,
        #[arg(long)]
        roi: Vec<String>,
        #[arg(long)]
        rigidity: Vec<String>,
        /// Field resolution.
        #[arg(long, default_value_t = 64)]
        size: usize,
        /// Samples per cell and axis.
        #[arg(long, default_value_t = 4)]
        samples: usize,
        /// Starting grid: `auto` or `MxN`.
        #[arg(long, default_value = "auto")]
        grid: String,
    },
    /// unwarp_pass: one pass (phase 0) from a state after two reference sweeps.
    Unwarp {
        /// Height map (PNG/EXR); default the built-in cones.
        input: Option<PathBuf>,
        #[arg(long, default_value_t = 32)]
        size: usize,
        #[arg(long, default_value_t = 0.05)]
        scale: f64,
    },
    /// maps_priority, maps_flatten (.points, .rings) on the rings of levels 0 and the middle one;
    /// maps_inverse: Π⁻¹ at the points of a uniform remesh; maps_run.
    Maps {
        /// The mesh (.obj, .ply, .off or procedural:NAME). Default: the demo's torus.
        #[arg(default_value = "procedural:torus")]
        mesh: String,
        /// Stop the hierarchy at this many base triangles (0: as coarse as possible).
        #[arg(long, default_value_t = 0)]
        base_size: usize,
        /// The points: each base triangle quadrisected J times.
        #[arg(long, default_value_t = 2)]
        uniform: u32,
    },
    /// skinsimp_lbs, skinsimp_quadrics (source, vertex) and skinsimp_collapse_cost.
    Skinsimp {
        /// A skinned glTF/GLB; default the built-in tube.
        model: Option<PathBuf>,
        #[arg(long, default_value = "4")]
        poses: String,
    },
}

/// The kernels, input name and (with `gpu`) reparam's own candidates.
type Made = (Vec<KernelData>, String, Vec<(String, Array)>);

fn make(algorithm: &VectorsAlgorithm, gpu: Option<&reparam_gpu::Gpu>) -> Result<Made> {
    match algorithm {
        VectorsAlgorithm::Bpm { mesh } => {
            let m = super::inputs::load_mesh(mesh)?;
            if m.uvs.is_empty() {
                return Err(Error::MissingUvs { mesh: m.name });
            }
            let kernels = crate::vectors::bpm::vectors(&m)?;
            let candidates = match gpu {
                Some(g) => {
                    let mut c = crate::vectors::bpm::gpu_candidates(g, &m)?;
                    // Not a kernel of its own: the seed's fit, to verify with --kernel bpm_eval.
                    c.push((
                        "bpm_eval.determinant_fit".into(),
                        crate::vectors::bpm::determinant_fit_candidate(g, &m)?,
                    ));
                    // The same fit's per-triangle data, to verify with --kernel bpm_precompute.
                    c.push((
                        "bpm_precompute.determinant_fit".into(),
                        crate::vectors::bpm::determinant_fit_maps_candidate(g, &m)?,
                    ));
                    c
                }
                None => Vec::new(),
            };
            Ok((kernels, mesh.clone(), candidates))
        }
        VectorsAlgorithm::Gridwarp {
            scene,
            gltf,
            animation,
            roi,
            rigidity,
            size,
            samples,
            grid,
        } => {
            let mut args = super::crosscheck::default_gridwarp_args()?;
            args.scene = scene.clone();
            args.gltf = gltf.clone();
            args.animation = animation.clone();
            args.roi = roi.clone();
            args.rigidity = rigidity.clone();
            args.size = *size;
            args.samples = *samples;
            args.grid = grid.clone();
            let input = super::gridwarp::warp_inputs(&args)?
                .into_iter()
                .next()
                .ok_or_else(|| Error::InvalidArgument("no ROI".into()))?;
            let (k, c) = crate::vectors::gridwarp::all_vectors(
                gpu,
                &input.rest,
                &input.rest_grid,
                &input.frames,
                &super::gridwarp::solve_options(&args),
            )?;
            Ok((k, input.name, c))
        }
        VectorsAlgorithm::Unwarp { input, size, scale } => {
            let heights = match input {
                Some(p) => crate::unwarp::load_height_map(p)?,
                None => crate::unwarp::procedural("cones", *size)?,
            };
            let options = crate::unwarp::UnwarpOptions {
                scale: *scale,
                ..Default::default()
            };
            let (k, c) = crate::vectors::unwarp::vectors(gpu, &heights, &options)?;
            let name = input
                .as_ref()
                .map_or(format!("cones {size}²"), |p| p.display().to_string());
            Ok((k, name, c))
        }
        VectorsAlgorithm::Maps {
            mesh,
            base_size,
            uniform,
        } => {
            let m = super::maps::load(mesh)?;
            let options = crate::maps::MapsOptions {
                base_size: *base_size,
                ..Default::default()
            };
            let built = crate::maps::build(&m, &Default::default(), &options)?;
            let remesh = crate::maps::remesh::uniform(&built, *uniform)?;
            let rings = crate::vectors::maps::RingSet::of(&built, &options);
            let (k, c) = crate::vectors::maps::all_vectors(gpu, &built, &remesh, &rings)?;
            Ok((k, mesh.clone(), c))
        }
        VectorsAlgorithm::Skinsimp { model, poses } => {
            use crate::skinsimp::poses::select_poses;
            let m = match model {
                Some(p) => crate::mesh::load_gltf(p)?,
                None => crate::skinsimp::tube::skinned_tube(12, 12),
            };
            let sets = select_poses(&m, &super::skinsimp::parse_poses(poses)?)?;
            let kernels = match gpu {
                Some(g) => Some(crate::skinsimp::gpu::SkinsimpKernels::new(g.clone())?),
                None => None,
            };
            let (k, c) = crate::vectors::skinsimp::all_vectors(&m, &sets, kernels.as_ref())?;
            let name = model
                .as_ref()
                .map_or(m.mesh.name.clone(), |p| p.display().to_string());
            Ok((k, name, c))
        }
    }
}

impl VectorsAlgorithm {
    /// The algorithm's name (`bpm`, `gridwarp`, …).
    pub fn name(&self) -> &'static str {
        match self {
            VectorsAlgorithm::Bpm { .. } => "bpm",
            VectorsAlgorithm::Gridwarp { .. } => "gridwarp",
            VectorsAlgorithm::Unwarp { .. } => "unwarp",
            VectorsAlgorithm::Maps { .. } => "maps",
            VectorsAlgorithm::Skinsimp { .. } => "skinsimp",
        }
    }
}

/// `reparam vectors`: write the vectors (and the GPU's candidates); with `--twins`, exit 1 when
/// a twin exceeds a bound under some model.
pub fn run(args: VectorsArgs) -> Result<u8> {
    let gpu = match &args.gpu_candidate {
        Some(_) => Some(reparam_gpu::Gpu::new().map_err(|e| Error::Gpu(e.to_string()))?),
        None => None,
    };
    let (kernels, input, candidates) = make(&args.algorithm, gpu.as_ref())?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let manifest = write_vectors(&args.out, &command, &input, &kernels)?;
    for k in &manifest.kernels {
        outln!(
            "{}: {} input arrays, expected {:?} ({}), bound {}",
            k.name,
            k.inputs.len(),
            k.expected.shape,
            k.metric.unit(),
            k.bound_formula
        );
    }
    outln!("wrote {}", args.out.join("manifest.json").display());
    if let Some(dir) = &args.gpu_candidate {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let adapter = gpu
            .as_ref()
            .map(|g| g.adapter_summary())
            .unwrap_or_default();
        for (name, array) in &candidates {
            let path = dir.join(format!("{name}.npy"));
            array.save(&path)?;
            outln!("GPU candidate ({adapter}): {}", path.display());
        }
    }
    if args.twins {
        return twins(&args, &manifest);
    }
    Ok(0)
}

/// `--twins`: the arithmetic-model table of the vectors just written.
fn twins(args: &VectorsArgs, manifest: &crate::vectors::Manifest) -> Result<u8> {
    use crate::crosscheck::sweep::{twin_model_sweep_of, twins_within_bounds};
    let algorithm = args.algorithm.name();
    let Some(sweep) = twin_model_sweep_of(algorithm, &args.out, manifest)? else {
        outln!("no kernel of {algorithm} has a twin runner");
        return Ok(0);
    };
    let (header, rows) = sweep.table();
    outln!("\n{}", sweep.title);
    outln!("{}", header.join(" | "));
    for row in rows {
        outln!("{}", row.join(" | "));
    }
    let within = twins_within_bounds(&sweep);
    outln!(
        "{}",
        if within {
            "every twin within its bounds under every model"
        } else {
            "FAIL: a twin exceeds a bound under some model"
        }
    );
    Ok(if within { 0 } else { 1 })
}

#[derive(Args)]
pub struct VerifyArgs {
    /// The vectors folder (with manifest.json).
    pub dir: PathBuf,
    /// The candidate's output (.npy, f32 or f64, the expected shape).
    #[arg(long, required_unless_present_any = ["shader", "print_abi"], conflicts_with = "shader")]
    pub candidate: Option<PathBuf>,
    /// Run this compute shader (.wgsl, .comp/.glsl GLSL 450, .spv SPIR-V) on the vectors'
    /// inputs, bound by the kernel's ABI (`--print-abi`), and judge its output.
    #[arg(long)]
    pub shader: Option<PathBuf>,
    #[command(flatten)]
    pub shader_options: super::shader::ShaderOptions,
    /// The kernel (default: the only one, or the candidate's file stem).
    #[arg(long)]
    pub kernel: Option<String>,
    /// Print machine-readable results.
    #[arg(long)]
    pub json: bool,
}

/// `reparam verify`: whether the candidate passes (exit 0 pass, 1 fail; `main` gives an error
/// status 2).
pub fn try_verify(args: &VerifyArgs) -> Result<bool> {
    use crate::report::sig;
    let candidate = match (&args.shader, &args.candidate) {
        (Some(shader), _) => return super::shader::verify_shader(args, shader),
        (None, _) if args.shader_options.print_abi => return super::shader::print_abi(args),
        (None, Some(c)) => c,
        (None, None) => {
            return Err(Error::InvalidArgument(
                "verify needs --candidate OUT.npy or --shader FILE".into(),
            ))
        }
    };
    let r = crate::vectors::verify::verify(&args.dir, candidate, args.kernel.as_deref())?;
    if args.json {
        super::print_json(&r)?;
    } else {
        print_verify(&r);
    }
    if super::stdout_gone() {
        eprintln!(
            "verify {}: {} (over {}, NaN/∞ {}, worst error/bound {}) (stdout closed)",
            r.kernel,
            if r.pass { "pass" } else { "FAIL" },
            r.over,
            r.non_finite,
            sig(r.worst_ratio, 3)
        );
    }
    Ok(r.pass)
}

/// The verify report as text: the summary table, the bound's formula and the worst elements.
pub(super) fn print_verify(r: &crate::vectors::verify::VerifyReport) {
    use crate::report::sig;
    let e = &r.errors;
    outln!(
        "kernel {} · candidate {} ({:?})",
        r.kernel,
        r.candidate,
        r.candidate_dtype
    );
    let header = [
        "count",
        "max",
        "p50",
        "p99",
        "RMS",
        "unit",
        "bound (largest)",
        "over",
        "NaN/∞",
        "verdict",
    ]
    .map(String::from)
    .to_vec();
    let row = vec![
        e.count.to_string(),
        sig(e.max_abs, 2),
        sig(e.p50, 2),
        sig(e.p99, 2),
        sig(e.rms, 2),
        e.unit.clone(),
        sig(r.bound_max, 2),
        e.over_tolerance.to_string(),
        e.non_finite.to_string(),
        if r.pass { "pass" } else { "FAIL" }.into(),
    ];
    outln!("{}", super::text_table(&header, &[row]));
    outln!("bound: {}", r.bound_formula);
    outln!("worst elements:");
    for w in &r.worst {
        let inputs: Vec<String> = w
            .inputs
            .iter()
            .map(|(name, v)| {
                let values: Vec<String> = v.iter().map(|x| sig(*x, 4)).collect();
                format!("{name} [{}]", values.join(", "))
            })
            .collect();
        outln!(
            "  {:?}: error {} (bound {}) {}",
            w.index,
            w.error.map_or("NaN/∞".into(), |e| sig(e, 3)),
            sig(w.bound, 3),
            inputs.join("; ")
        );
    }
}
