//! `reparam crosscheck bpm`: the GPU f32 kernels against the f64 reference.

use clap::{Args, Subcommand};
use reparam::Result;

#[derive(Subcommand)]
pub enum CrosscheckCommand {
    /// BPM: eval kernel alone, and the GPU pipeline with the local and the determinant fit.
    Bpm(CrosscheckBpmArgs),
}

#[derive(Args)]
pub struct CrosscheckBpmArgs {
    /// Mesh (OBJ with `vt`, or `procedural:<name>`); default: every small built-in mesh.
    #[arg(long)]
    pub mesh: Vec<String>,
    /// Print machine-readable results.
    #[arg(long)]
    pub json: bool,
}

pub fn run(cmd: CrosscheckCommand) -> Result<()> {
    match cmd {
        CrosscheckCommand::Bpm(args) => bpm(args),
    }
}

#[cfg(feature = "gpu")]
fn bpm(args: CrosscheckBpmArgs) -> Result<()> {
    use reparam::crosscheck::bpm::{crosscheck_bpm, crosscheck_table, UNIT};
    let meshes = if args.mesh.is_empty() {
        reparam::mesh::procedural::all_small()
    } else {
        args.mesh
            .iter()
            .map(|m| super::inputs::load_mesh(m))
            .collect::<Result<Vec<_>>>()?
    };
    let gpu = reparam::bpm::gpu::context()?;
    let results = meshes
        .iter()
        .map(|m| crosscheck_bpm(&gpu, m))
        .collect::<Result<Vec<_>>>()?;
    if args.json {
        let rounded: Vec<_> = results
            .iter()
            .map(|r| {
                let mut r = r.clone();
                for s in [
                    &mut r.eval_kernel,
                    &mut r.linear_kernel,
                    &mut r.local,
                    &mut r.det,
                ] {
                    *s = s.rounded(3);
                }
                r
            })
            .collect();
        return super::print_json(&rounded);
    }
    println!("adapter: {}", gpu.adapter_summary());
    println!("errors in {UNIT}; f32 GPU against f64 CPU from identical (f32-rounded) inputs");
    let (header, rows) = crosscheck_table(&results);
    println!("{}", super::text_table(&header, &rows));
    Ok(())
}

#[cfg(not(feature = "gpu"))]
fn bpm(_: CrosscheckBpmArgs) -> Result<()> {
    Err(reparam::Error::Gpu(
        "this build has no GPU support (feature `gpu` is off)".into(),
    ))
}
