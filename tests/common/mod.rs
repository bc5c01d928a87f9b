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
