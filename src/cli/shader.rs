//! `reparam verify DIR --shader FILE`: run a user's compute shader (WGSL, GLSL 450 compute,
//! SPIR-V) on a kernel's conformance vectors, bound by the kernel's ABI
//! ([`crate::vectors::shader_abi`]), on one adapter or every one, and judge its output with the
//! kernel's bounds, as `verify --candidate` judges a `.npy`. Exit 0 when every adapter passes,
//! 1 when one fails (a bound exceeded, NaN, a dispatch that did not finish, a write past a
//! binding), 2 on bad input (an unreadable shader, a syntax or validation error, a binding off
//! the ABI).

use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::Args;
use reparam_gpu::user_shader::{exercising_grid, ShaderError, ShaderLanguage, UserShader};
use serde::Serialize;

use super::vectors::VerifyArgs;
use crate::vectors::shader_abi::{self, ShaderAbi};
use crate::vectors::verify::{choose, verify_array, VerifyReport};
use crate::vectors::{read_manifest, KernelVectors};
use crate::{Error, Result};

/// The options of `verify --shader` (and `--print-abi`).
#[derive(Args, Clone, Debug)]
pub struct ShaderOptions {
    /// The shader's compute entry point.
    #[arg(long, default_value = shader_abi::DEFAULT_ENTRY)]
    pub entry: String,
    /// The adapter to run on: an index or a substring of its name (as `crosscheck --adapter`).
    #[arg(long, requires = "shader", conflicts_with = "all_adapters")]
    pub adapter: Option<String>,
    /// Run on every adapter, one verdict each (exit 1 if any fails).
    #[arg(long, requires = "shader")]
    pub all_adapters: bool,
    /// Write the shader's output (f32 .npy) here; with --all-adapters, `<stem>.<adapter>.npy`.
    #[arg(long, requires = "shader")]
    pub save_output: Option<PathBuf>,
    /// Seconds the compilation, dispatch and read-back may take before the verdict is "did
    /// not finish" (exit 1).
    #[arg(long, default_value_t = 60.0)]
    pub timeout: f64,
    /// Print the kernel's binding ABI as WGSL declarations and exit.
    #[arg(long)]
    pub print_abi: bool,
}

/// One adapter's verdict.
#[derive(Debug, Serialize)]
pub struct AdapterVerdict {
    pub adapter: String,
    pub pass: bool,
    /// Why there is no report (the dispatch did not finish, a guard region changed, the device
    /// failed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    #[serde(flatten)]
    pub report: Option<VerifyReport>,
}

/// What `verify --shader --json` prints.
#[derive(Debug, Serialize)]
pub struct ShaderVerifyReport {
    pub kernel: String,
    pub shader: String,
    pub entry: String,
    pub verdicts: Vec<AdapterVerdict>,
    /// Adapters that refused a device (`--all-adapters`): (adapter, reason).
    pub skipped: Vec<(String, String)>,
    pub pass: bool,
    pub verdict: &'static str,
}

/// The kernel of the vectors in `args.dir` that `args` names and its ABI.
fn kernel_and_abi(args: &VerifyArgs, file: &Path) -> Result<(KernelVectors, ShaderAbi)> {
    let manifest = read_manifest(&args.dir)?;
    let k = choose(&manifest.kernels, args.kernel.as_deref(), file, &args.dir)?.clone();
    let path = args.dir.join("manifest.json").display().to_string();
    let abi = ShaderAbi::of(&k, &path)?;
    Ok((k, abi))
}

/// `verify DIR --kernel K --print-abi`.
pub fn print_abi(args: &VerifyArgs) -> Result<bool> {
    let (_, abi) = kernel_and_abi(args, Path::new(""))?;
    outln!("{}", abi.wgsl());
    Ok(true)
}

/// A shader's error as the CLI's.
fn shader_error(e: ShaderError) -> Error {
    Error::Shader(e.to_string())
}

/// `verify DIR --shader FILE`: whether the shader passes on every adapter it ran on.
pub fn verify_shader(args: &VerifyArgs, shader: &Path) -> Result<bool> {
    let o = &args.shader_options;
    let file = shader.display().to_string();
    let (k, abi) = kernel_and_abi(args, shader)?;
    let language = ShaderLanguage::of_file(&file).ok_or_else(|| Error::Vectors {
        file: file.clone(),
        reason: "unknown shader extension; reparam reads .wgsl, .comp or .glsl (GLSL 450 \
                 compute) and .spv (SPIR-V)"
            .into(),
    })?;
    if !(o.timeout.is_finite() && o.timeout > 0.0) {
        return Err(Error::InvalidArgument(format!(
            "--timeout {}: seconds, > 0",
            o.timeout
        )));
    }
    let source = crate::input::read_input(shader)?;
    let parsed = UserShader::parse(&source, language, &file).map_err(shader_error)?;
    let bindings = parsed.bindings(&o.entry).map_err(shader_error)?;
    let workgroup = parsed.workgroup_size(&o.entry).map_err(shader_error)?;
    abi.check(&file, &bindings, workgroup)?;
    let buffers = shader_abi::buffers(&abi, &args.dir)?;
    let gpus: Vec<(String, std::result::Result<reparam_gpu::Gpu, String>)> = if o.all_adapters {
        reparam_gpu::Gpu::all_adapters()
            .into_iter()
            .map(|(d, g)| {
                (
                    format!("{}: {}", d.index, d.summary()),
                    g.map_err(|e| e.to_string()),
                )
            })
            .collect()
    } else {
        let gpu = match &o.adapter {
            Some(a) => reparam_gpu::Gpu::with_adapter(a),
            None => reparam_gpu::Gpu::new(),
        }
        .map_err(|e| Error::Gpu(e.to_string()))?;
        vec![(gpu.adapter_summary(), Ok(gpu))]
    };
    let mut verdicts = Vec::new();
    let mut skipped = Vec::new();
    for (n, (adapter, gpu)) in gpus.into_iter().enumerate() {
        let gpu = match gpu {
            Ok(g) => g,
            Err(e) => {
                skipped.push((adapter, e));
                continue;
            }
        };
        let grid = exercising_grid(&abi.kernel, abi.count.max(1), &gpu)
            .map_err(|e| Error::Gpu(e.to_string()))?;
        let timeout = Duration::from_secs_f64(o.timeout);
        let result = parsed.dispatch(&gpu, &o.entry, buffers.clone(), grid, timeout);
        let verdict = match result {
            Ok(outputs) => {
                let bytes = outputs.first().map(Vec::as_slice).unwrap_or(&[]);
                let candidate = shader_abi::candidate(&abi, bytes);
                if let Some(path) = &o.save_output {
                    candidate.save(&save_path(path, o.all_adapters, n))?;
                }
                let report = verify_array(&args.dir, &k, &candidate, &file)?;
                AdapterVerdict {
                    adapter,
                    pass: report.pass,
                    error: None,
                    report: Some(report),
                }
            }
            Err(
                e @ (ShaderError::DidNotFinish { .. }
                | ShaderError::GuardOverwritten { .. }
                | ShaderError::Gpu(_)),
            ) => AdapterVerdict {
                adapter,
                pass: false,
                error: Some(e.to_string()),
                report: None,
            },
            Err(e) => return Err(shader_error(e)),
        };
        verdicts.push(verdict);
    }
    if verdicts.is_empty() {
        return Err(Error::Gpu(format!(
            "no adapter ran the shader: {}",
            skipped
                .iter()
                .map(|(a, e)| format!("{a}: {e}"))
                .collect::<Vec<_>>()
                .join("; ")
        )));
    }
    let pass = verdicts.iter().all(|v| v.pass);
    let report = ShaderVerifyReport {
        kernel: k.name.clone(),
        shader: file,
        entry: o.entry.clone(),
        verdicts,
        skipped,
        pass,
        verdict: if pass { "pass" } else { "fail" },
    };
    if args.json {
        super::print_json(&report)?;
    } else {
        print_report(&report);
    }
    if super::stdout_gone() {
        for v in &report.verdicts {
            eprintln!(
                "verify {} --shader {} on {}: {} (stdout closed)",
                report.kernel,
                report.shader,
                v.adapter,
                if v.pass { "pass" } else { "FAIL" }
            );
        }
    }
    Ok(pass)
}

/// `--save-output`: the path itself, or with several adapters `<stem>.<n>.npy`.
fn save_path(path: &Path, several: bool, n: usize) -> PathBuf {
    if !several {
        return path.to_path_buf();
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}.{n}.npy"))
}

fn print_report(r: &ShaderVerifyReport) {
    for v in &r.verdicts {
        outln!("adapter {}", v.adapter);
        match (&v.report, &v.error) {
            (Some(report), _) => super::vectors::print_verify(report),
            (None, Some(e)) => outln!("kernel {} · shader {}: FAIL: {e}", r.kernel, r.shader),
            (None, None) => outln!("kernel {} · shader {}: FAIL", r.kernel, r.shader),
        }
    }
    for (a, e) in &r.skipped {
        outln!("skipped adapter {a}: {e}");
    }
    outln!(
        "{}: {} of {} adapters pass",
        if r.pass { "pass" } else { "FAIL" },
        r.verdicts.iter().filter(|v| v.pass).count(),
        r.verdicts.len()
    );
}
