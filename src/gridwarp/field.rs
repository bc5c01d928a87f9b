//! Scalar fields over the ROI's unit square (s, t) ∈ [0, 1]², stored as W×H samples at texel
//! centres ((x + ½)/W, (y + ½)/H), as the paper stores them in textures (seed §7): the stretch
//! lengths ‖O_s‖, ‖O_t‖, ‖D_s‖, ‖D_t‖ and the rigidity map R.
//!
//! Row y = 0 is t = 0 (bottom of the ROI). Stretch fields are sampled bilinearly (their gradient
//! enters the analytic Jacobian); the rigidity map is sampled at the nearest texel (a per-texel
//! weight with sharp feature edges; it is only read at fixed rest points).

/// A W×H field over the unit square.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    pub width: usize,
    pub height: usize,
    /// Row-major, row 0 at t = 0.
    pub values: Vec<f64>,
}

/// A bilinear sample and its gradient (∂/∂s, ∂/∂t).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub value: f64,
    pub ds: f64,
    pub dt: f64,
}

impl Field {
    /// The field f(s, t) sampled at the texel centres of a `width`×`height` grid.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(f64, f64) -> f64) -> Field {
        let mut values = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                values.push(f(
                    (x as f64 + 0.5) / width as f64,
                    (y as f64 + 0.5) / height as f64,
                ));
            }
        }
        Field {
            width,
            height,
            values,
        }
    }

    /// A constant field (1×1).
    pub fn constant(value: f64) -> Field {
        Field {
            width: 1,
            height: 1,
            values: vec![value],
        }
    }

    #[inline]
    fn at(&self, x: usize, y: usize) -> f64 {
        self.values[y * self.width + x]
    }

    /// Bilinear interpolation between texel centres (clamped to the edge texels) with its
    /// gradient: with u = s·W − ½ = x₀ + α, v = t·H − ½ = y₀ + β,
    ///   f = (1−α)(1−β) f₀₀ + α(1−β) f₁₀ + (1−α)β f₀₁ + αβ f₁₁,
    ///   ∂f/∂s = W [(1−β)(f₁₀ − f₀₀) + β(f₁₁ − f₀₁)],  ∂f/∂t = H [(1−α)(f₀₁ − f₀₀) + α(f₁₁ − f₁₀)],
    /// the gradient being 0 along an axis where the sample is clamped.
    #[inline]
    pub fn bilinear(&self, s: f64, t: f64) -> Sample {
        self.bilinear_on_axes(&Axis::new(s, self.width), &Axis::new(t, self.height))
    }

    /// [`Field::bilinear`] at a point whose [`Axis`] positions are already known (an
    /// axis-aligned grid's sample points share them along whole columns and rows). An `Axis`
    /// made for another resolution is recomputed for this field's.
    #[inline(always)]
    pub fn bilinear_at(&self, x: &Axis, y: &Axis) -> Sample {
        if x.texels != self.width || y.texels != self.height {
            return self.bilinear(x.s, y.s);
        }
        self.bilinear_on_axes(x, y)
    }

    /// The interpolation itself, `x` and `y` made for this field's width and height.
    #[inline(always)]
    fn bilinear_on_axes(&self, x: &Axis, y: &Axis) -> Sample {
        let (row0, row1) = (y.lower * self.width, y.upper * self.width);
        interpolate(
            x,
            y,
            [
                self.values[row0 + x.lower],
                self.values[row0 + x.upper],
                self.values[row1 + x.lower],
                self.values[row1 + x.upper],
            ],
        )
    }

    /// The value of the texel containing (s, t) (clamped to the field).
    pub fn nearest(&self, s: f64, t: f64) -> f64 {
        self.at(nearest_texel(s, self.width), nearest_texel(t, self.height))
    }
}

/// The index of the texel containing coordinate s on an axis of `texels` texels:
/// ⌊s·n⌋ clamped to 0 … n − 1.
#[inline]
pub fn nearest_texel(s: f64, texels: usize) -> usize {
    ((s * texels as f64).floor().max(0.0) as usize).min(texels - 1)
}

/// The bilinear formula of [`Field::bilinear`] on the four texels [f₀₀, f₁₀, f₀₁, f₁₁] around a
/// point at [`Axis`] positions x, y (fractions α = x.frac, β = y.frac).
#[inline(always)]
pub fn interpolate(x: &Axis, y: &Axis, f: [f64; 4]) -> Sample {
    bilinear_formula((x.frac, x.scale), (y.frac, y.scale), f)
}

/// [`interpolate`] given each axis as (fraction, scale) = (α, du/ds) and (β, dv/dt): the one
/// place the formula is written, so that every caller (a single sample, or a lane of a
/// vectorised loop) gets the same operations in the same order. Interpolated along s on the
/// two texel rows, then along t between them:
///
///   f₀ = f₀₀ + α (f₁₀ − f₀₀),  f₁ = f₀₁ + α (f₁₁ − f₀₁),  f = f₀ + β (f₁ − f₀),
///   ∂f/∂s = du/ds ((f₁₀ − f₀₀) + β ((f₁₁ − f₀₁) − (f₁₀ − f₀₀))),  ∂f/∂t = dv/dt (f₁ − f₀),
///
/// (1−α)(1−β) f₀₀ + α(1−β) f₁₀ + (1−α)β f₀₁ + αβ f₁₁ written with the fewest operations.
#[inline(always)]
pub fn bilinear_formula(
    (alpha, scale_s): (f64, f64),
    (beta, scale_t): (f64, f64),
    [f00, f10, f01, f11]: [f64; 4],
) -> Sample {
    let (along_0, along_1) = (f10 - f00, f11 - f01);
    let (f0, f1) = (f00 + alpha * along_0, f01 + alpha * along_1);
    let across = f1 - f0;
    Sample {
        value: f0 + beta * across,
        ds: scale_s * (along_0 + beta * (along_1 - along_0)),
        dt: scale_t * across,
    }
}

/// The value part of [`bilinear_formula`] (the same operations): f₀ + β (f₁ − f₀).
#[inline(always)]
pub fn bilinear_value(alpha: f64, beta: f64, [f00, f10, f01, f11]: [f64; 4]) -> f64 {
    let (f0, f1) = (f00 + alpha * (f10 - f00), f01 + alpha * (f11 - f01));
    f0 + beta * (f1 - f0)
}

/// Where a coordinate s falls on one axis of `texels` texel centres: u = s·n − ½ = lower + frac,
/// upper = min(lower + 1, n − 1), and scale = du/ds = n inside the texel-centre range, 0 where
/// the sample is clamped to an edge texel. (`!(u > 0)` also sends NaN to the first texel:
/// never an out-of-range index.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    pub s: f64,
    pub texels: usize,
    pub lower: usize,
    pub upper: usize,
    pub frac: f64,
    pub scale: f64,
}

impl Axis {
    /// The position of s on an axis of `texels` texels.
    #[inline]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(u > 0)` is meant: it catches NaN too
    pub fn new(s: f64, texels: usize) -> Axis {
        let n = texels;
        let u = s * n as f64 - 0.5;
        let clamped = |i: usize| Axis {
            s,
            texels,
            lower: i,
            upper: i,
            frac: 0.0,
            scale: 0.0,
        };
        if n <= 1 || !(u > 0.0) {
            return clamped(0);
        }
        if u >= (n - 1) as f64 {
            return clamped(n - 1);
        }
        // u > 0: truncation is the floor, without a libm call.
        let lower = u as usize;
        Axis {
            s,
            texels,
            lower,
            upper: lower + 1,
            frac: u - lower as f64,
            scale: n as f64,
        }
    }
}
