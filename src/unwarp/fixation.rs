//! Fixation (seed: "Fixation Energy — mark parts of textures fixed"; notes § Fixation): pin
//! weights from the height map or a painted mask, and the barrier that keeps a pinned node near
//! its start.
//!
//! Pin weight w = max(1 − |h − h_fix|/Δ, 0) (Δ ≤ 0 disables it), or the larger of that and a
//! painted mask value. Barrier E_pin(o) = ½ / (1 − ‖w R⊙o‖²) with R = (W, H), so R⊙o is the
//! offset in texels: a node of weight w stays strictly within 1/w texels of offset 0.

use crate::error::{Error, Result};
use crate::texture::Image;

use super::height::HeightMap;

/// Where texels are pinned.
#[derive(Clone, Debug, PartialEq)]
pub struct FixationOptions {
    /// Height at which texels are pinned fully. Default 0 (the undisplaced base).
    pub h_fix: f64,
    /// Width of the pinned height band; ≤ 0 disables height-based pinning. Default 0.04.
    pub delta: f64,
    /// A painted pin mask (values in [0, 1], 1 = pinned), the same size as the height map;
    /// the weight is the larger of mask and height-based weight. Default: none.
    pub mask: Option<Image<f32>>,
}

impl Default for FixationOptions {
    fn default() -> Self {
        FixationOptions {
            h_fix: 0.0,
            delta: 0.04,
            mask: None,
        }
    }
}

/// w = max(1 − |h − h_fix|/Δ, 0), or 0 when Δ ≤ 0.
pub fn pin_weight(h: f64, h_fix: f64, delta: f64) -> f64 {
    if delta > 0.0 {
        (1.0 - (h - h_fix).abs() / delta).max(0.0)
    } else {
        0.0
    }
}

/// The pin weight of every texel of `heights` (row-major). Errors: non-finite h_fix or Δ
/// ([`Error::InvalidArgument`]), a mask of another size ([`Error::HeightMapSize`]) or with a
/// non-finite value ([`Error::NonFiniteHeight`]). Mask values are clamped to [0, 1].
pub fn pin_weights(heights: &HeightMap, options: &FixationOptions) -> Result<Vec<f64>> {
    if !options.h_fix.is_finite() || !options.delta.is_finite() {
        return Err(Error::InvalidArgument(format!(
            "fixation h_fix = {}, Δ = {} must be finite",
            options.h_fix, options.delta
        )));
    }
    let mut weights: Vec<f64> = heights
        .values
        .iter()
        .map(|&h| pin_weight(h, options.h_fix, options.delta))
        .collect();
    if let Some(mask) = &options.mask {
        if mask.width != heights.width || mask.height != heights.height {
            return Err(Error::HeightMapSize {
                map: "pin mask".into(),
                width: mask.width,
                height: mask.height,
                reason: format!(
                    "the pin mask must have the height map's size {}x{}",
                    heights.width, heights.height
                ),
            });
        }
        for (i, (&m, w)) in mask.pixels.iter().zip(&mut weights).enumerate() {
            if !m.is_finite() {
                return Err(Error::NonFiniteHeight {
                    map: "pin mask".into(),
                    x: i % mask.width,
                    y: i / mask.width,
                    value: m.to_string(),
                });
            }
            *w = w.max((m as f64).clamp(0.0, 1.0));
        }
    }
    Ok(weights)
}

/// q = ‖w R⊙o‖² = w² ((W o.x)² + (H o.y)²).
pub fn pin_q(weight: f64, resolution: [f64; 2], o: [f64; 2]) -> f64 {
    let (tx, ty) = (weight * resolution[0] * o[0], weight * resolution[1] * o[1]);
    tx * tx + ty * ty
}

/// E_pin(o) = ½ / (1 − q); +∞ outside the barrier (q ≥ 1). ½ for an unpinned node (w = 0).
pub fn pin_energy(weight: f64, resolution: [f64; 2], o: [f64; 2]) -> f64 {
    let q = pin_q(weight, resolution, o);
    if q < 1.0 {
        0.5 / (1.0 - q)
    } else {
        f64::INFINITY
    }
}

/// ∇E_pin(o) = ½ ∇q / (1 − q)², ∇q = 2 w² (W² o.x, H² o.y).
pub fn pin_gradient(weight: f64, resolution: [f64; 2], o: [f64; 2]) -> [f64; 2] {
    let q = pin_q(weight, resolution, o);
    let s = 0.5 / ((1.0 - q) * (1.0 - q));
    let w2 = weight * weight;
    [
        s * 2.0 * w2 * resolution[0] * resolution[0] * o[0],
        s * 2.0 * w2 * resolution[1] * resolution[1] * o[1],
    ]
}

/// The barrier's root along the step o − t g: the positive t with q(o − t g) = 1, i.e. of
/// α t² − 2β t − (1 − γ) = 0 with α = w²Σ Rᵢ² gᵢ², β = w²Σ Rᵢ² oᵢ gᵢ, γ = q(o) < 1:
/// t₊ = (β + √(β² + α(1 − γ)))/α, computed as (1 − γ)/(√… − β) when β < 0 (no
/// cancellation). `None` when w = 0, g = 0 or the start is not inside (γ ≥ 1).
pub fn pin_root(weight: f64, resolution: [f64; 2], o: [f64; 2], g: [f64; 2]) -> Option<f64> {
    let w2 = weight * weight;
    let (rx2, ry2) = (resolution[0] * resolution[0], resolution[1] * resolution[1]);
    let alpha = w2 * (rx2 * g[0] * g[0] + ry2 * g[1] * g[1]);
    let beta = w2 * (rx2 * o[0] * g[0] + ry2 * o[1] * g[1]);
    let gamma = pin_q(weight, resolution, o);
    if !(alpha > 0.0 && gamma < 1.0) {
        return None;
    }
    let disc = (beta * beta + alpha * (1.0 - gamma)).sqrt();
    let root = if beta >= 0.0 {
        (beta + disc) / alpha
    } else {
        (1.0 - gamma) / (disc - beta)
    };
    Some(root)
}
