//! Mutation fuzzing of the file parsers on stable Rust (issue #25, first slice).
//!
//! Seeds: small files written from the procedural meshes (OBJ with an MTL, OFF, ASCII and
//! binary PLY) and images (PNG, EXR). Each case mutates a seed's bytes or tokens (flipped,
//! inserted and deleted bytes, duplicated and deleted tokens, numbers replaced by huge or
//! special ones, truncation, two seeds spliced) with a seeded xorshift generator, writes it and
//! loads it. For every case: no panic, an error is one line naming the file, a loaded mesh or
//! image is finite, and the load takes less than a generous bound.
//!
//! `REPARAM_FUZZ_CASES` (default 200 per parser: a few seconds in a debug build) and
//! `REPARAM_FUZZ_SEED` choose the run; a failing case is written to `target/fuzz-failures/`
//! and named in the failure. A long run: `REPARAM_FUZZ_CASES=1000000 cargo test --release
//! --test fuzz_parsers`.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use reparam::mesh::procedural::{cone_fan, torus};
use reparam::mesh::{load_gltf, load_mesh, write_obj, TriMesh};
use reparam::skinsimp::glb::glb_bytes;
use reparam::skinsimp::tube::skinned_tube;
use reparam::texture::{load_gray_f32, save_exr_rg, save_png, Image};

/// xorshift64*: deterministic, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Numbers that break naive parsers: signs, the integer type edges, overflow, specials.
const HOSTILE_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "3",
    "255",
    "65536",
    "2147483648",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "9223372036854775808",
    "18446744073709551616",
    "99999999999999999999999",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "1e-320",
];

/// Byte ranges of the whitespace-separated tokens of `bytes`.
fn tokens(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, b) in bytes.iter().enumerate() {
        match (b.is_ascii_whitespace(), start) {
            (false, None) => start = Some(i),
            (true, Some(s)) => {
                out.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, bytes.len()));
    }
    out
}

/// Byte ranges of the maximal runs of ASCII digits of `bytes`.
fn digit_runs(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i].is_ascii_digit() {
            let start = i;
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

/// One to three mutations of `seed` (`other` is a second seed for splicing).
fn mutate(rng: &mut Rng, seed: &[u8], other: &[u8]) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    for _ in 0..1 + rng.below(3) {
        let toks = tokens(&bytes);
        match rng.below(9) {
            0 if !bytes.is_empty() => {
                let i = rng.below(bytes.len());
                bytes[i] ^= 1 << rng.below(8);
            }
            1 => {
                let i = rng.below(bytes.len() + 1);
                bytes.insert(i, rng.next() as u8);
            }
            2 if !bytes.is_empty() => {
                let i = rng.below(bytes.len());
                let n = 1 + rng.below(16).min(bytes.len() - i - 1);
                bytes.drain(i..i + n);
            }
            3 if !toks.is_empty() => {
                // Duplicate a token many times (long runs of repeated tokens).
                let (s, e) = toks[rng.below(toks.len())];
                let token = [&bytes[s..e], b" "].concat();
                let copies = 1 + rng.below(2000);
                let run: Vec<u8> = token.repeat(copies);
                bytes.splice(s..s, run);
            }
            4 if !toks.is_empty() => {
                let (s, e) = toks[rng.below(toks.len())];
                bytes.drain(s..e);
            }
            5 if !toks.is_empty() => {
                let (s, e) = toks[rng.below(toks.len())];
                let number = HOSTILE_NUMBERS[rng.below(HOSTILE_NUMBERS.len())];
                bytes.splice(s..e, number.bytes());
            }
            6 => {
                let n = rng.below(bytes.len() + 1);
                bytes.truncate(n);
            }
            7 => {
                // A run of digits (a count, an index, a JSON number) made hostile.
                let runs = digit_runs(&bytes);
                if !runs.is_empty() {
                    let (s, e) = runs[rng.below(runs.len())];
                    let number = HOSTILE_NUMBERS[rng.below(HOSTILE_NUMBERS.len())];
                    bytes.splice(s..e, number.bytes());
                }
            }
            _ => {
                let cut = rng.below(bytes.len() + 1);
                let from = rng.below(other.len() + 1);
                bytes.truncate(cut);
                bytes.extend_from_slice(&other[from..]);
            }
        }
    }
    bytes
}

/// The number of cases per parser and the first seed, from the environment.
fn run_size() -> (usize, u64) {
    let var = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok());
    let cases = var("REPARAM_FUZZ_CASES").unwrap_or(200) as usize;
    let seed = var("REPARAM_FUZZ_SEED")
        .unwrap_or(0x9E37_79B9_7F4A_7C15)
        .max(1);
    (cases, seed)
}

/// Keep a failing input where a developer can find it, and return its path.
fn keep_failure(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// Fuzz `load` on files `case.<ext>` mutated from `seeds`; `check` judges a successful load.
fn fuzz<T>(
    ext: &str,
    seeds: &[Vec<u8>],
    load: impl Fn(&Path) -> reparam::Result<T>,
    check: impl Fn(&T) -> Result<(), String>,
) {
    let (cases, seed) = run_size();
    let mut rng = Rng(seed ^ ext.bytes().fold(0, |h, b| h * 31 + b as u64));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("case.{ext}"));
    for case in 0..cases {
        let first = &seeds[rng.below(seeds.len())];
        let second = &seeds[rng.below(seeds.len())];
        let bytes = mutate(&mut rng, first, second);
        std::fs::write(&path, &bytes).unwrap();
        let start = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| load(&path)));
        let took = start.elapsed();
        let problem = match &outcome {
            Err(_) => Some("panicked".to_string()),
            Ok(Err(e)) => {
                let shown = e.to_string();
                (shown.contains('\n') || !shown.contains("case."))
                    .then(|| format!("error not one line naming the file: {shown:?}"))
            }
            Ok(Ok(value)) => check(value).err(),
        };
        let problem = problem.or_else(|| {
            (took > Duration::from_secs(5))
                .then(|| format!("took {took:?} for {} bytes", bytes.len()))
        });
        if let Some(problem) = problem {
            let kept = keep_failure(&format!("{ext}-case{case}.{ext}"), &bytes);
            panic!(
                "{ext} case {case}: {problem} (input kept in {})",
                kept.display()
            );
        }
    }
}

/// A loaded mesh is finite and its indices are in range.
fn finite_mesh(mesh: &TriMesh) -> Result<(), String> {
    mesh.validate()
        .map_err(|e| format!("loaded an invalid mesh: {e}"))
}

/// The seed meshes: a cone fan and a small torus.
fn seed_meshes() -> Vec<TriMesh> {
    vec![cone_fan(6, 1.0), torus(4, 3, 1.0, 0.3)]
}

/// `mesh` as OFF text.
fn off_text(mesh: &TriMesh) -> String {
    let mut text = format!("OFF\n{} {} 0\n", mesh.positions.len(), mesh.faces.len());
    for p in &mesh.positions {
        text += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    for [a, b, c] in &mesh.faces {
        text += &format!("3 {a} {b} {c}\n");
    }
    text
}

/// `mesh` as an ASCII or binary little-endian PLY.
fn ply_bytes(mesh: &TriMesh, binary: bool) -> Vec<u8> {
    let format = if binary {
        "binary_little_endian"
    } else {
        "ascii"
    };
    let mut bytes = format!(
        "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.faces.len()
    )
    .into_bytes();
    for p in &mesh.positions {
        if binary {
            for c in [p.x, p.y, p.z] {
                bytes.extend_from_slice(&(c as f32).to_le_bytes());
            }
        } else {
            bytes.extend_from_slice(format!("{} {} {}\n", p.x, p.y, p.z).as_bytes());
        }
    }
    for f in &mesh.faces {
        if binary {
            bytes.push(3);
            for i in f {
                bytes.extend_from_slice(&(*i as i32).to_le_bytes());
            }
        } else {
            bytes.extend_from_slice(format!("3 {} {} {}\n", f[0], f[1], f[2]).as_bytes());
        }
    }
    bytes
}

#[test]
fn fuzz_obj() {
    let dir = tempfile::tempdir().unwrap();
    let seeds: Vec<Vec<u8>> = seed_meshes()
        .iter()
        .map(|mesh| {
            let path = dir.path().join("seed.obj");
            write_obj(mesh, &path).unwrap();
            std::fs::read(&path).unwrap()
        })
        .collect();
    fuzz("obj", &seeds, load_mesh, finite_mesh);
}

#[test]
fn fuzz_off() {
    let seeds: Vec<Vec<u8>> = seed_meshes()
        .iter()
        .map(|m| off_text(m).into_bytes())
        .collect();
    fuzz("off", &seeds, load_mesh, finite_mesh);
}

#[test]
fn fuzz_ply() {
    let seeds: Vec<Vec<u8>> = seed_meshes()
        .iter()
        .flat_map(|m| [ply_bytes(m, false), ply_bytes(m, true)])
        .collect();
    fuzz("ply", &seeds, load_mesh, finite_mesh);
}

/// A loaded image is finite, its size matches its pixels, and it is below the pixel limit.
fn finite_image(image: &Image<f32>) -> Result<(), String> {
    if image.pixels.len() != image.width * image.height {
        return Err(format!(
            "{}x{} image with {} pixels",
            image.width,
            image.height,
            image.pixels.len()
        ));
    }
    Ok(())
}

#[test]
fn fuzz_png_and_exr() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("seed.png");
    let checker = reparam::texture::checker(8, 2);
    save_png(&checker, &png).unwrap();
    fuzz(
        "png",
        &[std::fs::read(&png).unwrap()],
        load_gray_f32,
        finite_image,
    );
    let exr = dir.path().join("seed.exr");
    let values: Vec<[f32; 2]> = (0..64).map(|i| [i as f32 / 64.0, 0.5]).collect();
    save_exr_rg(&exr, 8, 8, &values).unwrap();
    fuzz(
        "exr",
        &[std::fs::read(&exr).unwrap()],
        load_gray_f32,
        finite_image,
    );
}

/// Standard base64 (for a `.gltf` seed with its buffer in a `data:` URI).
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            out.push(if k <= chunk.len() {
                ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    out
}

/// The GLB's JSON chunk, pretty-printed (tokens to mutate), with its BIN chunk as a data URI.
fn gltf_text(glb: &[u8]) -> Vec<u8> {
    let chunk = |at: usize| {
        let length = u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
        &glb[at + 8..at + 8 + length]
    };
    let json = chunk(12);
    let bin = chunk(12 + 8 + json.len());
    let mut document: serde_json::Value = serde_json::from_slice(json).unwrap();
    document["buffers"][0]["uri"] =
        format!("data:application/octet-stream;base64,{}", base64(bin)).into();
    serde_json::to_vec_pretty(&document).unwrap()
}

#[test]
fn fuzz_gltf_and_glb() {
    let glb = glb_bytes(&skinned_tube(6, 2)).unwrap();
    let check = |skinned: &reparam::mesh::SkinnedMesh| finite_mesh(&skinned.mesh);
    fuzz("gltf", &[gltf_text(&glb)], load_gltf, check);
    fuzz("glb", &[glb], load_gltf, check);
}
