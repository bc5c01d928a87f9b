//! The edge-flap stage of the equalised parameterisation (beyond the paper; issue #37): a
//! homeomorphism Φ_E of the base domain that moves parameter area *across* base edges, which
//! the per-face stage of [`super::equalise`] cannot (it maps every base face onto itself).
//!
//! - **The flaps.** Cut every base face (c₀, c₁, c₂) at its centroid C into the three pieces
//!   (c_k, c_{k+1}, C), k = 0, 1, 2. The two pieces on either side of a base edge form its
//!   *flap*, a quadrilateral (a, C_f, b, C_g) laid out in the plane by unfolding the two faces
//!   about the edge (each face's isometric [`frame`], the second one rotated onto the first's
//!   edge). The flaps tile the base domain and do not overlap.
//! - **Φ_E maps every flap onto itself**, piecewise linearly on the dyadic lattice of depth K of
//!   each piece (4^K triangles per piece): the points on the flap's border (the segments from
//!   the edge's ends to the two centroids) stay, the others move freely in the flap's plane,
//!   those on the base edge included, so a lattice triangle of one face may come to lie partly
//!   in the other. Φ_E is the identity on every flap's border, so it is continuous across
//!   flaps; while no moved lattice triangle folds it is a bijection of every flap, and its
//!   inverse is exact up to rounding (locate the point among the moved triangles, map it back
//!   by the same barycentrics).
//! - **The energy** is the per-face stage's ([`super::equalise`] module docs), the stretch of
//!   the map from the moved lattice to the surface plus μ times its Dirichlet energy; each
//!   lattice triangle's 3D target is the surface under its reference corners through the
//!   stages before this one ([`solve`]'s `surface`).
//!
//! What it cannot do: move area across the centroids' segments, or away from a base vertex
//! (both are fixed); the per-face stage, which moves points freely inside each face, is the
//! complement.

use std::collections::HashMap;
use std::time::Instant;

use nalgebra::Point3;
use rayon::prelude::*;

use super::lattice::{
    cell, combine, folded, frame, in_frame, lattice_cells, locate_bucketed, moved_at, reference,
    solve_net, Buckets, Corner, EqualiseReport,
};
use super::param::BasePoint;
use super::retriangulate::barycentric;
use super::stretch::StretchTarget;
use super::Maps;
use crate::error::{Error, Result};
use crate::lbfgs::LbfgsOptions;

/// [`super::equalise::EqualiseOptions::edge_depth`] by default: K_E = 4, 4^4 lattice triangles
/// per piece, 768 per base face (measured in `src/maps/README.md`).
pub const DEFAULT_DEPTH: u32 = 4;

/// One side of a flap: base face `face`'s piece (c_k, c_{k+1}, C), and those three corners in
/// the flap's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Piece {
    face: u32,
    k: usize,
    layout: [[f64; 2]; 3],
}

/// A flap: its one or two pieces (one on a boundary edge of the base domain), their moved
/// lattice points (piece p's cell c at p (s + 1)² + c) and lattice triangles (cells offset the
/// same way), and the buckets Φ_E⁻¹ searches.
#[derive(Clone, Debug)]
struct Flap {
    pieces: Vec<Piece>,
    moved: Vec<[f64; 2]>,
    cells: Vec<[usize; 3]>,
    buckets: Buckets,
}

/// The edge-flap stage Φ_E (module docs).
#[derive(Clone, Debug)]
pub struct EdgeFlaps {
    depth: u32,
    piece_of: Vec<PieceSlots>,
    flaps: Vec<Flap>,
    /// The solve's figures.
    pub report: EqualiseReport,
}

/// The piece of the point with face barycentrics `b` (the slot k whose opposite corner
/// m = k + 2 has the smallest barycentric) and its barycentrics in (c_k, c_{k+1}, C):
/// q = (b_k − b_m, b_{k+1} − b_m, 3 b_m).
pub fn piece_barycentrics(b: [f64; 3]) -> (usize, [f64; 3]) {
    let m = (0..3).fold(0, |m, c| if b[c] < b[m] { c } else { m });
    let k = (m + 1) % 3;
    let k1 = (k + 1) % 3;
    (k, [b[k] - b[m], b[k1] - b[m], 3.0 * b[m]])
}

/// The face barycentrics of piece barycentrics q in slot k, the inverse of
/// [`piece_barycentrics`]: b_k = q₀ + q₂/3, b_{k+1} = q₁ + q₂/3, b_{k+2} = q₂/3.
pub fn face_barycentrics(k: usize, q: [f64; 3]) -> [f64; 3] {
    let mut b = [0.0; 3];
    b[k] = q[0] + q[2] / 3.0;
    b[(k + 1) % 3] = q[1] + q[2] / 3.0;
    b[(k + 2) % 3] = q[2] / 3.0;
    b
}

/// The rigid motion of the plane taking a → a' and b → b' (|b − a| = |b' − a'|), applied to p.
fn rigid(a: [f64; 2], b: [f64; 2], a2: [f64; 2], b2: [f64; 2], p: [f64; 2]) -> [f64; 2] {
    let angle = (b2[1] - a2[1]).atan2(b2[0] - a2[0]) - (b[1] - a[1]).atan2(b[0] - a[0]);
    let (s, c) = angle.sin_cos();
    let d = [p[0] - a[0], p[1] - a[1]];
    [a2[0] + c * d[0] - s * d[1], a2[1] + s * d[0] + c * d[1]]
}

/// Per base face and edge slot k: (flap, piece index in it).
type PieceSlots = [(u32, usize); 3];

/// The flaps of the base domain, in face order: each base edge's pieces laid out in the frame
/// of the first face that has it. Errors: a degenerate base face; an edge with more than two
/// faces, or two faces that run it the same way (a base domain MAPS does not build).
fn layout(maps: &Maps) -> Result<(Vec<Vec<Piece>>, Vec<PieceSlots>)> {
    let mut flaps: Vec<Vec<Piece>> = Vec::new();
    let mut piece_of = Vec::with_capacity(maps.base_faces.len());
    let mut by_edge: HashMap<(u32, u32), u32> = HashMap::new();
    for (f, corners) in maps.base_faces.iter().enumerate() {
        let fr = frame(maps, f as u32)?;
        let centroid = in_frame(&fr, [1.0 / 3.0; 3]);
        let mut slots = [(0, 0); 3];
        for k in 0..3 {
            let (a, b) = (corners[k], corners[(k + 1) % 3]);
            let own = [fr[k], fr[(k + 1) % 3], centroid];
            let key = (a.min(b), a.max(b));
            match by_edge.get(&key) {
                None => {
                    by_edge.insert(key, flaps.len() as u32);
                    slots[k] = (flaps.len() as u32, 0);
                    flaps.push(vec![Piece {
                        face: f as u32,
                        k,
                        layout: own,
                    }]);
                }
                Some(&e) => {
                    let first = flaps[e as usize][0];
                    let (fa, fb) = (
                        maps.base_faces[first.face as usize][first.k],
                        maps.base_faces[first.face as usize][(first.k + 1) % 3],
                    );
                    if flaps[e as usize].len() > 1 || (fa, fb) != (b, a) {
                        return Err(Error::InvalidArgument(format!(
                            "{}: base edge {a}–{b} (base face {f}) is not shared by exactly two \
                             consistently oriented base faces, so the edge flaps of --equalise \
                             cannot unfold it; leave out the edge stage",
                            maps.name
                        )));
                    }
                    // This face runs the edge b → a: its c_k lands on the first piece's c_{k+1}.
                    let (a2, b2) = (first.layout[1], first.layout[0]);
                    let c = rigid(own[0], own[1], a2, b2, centroid);
                    slots[k] = (e, 1);
                    flaps[e as usize].push(Piece {
                        face: f as u32,
                        k,
                        layout: [a2, b2, c],
                    });
                }
            }
        }
        piece_of.push(slots);
    }
    Ok((flaps, piece_of))
}

/// The lattice of depth K over the flaps: each piece's (i, j) → point index, each point's
/// corner rule and base point (for its 3D target), and the lattice triangles.
struct FlapLattice {
    /// Per flap, per piece, the dense grid of point indices.
    grid: Vec<Vec<Vec<u32>>>,
    corners: Vec<Corner>,
    points: Vec<BasePoint>,
    count: usize,
    triangles: Vec<[u32; 3]>,
}

impl FlapLattice {
    /// A piece's lattice point (i, j) (piece barycentrics ((s − i − j)/s, i/s, j/s)) is fixed
    /// on the flap's border (i = 0, i + j = s, or on a base edge with one face), shared with
    /// the other piece's (s − i, 0) on the base edge, and free otherwise.
    fn new(flaps: &[Vec<Piece>], depth: u32) -> FlapLattice {
        let s = 1u32 << depth;
        let sf = s as f64;
        let (mut corners, mut points) = (Vec::new(), Vec::new());
        let mut count = 0;
        let mut grid = Vec::with_capacity(flaps.len());
        for pieces in flaps {
            let mut per_piece: Vec<Vec<u32>> = Vec::with_capacity(pieces.len());
            for (n, piece) in pieces.iter().enumerate() {
                let mut g = vec![u32::MAX; ((s + 1) * (s + 1)) as usize];
                for i in 0..=s {
                    for j in 0..=s - i {
                        let q = [(s - i - j) as f64 / sf, i as f64 / sf, j as f64 / sf];
                        let on_edge = j == 0 && i > 0 && i < s;
                        if on_edge && n == 1 {
                            g[cell(s, i, j)] = per_piece[0][cell(s, s - i, 0)];
                            continue;
                        }
                        let free = (on_edge && pieces.len() == 2) || (j > 0 && i > 0 && i + j < s);
                        corners.push(if free {
                            count += 2;
                            Corner::Inside(count - 2)
                        } else {
                            Corner::Fixed(in_frame(&piece.layout, q))
                        });
                        points.push(BasePoint {
                            face: piece.face,
                            bary: face_barycentrics(piece.k, q),
                        });
                        g[cell(s, i, j)] = points.len() as u32 - 1;
                    }
                }
                per_piece.push(g);
            }
            grid.push(per_piece);
        }
        let cells = lattice_cells(s);
        let triangles = grid
            .iter()
            .flat_map(|pieces| pieces.iter())
            .flat_map(|g| cells.iter().map(move |c| c.map(|k| g[k])))
            .collect();
        FlapLattice {
            grid,
            corners,
            points,
            count,
            triangles,
        }
    }

    /// The unknowns that put every free point at `at(flap, piece, q)` (a point of the flap's
    /// plane for the piece barycentrics q): Φ_E = id for the reference layout.
    fn start(&self, depth: u32, at: impl Fn(usize, usize, [f64; 3]) -> [f64; 2]) -> Vec<f64> {
        let s = 1u32 << depth;
        let sf = s as f64;
        let mut x = vec![0.0; self.count];
        for (e, pieces) in self.grid.iter().enumerate() {
            for (n, g) in pieces.iter().enumerate() {
                for i in 0..=s {
                    for j in 0..=s - i {
                        if let Corner::Inside(o) = self.corners[g[cell(s, i, j)] as usize] {
                            let q = [(s - i - j) as f64 / sf, i as f64 / sf, j as f64 / sf];
                            let p = at(e, n, q);
                            x[o] = p[0];
                            x[o + 1] = p[1];
                        }
                    }
                }
            }
        }
        x
    }
}

/// Solve Φ_E for `maps` (module docs), coarse to fine from depth `start_depth` to `depth`, the
/// 3D target of a lattice point p being `surface(p)`: Π⁻¹ through the stages before this one.
/// `mu` is the Dirichlet term's weight, `solver` the L-BFGS options per depth (its first step
/// scaled by the lattice's shortest edge). Errors: a degenerate base face, a non-manifold or
/// inconsistently oriented base edge.
pub fn solve(
    maps: &Maps,
    depth: u32,
    start_depth: u32,
    mu: f64,
    solver: &LbfgsOptions,
    surface: &(dyn Fn(&BasePoint) -> Point3<f64> + Sync),
) -> Result<EdgeFlaps> {
    let (pieces, piece_of) = layout(maps)?;
    let mut phi: Option<EdgeFlaps> = None;
    for d in start_depth.min(depth)..=depth {
        let t0 = Instant::now();
        let lattice = FlapLattice::new(&pieces, d);
        let surface_points: Vec<Point3<f64>> = lattice.points.par_iter().map(surface).collect();
        let targets: Vec<StretchTarget> = lattice
            .triangles
            .iter()
            .map(|t| StretchTarget::of(t.map(|p| surface_points[p as usize].coords.into())))
            .collect();
        let corners: Vec<[Corner; 3]> = lattice
            .triangles
            .iter()
            .map(|t| t.map(|p| lattice.corners[p as usize]))
            .collect();
        let lattice_seconds = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let identity = lattice.start(d, |e, n, q| in_frame(&pieces[e][n].layout, q));
        let start = phi
            .as_ref()
            .map(|c| lattice.start(d, |e, n, q| c.moved_in_flap(e, n, q)));
        let (x, solved) = solve_net(&corners, &targets, identity, start, solver, mu);
        let report = EqualiseReport {
            depth: d,
            unknowns: lattice.count,
            triangles: lattice.triangles.len(),
            stretch_before: solved.stretch_before,
            stretch_after: solved.stretch_after,
            solver: solved.solver,
            lattice_seconds,
            solve_seconds: t1.elapsed().as_secs_f64(),
        };
        let level = assemble(&pieces, &piece_of, &lattice, &x, d, report);
        phi = Some(match phi {
            None => level,
            Some(c) => EdgeFlaps {
                report: combine(&c.report, &level.report),
                ..level
            },
        });
    }
    phi.ok_or_else(|| Error::InvalidArgument("no lattice depth".into()))
}

/// The stage of the solved unknowns `x`.
fn assemble(
    pieces: &[Vec<Piece>],
    piece_of: &[PieceSlots],
    lattice: &FlapLattice,
    x: &[f64],
    depth: u32,
    report: EqualiseReport,
) -> EdgeFlaps {
    let s = 1u32 << depth;
    let cells = lattice_cells(s);
    let block = ((s + 1) * (s + 1)) as usize;
    let flaps = pieces
        .iter()
        .zip(&lattice.grid)
        .map(|(ps, grids)| {
            let moved: Vec<[f64; 2]> = grids
                .iter()
                .flat_map(|g| {
                    g.iter().map(|&p| match p {
                        u32::MAX => [0.0; 2], // (i, j) outside the piece: never read
                        p => lattice.corners[p as usize].at(x),
                    })
                })
                .collect();
            let flap_cells: Vec<[usize; 3]> = (0..ps.len())
                .flat_map(|n| cells.iter().map(move |c| c.map(|k| k + n * block)))
                .collect();
            let domain: Vec<[f64; 2]> = ps.iter().flat_map(|p| p.layout).collect();
            let buckets = Buckets::new(&domain, &moved, &flap_cells, s as usize);
            Flap {
                pieces: ps.clone(),
                moved,
                cells: flap_cells,
                buckets,
            }
        })
        .collect();
    EdgeFlaps {
        depth,
        piece_of: piece_of.to_vec(),
        flaps,
        report,
    }
}

impl EdgeFlaps {
    fn side(&self) -> u32 {
        1 << self.depth
    }

    fn block(&self) -> usize {
        let s = self.side() as usize;
        (s + 1) * (s + 1)
    }

    /// Φ_E of the point with barycentrics q in piece n of flap e, in the flap's plane.
    fn moved_in_flap(&self, e: usize, n: usize, q: [f64; 3]) -> [f64; 2] {
        let b = self.block();
        moved_at(self.side(), &self.flaps[e].moved[n * b..(n + 1) * b], q)
    }

    /// The base point of a point u of flap e's plane: the piece whose reference triangle
    /// holds it (the nearest when rounding put it a hair outside both), its barycentrics there.
    fn to_face(&self, e: usize, u: [f64; 2]) -> BasePoint {
        let mut best = (0, [0.0; 3], f64::NEG_INFINITY);
        for (n, p) in self.flaps[e].pieces.iter().enumerate() {
            let l = barycentric(u, p.layout[0], p.layout[1], p.layout[2]);
            let min = l[0].min(l[1]).min(l[2]);
            if min > best.2 {
                best = (n, l, min);
            }
        }
        let p = self.flaps[e].pieces[best.0];
        BasePoint {
            face: p.face,
            bary: super::param::clamp(face_barycentrics(p.k, super::param::clamp(best.1))),
        }
    }

    /// Φ_E(p): the piece holding p, Σ λ_c Φ_E(corner_c) over its lattice triangle holding p,
    /// and the base face of the flap's plane that point lies on.
    pub fn forward(&self, p: &BasePoint) -> BasePoint {
        let (k, q) = piece_barycentrics(p.bary);
        let (e, n) = self.piece_of[p.face as usize][k];
        self.to_face(e as usize, self.moved_in_flap(e as usize, n, q))
    }

    /// Φ_E⁻¹(d): d in its flap's plane, the moved lattice triangle holding it (the buckets'
    /// first, all of the flap's when none holds it), and the same barycentrics in that
    /// triangle's reference.
    pub fn inverse(&self, d: &BasePoint) -> BasePoint {
        let (k, q) = piece_barycentrics(d.bary);
        let (e, n) = self.piece_of[d.face as usize][k];
        let flap = &self.flaps[e as usize];
        let u = in_frame(&flap.pieces[n].layout, q);
        let (t, l) = locate_bucketed(u, &flap.moved, &flap.cells, &flap.buckets);
        let b = self.block();
        let piece = t / (flap.cells.len() / flap.pieces.len());
        let local = flap.cells[t].map(|c| c - piece * b);
        let p = flap.pieces[piece];
        let r = reference(self.side(), local, l);
        BasePoint {
            face: p.face,
            bary: super::param::clamp(face_barycentrics(p.k, r)),
        }
    }

    /// The moved lattice triangles that are not strictly counter-clockwise (robust
    /// orientation): 0 for a Φ_E that is a bijection of every flap.
    pub fn folded_triangles(&self) -> usize {
        self.flaps.iter().map(|f| folded(&f.moved, &f.cells)).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maps::equalise::{equalise, EqualiseOptions};
    use crate::maps::{build, Features, MapsOptions};
    use crate::mesh::procedural::torus;

    /// A 40 × 20 torus of radii 1 and 0.4 down to 48 base faces: its inner side's triangles
    /// are (1 − 0.4)/(1 + 0.4) ≈ 0.43 of the outer side's, and the base faces on the inner
    /// side carry less surface than their own area, so area has to cross base edges.
    fn torus_maps() -> crate::Result<Maps> {
        build(
            &torus(40, 20, 1.0, 0.4),
            &Features::default(),
            &MapsOptions {
                base_size: 48,
                ..MapsOptions::default()
            },
        )
    }

    /// The per-face stage at depth 2 (few iterations), then the edge stage at `depth`.
    fn options(depth: u32, iterations: usize) -> EqualiseOptions {
        let mut o = EqualiseOptions {
            depth: 2,
            edge_depth: Some(depth),
            ..EqualiseOptions::default()
        };
        o.solver.max_iterations = iterations;
        o
    }

    /// Piece barycentrics and back, on points of all three pieces and their borders (a few
    /// operations on numbers of order 1: 1e-15).
    #[test]
    fn piece_barycentrics_invert() {
        for i in 0..=9u32 {
            for j in 0..=9 - i {
                let b = [(9 - i - j) as f64 / 9.0, i as f64 / 9.0, j as f64 / 9.0];
                let (k, q) = piece_barycentrics(b);
                assert!(q.iter().all(|&x| x >= -1e-15), "{b:?} → {q:?}");
                assert!((q.iter().sum::<f64>() - 1.0).abs() < 1e-15);
                let back = face_barycentrics(k, q);
                for c in 0..3 {
                    assert!((back[c] - b[c]).abs() < 1e-15, "{b:?} → {back:?}");
                }
            }
        }
    }

    /// Every interior base edge's two pieces are unfolded about it: they share the edge's two
    /// ends, both are counter-clockwise (on opposite sides), and the unfolding keeps each
    /// piece's side lengths (the distances from the edge's ends to the face's centroid in 3D).
    /// Lengths of order 1 through one rotation: 1e-12.
    #[test]
    fn flaps_unfold_the_two_faces_about_their_edge() -> crate::Result<()> {
        let maps = torus_maps()?;
        let (flaps, _) = layout(&maps)?;
        assert_eq!(flaps.len(), maps.base_faces.len() * 3 / 2);
        for pieces in &flaps {
            assert_eq!(pieces.len(), 2);
            let (p, q) = (pieces[0], pieces[1]);
            assert_eq!((q.layout[0], q.layout[1]), (p.layout[1], p.layout[0]));
            for piece in [p, q] {
                let l = piece.layout;
                assert!(super::super::retriangulate::orient2d(l[0], l[1], l[2]) > 0.0);
                let face = maps.base_faces[piece.face as usize].map(|v| maps.positions[v as usize]);
                let centroid = (face[0].coords + face[1].coords + face[2].coords) / 3.0;
                for (c, corner) in [(0, piece.k), (1, (piece.k + 1) % 3)] {
                    let planar = (l[c][0] - l[2][0]).hypot(l[c][1] - l[2][1]);
                    let spatial = (face[corner].coords - centroid).norm();
                    assert!((planar - spatial).abs() < 1e-12, "{planar} vs {spatial}");
                }
            }
        }
        Ok(())
    }

    /// The solve lowers the stretch, folds nothing, Φ_E⁻¹(Φ_E(p)) = p (two lattice locations
    /// of a few operations on coordinates of order 1 through triangles of aspect at most ~10²:
    /// 1e-11), and it moves area across base edges: lattice points of the edges leave them,
    /// and some points of one face map into the other face of their flap.
    #[test]
    fn solve_moves_points_across_edges_and_stays_a_bijection() -> crate::Result<()> {
        let maps = torus_maps()?;
        let phi = equalise(&maps, &options(3, 200))?;
        let flaps = phi
            .flaps()
            .ok_or(Error::InvalidArgument("no flaps".into()))?;
        let r = flaps.report;
        assert!(r.stretch_after < r.stretch_before, "{r:?}");
        assert_eq!(flaps.folded_triangles(), 0);
        let (mut worst, mut crossed): (f64, usize) = (0.0, 0);
        for f in 0..maps.base_faces.len() as u32 {
            for k in 0..30 {
                let a = (k as f64 * 0.618_034).fract();
                let b = (k as f64 * 0.414_214).fract() * (1.0 - a);
                let p = BasePoint {
                    face: f,
                    bary: [1.0 - a - b, a, b],
                };
                let image = flaps.forward(&p);
                crossed += usize::from(image.face != p.face && p.bary.iter().all(|&x| x > 1e-3));
                // Compared on the base mesh: a point on a base edge may come back in the
                // edge's other face.
                let back = flaps.inverse(&image);
                worst = worst.max((maps.on_base_mesh(&back) - maps.on_base_mesh(&p)).norm());
            }
        }
        assert!(worst < 1e-11, "round trip off by {worst}");
        assert!(crossed > 0, "no point crossed a base edge");
        Ok(())
    }

    /// With no iterations Φ_E = id: every point maps to itself (one lattice location on
    /// coordinates of order 1: 1e-14).
    #[test]
    fn no_iterations_is_the_identity() -> crate::Result<()> {
        let maps = torus_maps()?;
        let phi = equalise(&maps, &options(2, 0))?;
        let flaps = phi
            .flaps()
            .ok_or(Error::InvalidArgument("no flaps".into()))?;
        for f in 0..maps.base_faces.len() as u32 {
            for b in [
                [0.2, 0.3, 0.5],
                [0.5, 0.5, 0.0],
                [1.0 / 3.0; 3],
                [0.9, 0.05, 0.05],
            ] {
                let p = BasePoint { face: f, bary: b };
                for q in [flaps.forward(&p), flaps.inverse(&p)] {
                    // On the base mesh: [0.5, 0.5, 0] may come back in the edge's other face.
                    let d = (maps.on_base_mesh(&q) - maps.on_base_mesh(&p)).norm();
                    assert!(d < 1e-14, "{p:?} → {q:?}");
                }
            }
        }
        Ok(())
    }

    /// The fold check can fail: swapping two moved lattice points of a flap folds triangles.
    #[test]
    fn a_swapped_lattice_is_counted_as_folded() -> crate::Result<()> {
        let maps = torus_maps()?;
        let mut phi = equalise(&maps, &options(2, 0))?;
        assert_eq!(phi.folded_triangles(), 0);
        let flaps = match phi.later.first_mut() {
            Some(crate::maps::equalise::Stage::Edges(e)) => e,
            _ => return Err(Error::InvalidArgument("no flaps".into())),
        };
        let s = flaps.side();
        flaps.flaps[0].moved.swap(cell(s, 1, 1), cell(s, 2, 1));
        assert!(flaps.folded_triangles() > 0);
        // The composition counts every stage's folds.
        assert!(phi.folded_triangles() > 0);
        Ok(())
    }

    /// The same Φ_E on one thread and on two.
    #[test]
    fn thread_count_does_not_change_the_flaps() -> Result<(), Box<dyn std::error::Error>> {
        let maps = torus_maps()?;
        let run = |threads: usize| -> Result<Vec<Vec<[f64; 2]>>, Box<dyn std::error::Error>> {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()?;
            let phi = pool.install(|| equalise(&maps, &options(2, 30)))?;
            let flaps = phi.flaps().ok_or("no flaps")?;
            Ok(flaps.flaps.iter().map(|f| f.moved.clone()).collect())
        };
        assert!(run(1)? == run(2)?, "the moved flaps differ");
        Ok(())
    }

    /// A base face turned the other way makes its edges run the same way as its neighbours':
    /// an error naming the edge and the face, not a folded flap.
    #[test]
    fn an_inconsistent_orientation_is_an_error() -> crate::Result<()> {
        let mut maps = torus_maps()?;
        maps.base_faces[5].swap(1, 2);
        match equalise(&maps, &options(2, 0)) {
            Err(Error::InvalidArgument(m)) => {
                assert!(m.contains("base edge") && m.contains("base face"), "{m}")
            }
            other => panic!("expected an error, got {:?}", other.map(|p| p.report)),
        }
        Ok(())
    }
}
