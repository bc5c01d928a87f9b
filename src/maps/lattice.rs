//! The lattice machinery shared by the stages of the equalised parameterisation
//! ([`super::equalise`]'s per-face Φ and [`super::flaps`]' per-edge Φ): a triangle cut into the
//! 4^K triangles of its dyadic lattice, how a lattice point moves ([`Corner`]), the stretch
//! energy of a moved lattice, and the buckets Φ⁻¹ searches.

use rayon::prelude::*;

use super::retriangulate::{barycentric, locate};
use super::stretch::{l2_stretch, signed_area, weighted_stretch, StretchTarget};
use super::Maps;
use crate::error::{Error, Result};
use crate::lbfgs::{minimise, LbfgsOptions, LbfgsReport};

/// Where a lattice point is, seen from the frame it moves in (a base face's, or an edge
/// flap's): fixed, sliding along a base edge (x[offset] is its arclength from `origin`), or free
/// (x[offset], x[offset + 1]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Corner {
    Fixed([f64; 2]),
    Edge {
        origin: [f64; 2],
        unit: [f64; 2],
        offset: usize,
    },
    Inside(usize),
}

impl Corner {
    pub(super) fn at(&self, x: &[f64]) -> [f64; 2] {
        match *self {
            Corner::Fixed(p) => p,
            Corner::Edge {
                origin,
                unit,
                offset,
            } => [
                origin[0] + x[offset] * unit[0],
                origin[1] + x[offset] * unit[1],
            ],
            Corner::Inside(o) => [x[o], x[o + 1]],
        }
    }

    /// Add the gradient with respect to this corner's 2D position to the unknowns' gradient.
    pub(super) fn add_gradient(&self, g: [f64; 2], grad: &mut [f64]) {
        match *self {
            Corner::Fixed(_) => {}
            Corner::Edge { unit, offset, .. } => grad[offset] += g[0] * unit[0] + g[1] * unit[1],
            Corner::Inside(o) => {
                grad[o] += g[0];
                grad[o + 1] += g[1];
            }
        }
    }
}

/// The isometric layout of base face `f` in the plane: corner 0 at the origin, corner 1 on the
/// positive x axis, corner 2 above it (counter-clockwise). Error for a degenerate face.
pub fn frame(maps: &Maps, f: u32) -> Result<[[f64; 2]; 3]> {
    let [a, b, c] = maps.base_faces[f as usize].map(|v| maps.positions[v as usize]);
    let (e, d) = (b - a, c - a);
    let length = e.norm();
    let height = e.cross(&d).norm() / length;
    if !(length > 0.0 && height > 0.0 && height.is_finite()) {
        return Err(Error::InvalidArgument(format!(
            "{}: base face {f} (input vertices {}, {}, {}) has no area, so --equalise cannot lay \
             it out in the plane; try another --base-size, or leave out --equalise",
            maps.name,
            maps.base_faces[f as usize][0],
            maps.base_faces[f as usize][1],
            maps.base_faces[f as usize][2]
        )));
    }
    Ok([[0.0, 0.0], [length, 0.0], [d.dot(&e) / length, height]])
}

/// The point with barycentrics `b` in a frame.
pub(super) fn in_frame(frame: &[[f64; 2]; 3], b: [f64; 3]) -> [f64; 2] {
    [
        b[0] * frame[0][0] + b[1] * frame[1][0] + b[2] * frame[2][0],
        b[0] * frame[0][1] + b[1] * frame[1][1] + b[2] * frame[2][1],
    ]
}

/// Index of lattice point (i, j) in a lattice's dense grid.
pub(super) fn cell(s: u32, i: u32, j: u32) -> usize {
    (i * (s + 1) + j) as usize
}

/// A uniform grid of s × s buckets over a region's frame (a base face, an edge flap), each holding the moved triangles whose
/// bounding box meets it: Φ⁻¹ tests the few triangles of one bucket instead of all 4^K.
#[derive(Clone, Debug)]
pub(super) struct Buckets {
    lo: [f64; 2],
    cell: [f64; 2],
    side: usize,
    triangles: Vec<Vec<u32>>,
}

impl Buckets {
    /// Buckets over the bounding box of `domain` (the points of the region Φ maps onto
    /// itself), holding the triangles `cells` of the points `moved`.
    pub(super) fn new(
        domain: &[[f64; 2]],
        moved: &[[f64; 2]],
        cells: &[[usize; 3]],
        side: usize,
    ) -> Self {
        let lo = [0, 1].map(|a| domain.iter().map(|p| p[a]).fold(f64::INFINITY, f64::min));
        let hi = [0, 1].map(|a| {
            domain
                .iter()
                .map(|p| p[a])
                .fold(f64::NEG_INFINITY, f64::max)
        });
        let cell = [0, 1].map(|a| (hi[a] - lo[a]) / side as f64);
        let mut b = Buckets {
            lo,
            cell,
            side,
            triangles: vec![Vec::new(); side * side],
        };
        for (t, c) in cells.iter().enumerate() {
            let q = c.map(|k| moved[k]);
            let (a0, a1) = b.bucket(
                q.iter()
                    .fold([f64::INFINITY; 2], |m, p| [m[0].min(p[0]), m[1].min(p[1])]),
            );
            let (z0, z1) = b.bucket(q.iter().fold([f64::NEG_INFINITY; 2], |m, p| {
                [m[0].max(p[0]), m[1].max(p[1])]
            }));
            for x in a0..=z0 {
                for y in a1..=z1 {
                    b.triangles[x * side + y].push(t as u32);
                }
            }
        }
        b
    }

    /// The bucket (column, row) of a point, clamped to the grid.
    fn bucket(&self, u: [f64; 2]) -> (usize, usize) {
        let at = |a: usize| {
            let x = ((u[a] - self.lo[a]) / self.cell[a]).floor();
            (x.max(0.0) as usize).min(self.side - 1)
        };
        (at(0), at(1))
    }

    /// The triangles of u's bucket.
    pub(super) fn near(&self, u: [f64; 2]) -> &[u32] {
        let (x, y) = self.bucket(u);
        &self.triangles[x * self.side + y]
    }
}

/// The 4^K triangles of a face's lattice (s = 2^K) as cells i (s + 1) + j of its points: for
/// each (i, j) the upward triangle (i, j), (i + 1, j), (i, j + 1) and, inside the face, the
/// downward one (i + 1, j + 1), (i, j + 1), (i + 1, j); both counter-clockwise.
pub(super) fn lattice_cells(s: u32) -> Vec<[usize; 3]> {
    let mut tris = Vec::with_capacity((s * s) as usize);
    for i in 0..s {
        for j in 0..s - i {
            tris.push([cell(s, i, j), cell(s, i + 1, j), cell(s, i, j + 1)]);
            if i + j + 1 < s {
                tris.push([cell(s, i + 1, j + 1), cell(s, i, j + 1), cell(s, i + 1, j)]);
            }
        }
    }
    tris
}

/// The lattice triangle of a lattice of side s holding the point of barycentrics `b` (in the
/// triangle the lattice cuts), as its corners' (i, j) and the barycentrics λ of `b` in it, by
/// the lattice's arithmetic: i = ⌊b₁ s⌋, j = ⌊b₂ s⌋, the lower or upper triangle of that cell
/// by the fractional parts.
pub(super) fn lattice_triangle(s: u32, b: [f64; 3]) -> ([(u32, u32); 3], [f64; 3]) {
    let sf = s as f64;
    let (u, v) = (b[1] * sf, b[2] * sf);
    let i = (u.floor().max(0.0) as u32).min(s - 1);
    let j = (v.floor().max(0.0) as u32).min(s - 1 - i);
    let (fu, fv) = (u - i as f64, v - j as f64);
    if fu + fv <= 1.0 || i + j + 1 == s {
        ([(i, j), (i + 1, j), (i, j + 1)], [1.0 - fu - fv, fu, fv])
    } else {
        (
            [(i + 1, j + 1), (i, j + 1), (i + 1, j)],
            [fu + fv - 1.0, 1.0 - fu, 1.0 - fv],
        )
    }
}

/// Σ_c λ_c r_c: the point with barycentrics λ in the reference lattice triangle of cells `t`
/// (a lattice of side s), r_c = ((s − i − j)/s, i/s, j/s) for cell c = i (s + 1) + j.
pub(super) fn reference(s: u32, t: [usize; 3], l: [f64; 3]) -> [f64; 3] {
    let sf = s as f64;
    let mut b = [0.0; 3];
    for (&k, lc) in t.iter().zip(l) {
        let (i, j) = (k as u32 / (s + 1), k as u32 % (s + 1));
        let r = [(s - i - j) as f64 / sf, i as f64 / sf, j as f64 / sf];
        for (ba, ra) in b.iter_mut().zip(r) {
            *ba += lc * ra;
        }
    }
    b
}

/// How many of the triangles `cells` over the points `moved` are not strictly
/// counter-clockwise (robust orientation): 0 for a lattice that does not fold.
pub(super) fn folded(moved: &[[f64; 2]], cells: &[[usize; 3]]) -> usize {
    cells
        .iter()
        .filter(|t| super::retriangulate::orient2d(moved[t[0]], moved[t[1]], moved[t[2]]) <= 0.0)
        .count()
}

/// The moved lattice triangle holding u, as its index into `cells` and u's barycentrics in it:
/// the first triangle of u's bucket whose robust orientations are all ≥ 0, and when none is
/// (u on the region's border, a hair outside by rounding), [`locate`] over all of `cells`.
/// Φ⁻¹'s search in every stage; it allocates nothing, as it runs for every point the
/// relaxation places.
pub(super) fn locate_bucketed(
    u: [f64; 2],
    moved: &[[f64; 2]],
    cells: &[[usize; 3]],
    buckets: &Buckets,
) -> (usize, [f64; 3]) {
    for &t in buckets.near(u) {
        let c = cells[t as usize];
        let l = barycentric(u, moved[c[0]], moved[c[1]], moved[c[2]]);
        if l[0].min(l[1]).min(l[2]) >= 0.0 {
            return (t as usize, l);
        }
    }
    locate(u, moved, cells)
}

/// Σ_c λ_c m_c over the lattice triangle of side s holding barycentrics `b`, m the moved
/// lattice points by cell: the piecewise-linear map Φ of the lattice at `b`.
pub(super) fn moved_at(s: u32, moved: &[[f64; 2]], b: [f64; 3]) -> [f64; 2] {
    let (ij, l) = lattice_triangle(s, b);
    let mut q = [0.0; 2];
    for c in 0..3 {
        let m = moved[cell(s, ij[c].0, ij[c].1)];
        q[0] += l[c] * m[0];
        q[1] += l[c] * m[1];
    }
    q
}

/// The energy E(x) of [`super::equalise`]'s module docs (with the Dirichlet term's weight `mu`) and its
/// gradient; `None` where a moved triangle folds. Per triangle in parallel, summed in triangle
/// order (the same on any thread count).
pub(super) fn energy(
    corners: &[[Corner; 3]],
    targets: &[StretchTarget],
    x: &[f64],
    mu: f64,
) -> Option<(f64, Vec<f64>)> {
    let terms: Vec<Option<(f64, [[f64; 2]; 3])>> = corners
        .par_iter()
        .zip(targets)
        .map(|(c, t)| weighted_stretch(t, c.map(|k| k.at(x)), mu))
        .collect();
    let mut e = 0.0;
    let mut grad = vec![0.0; x.len()];
    for (term, c) in terms.into_iter().zip(corners) {
        let (value, g) = term?;
        e += value;
        for k in 0..3 {
            c[k].add_gradient(g[k], &mut grad);
        }
    }
    Some((e, grad))
}

/// Sander et al.'s L²(M) of the net at x (module docs of [`super::stretch`]).
pub(super) fn net_stretch(corners: &[[Corner; 3]], targets: &[StretchTarget], x: &[f64]) -> f64 {
    let e = energy(corners, targets, x, 0.0).map_or(f64::INFINITY, |r| r.0);
    let area: f64 = targets.iter().map(|t| t.area).sum();
    let parameter_area: f64 = corners
        .iter()
        .map(|c| signed_area(c.map(|k| k.at(x))))
        .sum();
    l2_stretch(e, area, parameter_area)
}

/// The shortest edge of the net at x (the solver's length scale).
pub(super) fn shortest_edge(corners: &[[Corner; 3]], x: &[f64]) -> f64 {
    corners
        .iter()
        .flat_map(|c| {
            let q = c.map(|k| k.at(x));
            (0..3).map(move |k| {
                let (a, b) = (q[k], q[(k + 1) % 3]);
                (b[0] - a[0]).hypot(b[1] - a[1])
            })
        })
        .fold(f64::INFINITY, f64::min)
}

/// What a stage's solve did.
/// What the solve did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct EqualiseReport {
    /// K.
    pub depth: u32,
    /// Unknowns: 2 per free lattice point, 1 per lattice point sliding along a base edge.
    pub unknowns: usize,
    /// Lattice triangles.
    pub triangles: usize,
    /// Sander et al.'s L²(M) of the net before (Φ = id) and after (1 is an isometry up to
    /// scale).
    pub stretch_before: f64,
    pub stretch_after: f64,
    /// The solver's iterations, evaluations and stop.
    pub solver: LbfgsReport,
    /// Wall-clock seconds: Π⁻¹ of the lattice, and the solve.
    pub lattice_seconds: f64,
    pub solve_seconds: f64,
}

/// The reports of two depths of one coarse-to-fine solve as one: `finer`'s figures, the
/// iterations, evaluations and seconds summed.
pub(super) fn combine(coarser: &EqualiseReport, finer: &EqualiseReport) -> EqualiseReport {
    EqualiseReport {
        solver: LbfgsReport {
            iterations: coarser.solver.iterations + finer.solver.iterations,
            evaluations: coarser.solver.evaluations + finer.solver.evaluations,
            ..finer.solver
        },
        lattice_seconds: coarser.lattice_seconds + finer.lattice_seconds,
        solve_seconds: coarser.solve_seconds + finer.solve_seconds,
        ..*finer
    }
}

/// One depth's solve: the stretch energy ([`energy`]) minimised by L-BFGS from `start`
/// (`identity` without one), the first step `solver.first_step` times the net's shortest edge.
pub(super) struct Solved {
    /// Sander et al.'s L²(M) of the net at Φ = id and at the result.
    pub stretch_before: f64,
    pub stretch_after: f64,
    pub solver: LbfgsReport,
}

/// See [`Solved`]: returns the unknowns at the minimum and the figures.
pub(super) fn solve_net(
    corners: &[[Corner; 3]],
    targets: &[StretchTarget],
    identity: Vec<f64>,
    start: Option<Vec<f64>>,
    solver: &LbfgsOptions,
    mu: f64,
) -> (Vec<f64>, Solved) {
    let stretch_before = net_stretch(corners, targets, &identity);
    let shortest = shortest_edge(corners, &identity);
    let mut x = start.unwrap_or(identity);
    let solver = LbfgsOptions {
        first_step: solver.first_step * shortest,
        ..*solver
    };
    let report = minimise(&mut x, |x| energy(corners, targets, x, mu), &solver);
    let stretch_after = net_stretch(corners, targets, &x);
    (
        x,
        Solved {
            stretch_before,
            stretch_after,
            solver: report,
        },
    )
}
