//! A stretch-minimising reparameterisation of the base domain, Π' = (Φ_E ∘ Φ)ⁿ ∘ Π (beyond
//! the paper; issue #37): the per-face stage Φ here, the edge stage Φ_E in [`super::flaps`].
//!
//! MAPS's Π gives each part of the surface the share of the base domain its removals happened
//! to leave it; a uniform remesh then puts the same number of vertices in every base triangle
//! wherever Π put the surface ([`super::relax`] moves the remesh's own parameters instead, a
//! fraction of a face per sweep). Here Π itself is composed with a homeomorphism Φ of the base
//! domain chosen over the whole domain at once:
//!
//! - **The net.** Every base face f is cut into the 2^K × 2^K lattice of its dyadic points
//!   (i, j) ↦ barycentrics ((s − i − j)/s, i/s, j/s), s = 2^K, and its 2·4^K lattice triangles
//!   (the uniform remesh's triangles of level K); a lattice point is shared by the faces it lies
//!   on ([`VKey`]). Each base face is laid out isometrically in the plane ([`frame`]), so the
//!   parameter domain carries the base triangles' own metric.
//! - **Φ is piecewise linear on the net and maps every base face onto itself:** a base vertex
//!   stays, a lattice point on a base edge slides along that edge (one unknown: its arclength
//!   from the edge's lower vertex, shared by the edge's faces), an interior lattice point moves
//!   in its face's plane (two unknowns). Φ of a point is Σ λ_c Φ(corner_c) in the lattice
//!   triangle that holds it, Φ⁻¹ the same through the moved triangle that holds it: while no
//!   moved triangle folds, Φ is a bijection of every base face, continuous across base edges,
//!   and Π' = Φ ∘ Π stays a bijection whose inverse Π⁻¹ ∘ Φ⁻¹ is exact up to rounding. Base
//!   edges, and the feature chains Π maps onto them, stay where they were.
//! - **The energy** is Sander et al.'s L² stretch ([`super::stretch`]) of the piecewise-linear
//!   map from the moved net to the surface, each lattice triangle t going to the 3D triangle
//!   X_t of Π⁻¹ of its reference corners:
//!
//!   E(Φ) = Σ_t (A(X_t) + μ A'(Φ(t))) ‖J_t‖²_F / 2,  J_t the Jacobian of Φ(t) → X_t.
//!
//!   With μ = 0 its minimiser gives each lattice triangle a parameter area proportional to
//!   A(X_t) under the fixed total area of each base face ([`super::stretch`] module docs); the
//!   μ term, the Dirichlet energy, charges anisotropy ([`EqualiseOptions::conformal_weight`]).
//!   E → ∞ as a moved triangle degenerates, so a descent that never accepts a fold keeps Φ a
//!   bijection.
//! - **The solve** is global: all unknowns at once by L-BFGS ([`crate::lbfgs`]) from Φ = id, a
//!   step refused wherever a moved triangle would fold. Area flows across a base face in one
//!   solve, not by a fraction of a lattice triangle per sweep.
//!
//! What Φ cannot do: move area from one base face to another (each maps onto itself). A base
//! face's share of the base domain is its 3D area, close to the area of the surface Π maps
//! onto it wherever that part of the surface is not much more curved than the face; where a
//! whole tip is squeezed into a corner of a base face, Φ can widen the corner within the face.
//! Neither can it widen what a single lattice triangle's corners do not see: X_t is flat.
//!
//! **The edge stage.** [`super::flaps`] adds Φ_E, solved after Φ on the same energy with the
//! targets of Π⁻¹ ∘ Φ⁻¹: it maps each base edge's *flap* (the edge's two half-faces, cut at the
//! faces' centroids and unfolded about the edge) onto itself, the lattice points on the edge
//! free, so that area crosses base edges. [`Equalised`] is the composition of the stages in
//! the order they are solved, each on the map the ones before leave:
//! [`EqualiseOptions::edge_rounds`] = n alternates n edge stages with per-face ones, so that
//! area travels further than one flap (Π' = Φ_E ∘ Φ ∘ Φ_E ∘ Φ ∘ Π by default, n = 2);
//! [`EqualiseOptions::refine`] ends with a per-face stage. Its inverse, each stage's inverse in
//! reverse order, is exact up to rounding as each stage's is.

use std::collections::HashMap;
use std::time::Instant;

use nalgebra::Point3;
use rayon::prelude::*;

use super::flaps::EdgeFlaps;
use super::lattice::{
    cell, combine, folded, in_frame, lattice_cells, locate_bucketed, moved_at, reference,
    solve_net, Buckets, Corner,
};
pub use super::lattice::{frame, EqualiseReport};
use super::param::BasePoint;
use super::remesh::{finish, place, uniform_leaves, vkey, Remesh, VKey};
use super::retriangulate::barycentric;
use super::stretch::StretchTarget;
use super::Maps;
use crate::error::{Error, Result};
use crate::lbfgs::LbfgsOptions;

/// Options of the reparameterisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EqualiseOptions {
    /// K: each base face is cut into 4^K lattice triangles. Default 5 (measured in
    /// `src/maps/README.md`).
    pub depth: u32,
    /// The coarsest lattice solved first (coarse to fine, [`equalise`]). Default 1 (its
    /// unknowns are the base edges' midpoints).
    pub start_depth: u32,
    /// μ, the weight of the Dirichlet term μ Σ_t A'(t) ‖J_t‖²_F / 2 added to the stretch
    /// ([`super::stretch::weighted_stretch`]), which charges anisotropy. Default 5 (measured in
    /// `src/maps/README.md`: 0 is the stretch alone, whose remeshes had more wrong-facing area
    /// on spot, genus3 and genus2_uneven9).
    pub conformal_weight: f64,
    /// The solver's options at each depth; `first_step` is scaled by the lattice's shortest
    /// edge. Default: [`LbfgsOptions::default`] with at most 1000 iterations per depth, a
    /// tolerance of 1e-6 and a first step of ¼ of the shortest edge (measured in
    /// `src/maps/README.md`).
    pub solver: LbfgsOptions,
    /// K_E, the depth of the edge-flap stage Φ_E ([`super::flaps`]), solved after the per-face
    /// stage (Π' = Φ_E ∘ Φ ∘ Π for one round), each of a face's three pieces cut into 4^K_E lattice
    /// triangles; `None`: no edge stage. Default `Some(`[`super::flaps::DEFAULT_DEPTH`]`)`
    /// (measured in `src/maps/README.md`).
    pub edge_depth: Option<u32>,
    /// With an edge stage: end with a per-face stage, solved on the map the others leave
    /// (Π' = Φ₂ ∘ Φ_E ∘ Φ ∘ Π with one round). Default `false` (measured in
    /// `src/maps/README.md`).
    pub refine: bool,
    /// With an edge stage: how many edge stages, a per-face stage between each two
    /// (Φ_E ∘ Φ ∘ Φ_E ∘ Φ ∘ Π for 2); 0 counts as 1. Default [`DEFAULT_EDGE_ROUNDS`].
    pub edge_rounds: u32,
}

impl Default for EqualiseOptions {
    fn default() -> Self {
        EqualiseOptions {
            depth: DEFAULT_DEPTH,
            start_depth: 1,
            conformal_weight: 5.0,
            solver: LbfgsOptions {
                max_iterations: 1000,
                tolerance: 1e-6,
                first_step: 0.25,
                ..LbfgsOptions::default()
            },
            edge_depth: Some(super::flaps::DEFAULT_DEPTH),
            refine: false,
            edge_rounds: DEFAULT_EDGE_ROUNDS,
        }
    }
}

/// [`EqualiseOptions::edge_rounds`] by default: 2, Π' = Φ_E ∘ Φ ∘ Φ_E ∘ Φ ∘ Π (measured in
/// `src/maps/README.md`: with one round spot's equalised relaxed remesh had more wrong-facing
/// area than its relaxed one at 4 of 6 sweep counts; with two, within the relaxed one's
/// spread at every count).
pub const DEFAULT_EDGE_ROUNDS: u32 = 2;

/// [`EqualiseOptions::depth`] by default.
pub const DEFAULT_DEPTH: u32 = 5;

/// The largest depth accepted (4^7 lattice triangles per base face).
pub const MAX_DEPTH: u32 = 7;

/// The most lattice triangles (base faces × 4^K) a solve may hold: about 250 bytes each (the
/// target, the corners' rules, the energy's terms), so 2²¹ keep it near half a gigabyte.
pub const MAX_LATTICE_TRIANGLES: usize = 1 << 21;

/// How a lattice point moves (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Unknown {
    /// A base vertex: fixed.
    Fixed,
    /// On base edge (lo, hi) of 3D length `length`: x[offset] is the arclength from lo.
    Edge {
        lo: u32,
        hi: u32,
        length: f64,
        offset: usize,
    },
    /// Inside base face `face`: x[offset], x[offset + 1] in that face's [`frame`].
    Inside { face: u32, offset: usize },
}

/// The per-face stage Φ of the reparameterisation (module docs): every base face onto itself.
#[derive(Clone, Debug)]
pub struct FaceStage {
    depth: u32,
    frames: Vec<[[f64; 2]; 3]>,
    /// Per base face, the lattice point (i, j) as index i (s + 1) + j: its moved position in
    /// the face's frame (0 where i + j > s, outside the face).
    moved: Vec<Vec<[f64; 2]>>,
    /// The lattice triangles of a face as cells, counter-clockwise ([`lattice_cells`]).
    cells: Vec<[usize; 3]>,
    /// Per base face, the moved triangles binned by their bounding boxes (Φ⁻¹'s search).
    buckets: Vec<Buckets>,
    /// The solve's figures (all depths).
    pub report: EqualiseReport,
}

/// A stage after the first per-face one.
#[derive(Clone, Debug)]
pub enum Stage {
    Edges(EdgeFlaps),
    Faces(FaceStage),
}

impl Stage {
    fn forward(&self, p: &BasePoint) -> BasePoint {
        match self {
            Stage::Edges(e) => e.forward(p),
            Stage::Faces(f) => f.forward(p),
        }
    }

    fn inverse(&self, d: &BasePoint) -> BasePoint {
        match self {
            Stage::Edges(e) => e.inverse(d),
            Stage::Faces(f) => f.inverse(d),
        }
    }

    fn folded_triangles(&self) -> usize {
        match self {
            Stage::Edges(e) => e.folded_triangles(),
            Stage::Faces(f) => f.folded_triangles(),
        }
    }

    /// The stage's solve.
    pub fn report(&self) -> EqualiseReport {
        match self {
            Stage::Edges(e) => e.report,
            Stage::Faces(f) => f.report,
        }
    }
}

/// The reparameterisation Π' = … Φ_E ∘ Φ ∘ Π of a MAPS base domain (module docs): the first
/// per-face stage Φ, then the later stages in the order they apply ([`EqualiseOptions`]'s
/// `edge_depth`, `edge_rounds`, `refine`).
#[derive(Clone, Debug)]
pub struct Equalised {
    pub faces: FaceStage,
    /// The stages after the first per-face one, in the order they apply.
    pub later: Vec<Stage>,
    /// The first stage's figures ([`FaceStage::report`]).
    pub report: EqualiseReport,
}

/// The lattice of depth K over the base domain: the distinct points (by key), each one's
/// unknown, each face's (i, j) → point index, and the lattice triangles (face, corners).
struct Lattice {
    points: Vec<BasePoint>,
    keys: Vec<VKey>,
    unknowns: Vec<Unknown>,
    count: usize,
    grid: Vec<Vec<u32>>,
    triangles: Vec<(u32, [u32; 3])>,
}

impl Lattice {
    fn new(maps: &Maps, depth: u32) -> Lattice {
        let s = 1u32 << depth;
        let mut index: HashMap<VKey, u32> = HashMap::new();
        let (mut points, mut keys, mut unknowns) = (Vec::new(), Vec::new(), Vec::new());
        let mut count = 0;
        let mut grid = Vec::with_capacity(maps.base_faces.len());
        for f in 0..maps.base_faces.len() as u32 {
            let mut g = vec![u32::MAX; ((s + 1) * (s + 1)) as usize];
            for i in 0..=s {
                for j in 0..=s - i {
                    let p = [s - i - j, i, j];
                    let key = vkey(&maps.base_faces, f, p, depth);
                    let id = *index.entry(key).or_insert_with(|| {
                        let unknown = match key {
                            VKey::Vertex(_) => Unknown::Fixed,
                            VKey::Edge { lo, hi, .. } => {
                                count += 1;
                                Unknown::Edge {
                                    lo,
                                    hi,
                                    length: (maps.positions[hi as usize]
                                        - maps.positions[lo as usize])
                                        .norm(),
                                    offset: count - 1,
                                }
                            }
                            VKey::Face { .. } => {
                                count += 2;
                                Unknown::Inside {
                                    face: f,
                                    offset: count - 2,
                                }
                            }
                        };
                        points.push(BasePoint {
                            face: f,
                            bary: p.map(|x| x as f64 / s as f64),
                        });
                        keys.push(key);
                        unknowns.push(unknown);
                        points.len() as u32 - 1
                    });
                    g[cell(s, i, j)] = id;
                }
            }
            grid.push(g);
        }
        let cells = lattice_cells(s);
        let triangles = grid
            .iter()
            .enumerate()
            .flat_map(|(f, g)| cells.iter().map(move |c| (f as u32, c.map(|k| g[k]))))
            .collect();
        Lattice {
            points,
            keys,
            unknowns,
            count,
            grid,
            triangles,
        }
    }

    /// How lattice point `p` is seen from base face `f` (whose frame is `frame`).
    fn corner(&self, maps: &Maps, f: u32, frame: &[[f64; 2]; 3], p: u32) -> Corner {
        let slot = |v: u32| {
            maps.base_faces[f as usize]
                .iter()
                .position(|&w| w == v)
                .unwrap_or(0)
        };
        match (self.unknowns[p as usize], self.keys[p as usize]) {
            (Unknown::Fixed, VKey::Vertex(v)) => Corner::Fixed(frame[slot(v)]),
            (Unknown::Edge { lo, hi, offset, .. }, _) => {
                let (a, b) = (frame[slot(lo)], frame[slot(hi)]);
                let d = [b[0] - a[0], b[1] - a[1]];
                let n = d[0].hypot(d[1]);
                Corner::Edge {
                    origin: a,
                    unit: [d[0] / n, d[1] / n],
                    offset,
                }
            }
            (Unknown::Inside { offset, .. }, _) => Corner::Inside(offset),
            (Unknown::Fixed, _) => Corner::Fixed(in_frame(frame, self.points[p as usize].bary)),
        }
    }

    /// The unknowns that put every lattice point p at `at(p)` (a point of p's own base face,
    /// on its base edge for a point of an edge): Φ = id for `at(p) = p`.
    fn start(
        &self,
        maps: &Maps,
        frames: &[[[f64; 2]; 3]],
        at: impl Fn(&BasePoint) -> BasePoint,
    ) -> Vec<f64> {
        let mut x = vec![0.0; self.count];
        for (p, u) in self.points.iter().zip(&self.unknowns) {
            let p = &at(p);
            match *u {
                Unknown::Fixed => {}
                Unknown::Edge {
                    hi, length, offset, ..
                } => {
                    let corners = maps.base_faces[p.face as usize];
                    let slot = corners.iter().position(|&w| w == hi).unwrap_or(0);
                    x[offset] = p.bary[slot] * length;
                }
                Unknown::Inside { face, offset } => {
                    let q = in_frame(&frames[face as usize], p.bary);
                    x[offset] = q[0];
                    x[offset + 1] = q[1];
                }
            }
        }
        x
    }
}

/// Build Φ for `maps` by minimising the net's stretch (module docs), coarse to fine: the
/// solve runs on the lattice of depth `options.start_depth`, then on each finer one up to
/// `options.depth`, each started from the coarser Φ (exact: a lattice triangle lies in one
/// triangle of the coarser lattice, on which Φ is affine, so the start has no fold). Then the
/// later stages ([`super::flaps::solve`], and per-face ones as above), each with the 3D targets
/// of the map the stages before it leave. Errors: a depth or edge depth above [`MAX_DEPTH`],
/// more than [`MAX_LATTICE_TRIANGLES`] in a stage, a degenerate base face, a base edge that is
/// not shared by two consistently oriented faces (the edge stage).
pub fn equalise(maps: &Maps, options: &EqualiseOptions) -> Result<Equalised> {
    if options.depth > MAX_DEPTH {
        return Err(Error::InvalidArgument(format!(
            "reparameterisation depth {} is above {MAX_DEPTH}",
            options.depth
        )));
    }
    if options.edge_depth.is_some_and(|k| k > MAX_DEPTH) {
        return Err(Error::InvalidArgument(format!(
            "edge-flap depth {} is above {MAX_DEPTH}",
            options.edge_depth.unwrap_or_default()
        )));
    }
    let per_face = (1usize << (2 * options.depth)).max(3 << (2 * options.edge_depth.unwrap_or(0)));
    let triangles = maps.base_faces.len().saturating_mul(per_face);
    if triangles > MAX_LATTICE_TRIANGLES {
        return Err(Error::InvalidArgument(format!(
            "{}: --equalise {} on {} base faces needs {triangles} lattice triangles, more than \
             {MAX_LATTICE_TRIANGLES}; use a smaller depth K or a smaller --base-size",
            maps.name,
            options.depth,
            maps.base_faces.len()
        )));
    }
    let frames: Vec<[[f64; 2]; 3]> = (0..maps.base_faces.len() as u32)
        .map(|f| frame(maps, f))
        .collect::<Result<_>>()?;
    let plain = |p: &BasePoint| place(maps, p).0;
    let faces = solve_faces(maps, &frames, options, &plain)?;
    let mut phi = Equalised {
        report: faces.report,
        faces,
        later: Vec::new(),
    };
    if let Some(edge_depth) = options.edge_depth {
        for round in 0..options.edge_rounds.max(1) {
            if round > 0 {
                let surface = |q: &BasePoint| place(maps, &phi.inverse(q)).0;
                let faces = solve_faces(maps, &frames, options, &surface)?;
                phi.later.push(Stage::Faces(faces));
            }
            let surface = |q: &BasePoint| place(maps, &phi.inverse(q)).0;
            let flaps = super::flaps::solve(
                maps,
                edge_depth,
                options.start_depth,
                options.conformal_weight,
                &options.solver,
                &surface,
            )?;
            phi.later.push(Stage::Edges(flaps));
        }
        if options.refine {
            let surface = |q: &BasePoint| place(maps, &phi.inverse(q)).0;
            let refined = solve_faces(maps, &frames, options, &surface)?;
            phi.later.push(Stage::Faces(refined));
        }
    }
    Ok(phi)
}

/// The per-face stage, coarse to fine from `options.start_depth` to `options.depth`, each
/// lattice point's 3D target `surface(p)` (Π⁻¹ through the stages before it).
fn solve_faces(
    maps: &Maps,
    frames: &[[[f64; 2]; 3]],
    options: &EqualiseOptions,
    surface: &(dyn Fn(&BasePoint) -> Point3<f64> + Sync),
) -> Result<FaceStage> {
    let mut phi: Option<FaceStage> = None;
    for depth in options.start_depth.min(options.depth)..=options.depth {
        let level = solve_level(
            maps,
            frames,
            depth,
            phi.as_ref(),
            &options.solver,
            options.conformal_weight,
            surface,
        );
        phi = Some(match phi {
            None => level,
            Some(c) => FaceStage {
                report: combine(&c.report, &level.report),
                ..level
            },
        });
    }
    phi.ok_or_else(|| Error::InvalidArgument("no lattice depth".into()))
}

/// The lattice of `depth`, the 3D target of each lattice triangle (Π⁻¹ of its reference
/// corners; a base vertex is its input vertex) and how each triangle's corners move.
fn problem(
    maps: &Maps,
    frames: &[[[f64; 2]; 3]],
    depth: u32,
    surface: &(dyn Fn(&BasePoint) -> Point3<f64> + Sync),
) -> (Lattice, Vec<StretchTarget>, Vec<[Corner; 3]>) {
    let lattice = Lattice::new(maps, depth);
    let surface: Vec<Point3<f64>> = lattice
        .points
        .par_iter()
        .zip(&lattice.keys)
        .map(|(p, k)| match k {
            VKey::Vertex(v) => maps.positions[*v as usize],
            _ => surface(p),
        })
        .collect();
    let targets = lattice
        .triangles
        .iter()
        .map(|(_, t)| StretchTarget::of(t.map(|p| surface[p as usize].coords.into())))
        .collect();
    let corners = lattice
        .triangles
        .iter()
        .map(|&(f, t)| t.map(|p| lattice.corner(maps, f, &frames[f as usize], p)))
        .collect();
    (lattice, targets, corners)
}

/// One level of [`equalise`]: the lattice of `depth`, started at Φ = `coarser` (identity
/// without one), solved.
fn solve_level(
    maps: &Maps,
    frames: &[[[f64; 2]; 3]],
    depth: u32,
    coarser: Option<&FaceStage>,
    solver: &LbfgsOptions,
    mu: f64,
    surface: &(dyn Fn(&BasePoint) -> Point3<f64> + Sync),
) -> FaceStage {
    let t0 = Instant::now();
    let (lattice, targets, corners) = problem(maps, frames, depth, surface);
    let lattice_seconds = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    let identity = lattice.start(maps, frames, |p| *p);
    let start = coarser.map(|phi| lattice.start(maps, frames, |p| phi.forward(p)));
    let (x, solved) = solve_net(&corners, &targets, identity, start, solver, mu);
    let solve_seconds = t1.elapsed().as_secs_f64();

    let moved: Vec<Vec<[f64; 2]>> = lattice
        .grid
        .iter()
        .enumerate()
        .map(|(f, g)| {
            g.iter()
                .map(|&p| {
                    if p == u32::MAX {
                        [0.0; 2] // (i, j) outside the face: never read
                    } else {
                        lattice.corner(maps, f as u32, &frames[f], p).at(&x)
                    }
                })
                .collect()
        })
        .collect();
    let cells = lattice_cells(1 << depth);
    let buckets = frames
        .iter()
        .zip(&moved)
        .map(|(fr, m)| Buckets::new(fr, m, &cells, 1 << depth))
        .collect();
    FaceStage {
        depth,
        frames: frames.to_vec(),
        moved,
        cells,
        buckets,
        report: EqualiseReport {
            depth,
            unknowns: lattice.count,
            triangles: lattice.triangles.len(),
            stretch_before: solved.stretch_before,
            stretch_after: solved.stretch_after,
            solver: solved.solver,
            lattice_seconds,
            solve_seconds,
        },
    }
}

impl Equalised {
    /// Π'(p) from Π(p): Φ, then each later stage in order.
    pub fn forward(&self, p: &BasePoint) -> BasePoint {
        let q = self.faces.forward(p);
        self.later.iter().fold(q, |q, s| s.forward(&q))
    }

    /// Π'⁻¹ = Π⁻¹ ∘ Φ⁻¹ ∘ Φ_E⁻¹ ∘ …: each later stage's inverse in reverse order, then Φ⁻¹.
    pub fn inverse(&self, d: &BasePoint) -> BasePoint {
        let q = self.later.iter().rev().fold(*d, |q, s| s.inverse(&q));
        self.faces.inverse(&q)
    }

    /// The first edge stage, if any.
    pub fn flaps(&self) -> Option<&EdgeFlaps> {
        self.later.iter().find_map(|s| match s {
            Stage::Edges(e) => Some(e),
            Stage::Faces(_) => None,
        })
    }

    /// Π'(v) = Φ(Π(p_v)) (through every stage) of every input vertex (`None` for a vertex no
    /// face uses).
    pub fn vertex_parameters(&self, maps: &Maps) -> Vec<Option<BasePoint>> {
        (0..maps.positions.len() as u32)
            .into_par_iter()
            .map(|v| maps.param.vertex(v).map(|p| self.forward(&p)))
            .collect()
    }

    /// The moved lattice triangles of every stage that are not strictly counter-clockwise: 0
    /// for a Π' that is a bijection.
    pub fn folded_triangles(&self) -> usize {
        self.faces.folded_triangles()
            + self
                .later
                .iter()
                .map(Stage::folded_triangles)
                .sum::<usize>()
    }
}

impl FaceStage {
    fn side(&self) -> u32 {
        1 << self.depth
    }

    /// Φ(p): Σ λ_c Φ(corner_c) over the lattice triangle holding p, in p's base face.
    pub fn forward(&self, p: &BasePoint) -> BasePoint {
        let q = moved_at(self.side(), &self.moved[p.face as usize], p.bary);
        let fr = &self.frames[p.face as usize];
        BasePoint {
            face: p.face,
            bary: super::param::clamp(barycentric(q, fr[0], fr[1], fr[2])),
        }
    }

    /// Φ⁻¹(d): the moved lattice triangle of d's base face holding d (robust orientations, the
    /// nearest when rounding put d a hair outside every one), and the same barycentrics in its
    /// reference triangle. The triangles of d's bucket are tested first; when none holds d
    /// (rounding on the face's border), all 4^K.
    pub fn inverse(&self, d: &BasePoint) -> BasePoint {
        let fr = &self.frames[d.face as usize];
        let u = in_frame(fr, d.bary);
        let moved = &self.moved[d.face as usize];
        let (t, l) = locate_bucketed(u, moved, &self.cells, &self.buckets[d.face as usize]);
        let t = self.cells[t];
        let b = self.reference(t, l);
        BasePoint {
            face: d.face,
            bary: super::param::clamp(b),
        }
    }

    /// The point with barycentrics λ in the reference lattice triangle of cells `t`.
    fn reference(&self, t: [usize; 3], l: [f64; 3]) -> [f64; 3] {
        reference(self.side(), t, l)
    }
}

/// The uniform remesh of level `j` of Π' = Φ ∘ Π: the connectivity and numbering of
/// [`super::remesh::uniform`], vertex i at Π⁻¹(Φ⁻¹(d_i)) for its dyadic point d_i (a base
/// vertex stays the input vertex). Error: `j` above [`super::remesh::MAX_UNIFORM_LEVEL`].
pub fn uniform_equalised(maps: &Maps, j: u32, phi: &Equalised) -> Result<Remesh> {
    let net = super::smooth::ParamNet::dyadic(maps, uniform_leaves(maps, j)?);
    let params: Vec<BasePoint> = net
        .dyadic
        .par_iter()
        .zip(&net.keys)
        .map(|(d, k)| match k {
            VKey::Vertex(_) => *d,
            _ => phi.inverse(d),
        })
        .collect();
    let placed: Vec<(Point3<f64>, bool)> = params
        .par_iter()
        .zip(&net.keys)
        .map(|(p, k)| match k {
            VKey::Vertex(v) => (maps.positions[*v as usize], true),
            _ => place(maps, p),
        })
        .collect();
    let unmapped = placed.iter().filter(|p| !p.1).count();
    let positions = placed.into_iter().map(|p| p.0).collect();
    let name = format!("{} (equalised uniform remesh j={j})", maps.name);
    Ok(finish(maps, name, positions, net.faces, params, unmapped))
}

/// [`uniform_equalised`] whose parameters are then relaxed ([`super::relax`]) in the domain of
/// Π': the relaxation's sweeps on the dyadic net with every vertex placed by Π⁻¹ ∘ Φ⁻¹; vertex
/// i at Π⁻¹(Φ⁻¹(u_i)) for its relaxed parameter u_i. Error: `j` above
/// [`super::remesh::MAX_UNIFORM_LEVEL`].
pub fn uniform_equalised_relaxed(
    maps: &Maps,
    j: u32,
    phi: &Equalised,
    options: &super::relax::RelaxOptions,
) -> Result<super::relax::Relaxed> {
    let placement = |p: &BasePoint| place(maps, &phi.inverse(p));
    let net = super::smooth::dyadic_net(maps, j)?;
    let (net, stats) = super::relax::relax_net_with(maps, &net, options, &placement);
    let params: Vec<BasePoint> = net.params.par_iter().map(|p| phi.inverse(p)).collect();
    let placed: Vec<(Point3<f64>, bool)> = params.par_iter().map(|p| place(maps, p)).collect();
    let unmapped = placed.iter().filter(|p| !p.1).count();
    let positions = placed.into_iter().map(|p| p.0).collect();
    let name = format!("{} (equalised relaxed uniform remesh j={j})", maps.name);
    let remesh = finish(maps, name, positions, net.faces, params, unmapped);
    Ok(super::relax::Relaxed { remesh, stats })
}

impl FaceStage {
    /// The moved lattice triangles that are not strictly counter-clockwise (robust
    /// orientation): 0 for a Φ that is a bijection of every base face.
    pub fn folded_triangles(&self) -> usize {
        self.moved.iter().map(|m| folded(m, &self.cells)).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lbfgs::minimise;
    use crate::maps::lattice::energy;
    use crate::maps::retriangulate::locate;
    use crate::maps::{build, remesh::uniform, Features, MapsOptions};
    use crate::mesh::procedural::torus;

    fn torus_maps() -> crate::Result<Maps> {
        // 48 × 24 torus: the inner side's triangles are (1 − 0.35)/(1 + 0.35) ≈ 0.48 of the
        // outer side's, so the hierarchy's Π is uneven enough for Φ to have work to do.
        build(
            &torus(48, 24, 1.0, 0.35),
            &Features::default(),
            &MapsOptions {
                base_size: 64,
                ..MapsOptions::default()
            },
        )
    }

    fn options(depth: u32, iterations: usize) -> EqualiseOptions {
        let mut o = EqualiseOptions {
            depth,
            ..EqualiseOptions::default()
        };
        o.solver.max_iterations = iterations;
        o
    }

    /// With no iterations Φ = id, and the remesh of Π' is the uniform remesh: each dyadic
    /// point is located in the lattice and mapped back through the same triangle (rounding of
    /// a few operations on barycentrics of order 1, then Π⁻¹ of a point moved by ~1e-16:
    /// 1e-12 of the diagonal leaves room for Π⁻¹'s conditioning, ~10³ on this torus).
    #[test]
    fn identity_reproduces_the_uniform_remesh() -> crate::Result<()> {
        let maps = torus_maps()?;
        let phi = equalise(&maps, &options(3, 0))?;
        assert_eq!(phi.folded_triangles(), 0);
        let (plain, ours) = (uniform(&maps, 2)?, uniform_equalised(&maps, 2, &phi)?);
        assert_eq!(plain.mesh.faces, ours.mesh.faces);
        for (a, b) in plain.mesh.positions.iter().zip(&ours.mesh.positions) {
            assert!((a - b).norm() <= 1e-12 * plain.diagonal, "{a} vs {b}");
        }
        Ok(())
    }

    /// The solve of the stretch alone (μ = 0) lowers it, Φ stays a bijection of every base
    /// face (no moved triangle folds, Φ⁻¹(Φ(p)) = p), and Π' spreads the base domain more
    /// evenly over the surface than Π (with the default μ = 5 the torus trades some of that
    /// for conformality: p95 0.433 → 0.466, still checked to lower its own energy below). The
    /// round trip's tolerance: two lattice locations, each a few operations on coordinates of
    /// order 1 through lattice triangles whose aspect is at most ~10² here: 1e-11.
    #[test]
    fn solve_is_a_bijection_that_lowers_the_stretch() -> crate::Result<()> {
        let maps = torus_maps()?;
        let mixed = equalise(&maps, &options(3, 300))?;
        assert!(mixed.report.solver.last < mixed.report.solver.initial);
        assert_eq!(mixed.folded_triangles(), 0);
        let phi = equalise(
            &maps,
            &EqualiseOptions {
                conformal_weight: 0.0,
                ..options(3, 300)
            },
        )?;
        let r = phi.report;
        assert!(r.stretch_after < r.stretch_before, "{r:?}");
        assert!(r.solver.iterations > 0, "{r:?}");
        assert_eq!(phi.folded_triangles(), 0);
        let mut worst: f64 = 0.0;
        for f in 0..maps.base_faces.len() as u32 {
            for k in 0..20 {
                let a = (k as f64 * 0.618_034).fract();
                let b = (k as f64 * 0.414_214).fract() * (1.0 - a);
                let p = BasePoint {
                    face: f,
                    bary: [1.0 - a - b, a, b],
                };
                // Compared on the base mesh: a point on a base edge may come back in the
                // edge's other face. Lengths of order 1: 1e-11 as for barycentrics.
                let back = phi.inverse(&phi.forward(&p));
                worst = worst.max((maps.on_base_mesh(&back) - maps.on_base_mesh(&p)).norm());
            }
        }
        assert!(worst < 1e-11, "round trip off by {worst}");
        let plain = crate::maps::distortion::distortion(&maps).final_map;
        let (ours, _) =
            crate::maps::distortion::map_distortion(&maps, &phi.vertex_parameters(&maps));
        assert!(
            ours.area_p95 < plain.area_p95,
            "{} vs {}",
            ours.area_p95,
            plain.area_p95
        );
        Ok(())
    }

    /// The fold check can fail: swapping two moved lattice points of a face folds triangles.
    #[test]
    fn a_swapped_lattice_is_counted_as_folded() -> crate::Result<()> {
        let maps = torus_maps()?;
        let mut phi = equalise(&maps, &options(2, 0))?;
        let s = phi.faces.side();
        phi.faces.moved[0].swap(cell(s, 1, 1), cell(s, 1, 2));
        assert!(phi.folded_triangles() > 0);
        Ok(())
    }

    /// The same Φ on one thread and on two (every sum is in triangle order).
    #[test]
    fn thread_count_does_not_change_phi() -> Result<(), Box<dyn std::error::Error>> {
        let maps = torus_maps()?;
        let run = |threads: usize| -> Result<Equalised, Box<dyn std::error::Error>> {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()?;
            Ok(pool.install(|| equalise(&maps, &options(2, 50)))?)
        };
        let (one, two) = (run(1)?, run(2)?);
        assert!(
            one.faces.moved == two.faces.moved,
            "the moved lattices differ"
        );
        assert_eq!(one.report.solver, two.report.solver);
        Ok(())
    }

    /// The assembled gradient (the chain through edge arclengths and interior positions)
    /// against central differences of the energy, at a state 3 iterations away from Φ = id
    /// (not yet near the minimum, where the gradient would be lost in rounding).
    /// h = 1e-6 of coordinates of order 0.1–1 on an energy of order 10: truncation O(h²) and
    /// rounding ε·E/h ≈ 1e-9; 1e-5 relative to the largest component leaves room for both.
    #[test]
    fn gradient_matches_differences() -> crate::Result<()> {
        let maps = torus_maps()?;
        let frames: Vec<[[f64; 2]; 3]> = (0..maps.base_faces.len() as u32)
            .map(|f| frame(&maps, f))
            .collect::<crate::Result<_>>()?;
        let plain = |p: &BasePoint| place(&maps, p).0;
        let (lattice, targets, corners) = problem(&maps, &frames, 2, &plain);
        let mut x = lattice.start(&maps, &frames, |p| *p);
        let solver = LbfgsOptions {
            max_iterations: 3,
            tolerance: 0.0,
            first_step: 0.01,
            ..LbfgsOptions::default()
        };
        let mu = EqualiseOptions::default().conformal_weight;
        minimise(&mut x, |x| energy(&corners, &targets, x, mu), &solver);
        let e = |x: &[f64]| energy(&corners, &targets, x, mu).map(|r| r.0);
        let (_, grad) =
            energy(&corners, &targets, &x, mu).ok_or(Error::InvalidArgument("fold".into()))?;
        let largest = grad.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        let mut kinds = [0usize; 2];
        for u in &lattice.unknowns {
            let (k, offsets) = match *u {
                Unknown::Edge { offset, .. } => (0, vec![offset]),
                Unknown::Inside { offset, .. } => (1, vec![offset, offset + 1]),
                Unknown::Fixed => continue,
            };
            kinds[k] += 1;
            for o in offsets {
                let h = 1e-6;
                let (mut plus, mut minus) = (x.clone(), x.clone());
                plus[o] += h;
                minus[o] -= h;
                let fd = match (e(&plus), e(&minus)) {
                    (Some(a), Some(b)) => (a - b) / (2.0 * h),
                    _ => continue,
                };
                assert!(
                    (fd - grad[o]).abs() <= 1e-5 * largest,
                    "unknown {o}: {fd} vs {} (largest component {largest})",
                    grad[o]
                );
            }
        }
        assert!(kinds[0] > 0 && kinds[1] > 0, "{kinds:?}");
        Ok(())
    }

    /// Φ⁻¹ through the buckets finds the triangle a scan of all 4^K finds, on a grid of points
    /// of every face (its border included) after a solve.
    #[test]
    fn buckets_find_what_a_scan_finds() -> crate::Result<()> {
        let maps = torus_maps()?;
        let phi = equalise(&maps, &options(3, 100))?;
        for f in 0..maps.base_faces.len() as u32 {
            for i in 0..=12u32 {
                for j in 0..=12 - i {
                    let b = [(12 - i - j) as f64 / 12.0, i as f64 / 12.0, j as f64 / 12.0];
                    let d = BasePoint { face: f, bary: b };
                    let u = in_frame(&phi.faces.frames[f as usize], b);
                    let (t, l) = locate(u, &phi.faces.moved[f as usize], &phi.faces.cells);
                    let want = phi.faces.reference(phi.faces.cells[t], l);
                    let got = phi.faces.inverse(&d);
                    for x in 0..3 {
                        // Two triangles sharing the point give the same image up to rounding.
                        assert!((got.bary[x] - want[x]).abs() < 1e-12, "{got:?} vs {want:?}");
                    }
                }
            }
        }
        Ok(())
    }

    /// Errors: a lattice deeper than [`MAX_DEPTH`] or larger than [`MAX_LATTICE_TRIANGLES`];
    /// a degenerate base face, named.
    #[test]
    fn errors_name_the_problem() -> crate::Result<()> {
        let mut maps = torus_maps()?;
        let deep = equalise(&maps, &options(MAX_DEPTH + 1, 0));
        assert!(matches!(deep, Err(Error::InvalidArgument(ref m)) if m.contains("depth")));
        // A base of 200 faces at depth 7: 200 · 4⁷ ≈ 3.3·10⁶ > 2²¹.
        let fine = build(
            &torus(48, 24, 1.0, 0.35),
            &Features::default(),
            &MapsOptions {
                base_size: 200,
                ..MapsOptions::default()
            },
        )?;
        assert!(fine.base_faces.len() * (1 << (2 * MAX_DEPTH)) > MAX_LATTICE_TRIANGLES);
        let big = equalise(&fine, &options(MAX_DEPTH, 0));
        assert!(
            matches!(big, Err(Error::InvalidArgument(ref m)) if m.contains("lattice triangles")),
            "{:?}",
            big.map(|p| p.report)
        );
        let [a, b, _] = maps.base_faces[3];
        maps.positions[b as usize] = maps.positions[a as usize];
        match equalise(&maps, &options(2, 0)) {
            Err(Error::InvalidArgument(m)) => {
                assert!(
                    m.contains("base face 3") && m.contains("has no area"),
                    "{m}"
                )
            }
            other => panic!("expected an error, got {:?}", other.map(|p| p.report)),
        }
        Ok(())
    }
}
