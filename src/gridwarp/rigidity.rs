//! Rigidity maps R over a ROI that are not painted by hand (the paper authored its maps, seed §9:
//! "for all the distortion control map features we used (bounding) circles").
//!
//! - [`rigidity_from_texture`]: R from the colour texture's own detail — where the texture has
//!   edges (colour boundaries, painted features) its content is marked rigid;
//! - [`parse_discs`]: the paper's circles, given as text `s,t,r;s,t,r;…` in ROI coordinates and
//!   turned into a map by [`super::scene::disc_rigidity`].

use nalgebra::Point2;

use super::field::Field;
use super::rasterize::Roi;
use crate::error::{Error, Result};
use crate::texture::{sample_bilinear, Image};

/// Options of [`rigidity_from_texture`]. Defaults: blur σ = 2 field texels, threshold 0.25,
/// background rigidity 0.1 (as the built-in scenes' maps), 3×3 sub-samples per texel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoRigidityOptions {
    /// Standard deviation σ of the Gaussian blur of the edge strength, in field texels.
    pub blur: f64,
    /// Normalised edge strength at and above which a texel is rigid (R = 1).
    pub threshold: f64,
    /// R of the other texels.
    pub background: f64,
    /// Sub-samples per texel and axis of the colour (box pre-filter against aliasing).
    pub supersample: usize,
}

impl Default for AutoRigidityOptions {
    fn default() -> Self {
        AutoRigidityOptions {
            blur: 2.0,
            threshold: 0.25,
            background: 0.1,
            supersample: 3,
        }
    }
}

/// R from a colour texture's detail over `roi` on a `size` = (W, H) field:
///
/// 1. C(x, y): the texture's RGB (in [0, 1]) averaged over `supersample`² bilinear samples of
///    field texel (x, y) (UV of ROI point ((x + ½)/W, (y + ½)/H), OBJ convention v = 0 at the
///    bottom of the image, clamp-to-edge addressing);
/// 2. G = ‖∇C‖ = √(Σ_c (∂_x C_c)² + (∂_y C_c)²) by central differences (one-sided at the field's
///    edges), colour change per field texel; G = 0 where `covered` (if given) marks the texel
///    or one of its 4 neighbours as outside the UV charts, so that chart outlines against the
///    atlas background are not taken for detail;
/// 3. G_σ: G blurred by a Gaussian of σ = `blur` texels (separable, truncated at 3σ, clamped
///    edges);
/// 4. E = G_σ / max G_σ ∈ [0, 1] (E ≡ 0 for a flat texture);
/// 5. R = 1 where E ≥ `threshold`, `background` elsewhere.
///
/// Errors ([`Error::InvalidArgument`]): a zero field size, an empty texture, a `covered` mask of
/// the wrong length, non-finite or out-of-range options (σ < 0, threshold or background outside
/// [0, 1], zero sub-samples).
pub fn rigidity_from_texture(
    texture: &Image<[u8; 4]>,
    roi: &Roi,
    size: (usize, usize),
    covered: Option<&[bool]>,
    options: &AutoRigidityOptions,
) -> Result<Field> {
    let (w, h) = size;
    let o = options;
    let bad = |what: String| {
        Err(Error::InvalidArgument(format!(
            "automatic rigidity: {what}"
        )))
    };
    if w == 0 || h == 0 {
        return bad(format!("field size {w}x{h} must be at least 1x1"));
    }
    if texture.width == 0 || texture.height == 0 {
        return bad("the texture is empty".into());
    }
    if covered.is_some_and(|c| c.len() != w * h) {
        return bad(format!(
            "coverage mask has the wrong length (need {})",
            w * h
        ));
    }
    let valid = o.blur.is_finite()
        && o.blur >= 0.0
        && (0.0..=1.0).contains(&o.threshold)
        && (0.0..=1.0).contains(&o.background)
        && o.supersample > 0;
    if !valid {
        return bad(format!("invalid options {o:?}"));
    }
    // 1. Colour per field texel.
    let n = o.supersample;
    let colour: Vec<[f64; 3]> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut sum = [0.0; 3];
            for a in 0..n {
                for b in 0..n {
                    let s = (x as f64 + (a as f64 + 0.5) / n as f64) / w as f64;
                    let t = (y as f64 + (b as f64 + 0.5) / n as f64) / h as f64;
                    let uv: Point2<f64> = roi.uv(s, t);
                    let c = sample_bilinear(texture, clamp_to_edge(texture, [uv.x, uv.y]));
                    for k in 0..3 {
                        sum[k] += c[k] / 255.0;
                    }
                }
            }
            sum.map(|v| v / (n * n) as f64)
        })
        .collect();
    // 2. Gradient magnitude.
    let inside = |x: usize, y: usize| covered.is_none_or(|c| c[y * w + x]);
    let mut g = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let (xl, xr) = (x.saturating_sub(1), (x + 1).min(w - 1));
            let (yd, yu) = (y.saturating_sub(1), (y + 1).min(h - 1));
            if ![(x, y), (xl, y), (xr, y), (x, yd), (x, yu)]
                .iter()
                .all(|&(a, b)| inside(a, b))
            {
                continue;
            }
            let (dx, dy) = ((xr - xl).max(1) as f64, (yu - yd).max(1) as f64);
            let (left, right) = (colour[y * w + xl], colour[y * w + xr]);
            let (down, up) = (colour[yd * w + x], colour[yu * w + x]);
            let mut sum = 0.0;
            for k in 0..3 {
                let gx = (right[k] - left[k]) / dx;
                let gy = (up[k] - down[k]) / dy;
                sum += gx * gx + gy * gy;
            }
            g[y * w + x] = sum.sqrt();
        }
    }
    // 3. Blur, 4. normalise, 5. threshold.
    let blurred = gaussian_blur(&g, w, h, o.blur);
    let max = blurred.iter().copied().fold(0.0, f64::max);
    let values = blurred
        .iter()
        .map(|&v| {
            let e = if max > 0.0 { v / max } else { 0.0 };
            if max > 0.0 && e >= o.threshold {
                1.0
            } else {
                o.background
            }
        })
        .collect();
    Ok(Field {
        width: w,
        height: h,
        values,
    })
}

/// `uv` moved inside the outermost texel centres, so that [`sample_bilinear`] (which repeats
/// the texture) does not blend in the opposite edge: clamp-to-edge addressing.
fn clamp_to_edge(texture: &Image<[u8; 4]>, uv: [f64; 2]) -> [f64; 2] {
    let (hu, hv) = (0.5 / texture.width as f64, 0.5 / texture.height as f64);
    [uv[0].clamp(hu, 1.0 - hu), uv[1].clamp(hv, 1.0 - hv)]
}

/// Separable Gaussian blur of a W×H image, σ in texels (σ = 0: a copy), kernel truncated at 3σ
/// and normalised, clamp-to-edge.
pub fn gaussian_blur(values: &[f64], w: usize, h: usize, sigma: f64) -> Vec<f64> {
    if sigma <= 0.0 {
        return values.to_vec();
    }
    let radius = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f64> = (-radius..=radius)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = kernel.iter().sum();
    let kernel: Vec<f64> = kernel.iter().map(|k| k / total).collect();
    let pass = |src: &[f64], horizontal: bool| -> Vec<f64> {
        let mut out = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut sum = 0.0;
                for (k, weight) in kernel.iter().enumerate() {
                    let d = k as isize - radius;
                    let (xx, yy) = if horizontal {
                        ((x as isize + d).clamp(0, w as isize - 1) as usize, y)
                    } else {
                        (x, (y as isize + d).clamp(0, h as isize - 1) as usize)
                    };
                    sum += weight * src[yy * w + xx];
                }
                out[y * w + x] = sum;
            }
        }
        out
    };
    pass(&pass(values, true), false)
}

/// Rigid discs `s,t,r;s,t,r;…` (ROI coordinates, radius r > 0; `;` or whitespace between
/// discs). Errors ([`Error::InvalidArgument`] quoting the text): not three numbers per disc, a
/// non-finite value, r ≤ 0, no disc.
pub fn parse_discs(spec: &str) -> Result<Vec<(f64, f64, f64)>> {
    let bad = |why: &str| {
        Error::InvalidArgument(format!(
            "rigid discs must be 's,t,r;s,t,r;…' with r > 0 ({why}), got '{spec}'"
        ))
    };
    let mut discs = Vec::new();
    for part in spec.split([';', ' ']).filter(|p| !p.trim().is_empty()) {
        let v: Vec<f64> = part
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| bad("not a number"))?;
        match v[..] {
            [s, t, r] if s.is_finite() && t.is_finite() && r.is_finite() && r > 0.0 => {
                discs.push((s, t, r))
            }
            [_, _, _] => return Err(bad("non-finite value or r ≤ 0")),
            _ => return Err(bad("three numbers per disc")),
        }
    }
    if discs.is_empty() {
        return Err(bad("no disc"));
    }
    Ok(discs)
}
