//! Command-line parsing (clap derive) and dispatch. Each subcommand lives in its own file and
//! only glues the library together: parse, call, print (or `--json`), save.

mod bpm;
mod crosscheck;
mod demo;
mod gridwarp;
mod inputs;
mod maps;
mod skinsimp;
mod unwarp;
#[cfg(feature = "gpu")]
mod vectors;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// reparam — reference f64 implementations of texture-parameterisation algorithms, with f32
/// GPU kernels cross-checked against them.
#[derive(Parser)]
#[command(name = "reparam", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run every algorithm on built-in data; write pictures and report.md to the output folder.
    Demo(demo::DemoArgs),
    /// Blended Piecewise Möbius Maps: render, quality protocol.
    #[command(subcommand)]
    Bpm(bpm::BpmCommand),
    /// Content-aware grid warp of texture regions (axis-aligned or not): built-in scenes, OBJ
    /// frames or a skinned glTF.
    Gridwarp(gridwarp::GridwarpArgs),
    /// Distortion-free displacement mapping: the per-texel offset map of a height map.
    Unwarp(unwarp::UnwarpArgs),
    /// Quadric simplification of a skinned glTF model with optimised skin weights (or of an
    /// OBJ frame sequence); writes a skinned GLB.
    Skinsimp(skinsimp::SkinsimpArgs),
    /// MAPS: multiresolution parameterisation over a base domain, and remeshing (OBJ/PLY/OFF).
    Maps(maps::MapsArgs),
    /// Every GPU f32 kernel against the f64 reference from identical inputs: one row per
    /// kernel with its derived bound and verdict (exit 1 if any exceeds it, 2 on bad input).
    Crosscheck(crosscheck::CrosscheckArgs),
    /// Conformance vectors of every kernel of an algorithm (.npy + manifest.json), for checking
    /// other implementations with `reparam verify`.
    #[cfg(feature = "gpu")]
    Vectors(vectors::VectorsArgs),
    /// Judge a candidate implementation's output against conformance vectors (exit 0 pass, 1
    /// fail, 2 bad input).
    #[cfg(feature = "gpu")]
    Verify(vectors::VerifyArgs),
    /// Regenerate reference_data/: canonical meshes and golden f64 outputs.
    ReferenceData {
        /// Output folder.
        #[arg(long, default_value = "reference_data")]
        out: std::path::PathBuf,
    },
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(args) => demo::run(args),
        Command::Bpm(cmd) => bpm::run(cmd),
        Command::Crosscheck(args) => return crosscheck::run(args),
        #[cfg(feature = "gpu")]
        Command::Vectors(args) => vectors::run(args),
        #[cfg(feature = "gpu")]
        Command::Verify(args) => return vectors::verify(args),
        Command::Gridwarp(args) => gridwarp::run(args),
        Command::Maps(args) => maps::run(args),
        Command::Unwarp(args) => unwarp::run(args),
        Command::Skinsimp(args) => skinsimp::run(args),
        Command::ReferenceData { out } => reparam::reference_data::write_all(&out).map(|files| {
            for f in files {
                println!("wrote {}", f.display());
            }
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Print `value` as pretty JSON on stdout.
pub fn print_json<T: serde::Serialize>(value: &T) -> reparam::Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| reparam::Error::InvalidArgument(format!("cannot serialise results: {e}")))?;
    println!("{text}");
    Ok(())
}

/// A plain-text table, every column right-aligned to its widest cell (in characters), cells
/// separated by two spaces, the header first.
pub fn text_table(header: &[String], rows: &[Vec<String>]) -> String {
    let widths: Vec<usize> = (0..header.len())
        .map(|c| {
            rows.iter()
                .map(|r| r[c].chars().count())
                .chain([header[c].chars().count()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |cells: &[String]| {
        cells
            .iter()
            .zip(&widths)
            .map(|(c, w)| format!("{c:>w$}"))
            .collect::<Vec<_>>()
            .join("  ")
    };
    std::iter::once(header)
        .chain(rows.iter().map(|r| r.as_slice()))
        .map(line)
        .collect::<Vec<_>>()
        .join("\n")
}
