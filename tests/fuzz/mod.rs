//! The mutation fuzzer shared by `fuzz_parsers` and `fuzz_commands` (issue #25), on stable Rust.
//!
//! **Why hand-written.** cargo-fuzz needs nightly; `bolero`'s stable mode and `proptest` drive a
//! closure with generated *values*, but what breaks loaders is structure inside *bytes* (a
//! count in a header, a token repeated 2 000 times, a truncated chunk, two files spliced), which
//! needs a mutator that knows tokens and digit runs either way. The mutator below is 60 lines,
//! deterministic (seeded xorshift), and adds no dependency; the harness adds what those crates
//! do not give: a time bound linear in the input size, a peak-memory bound measured by a
//! counting global allocator, a watchdog for hangs, and counts of outcomes for long runs.
//!
//! **Per case:** no panic (caught, message kept), the target's own check (an error is one line
//! naming the file, a result is finite), time ≤ `base + per_byte · bytes`, peak heap growth
//! ≤ `mem_base + mem_per_byte · bytes` (all threads: cases run one at a time per process).
//! A failing case is kept under `target/tmp/fuzz-failures/` and the run goes on; the test fails
//! once all its targets have run, listing them ([`assert_clean`]). The case being run is always on disk at
//! `target/tmp/fuzz-current/<target>.<ext>`, so an abort (allocation beyond the 8 GiB hard cap,
//! or the watchdog after 120 s) leaves it behind.
//!
//! **Run size:** `REPARAM_FUZZ_CASES` (cases per target, default the target's CI size),
//! `REPARAM_FUZZ_SECS` (seconds per target; without `REPARAM_FUZZ_CASES`, as many cases as fit),
//! `REPARAM_FUZZ_SEED`. Each target prints one line of counts.

#![allow(dead_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock, PoisonError};
use std::time::{Duration, Instant};

use reparam::input::{with_reference_policy, ReferencePolicy};

// ---------------------------------------------------------------------------------------------
// Counting allocator

/// The system allocator, counting the bytes live and their peak; refuses (so the process aborts
/// with "memory allocation failed") past [`HARD_CAP`] while a case runs.
pub struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static FUZZING: AtomicBool = AtomicBool::new(false);

/// Live heap bytes beyond which a running case's allocations fail (8 GiB).
pub const HARD_CAP: usize = 8 << 30;

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
        if live > HARD_CAP && FUZZING.load(Ordering::Relaxed) {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            return std::ptr::null_mut();
        }
        PEAK.fetch_max(live, Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator.
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: `ptr` came from `alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let old = layout.size();
        if new_size > old {
            let live = LIVE.fetch_add(new_size - old, Ordering::Relaxed) + (new_size - old);
            if live > HARD_CAP && FUZZING.load(Ordering::Relaxed) {
                LIVE.fetch_sub(new_size - old, Ordering::Relaxed);
                return std::ptr::null_mut();
            }
            PEAK.fetch_max(live, Ordering::Relaxed);
        } else {
            LIVE.fetch_sub(old - new_size, Ordering::Relaxed);
        }
        // SAFETY: forwarded unchanged to the system allocator.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            if new_size > old {
                LIVE.fetch_sub(new_size - old, Ordering::Relaxed);
            } else {
                LIVE.fetch_add(old - new_size, Ordering::Relaxed);
            }
        }
        p
    }
}

// ---------------------------------------------------------------------------------------------
// Mutation

/// xorshift64*: deterministic, no dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Numbers that break naive parsers: signs, the integer type edges, overflow, specials.
pub const HOSTILE_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "3",
    "255",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999",
    "1e308",
    "-1e308",
    "nan",
    "NaN",
    "inf",
    "1e-320",
    "2e10",
];

/// The integer limits of issue #35, each put in place of a numeric token by the mutator: the
/// edges of i32, u32, i64 and u64 (2⁶⁴ − 1 as a corner count found a `capacity overflow`
/// panic that the list above, with 2⁶⁴ but not 2⁶⁴ − 1, missed), a huge float and NaN.
pub const INTEGER_LIMITS: &[&str] = &[
    "0",
    "-1",
    "2147483647",
    "4294967296",
    "9223372036854775807",
    "18446744073709551615",
    "1e308",
    "NaN",
];

/// Names that a mutated reference (a glTF `uri`, an OBJ `mtllib`, an MTL `map_Kd`) is replaced
/// with (issue #35): devices that never end, the special files [`prepare_special_files`] puts
/// next to the case (a FIFO without a writer, a directory, a file shorter than any buffer,
/// material libraries naming such files), `..` chains out of the folder, a `file:` URI.
pub const SPECIAL_PATHS: &[&str] = &[
    "/dev/zero",
    "/dev/urandom",
    "special-fifo",
    "special-dir",
    "special-short.bin",
    "special-zero.mtl",
    "special-fifo.mtl",
    "special-up.mtl",
    "../../../../../../../../../../dev/zero",
    "special-dir/../../fuzz-current/special-fifo",
    "../fuzz-current/special-fifo",
    "file:///dev/urandom",
];

/// Create, in `dir` (the folder of the case files), the files [`SPECIAL_PATHS`] names: a FIFO
/// nobody writes to (reading it would block forever), a directory, a 3-byte file, material
/// libraries whose `map_Kd` is a device, the FIFO and a `..` chain, and `fuzz-seed.mtl` /
/// `fuzz-texture.png`, the valid library and texture the OBJ seeds name.
pub fn prepare_special_files(dir: &Path) {
    std::fs::create_dir_all(dir.join("special-dir")).unwrap();
    let fifo = dir.join("special-fifo");
    if !fifo.exists() {
        #[cfg(unix)]
        {
            let name = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path.
            unsafe { libc::mkfifo(name.as_ptr(), 0o600) };
        }
    }
    let files: [(&str, &[u8]); 5] = [
        ("special-short.bin", b"abc"),
        ("special-zero.mtl", b"newmtl a\nmap_Kd /dev/zero\n"),
        ("special-fifo.mtl", b"newmtl a\nmap_Kd special-fifo\n"),
        (
            "special-up.mtl",
            b"newmtl a\nmap_Kd ../../../../../../../dev/zero\n",
        ),
        ("fuzz-seed.mtl", b"newmtl a\nmap_Kd fuzz-texture.png\n"),
    ];
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let texture = reparam::texture::checker(8, 2);
    reparam::texture::save_png(&texture, &dir.join("fuzz-texture.png")).unwrap();
}

/// An OBJ seed with `mtllib fuzz-seed.mtl` in front (the library and its texture are made by
/// [`prepare_special_files`]), so that the reference mutation has an `mtllib` to replace.
pub fn with_material_library(obj: &[u8]) -> Vec<u8> {
    [&b"mtllib fuzz-seed.mtl\n"[..], obj].concat()
}

/// Standard base64 (for a `.gltf` seed with its buffer in a `data:` URI).
pub fn base64(bytes: &[u8]) -> String {
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

/// A GLB's JSON chunk, pretty-printed (tokens to mutate), with its BIN chunk as a data URI and
/// a base-colour texture `fuzz-texture.png` on the first mesh's primitives (two references
/// for the reference mutation).
pub fn gltf_text(glb: &[u8]) -> Vec<u8> {
    let chunk = |at: usize| {
        let length = u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
        &glb[at + 8..at + 8 + length]
    };
    let json = chunk(12);
    let bin = chunk(12 + 8 + json.len());
    let mut document: serde_json::Value = serde_json::from_slice(json).unwrap();
    document["buffers"][0]["uri"] =
        format!("data:application/octet-stream;base64,{}", base64(bin)).into();
    document["images"] = serde_json::json!([{"uri": "fuzz-texture.png"}]);
    document["textures"] = serde_json::json!([{"source": 0}]);
    document["materials"] =
        serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    if let Some(primitives) = document["meshes"][0]["primitives"].as_array_mut() {
        for primitive in primitives {
            primitive["material"] = 0.into();
        }
    }
    serde_json::to_vec_pretty(&document).unwrap()
}

/// Byte ranges of the references in `bytes`: the string after each `"uri":` (JSON) and the
/// rest of each line starting with `mtllib` or `map_Kd` (OBJ, MTL).
pub fn reference_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let find = |from: usize, byte: u8| {
        bytes[from..]
            .iter()
            .position(|&b| b == byte)
            .map(|k| from + k)
    };
    let mut at = 0;
    while let Some(k) = bytes[at..].windows(5).position(|w| w == b"\"uri\"") {
        let key_end = at + k + 5;
        let Some(open) = find(key_end, b'"') else {
            break;
        };
        let Some(close) = find(open + 1, b'"') else {
            break;
        };
        out.push((open + 1, close));
        at = close + 1;
    }
    let mut start = 0;
    for line in bytes.split(|&b| b == b'\n') {
        for keyword in [&b"mtllib "[..], b"map_Kd "] {
            if line.starts_with(keyword) {
                let end = start + line.len() - usize::from(line.ends_with(b"\r"));
                out.push((start + keyword.len(), end));
            }
        }
        start += line.len() + 1;
    }
    out
}

/// Byte ranges of the numbers of `bytes`: runs of digits with a sign, a point and an exponent.
pub fn number_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    digit_runs(bytes)
        .into_iter()
        .map(|(mut s, mut e)| {
            if s > 0 && bytes[s - 1] == b'-' {
                s -= 1;
            }
            while e < bytes.len()
                && matches!(bytes[e], b'.' | b'e' | b'E' | b'+' | b'-' | b'0'..=b'9')
            {
                e += 1;
            }
            (s, e)
        })
        .collect()
}

/// Byte ranges of the whitespace-separated tokens of `bytes`.
pub fn tokens(bytes: &[u8]) -> Vec<(usize, usize)> {
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
pub fn digit_runs(bytes: &[u8]) -> Vec<(usize, usize)> {
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

/// One to three mutations of `seed` (`other` is a second seed for splicing): flipped, inserted
/// and deleted bytes, a token duplicated up to 2 000 times, a token deleted, a token or a run
/// of digits replaced by a hostile number, a number replaced by an integer limit
/// ([`INTEGER_LIMITS`]), a reference replaced by a special file ([`SPECIAL_PATHS`]),
/// truncation, splicing.
pub fn mutate(rng: &mut Rng, seed: &[u8], other: &[u8]) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    for _ in 0..1 + rng.below(3) {
        let toks = tokens(&bytes);
        match rng.below(11) {
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
                let runs = digit_runs(&bytes);
                if !runs.is_empty() {
                    let (s, e) = runs[rng.below(runs.len())];
                    let number = HOSTILE_NUMBERS[rng.below(HOSTILE_NUMBERS.len())];
                    bytes.splice(s..e, number.bytes());
                }
            }
            8 => {
                let numbers = number_spans(&bytes);
                if !numbers.is_empty() {
                    let (s, e) = numbers[rng.below(numbers.len())];
                    let limit = INTEGER_LIMITS[rng.below(INTEGER_LIMITS.len())];
                    bytes.splice(s..e, limit.bytes());
                }
            }
            9 => {
                let references = reference_spans(&bytes);
                if !references.is_empty() {
                    let (s, e) = references[rng.below(references.len())];
                    let path = SPECIAL_PATHS[rng.below(SPECIAL_PATHS.len())];
                    bytes.splice(s..e, path.bytes());
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

// ---------------------------------------------------------------------------------------------
// Harness

/// The limits one case must stay within.
#[derive(Clone, Copy, Debug)]
pub struct Bounds {
    pub base: Duration,
    pub per_byte: Duration,
    pub mem_base: usize,
    pub mem_per_byte: usize,
}

impl Bounds {
    fn time(&self, bytes: usize) -> Duration {
        self.base + self.per_byte * bytes as u32
    }
    fn memory(&self, bytes: usize) -> usize {
        self.mem_base + self.mem_per_byte * bytes
    }
}

/// What a target's check made of a case that neither panicked nor broke a bound.
pub enum Verdict {
    /// A result, checked.
    Result,
    /// A typed error, checked (one line, naming the file).
    Error,
}

/// Outcomes of one target's run.
#[derive(Default)]
pub struct Tally {
    pub cases: usize,
    pub results: usize,
    pub errors: usize,
    pub failures: Vec<String>,
    /// The largest time / limit and memory / limit ratios seen, and the most time per byte.
    pub worst_time_ratio: f64,
    pub worst_memory_ratio: f64,
    pub peak_bytes: usize,
    pub slowest: Duration,
    pub largest_input: usize,
}

/// One case at a time per process: the allocator's peak and the panic hook are global.
static SERIAL: Mutex<()> = Mutex::new(());
/// The message of the last panic during a case.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);
/// The running case: start, hard time limit, file.
static CURRENT: Mutex<Option<(Instant, Duration, PathBuf)>> = Mutex::new(None);

/// During a case, panics are recorded (not printed); otherwise the default hook prints them.
fn install_hooks() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if FUZZING.load(Ordering::Relaxed) {
                let mut last = LAST_PANIC.lock().unwrap_or_else(PoisonError::into_inner);
                if last.is_none() {
                    *last = Some(info.to_string().replace('\n', " "));
                }
            } else {
                default(info);
            }
        }));
        // Watchdog: a case past its hard limit is a hang; keep it and abort.
        std::thread::spawn(|| loop {
            std::thread::sleep(Duration::from_millis(500));
            let current = CURRENT
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .clone();
            if let Some((start, limit, path)) = current {
                if start.elapsed() > limit {
                    eprintln!(
                        "fuzz: case {} still running after {:?}: a hang; aborting",
                        path.display(),
                        start.elapsed()
                    );
                    std::process::abort();
                }
            }
        });
    });
}

/// Cases per target and seconds per target, and the first seed, from the environment.
pub fn plan(default_cases: usize) -> (usize, Option<Duration>, u64) {
    let var = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok());
    let secs = var("REPARAM_FUZZ_SECS").map(Duration::from_secs);
    let cases = match (var("REPARAM_FUZZ_CASES"), secs) {
        (Some(n), _) => n as usize,
        (None, Some(_)) => usize::MAX,
        (None, None) => default_cases,
    };
    let seed = var("REPARAM_FUZZ_SEED")
        .unwrap_or(0x9E37_79B9_7F4A_7C15)
        .max(1);
    (cases, secs, seed)
}

/// A directory under cargo's per-target temporary folder.
pub fn tmp_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Fuzz `run` on files `<target>.<ext>` mutated from `seeds` (`default_cases` unless the
/// environment says otherwise); print the tally and return it (see [`assert_clean`]).
/// Recompute the CRC-32 of every whole chunk of a PNG (length, type, data, CRC; PNG spec §5.3)
/// after a mutation, so that a changed width, bit depth or pixel reaches the caller of the
/// decoder rather than stopping at the checksum. Chunks are walked from byte 8 while they fit;
/// the rest is left as mutated.
pub fn repair_png_checksums(bytes: &mut [u8]) {
    let mut at = 8;
    while at + 12 <= bytes.len() {
        let length = u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
        let end = at + 8 + length as usize;
        if end + 4 > bytes.len() {
            return;
        }
        let crc = crc32fast::hash(&bytes[at + 4..end]);
        bytes[end..end + 4].copy_from_slice(&crc.to_be_bytes());
        at = end + 4;
    }
}

/// Rewrite a GLB's lengths after a mutation (glTF 2.0 §4.4: a 12-byte header with the total
/// length, then chunks of length, type, data): the total becomes the file's size and the JSON
/// chunk's length reaches the `BIN\0` chunk's header (or the end), so that an edit of the JSON
/// reaches the glTF loader instead of stopping at the container.
pub fn repair_glb_lengths(bytes: &mut [u8]) {
    if bytes.len() < 20 {
        return;
    }
    let total = u32::try_from(bytes.len()).unwrap_or(u32::MAX);
    bytes[8..12].copy_from_slice(&total.to_le_bytes());
    let bin = bytes[20..]
        .windows(4)
        .position(|w| w == b"BIN\0")
        .filter(|&at| at >= 4)
        .map_or(bytes.len(), |at| 20 + at - 4);
    let json = u32::try_from(bin - 20).unwrap_or(u32::MAX);
    bytes[12..16].copy_from_slice(&json.to_le_bytes());
}

pub fn fuzz(
    target: &str,
    ext: &str,
    seeds: &[Vec<u8>],
    default_cases: usize,
    bounds: Bounds,
    mut run: impl FnMut(&Path) -> Result<Verdict, String>,
) -> Tally {
    install_hooks();
    let (cases, secs, seed) = plan(default_cases);
    let mut rng = Rng(seed
        ^ target
            .bytes()
            .fold(0u64, |h, b| h.wrapping_mul(31).wrapping_add(b as u64)));
    let path = tmp_dir("fuzz-current").join(format!("{target}.{ext}"));
    prepare_special_files(path.parent().unwrap());
    let started = Instant::now();
    let mut tally = Tally::default();
    while tally.cases < cases && secs.is_none_or(|s| started.elapsed() < s) {
        let case = tally.cases;
        tally.cases += 1;
        let first = &seeds[rng.below(seeds.len())];
        let second = &seeds[rng.below(seeds.len())];
        let mut bytes = mutate(&mut rng, first, second);
        if rng.below(2) == 0 {
            match ext {
                "png" => repair_png_checksums(&mut bytes),
                "glb" => repair_glb_lengths(&mut bytes),
                _ => {}
            }
        }
        std::fs::write(&path, &bytes).unwrap();
        let (time_limit, memory_limit) = (bounds.time(bytes.len()), bounds.memory(bytes.len()));

        let serial = SERIAL.lock().unwrap_or_else(PoisonError::into_inner);
        *LAST_PANIC.lock().unwrap_or_else(PoisonError::into_inner) = None;
        let live = LIVE.load(Ordering::Relaxed);
        PEAK.store(live, Ordering::Relaxed);
        *CURRENT.lock().unwrap_or_else(PoisonError::into_inner) = Some((
            Instant::now(),
            4 * time_limit + Duration::from_secs(120),
            path.clone(),
        ));
        FUZZING.store(true, Ordering::Relaxed);
        let start = Instant::now();
        // Every other case follows references anywhere (`--allow-outside-references`), so that
        // a device named by an absolute path reaches the file checks, not only the policy.
        let policy = match case % 2 {
            0 => ReferencePolicy::ModelFolder,
            _ => ReferencePolicy::Anywhere,
        };
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            with_reference_policy(policy, || run(&path))
        }));
        let took = start.elapsed();
        FUZZING.store(false, Ordering::Relaxed);
        *CURRENT.lock().unwrap_or_else(PoisonError::into_inner) = None;
        let peak = PEAK.load(Ordering::Relaxed).saturating_sub(live);
        let panic = LAST_PANIC
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take();
        drop(serial);

        tally.worst_time_ratio = tally
            .worst_time_ratio
            .max(took.as_secs_f64() / time_limit.as_secs_f64());
        tally.worst_memory_ratio = tally
            .worst_memory_ratio
            .max(peak as f64 / memory_limit as f64);
        tally.peak_bytes = tally.peak_bytes.max(peak);
        tally.slowest = tally.slowest.max(took);
        tally.largest_input = tally.largest_input.max(bytes.len());
        let problem = match outcome {
            Err(_) => Some(format!(
                "panicked: {}",
                panic.unwrap_or_else(|| "(no message)".into())
            )),
            Ok(Err(problem)) => Some(problem),
            Ok(Ok(Verdict::Result)) => {
                tally.results += 1;
                None
            }
            Ok(Ok(Verdict::Error)) => {
                tally.errors += 1;
                None
            }
        };
        let problem = problem
            .or_else(|| {
                (took > time_limit).then(|| {
                    format!(
                        "took {took:?} for {} bytes (limit {time_limit:?})",
                        bytes.len()
                    )
                })
            })
            .or_else(|| {
                (peak > memory_limit).then(|| {
                    format!(
                        "peak heap {peak} bytes for {} bytes (limit {memory_limit})",
                        bytes.len()
                    )
                })
            });
        if let Some(problem) = problem {
            let kept = tmp_dir("fuzz-failures").join(format!("{target}-case{case}.{ext}"));
            std::fs::write(&kept, &bytes).unwrap();
            tally.failures.push(format!(
                "{target} case {case}: {problem} (input kept in {})",
                kept.display()
            ));
        }
    }
    println!(
        "fuzz {target}: {} cases in {:.1} s: {} results, {} typed errors, {} failures; slowest \
         {:?} ({:.0}% of its bound), peak heap {} KiB ({:.0}% of its bound), largest input {} \
         bytes",
        tally.cases,
        started.elapsed().as_secs_f64(),
        tally.results,
        tally.errors,
        tally.failures.len(),
        tally.slowest,
        100.0 * tally.worst_time_ratio,
        tally.peak_bytes >> 10,
        100.0 * tally.worst_memory_ratio,
        tally.largest_input,
    );
    tally
}

/// Fail listing the failing cases of `tallies` (at most 20), if any: called once every target
/// of a test has run, so that one target's failure does not stop the others of a long run.
pub fn assert_clean(tallies: &[Tally]) {
    let failures: Vec<&str> = tallies
        .iter()
        .flat_map(|t| t.failures.iter().map(|s| s.as_str()))
        .collect();
    if !failures.is_empty() {
        panic!(
            "{} failing case(s):\n{}",
            failures.len(),
            failures[..failures.len().min(20)].join("\n")
        );
    }
}

/// An error's message, checked to be one line naming `path`'s file name.
pub fn one_line_naming(shown: &str, path: &Path) -> Result<Verdict, String> {
    let name = path.file_name().unwrap().to_string_lossy();
    if shown.contains('\n') || !shown.contains(name.as_ref()) {
        return Err(format!("error not one line naming the file: {shown:?}"));
    }
    Ok(Verdict::Error)
}
