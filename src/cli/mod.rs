//! Command-line parsing (clap derive) and dispatch. Each subcommand lives in its own file and
//! only glues the library together: parse, call, print (or `--json`), save.
//!
//! Everything meant for stdout goes through `outln!` / `out!` ([`crate::cli::write_out`]): on a
//! closed stdout (`reparam verify … | head`) the rest of the output is dropped and the command
//! runs to its verdict, whose exit status is kept (a closed pipe may make a run quiet, never make
//! a failing one succeed); [`crate::cli::run_captured`] collects it in a buffer to run a command
//! in-process (the command fuzzer, `tests/fuzz_commands.rs`). `println!` is denied here by clippy's
//! `print_stdout`.

#![deny(clippy::print_stdout)]

use std::cell::RefCell;
use std::io::Write as _;
use std::sync::atomic::{AtomicBool, Ordering};

/// `println!` for the command line's output: through [`write_out`].
macro_rules! outln {
    () => {
        $crate::cli::write_out(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::write_out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` for the command line's output: through [`write_out`].
#[allow(unused_macros)]
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::write_out(format_args!($($arg)*))
    };
}

thread_local! {
    /// The buffer of [`run_captured`] while it runs a command on this thread.
    static CAPTURE: RefCell<Option<Vec<u8>>> = const { RefCell::new(None) };
}

/// Set once a write to stdout has failed: later output is dropped.
static STDOUT_GONE: AtomicBool = AtomicBool::new(false);
/// Set when that failure was not a closed pipe (a full disk, say): the run cannot succeed.
static STDOUT_FAILED: AtomicBool = AtomicBool::new(false);

/// Write command output: into [`run_captured`]'s buffer when one is active on this thread, else
/// to stdout (flushed, so that a failure shows here and not at exit). Once a write fails, later
/// output is dropped and the command goes on to its verdict: a reader that has gone away
/// (`BrokenPipe`, e.g. `| head`) asked for no more output, not for another exit status. The
/// Rust runtime ignores SIGPIPE, so the write returns the error instead of killing the process;
/// this is portable (Windows reports a closed pipe the same way) and needs no `unsafe` signal
/// handling. Any other write error is one line on stderr and makes the exit status at least 1
/// ([`main`]).
#[doc(hidden)]
pub fn write_out(args: std::fmt::Arguments) {
    let captured = CAPTURE.with(|c| match c.borrow_mut().as_mut() {
        Some(buffer) => {
            // Writing into a Vec cannot fail.
            let _ = buffer.write_fmt(args);
            true
        }
        None => false,
    });
    if captured || STDOUT_GONE.load(Ordering::Relaxed) {
        return;
    }
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout.write_fmt(args).and_then(|()| stdout.flush()) {
        STDOUT_GONE.store(true, Ordering::Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            STDOUT_FAILED.store(true, Ordering::Relaxed);
            eprintln!("error: cannot write to stdout: {e}");
        }
    }
}

/// Whether standard output has gone away (a closed pipe, a write error): a command whose
/// verdict matters then also writes it to stderr.
pub fn stdout_gone() -> bool {
    STDOUT_GONE.load(Ordering::Relaxed)
}

mod bpm;
mod crosscheck;
mod demo;
mod gridwarp;
mod inputs;
mod maps;
#[cfg(feature = "gpu")]
mod shader;
/// The mesh named as the `maps` command names it (a file, or `procedural:<name>` with the hard
/// models), for the `maps_compare` example.
pub use maps::load as load_maps_input;
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
    /// Follow files that a model names (glTF buffer and image URIs, OBJ `mtllib`, MTL `map_Kd`)
    /// outside the model's folder too: absolute paths, `..` above it, links out of it. Refused
    /// by default (`src/input.md`, "Limits on input").
    #[arg(long, global = true)]
    allow_outside_references: bool,
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
    let json = cli.json_errors();
    let code = match dispatch(cli) {
        Ok(code) => code,
        Err((e, code)) => {
            report_error(&e, code, json);
            code
        }
    };
    // Output lost to a failed write (not a closed pipe) is a failure, whatever the verdict.
    if code == 0 && STDOUT_FAILED.load(Ordering::Relaxed) {
        return ExitCode::from(1);
    }
    ExitCode::from(code)
}

impl Cli {
    /// Whether an error should also be written to stdout as JSON: `crosscheck` and `verify`
    /// with `--json`, whose output scripts parse.
    fn json_errors(&self) -> bool {
        match &self.command {
            Command::Crosscheck(args) => args.json(),
            #[cfg(feature = "gpu")]
            Command::Verify(args) => args.json,
            _ => false,
        }
    }
}

/// The JSON a script reads when a `--json` command fails on bad input.
#[derive(serde::Serialize)]
struct JsonError {
    error: String,
    exit_code: u8,
}

/// An error: `error: …` on stderr and, under `--json`, `{"error": …, "exit_code": …}` on stdout.
fn report_error(e: &crate::Error, code: u8, json: bool) {
    eprintln!("error: {e}");
    if json {
        // The error object has no floats, so this cannot fail on a non-finite figure.
        let _ = print_json(&JsonError {
            error: e.to_string(),
            exit_code: code,
        });
    }
}

/// Run the command line `args` (the first is the program name, as in `std::env::args`) in this
/// process, with its standard output captured: the exit code or the error `main` would print
/// after `error: `, and the bytes it wrote to stdout. Unparsable arguments are
/// [`crate::Error::InvalidArgument`] with clap's message. Progress bars and warnings still go
/// to stderr.
pub fn run_captured<I, T>(args: I) -> (crate::Result<ExitCode>, Vec<u8>)
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let previous = CAPTURE.with(|c| c.borrow_mut().replace(Vec::new()));
    let result = Cli::try_parse_from(args)
        .map_err(|e| crate::Error::InvalidArgument(e.to_string().trim().to_string()))
        .and_then(|cli| dispatch(cli).map(ExitCode::from).map_err(|(e, _)| e));
    let output = CAPTURE.with(|c| std::mem::replace(&mut *c.borrow_mut(), previous));
    (result, output.unwrap_or_default())
}

/// Run a parsed command line, under the reference policy it asks for: its exit status, or its
/// error and the exit status `main` gives it ([`crate::Error::exit_status`]; 2 for `crosscheck`
/// and `verify`, whose 1 means a bound exceeded).
fn dispatch(cli: Cli) -> Result<u8, (crate::Error, u8)> {
    use crate::input::{with_reference_policy, ReferencePolicy};
    let policy = match cli.allow_outside_references {
        true => ReferencePolicy::Anywhere,
        false => ReferencePolicy::ModelFolder,
    };
    with_reference_policy(policy, || dispatch_command(cli.command))
}

/// [`dispatch`] of one command.
fn dispatch_command(command: Command) -> Result<u8, (crate::Error, u8)> {
    let result = match command {
        Command::Demo(args) => demo::run(args),
        Command::Bpm(cmd) => bpm::run(cmd),
        Command::Crosscheck(args) => return crosscheck::try_run(args).map_err(|e| (e, 2)),
        #[cfg(feature = "gpu")]
        Command::Vectors(args) => {
            return vectors::run(args).map_err(|e| {
                let status = e.exit_status();
                (e, status)
            })
        }
        #[cfg(feature = "gpu")]
        Command::Verify(args) => {
            return match vectors::try_verify(&args) {
                Ok(true) => Ok(0),
                Ok(false) => Ok(1),
                Err(e) => Err((e, 2)),
            }
        }
        Command::Gridwarp(args) => gridwarp::run(args),
        Command::Maps(args) => maps::run(args),
        Command::Unwarp(args) => unwarp::run(args),
        Command::Skinsimp(args) => skinsimp::run(args),
        Command::ReferenceData { out } => crate::reference_data::write_all(&out).map(|files| {
            for f in files {
                outln!("wrote {}", f.display());
            }
        }),
    };
    result.map(|()| 0).map_err(|e| {
        let status = e.exit_status();
        (e, status)
    })
}

/// Print `value` as pretty JSON on stdout. A NaN or infinite number anywhere in it (which
/// serde_json would write as `null`) is [`crate::Error::NonFiniteOutput`] naming the field:
/// a figure that cannot be computed must be a typed error upstream, never a `null` with exit 0.
pub fn print_json<T: serde::Serialize>(value: &T) -> crate::Result<()> {
    if let Some(field) = crate::report::first_non_finite(value) {
        return Err(crate::Error::NonFiniteOutput { field });
    }
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| crate::Error::InvalidArgument(format!("cannot serialise results: {e}")))?;
    outln!("{text}");
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
