//! Area-equalising relaxation of a uniform remesh's parameters (beyond the paper; issue #23).
//!
//! The uniform remesh puts the same number of vertices in every base triangle, at the dyadic
//! points, wherever Π put the surface. Where the hierarchy squeezed a tip (a horn, an ear, a
//! fin) into a small part of a base triangle, few dyadic points land on it and the remesh cuts
//! across it (`…_area_distortion.png` shows such parts in blue). The relaxation keeps the
//! remesh's connectivity and moves its vertices' *parameters* so that each vertex drifts towards
//! where the surface's area is:
//!
//! u_c ← (1 − ω) u_c + ω Σ_f ρ_f g_f / Σ_f ρ_f,
//!
//! over the remesh faces f around vertex c, g_f the parameter-domain centroid of f (in the chart
//! of c: [`super::smooth::Chart`]) and ρ_f its weight ([`RelaxWeight`]: its 3D area, or its 3D
//! area over its parameter area, the stretch). A face with a large weight pulls its corners
//! towards it, which shrinks it in the parameter domain and, through Π⁻¹, in 3D: the vertex
//! density follows the surface's area instead of the base domain's. A vertex on a crease (base
//! boundary or feature edge) moves along it in its arclength chart by the same rule with the
//! crease edges (ρ their 3D length, or 3D over parameter length); a corner stays. Base vertices
//! move too unless [`RelaxOptions::move_base_vertices`] is off. A step that would turn a face around the
//! vertex over in the chart is halved (up to [`MAX_HALVINGS`] times, then the vertex stays).
//!
//! Every iteration is a Jacobi sweep (every new parameter from the previous ones, in parallel),
//! so the result does not depend on the thread count. The remesh vertices are Π⁻¹ of the
//! relaxed parameters: they lie on the input surface exactly as the unrelaxed ones do.

use nalgebra::Point3;
use rayon::prelude::*;

use super::param::BasePoint;
use super::remesh::{finish, place, Remesh, VKey};
use super::smooth::{
    crease_chain, dyadic_net, even_kind, place_in_chart, root_chart, topology, BaseDomain,
    EvenKind, ParamNet, SmoothOptions, SmoothStats, StencilPoint, Topology,
};
use super::Maps;
use crate::error::Result;

/// How a remesh face (or crease edge) weighs in the relaxation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RelaxWeight {
    /// Its 3D area (length on a crease).
    Area,
    /// Its 3D area over its parameter-domain area (lengths on a crease): the stretch. Default.
    #[default]
    Stretch,
}

/// Options of the relaxation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelaxOptions {
    /// Jacobi sweeps. Default 15 (measured in `src/maps/README.md`: the distances fall over
    /// the first 10–20 sweeps and rise again by 40 on some models).
    pub iterations: usize,
    /// ω, the fraction of the way to the weighted centroid each sweep moves. Default ½.
    pub step: f64,
    /// ρ of a face. Default [`RelaxWeight::Stretch`].
    pub weight: RelaxWeight,
    /// Whether the base vertices that are not corners move too (their remesh vertex then leaves
    /// the input vertex it sat on). Default true: held, a base vertex of high valence keeps
    /// the long thin faces around it (measured in `src/maps/README.md`).
    pub move_base_vertices: bool,
    /// Charts and corners as for the smoothing (grow rounds, corner turn). Default
    /// [`SmoothOptions::default`].
    pub charts: SmoothOptions,
}

impl Default for RelaxOptions {
    fn default() -> Self {
        RelaxOptions {
            iterations: DEFAULT_SWEEPS,
            step: 0.5,
            weight: RelaxWeight::Stretch,
            move_base_vertices: true,
            charts: SmoothOptions::default(),
        }
    }
}

/// [`RelaxOptions::iterations`] by default.
pub const DEFAULT_SWEEPS: usize = 15;

/// A step that flips a face around the vertex is halved at most this many times.
pub const MAX_HALVINGS: usize = 4;

/// What the sweeps did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RelaxStats {
    /// Sweeps run.
    pub iterations: usize,
    /// Vertex moves (all sweeps) that were halved to keep their faces' orientation.
    pub halved: usize,
    /// Vertex moves refused: every halving still flipped a face.
    pub refused: usize,
    /// Chart failures, as for the smoothing ([`SmoothStats`]: fallbacks, clamped).
    pub charts: SmoothStats,
}

impl RelaxStats {
    /// Add another's counts (not its sweeps).
    fn add(&mut self, o: &RelaxStats) {
        self.halved += o.halved;
        self.refused += o.refused;
        self.charts.add(&o.charts);
    }
}

/// The faces around each net vertex.
fn vertex_faces(net: &ParamNet) -> Vec<Vec<u32>> {
    let mut stars = vec![Vec::new(); net.keys.len()];
    for (f, t) in net.faces.iter().enumerate() {
        for &v in t {
            stars[v as usize].push(f as u32);
        }
    }
    stars
}

/// Twice the signed area of the 2D triangle (a, b, c).
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Half the norm of (b − a) × (c − a): the 3D area.
fn area3(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
    0.5 * (b - a).cross(&(c - a)).norm()
}

/// Everything one sweep reads.
struct Sweep<'a> {
    base: &'a BaseDomain<'a>,
    net: &'a ParamNet,
    topo: &'a Topology,
    stars: &'a [Vec<u32>],
    positions: &'a [Point3<f64>],
    options: &'a RelaxOptions,
}

impl Sweep<'_> {
    fn point(&self, i: u32) -> StencilPoint {
        (self.net.params[i as usize], self.net.dyadic[i as usize])
    }

    /// The new parameter of net vertex `c` (module docs).
    fn relax(&self, c: u32, stats: &mut RelaxStats) -> BasePoint {
        let key = self.net.keys[c as usize];
        let keep = self.net.params[c as usize];
        match (even_kind(self.base, key), key) {
            (EvenKind::Fixed, _) => keep,
            (_, VKey::Vertex(_)) if !self.options.move_base_vertices => keep,
            (EvenKind::Crease, _) => self.relax_on_crease(c, stats),
            (EvenKind::Interior, _) => self.relax_inside(c, key, stats),
        }
    }

    /// Interior vertex: the weighted centroid of its faces' centroids in its chart.
    fn relax_inside(&self, c: u32, key: VKey, stats: &mut RelaxStats) -> BasePoint {
        let ring = &self.topo.neighbours[c as usize];
        let mut points = vec![self.point(c)];
        points.extend(ring.iter().map(|&n| self.point(n)));
        let slot = |v: u32| -> usize {
            if v == c {
                0
            } else {
                1 + ring.iter().position(|&n| n == v).unwrap_or(0)
            }
        };
        let charts = &self.options.charts;
        let mut placed = place_in_chart(
            self.base,
            root_chart(self.base, key),
            &points,
            charts,
            &mut stats.charts,
        );
        let uv = &placed.positions;
        // The faces around c as chart triangles (c first, orientation kept), with weights.
        let faces: Vec<([usize; 3], f64)> = self.stars[c as usize]
            .iter()
            .map(|&f| {
                let t = self.net.faces[f as usize];
                let k = t.iter().position(|&v| v == c).unwrap_or(0);
                let corners = [t[k], t[(k + 1) % 3], t[(k + 2) % 3]];
                let [a, b, d] = corners.map(|v| self.positions[v as usize]);
                let s = corners.map(slot);
                let rho = match self.options.weight {
                    RelaxWeight::Area => area3(&a, &b, &d),
                    RelaxWeight::Stretch => {
                        let p = orient(uv[s[0]], uv[s[1]], uv[s[2]]).abs() * 0.5;
                        if p > 0.0 {
                            area3(&a, &b, &d) / p
                        } else {
                            0.0
                        }
                    }
                };
                (s, rho)
            })
            .collect();
        let total: f64 = faces.iter().map(|f| f.1).sum();
        if !(total > 0.0 && total.is_finite()) {
            return self.net.params[c as usize];
        }
        let mut target = [0.0; 2];
        for (s, rho) in &faces {
            for &i in s {
                target[0] += rho / (3.0 * total) * uv[i][0];
                target[1] += rho / (3.0 * total) * uv[i][1];
            }
        }
        let from = uv[0];
        let mut omega = self.options.step;
        for halving in 0..=MAX_HALVINGS {
            let u = [
                from[0] + omega * (target[0] - from[0]),
                from[1] + omega * (target[1] - from[1]),
            ];
            let flips = faces.iter().any(|(s, _)| {
                let before = orient(uv[s[0]], uv[s[1]], uv[s[2]]);
                let after = orient(u, uv[s[1]], uv[s[2]]);
                before * after <= 0.0
            });
            if !flips {
                stats.halved += usize::from(halving > 0);
                return placed.locate(self.base, u, charts, &mut stats.charts);
            }
            omega *= 0.5;
        }
        stats.refused += 1;
        self.net.params[c as usize]
    }

    /// Crease vertex: the weighted midpoint of its two crease edges along the crease.
    fn relax_on_crease(&self, c: u32, stats: &mut RelaxStats) -> BasePoint {
        let Some((chain, [prev, next])) = crease_chain(self.base, self.net, self.topo, c) else {
            stats.charts.fallbacks += 1;
            return self.net.params[c as usize];
        };
        let at = |i: u32| chain.position(self.base, &self.net.params[i as usize]);
        let (Some(sp), Some(sc), Some(sn)) = (at(prev), at(c), at(next)) else {
            stats.charts.fallbacks += 1;
            return self.net.params[c as usize];
        };
        let length = |i: u32| (self.positions[i as usize] - self.positions[c as usize]).norm();
        let rho = |i: u32, s: f64| match self.options.weight {
            RelaxWeight::Area => length(i),
            RelaxWeight::Stretch if s != sc => length(i) / (s - sc).abs(),
            RelaxWeight::Stretch => 0.0,
        };
        let (rp, rn) = (rho(prev, sp), rho(next, sn));
        if !(rp + rn > 0.0 && (rp + rn).is_finite()) {
            return self.net.params[c as usize];
        }
        let target = (rp * (sp + sc) + rn * (sc + sn)) / (2.0 * (rp + rn));
        let s = sc + self.options.step * (target - sc);
        chain.locate(self.base, s)
    }
}

/// `options.iterations` sweeps of the relaxation on `net` (module docs), vertices placed by Π⁻¹.
pub fn relax_net(maps: &Maps, net: &ParamNet, options: &RelaxOptions) -> (ParamNet, RelaxStats) {
    relax_net_with(maps, net, options, &|p| place(maps, p))
}

/// The map from parameters to the surface the relaxation weighs faces with: `(position, found)`
/// as Π⁻¹ gives it ([`super::Param::inverse`], the flat base point where it finds no input face),
/// or Π⁻¹ ∘ Φ⁻¹ for [`super::equalise`].
pub type Placement<'a> = &'a (dyn Fn(&BasePoint) -> (Point3<f64>, bool) + Sync);

/// [`relax_net`] with the vertices placed by `place`.
pub fn relax_net_with(
    maps: &Maps,
    net: &ParamNet,
    options: &RelaxOptions,
    place: Placement,
) -> (ParamNet, RelaxStats) {
    let base = BaseDomain::new(maps, options.charts.corner_turn);
    let topo = topology(maps, net);
    let stars = vertex_faces(net);
    let mut net = net.clone();
    let mut stats = RelaxStats::default();
    for _ in 0..options.iterations {
        let positions: Vec<Point3<f64>> = net.params.par_iter().map(|p| place(p).0).collect();
        let sweep = Sweep {
            base: &base,
            net: &net,
            topo: &topo,
            stars: &stars,
            positions: &positions,
            options,
        };
        let moved: Vec<(BasePoint, RelaxStats)> = (0..net.keys.len() as u32)
            .into_par_iter()
            .map(|c| {
                let mut s = RelaxStats::default();
                let p = sweep.relax(c, &mut s);
                (p, s)
            })
            .collect();
        net.params = moved
            .into_iter()
            .map(|(p, s)| {
                stats.add(&s);
                p
            })
            .collect();
        stats.iterations += 1;
    }
    (net, stats)
}

/// A relaxed remesh and what the sweeps did.
#[derive(Clone, Debug)]
pub struct Relaxed {
    /// The remesh: the connectivity of the uniform remesh of level j, vertices Π⁻¹ of the
    /// relaxed parameters.
    pub remesh: Remesh,
    /// Sweep counts ([`RelaxStats`]).
    pub stats: RelaxStats,
}

/// The uniform remesh of level `j` with relaxed parameters: the connectivity and numbering of
/// [`super::remesh::uniform`], vertex i at Π⁻¹(u_i) after [`relax_net`] on the dyadic net.
/// Error: `j` above [`super::remesh::MAX_UNIFORM_LEVEL`].
pub fn uniform_relaxed(maps: &Maps, j: u32, options: &RelaxOptions) -> Result<Relaxed> {
    let (net, stats) = relax_net(maps, &dyadic_net(maps, j)?, options);
    let (positions, unmapped) = net.positions(maps);
    let name = format!("{} (relaxed uniform remesh j={j})", maps.name);
    let remesh = finish(maps, name, positions, net.faces, net.params, unmapped);
    Ok(Relaxed { remesh, stats })
}
