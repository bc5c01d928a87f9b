//! Test support: tiny meshes, their stars in the kernels' layout, and f64 complex arithmetic for
//! expected values. Independent of the reference crate, as `reparam-gpu` itself is.

#![allow(dead_code)]

use reparam_gpu::bpm::{neighbour_bit, StarInput};

/// f32 unit roundoff u = 2⁻²⁴.
pub const U32: f64 = 5.960_464_477_539_063e-8;

/// A complex number in f64 (re, im).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct C(pub f64, pub f64);

impl C {
    pub fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    pub fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    pub fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    pub fn div(self, o: C) -> C {
        let n = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / n,
            (self.1 * o.0 - self.0 * o.1) / n,
        )
    }
    pub fn scale(self, s: f64) -> C {
        C(self.0 * s, self.1 * s)
    }
    pub fn conj(self) -> C {
        C(self.0, -self.1)
    }
    pub fn abs(self) -> f64 {
        self.0.hypot(self.1)
    }
    pub fn f32x2(self) -> [f32; 2] {
        [self.0 as f32, self.1 as f32]
    }
    pub fn from_f32x2(v: [f32; 2]) -> C {
        C(v[0] as f64, v[1] as f64)
    }
}

/// z ↦ (a z + b)/(c z + d).
#[derive(Clone, Copy, Debug)]
pub struct Mobius {
    pub a: C,
    pub b: C,
    pub c: C,
    pub d: C,
}

impl Mobius {
    pub fn apply(&self, z: C) -> C {
        self.a.mul(z).add(self.b).div(self.c.mul(z).add(self.d))
    }
}

/// A triangle mesh: 3D positions, faces (counter-clockwise in UV unless a test says otherwise)
/// and per-face-corner UVs (so seams are possible).
#[derive(Clone, Debug)]
pub struct Mesh {
    pub positions: Vec<[f64; 3]>,
    pub faces: Vec<[usize; 3]>,
    pub uvs: Vec<[C; 3]>,
}

impl Mesh {
    /// A mesh whose UVs are `uv(position)` at every corner (no seams).
    pub fn with_uv_map(
        positions: Vec<[f64; 3]>,
        faces: Vec<[usize; 3]>,
        uv: impl Fn([f64; 3]) -> C,
    ) -> Mesh {
        let uvs = faces.iter().map(|f| f.map(|v| uv(positions[v]))).collect();
        Mesh {
            positions,
            faces,
            uvs,
        }
    }

    /// The point of face `f` with barycentrics `b`.
    pub fn point(&self, f: usize, b: [f64; 3]) -> [f64; 3] {
        let p = self.faces[f].map(|v| self.positions[v]);
        std::array::from_fn(|x| b[0] * p[0][x] + b[1] * p[1][x] + b[2] * p[2][x])
    }

    /// Corner `c` of face `g` lies on edge (a, b) of another face: the apex is the remaining
    /// corner. Returns (neighbour face, its apex corner) across edge e = (corner e, corner e + 1)
    /// of face f: the face holding the same two vertices in reverse order with the same UVs there.
    fn neighbour(&self, f: usize, e: usize) -> Option<(usize, usize)> {
        let (a, b) = (self.faces[f][e], self.faces[f][(e + 1) % 3]);
        (0..self.faces.len()).filter(|&g| g != f).find_map(|g| {
            let edge =
                (0..3).find(|&c| self.faces[g][c] == b && self.faces[g][(c + 1) % 3] == a)?;
            let same_uvs = self.uvs[g][edge] == self.uvs[f][(e + 1) % 3]
                && self.uvs[g][(edge + 1) % 3] == self.uvs[f][e];
            same_uvs.then_some((g, (edge + 2) % 3))
        })
    }

    /// Every face's star in the kernels' layout (positions and UVs rounded to f32); a missing
    /// neighbour (boundary or seam) repeats corner i, as the reference does.
    pub fn stars(&self) -> Vec<StarInput> {
        (0..self.faces.len()).map(|f| self.star(f)).collect()
    }

    fn star(&self, f: usize) -> StarInput {
        let pos = |v: usize| {
            let p = self.positions[v];
            [p[0] as f32, p[1] as f32, p[2] as f32, 0.0]
        };
        let corners = self.faces[f];
        let mut star = StarInput {
            p: [pos(corners[0]); 6],
            w: [self.uvs[f][0].f32x2(); 6],
            ..Default::default()
        };
        for (c, &v) in corners.iter().enumerate() {
            star.p[c] = pos(v);
            star.w[c] = self.uvs[f][c].f32x2();
        }
        for e in 0..3 {
            if let Some((g, apex)) = self.neighbour(f, e) {
                star.p[3 + e] = pos(self.faces[g][apex]);
                star.w[3 + e] = self.uvs[g][apex].f32x2();
                star.mask |= neighbour_bit(e);
            }
        }
        star
    }
}

/// A planar star of four faces in the plane spanned by the orthonormal `e1`, `e2` through
/// `origin`: the centre triangle 0 = (0, 1, 2) and one neighbour across each of its edges
/// (faces 1, 2, 3 across ij, jk, ki), all counter-clockwise in (x, y). Returns the mesh
/// positions and faces, and the (x, y) plane coordinates of each vertex as complex numbers.
pub fn planar_star(scale: f64) -> (Vec<[f64; 3]>, Vec<[usize; 3]>, Vec<C>) {
    let xy = [
        C(0.0, 0.0),
        C(1.0, 0.0),
        C(0.4, 0.9),
        C(0.5, -0.8),
        C(1.1, 0.9),
        C(-0.6, 0.5),
    ]
    .map(|z| z.scale(scale));
    // A tilted plane, so the layout has to rotate it back.
    let origin = [0.3, -0.2, 0.5];
    let e1 = [0.6, 0.8, 0.0];
    let e2 = [-0.48, 0.36, 0.8];
    let positions = xy
        .iter()
        .map(|z| std::array::from_fn(|k| origin[k] + z.0 * e1[k] + z.1 * e2[k]))
        .collect();
    let faces = vec![[0, 1, 2], [1, 0, 3], [2, 1, 4], [0, 2, 5]];
    (positions, faces, xy.to_vec())
}

/// Barycentric points spread over a triangle: the corners, edge points and interior points of
/// a grid with `n` steps per side.
pub fn barycentric_grid(n: usize) -> Vec<[f64; 3]> {
    let mut points = Vec::new();
    for j in 0..=n {
        for k in 0..=n - j {
            let (bj, bk) = (j as f64 / n as f64, k as f64 / n as f64);
            points.push([1.0 - bj - bk, bj, bk]);
        }
    }
    points
}

/// Largest |a − b| over pairs of UVs.
pub fn max_distance(a: &[[f32; 2]], b: &[C]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| C::from_f32x2(*x).sub(*y).abs())
        .fold(0.0, f64::max)
}

/// exp of the 2×2 complex matrix [[a, b], [c, −a]] by its Taylor series Σ Yⁿ/n! (60 terms,
/// exact to f64 rounding for entries up to ≈ 3): an expected value independent of the
/// cosh/sinh formulas under test. Returns [a, b, c, d] of exp Y.
pub fn expm_taylor(y: [C; 3]) -> [C; 4] {
    let m = [y[0], y[1], y[2], y[0].scale(-1.0)];
    let mul = |p: [C; 4], q: [C; 4]| {
        [
            p[0].mul(q[0]).add(p[1].mul(q[2])),
            p[0].mul(q[1]).add(p[1].mul(q[3])),
            p[2].mul(q[0]).add(p[3].mul(q[2])),
            p[2].mul(q[1]).add(p[3].mul(q[3])),
        ]
    };
    let identity = [C(1.0, 0.0), C(0.0, 0.0), C(0.0, 0.0), C(1.0, 0.0)];
    let (mut sum, mut term) = (identity, identity);
    for n in 1..60 {
        term = mul(term, m).map(|x| x.scale(1.0 / n as f64));
        sum = std::array::from_fn(|k| sum[k].add(term[k]));
    }
    sum
}

/// The BPM interpolant of one triangle's (f32) data evaluated in f64 at barycentrics `b`:
/// z = b_j z_j + b_k z_k, γ_e ∝ |edge e| b_a b_b (normalised), ℓ = Σ_e γ_e l_e,
/// f = w_origin + M_t(exp(½ ℓ)(z)), the exponential by [`expm_taylor`].
pub fn eval_f64(t: &reparam_gpu::bpm::TriangleMaps, b: [f64; 3]) -> C {
    let c = |x: f32, y: f32| C(x as f64, y as f64);
    let z = [C(0.0, 0.0), c(t.z[0], t.z[1]), c(t.z[2], t.z[3])];
    let point = z[1].scale(b[1]).add(z[2].scale(b[2]));
    let g: [f64; 3] =
        std::array::from_fn(|e| z[(e + 1) % 3].sub(z[e]).abs() * b[e] * b[(e + 1) % 3]);
    let sum = g[0] + g[1] + g[2];
    let gamma = g.map(|x| if sum > 0.0 { x / sum } else { 0.0 });
    let mut half_log = [C(0.0, 0.0); 3];
    for (e, weight) in gamma.iter().enumerate() {
        let (l0, l1) = (t.logs[2 * e], t.logs[2 * e + 1]);
        let l = [c(l0[0], l0[1]), c(l0[2], l0[3]), c(l1[0], l1[1])];
        for k in 0..3 {
            half_log[k] = half_log[k].add(l[k].scale(0.5 * weight));
        }
    }
    let e = expm_taylor(half_log);
    let m = Mobius {
        a: c(t.m[0][0], t.m[0][1]),
        b: c(t.m[0][2], t.m[0][3]),
        c: c(t.m[1][0], t.m[1][1]),
        d: c(t.m[1][2], t.m[1][3]),
    };
    let e = Mobius {
        a: e[0],
        b: e[1],
        c: e[2],
        d: e[3],
    };
    c(t.uv_k_origin[2], t.uv_k_origin[3]).add(m.apply(e.apply(point)))
}
