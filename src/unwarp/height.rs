//! The input: a displacement (height) map, from a file or built in (notes § Discretisation).
//!
//! Heights are plain numbers, usually in [0, 1] (PNG: `x / 255` or `x / 65535`; EXR: the raw
//! values); the displacement scale s turns them into lengths. Texel (x, y) is column x, row y
//! (row 0 first, as stored), sampled at the texel centre ((x + ½)/W, (y + ½)/H) of the unit
//! square.

use std::path::Path;

use crate::error::{Error, Result};
use crate::texture::load_gray_f32;

/// A W×H height map, row-major: texel (x, y) is `values[y * width + x]`. Built only through
/// [`HeightMap::new`], so every value is finite and the map is not empty.
#[derive(Clone, Debug, PartialEq)]
pub struct HeightMap {
    pub width: usize,
    pub height: usize,
    pub values: Vec<f64>,
    /// Where the map came from (file path or `procedural:NAME`), used in errors.
    pub name: String,
}

/// The built-in maps of [`procedural`].
pub const PROCEDURAL: [&str; 4] = ["cones", "bumps", "cobbles", "tiles"];

impl HeightMap {
    /// A validated map: [`Error::HeightMapSize`] when empty or when `values` does not hold
    /// W·H values, [`Error::NonFiniteHeight`] naming the first NaN/∞ texel.
    pub fn new(
        name: impl Into<String>,
        width: usize,
        height: usize,
        values: Vec<f64>,
    ) -> Result<Self> {
        let name = name.into();
        let size_error = |reason: String| Error::HeightMapSize {
            map: name.clone(),
            width,
            height,
            reason,
        };
        if width == 0 || height == 0 {
            return Err(size_error("the map is empty".into()));
        }
        if values.len() != width * height {
            return Err(size_error(format!(
                "{} values for {} texels",
                values.len(),
                width * height
            )));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFiniteHeight {
                map: name,
                x: i % width,
                y: i / width,
                value: values[i].to_string(),
            });
        }
        Ok(HeightMap {
            width,
            height,
            values,
            name,
        })
    }

    /// Height of texel (x, y).
    pub fn get(&self, x: usize, y: usize) -> f64 {
        self.values[y * self.width + x]
    }

    /// The map transposed (texel (x, y) ↦ (y, x)); used by the equivariance tests.
    pub fn transposed(&self) -> HeightMap {
        let values = (0..self.width)
            .flat_map(|x| (0..self.height).map(move |y| (x, y)))
            .map(|(x, y)| self.get(x, y))
            .collect();
        HeightMap {
            width: self.height,
            height: self.width,
            values,
            name: format!("{} (transposed)", self.name),
        }
    }

    /// The map rolled by (dx, dy) texels with wrap-around: new (x, y) = old (x − dx, y − dy).
    pub fn rolled(&self, dx: usize, dy: usize) -> HeightMap {
        let (w, h) = (self.width, self.height);
        let values = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| self.get((x + w - dx % w) % w, (y + h - dy % h) % h))
            .collect();
        HeightMap {
            width: w,
            height: h,
            values,
            name: format!("{} (rolled {dx},{dy})", self.name),
        }
    }

    /// The next coarser level of coarse-to-fine: the 2×2 box average,
    /// h'(X, Y) = ¼ Σ h(2X + i, 2Y + j). `None` unless both sizes are even.
    pub fn downsampled(&self) -> Option<HeightMap> {
        if !self.width.is_multiple_of(2) || !self.height.is_multiple_of(2) {
            return None;
        }
        let (w, h) = (self.width / 2, self.height / 2);
        let values = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let (x2, y2) = (2 * x, 2 * y);
                0.25 * ((self.get(x2, y2) + self.get(x2 + 1, y2))
                    + (self.get(x2, y2 + 1) + self.get(x2 + 1, y2 + 1)))
            })
            .collect();
        Some(HeightMap {
            width: w,
            height: h,
            values,
            name: format!("{} (÷2)", self.name),
        })
    }
}

/// Load a height map: PNG (8- or 16-bit, grey or colour → luma in [0, 1]) or OpenEXR (raw
/// values, see [`load_gray_f32`]). Unreadable files give [`Error::Io`] / [`Error::Image`],
/// empty or non-finite maps the errors of [`HeightMap::new`].
pub fn load_height_map(path: &Path) -> Result<HeightMap> {
    let image = load_gray_f32(path)?;
    HeightMap::new(
        path.display().to_string(),
        image.width,
        image.height,
        image.pixels.iter().map(|&v| v as f64).collect(),
    )
}

/// A built-in periodic map of `size`×`size` texels (one of [`PROCEDURAL`]), sampled at texel
/// centres, values in [0, 1]:
///
/// - `cones`: **six clipped cones**, the 64² map of the notes' reference figures. The notes do
///   not define their map, so it is reconstructed: cone i has centre cᵢ (below), radius
///   r = [`CONE_RADIUS`] and height min(k (1 − d/r), 1) with k = [`CONE_STEEPNESS`] (d the
///   periodic distance to cᵢ): a flank of width r/k ≈ 1.55 texels at 64² rising to a flat top;
///   overlapping cones take the maximum. r and k were fitted (on a grid of 0.005 and 0.1) to
///   the two figures that depend on the map alone, the initial energy ratio 2.577 and the
///   initial area-ratio CV 0.178 at 64², s = 0.08, θ = 5 (ours: 2.607 and 0.177); the solver's
///   figures after pass 0 are then predictions (`tests/unwarp.rs`).
///   Centres: (0.20, 0.25), (0.55, 0.15), (0.85, 0.40), (0.35, 0.60), (0.70, 0.75), (0.10, 0.85).
/// - `bumps`: eight Gaussian bumps of varied widths, max-normalised.
/// - `cobbles`: rounded stones, h = √clamp((F₂ − F₁)/0.08) of a periodic 6×6 jittered Worley
///   pattern (F₁, F₂ the nearest and second-nearest feature distances).
/// - `tiles`: 4×4 square tiles with bevelled edges, h = clamp(distance to the tile edge / 0.03).
///
/// [`Error::InvalidArgument`] for an unknown name, [`Error::HeightMapSize`] for size 0.
pub fn procedural(name: &str, size: usize) -> Result<HeightMap> {
    let f: fn(f64, f64) -> f64 = match name {
        "cones" => six_clipped_cones,
        "bumps" => bumps,
        "cobbles" => cobbles,
        "tiles" => tiles,
        _ => {
            return Err(Error::InvalidArgument(format!(
                "unknown procedural height map '{name}' (known: {})",
                PROCEDURAL.join(", ")
            )))
        }
    };
    let n = size as f64;
    let values = (0..size)
        .flat_map(|y| (0..size).map(move |x| (x, y)))
        .map(|(x, y)| f((x as f64 + 0.5) / n, (y as f64 + 0.5) / n))
        .collect();
    HeightMap::new(format!("procedural:{name}"), size, size, values)
}

/// Distance on the unit torus.
fn periodic_distance(p: [f64; 2], q: [f64; 2]) -> f64 {
    let wrap = |d: f64| d - d.round();
    wrap(p[0] - q[0]).hypot(wrap(p[1] - q[1]))
}

/// Centres of the six clipped cones (see [`procedural`]).
pub const CONE_CENTRES: [[f64; 2]; 6] = [
    [0.20, 0.25],
    [0.55, 0.15],
    [0.85, 0.40],
    [0.35, 0.60],
    [0.70, 0.75],
    [0.10, 0.85],
];
/// Radius r of the six clipped cones (texture units).
pub const CONE_RADIUS: f64 = 0.08;
/// Steepness k of the six clipped cones: height min(k (1 − d/r), 1).
pub const CONE_STEEPNESS: f64 = 3.3;

fn six_clipped_cones(u: f64, v: f64) -> f64 {
    CONE_CENTRES
        .iter()
        .map(|&c| {
            (CONE_STEEPNESS * (1.0 - periodic_distance([u, v], c) / CONE_RADIUS)).clamp(0.0, 1.0)
        })
        .fold(0.0, f64::max)
}

fn bumps(u: f64, v: f64) -> f64 {
    const BUMPS: [([f64; 2], f64, f64); 8] = [
        ([0.15, 0.20], 0.08, 1.0),
        ([0.60, 0.30], 0.12, 0.8),
        ([0.40, 0.75], 0.06, 0.9),
        ([0.85, 0.80], 0.10, 0.7),
        ([0.30, 0.45], 0.04, 0.6),
        ([0.75, 0.55], 0.05, 1.0),
        ([0.05, 0.60], 0.07, 0.5),
        ([0.50, 0.05], 0.05, 0.8),
    ];
    let sum: f64 = BUMPS
        .iter()
        .map(|&(c, sigma, amp)| amp * (-(periodic_distance([u, v], c) / sigma).powi(2) / 2.0).exp())
        .sum();
    sum.min(1.0)
}

/// A deterministic hash of a cell to a point in [0.15, 0.85]² of that cell.
fn cell_jitter(i: i64, j: i64) -> [f64; 2] {
    let mut h = (i.wrapping_mul(73_856_093) ^ j.wrapping_mul(19_349_663)) as u64;
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    let a = (h & 0xffff) as f64 / 65535.0;
    let b = ((h >> 16) & 0xffff) as f64 / 65535.0;
    [0.15 + 0.7 * a, 0.15 + 0.7 * b]
}

fn cobbles(u: f64, v: f64) -> f64 {
    const CELLS: i64 = 6;
    let n = CELLS as f64;
    let (ci, cj) = ((u * n).floor() as i64, (v * n).floor() as i64);
    let (mut f1, mut f2) = (f64::INFINITY, f64::INFINITY);
    for dj in -1..=1 {
        for di in -1..=1 {
            let (i, j) = (ci + di, cj + dj);
            let jitter = cell_jitter(i.rem_euclid(CELLS), j.rem_euclid(CELLS));
            let p = [(i as f64 + jitter[0]) / n, (j as f64 + jitter[1]) / n];
            let d = periodic_distance([u, v], p);
            if d < f1 {
                f2 = f1;
                f1 = d;
            } else if d < f2 {
                f2 = d;
            }
        }
    }
    ((f2 - f1) / 0.08).clamp(0.0, 1.0).sqrt()
}

fn tiles(u: f64, v: f64) -> f64 {
    const TILES: f64 = 4.0;
    let edge = |t: f64| {
        let f = (t * TILES).fract();
        f.min(1.0 - f) / TILES
    };
    (edge(u).min(edge(v)) / 0.03).clamp(0.0, 1.0)
}
