//! The `reparam` command line: `demo` runs every algorithm on built-in data; each algorithm has
//! its own subcommand for real files; `crosscheck` compares the GPU f32 kernels with the f64
//! reference. See `reparam --help`.

fn main() -> std::process::ExitCode {
    reparam::cli::main()
}
