//! Shared helpers for the integration tests: a tiny deterministic random generator (the tests
//! must not depend on a random crate's stream staying stable across versions).
#![allow(dead_code)]

use num_complex::Complex64 as C;

/// SplitMix64: a deterministic stream of u64, good enough to draw test arguments.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn complex(&mut self, r: f64) -> C {
        C::new(self.uniform(-r, r), self.uniform(-r, r))
    }
    /// Random barycentric coordinates strictly inside the triangle.
    pub fn bary(&mut self) -> [f64; 3] {
        let (mut a, mut b) = (self.uniform(0.0, 1.0), self.uniform(0.0, 1.0));
        if a + b > 1.0 {
            a = 1.0 - a;
            b = 1.0 - b;
        }
        [1.0 - a - b, a, b]
    }
}

/// Run `f` in a rayon pool of `threads` threads (for the thread-count independence tests).
pub fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool")
        .install(f)
}

/// The mutation tables of the twin tests (`tests/mutants_bpm.rs`, `tests/twin_*.rs`): one line
/// per candidate judged by `verify`, the twin under each arithmetic model first (it must pass),
/// then each mutant (it must fail). [`MutationTable::finish`] prints the table (the conformance
/// guide's, `src/vectors/README.md`) and fails the test naming every twin that failed and every
/// mutant that survived.
#[cfg(feature = "gpu")]
pub mod mutation {
    use std::path::Path;

    use reparam::twin::Model;
    use reparam::vectors::verify::{verify_array, VerifyReport};
    use reparam::vectors::{Array, KernelVectors};

    pub struct MutationTable {
        lines: Vec<String>,
        wrong: Vec<String>,
    }

    impl Default for MutationTable {
        fn default() -> Self {
            MutationTable {
                lines: vec![
                    "| mutant | the porter's mistake | verdict | worst error/bound | over |".into(),
                    "|---|---|---|---|---|".into(),
                ],
                wrong: Vec::new(),
            }
        }
    }

    /// One row; `verdict` names what the report's pass or fail means for this candidate.
    fn line(name: &str, mistake: &str, verdict: [&str; 2], r: &VerifyReport) -> String {
        format!(
            "| `{name}` | {mistake} | {} | {:.3e} | {} of {} |",
            if r.pass { verdict[0] } else { verdict[1] },
            r.worst_ratio,
            r.over,
            r.errors.count
        )
    }

    impl MutationTable {
        /// The twin under `model` (a model's name): it must pass.
        pub fn twin(&mut self, model: &str, r: &VerifyReport) {
            self.lines.push(line(
                &format!("twin ({model})"),
                "none",
                ["pass", "**FAIL**"],
                r,
            ));
            if !r.pass {
                self.wrong.push(format!("the twin under {model} fails"));
            }
        }

        /// A mutant: it must fail.
        pub fn mutant(&mut self, name: &str, mistake: &str, r: &VerifyReport) {
            self.lines
                .push(line(name, mistake, ["**survived**", "killed"], r));
            if r.pass {
                self.wrong.push(format!("mutant {name} survives"));
            }
        }

        /// The whole judgement of a kernel on its canonical vectors in `dir`: no bound is
        /// exactly 0, `run(model, None)` (the twin) passes under every model of
        /// [`Model::CHECKED`], `run(Model::Nearest, Some(body))` fails for every mutant; the
        /// table is printed, and the test panics naming what went wrong.
        pub fn judge_kernel<B: Copy>(
            dir: &Path,
            k: &KernelVectors,
            run: impl Fn(Model, Option<B>) -> Array,
            mutants: &[(&str, &str, B)],
        ) {
            let bounds = Array::load(&dir.join(&k.bound.file)).unwrap().to_f64();
            let zero = bounds.iter().filter(|&&b| b == 0.0).count();
            assert_eq!(zero, 0, "{zero} of {} bounds are exactly 0", bounds.len());
            let judge = |c: &Array| verify_array(dir, k, c, "twin").unwrap();
            let mut table = MutationTable::default();
            for model in Model::CHECKED {
                table.twin(&model.name(), &judge(&run(model, None)));
            }
            for &(name, mistake, body) in mutants {
                table.mutant(name, mistake, &judge(&run(Model::Nearest, Some(body))));
            }
            table.finish();
        }

        /// The mutants' harness with no mistake is the twin: `harness` equals `twin` bit for
        /// bit (so that each mutant differs from the twin by its one mistake only).
        pub fn assert_bit_identical(twin: &Array, harness: &Array) {
            let (a, b) = (twin.to_f64(), harness.to_f64());
            assert_eq!(a.len(), b.len());
            let differ = a
                .iter()
                .zip(&b)
                .filter(|(x, y)| x.to_bits() != y.to_bits())
                .count();
            assert_eq!(differ, 0, "{differ} of {} values differ", a.len());
        }

        /// Print the table; panic if a twin failed or a mutant survived.
        pub fn finish(self) {
            let table = self.lines.join("\n");
            println!("{table}");
            assert!(self.wrong.is_empty(), "{:?}\n{table}", self.wrong);
        }
    }
}

/// The canonical conformance vectors (`reference_data/vectors/<algorithm>`), for the twin and
/// mutation tests: a kernel's manifest entry and its input arrays.
#[cfg(feature = "gpu")]
pub mod canonical {
    use std::path::{Path, PathBuf};

    use reparam::vectors::{read_manifest, Array, KernelVectors};

    /// The folder of `algorithm`'s canonical vectors.
    pub fn dir(algorithm: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("reference_data/vectors")
            .join(algorithm)
    }

    /// The manifest entry of kernel `name` in `algorithm`'s canonical vectors.
    pub fn kernel(algorithm: &str, name: &str) -> KernelVectors {
        read_manifest(&dir(algorithm))
            .unwrap()
            .kernels
            .into_iter()
            .find(|k| k.name == name)
            .unwrap()
    }

    /// Kernel `k`'s input array called `name` (`<kernel>.<name>.npy`).
    pub fn input(algorithm: &str, k: &KernelVectors, name: &str) -> Array {
        k.load_input(&dir(algorithm), name).unwrap()
    }
}

/// Running the `reparam` binary from an integration test (one runner for every CLI test).
pub mod cli {
    use std::io::{BufRead, BufReader, Read};
    use std::process::{Command, Output, Stdio};

    /// The binary with `args`, progress bars off.
    pub fn command(args: &[&str]) -> Command {
        let mut command = Command::new(env!("CARGO_BIN_EXE_reparam"));
        command.args(args).env("REPARAM_NO_PROGRESS", "1");
        command
    }

    /// (exit code, or −1 when a signal ended it; stdout; stderr).
    fn parts(out: Output, stdout: String) -> (i32, String, String) {
        (
            out.status.code().unwrap_or(-1),
            stdout,
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    }

    /// Run the binary with `args` to the end: (exit code, or −1 when a signal ended it; stdout;
    /// stderr). A success is code 0.
    pub fn reparam(args: &[&str]) -> (i32, String, String) {
        let out = command(args).output().expect("the binary runs");
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        parts(out, stdout)
    }

    /// What happens to the command's stdout.
    #[derive(Clone, Copy, Debug)]
    pub enum Stdout {
        /// Read to the end.
        Read,
        /// Closed before the command writes anything (`| head -0`).
        ClosedAtOnce,
        /// One line read, then closed (`| head -1`).
        ClosedAfterOneLine,
    }

    /// Run the binary with `args` and `stdout` handled as asked: (exit code, stdout read,
    /// stderr).
    pub fn reparam_with_stdout(args: &[&str], stdout: Stdout) -> (i32, String, String) {
        let mut command = command(args);
        command.stderr(Stdio::piped());
        let mut read = String::new();
        if let Stdout::ClosedAtOnce = stdout {
            // A pipe whose read end is closed before the command starts: its first write fails
            // (EPIPE), whatever the scheduling (closing after the spawn would race the write).
            let (reader, writer) = std::io::pipe().unwrap();
            drop(reader);
            let out = command.stdout(writer).output().unwrap();
            return parts(out, read);
        }
        let mut child = command.stdout(Stdio::piped()).spawn().unwrap();
        let pipe = child.stdout.take().unwrap();
        match stdout {
            Stdout::Read => {
                BufReader::new(pipe).read_to_string(&mut read).unwrap();
            }
            Stdout::ClosedAtOnce => unreachable!(),
            Stdout::ClosedAfterOneLine => {
                BufReader::new(pipe).read_line(&mut read).unwrap();
            }
        }
        let out = child.wait_with_output().unwrap();
        parts(out, read)
    }
}
