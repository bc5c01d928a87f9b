#![doc = include_str!("README.md")]

pub mod distortion;
pub mod equalise;
pub mod features;
pub mod flaps;
pub mod flatten;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod hierarchy;
mod lattice;
pub mod param;
pub mod picture;
pub mod priority;
pub mod quality;
pub mod relax;
pub mod remesh;
pub mod retriangulate;
pub mod shape;
pub mod smooth;
pub mod stretch;

use std::collections::BTreeSet;
use std::time::Instant;

use nalgebra::Point3;

pub use features::{detect_features, load_features, parse_features, FeatureOptions, Features};
pub use hierarchy::{
    HierarchyStop, Level, LevelReport, Location, RejectCounts, Removal, StopReason,
};
pub use param::{BasePoint, Param, SurfacePoint};

use crate::error::{Error, Result};
use crate::mesh::{check_manifold, TriMesh};
use hierarchy::{decimate, Work};

/// Options of the hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct MapsOptions {
    /// λ of the priority w(λ, i) (seed 2/5). Default 0.5, the paper's suggestion.
    pub lambda: f64,
    /// Stop as soon as the mesh has at most this many triangles. Default 0: simplify until no
    /// vertex is removable.
    pub base_size: usize,
    /// Vertices of higher degree are not removed (notes). Default 12.
    pub max_degree: usize,
    /// Stop after this many levels. Default `usize::MAX` (no limit); tests use it to look at
    /// Π of intermediate levels.
    pub max_levels: usize,
    /// Keep every level's faces in [`Level::faces`] (pictures, per-level tests). Default true.
    pub keep_levels: bool,
    /// A feature-line or boundary vertex whose two feature edges turn by more than this
    /// (radians) is a corner ([`features::vertex_role`]). Default 60°.
    pub corner_turn: f64,
    /// Beyond the paper (issue #23): when neither the CDT nor any fan of a hole passes the
    /// checks, try the best valid triangulation of the flattened hole by dynamic programming
    /// ([`retriangulate::best_triangulation`]: every triangle counter-clockwise in μ and facing
    /// the star normal's side in 3D, no diagonal that is already an edge, largest smallest
    /// angle) before rejecting the removal. Default false (the paper's CDT with the fans).
    pub best_triangulation: bool,
    /// Beyond the paper (issue #23): with a `base_size` above 0 not yet reached, when a level
    /// removes nothing but some candidates were left out of its independent set (each next to
    /// a rejected vertex), run another level without the rejected vertices instead of stopping.
    /// It changes nothing on a run that reaches `base_size` without such a level, nor on a run
    /// to the coarsest base (`base_size` 0); it lets the hierarchy go on where the paper's
    /// would stop short of the size asked for (genus-3 model at base size 96: 102 base faces
    /// with the paper's rule, 96 with this; every other measured model unchanged). Default
    /// true.
    pub retry_rejected: bool,
    /// Beyond the paper (issue #23): normalise the priority's terms by this quantile over the
    /// level's candidates instead of their maximum, clamped to 1
    /// ([`priority::priorities_quantile`]). Default 1 (the maximum: the paper's priority).
    /// Measured at base 96, J = 3 (Hausdorff / mean distance, % of the diagonal), paper → 0.95:
    /// spot 4.37/0.165 → 2.40/0.092, blub 13.8/0.655 → 6.40/0.223, bob 1.51/0.059 →
    /// 2.45/0.070, nefertiti 2.09/0.057 → 2.29/0.069, genus-2 0.33/0.054 → 0.33/0.047, genus-3
    /// 0.65/0.062 → 0.54/0.059; wrong-facing area up on spot, bob, nefertiti: no clear win, so
    /// not the default.
    pub priority_quantile: f64,
    /// Beyond the paper (issue #23): visit each level's candidates in a seeded pseudo-random
    /// order ([`priority::shuffle_key`], the order public ports use) instead of the priority
    /// w(λ, i). Default none (the paper's priority). Measured at base 96, J = 3 (Hausdorff, %
    /// of the diagonal; paper → seeds 1, 2, 3): spot 4.37 → 5.16, 2.62, 3.48; bob 1.51 → 5.58,
    /// 3.11, 1.81; nefertiti 2.09 → 2.31, 2.78, 2.18; blub 13.8 → 11.2, 12.3, 6.03; genus-2
    /// 0.33 → 0.44, 0.51, 0.54; genus-3 0.65 → 0.79, 0.85, 0.75. The spread across seeds is as
    /// large as the change: at 96 faces the figure hangs on which few vertices survive.
    pub shuffle_seed: Option<u64>,
    /// Beyond the paper (issue #23): the priority's second term is the collapse error (how far
    /// the input points a removal re-stores lie from its ring's plane, `hierarchy::collapse_error`)
    /// instead of the curvature κ. Default false (the paper's κ). Measured at base 96, J = 3
    /// (Hausdorff / mean distance, % of the diagonal), paper → this: spot 4.37/0.165 →
    /// 2.01/0.105, blub 13.8/0.655 → 5.73/0.173, nefertiti 2.09/0.057 → 2.00/0.093, bob
    /// 1.51/0.059 → 3.84/0.087, genus-2 0.33/0.054 → 0.45/0.047, genus-3 0.65/0.062 →
    /// 0.78/0.055: better on the models with tips and fins, worse on bob, so not the default.
    pub priority_error: bool,
    /// Beyond the paper (issue #23): how a removed vertex's ring is flattened
    /// ([`flatten::Flattening`]): the paper's conformal z^a (default) or the polar map that
    /// keeps the radii. The GPU cross-check's `maps_flatten` kernel and the smoothing's vertex
    /// charts use z^a whatever this says. Measured at base 96, J = 3 (Hausdorff, % of the
    /// diagonal), z^a → polar: spot 4.37 → 2.91, bob 1.51 → 1.35, nefertiti 2.09 → 1.80, blub
    /// 13.8 → 11.4, genus-2 0.33 → 0.43, genus-3 0.65 → 0.53; the wrong-facing area higher on
    /// spot, nefertiti and blub (the guide, `src/maps/README.md`, with bases 64 to 250): not the
    /// default.
    pub flattening: flatten::Flattening,
    /// Beyond the paper (issue #53): the removal rule of the coarse levels that keeps the
    /// shape's parts ([`shape::ShapeRule`]: the levels that start with at most
    /// `coarse_factor` × `base_size` faces ordered by the shape error of each removal, the
    /// costlier half of each level left for a later one). `None`: the paper's priority at
    /// every level. Default `Some(ShapeRule::default())`.
    pub shape_rule: Option<shape::ShapeRule>,
}

impl Default for MapsOptions {
    fn default() -> Self {
        MapsOptions {
            lambda: 0.5,
            base_size: 0,
            max_degree: 12,
            max_levels: usize::MAX,
            keep_levels: true,
            corner_turn: FeatureOptions::default().corner_turn,
            best_triangulation: false,
            retry_rejected: true,
            priority_quantile: 1.0,
            shuffle_seed: None,
            priority_error: false,
            flattening: flatten::Flattening::Conformal,
            shape_rule: Some(shape::ShapeRule::default()),
        }
    }
}

/// Wall-clock seconds per stage.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Timings {
    /// Manifold check and feature validation.
    pub check: f64,
    /// All levels (candidates, priorities, sets, plans, commits).
    pub hierarchy: f64,
    /// Building the base domain and Π / Π⁻¹.
    pub param: f64,
}

/// The MAPS hierarchy of a mesh and its parameterisation over the base domain.
#[derive(Clone, Debug)]
pub struct Maps {
    /// The input positions (base vertices are input vertices).
    pub positions: Vec<Point3<f64>>,
    /// The input faces.
    pub input_faces: Vec<[u32; 3]>,
    /// The levels in processing order ([`Level`]).
    pub levels: Vec<Level>,
    /// The base domain's faces (input vertex indices).
    pub base_faces: Vec<[u32; 3]>,
    /// Feature edges of the base domain (each the image of a chain of input feature edges).
    pub base_feature_edges: BTreeSet<(u32, u32)>,
    /// The features the hierarchy respected.
    pub features: Features,
    /// Π of every input vertex: (base face, barycentrics); face `u32::MAX` for a vertex that
    /// no input face uses.
    pub location: Vec<Location>,
    /// Removals rejected by the checks, by cause.
    pub rejects: RejectCounts,
    /// Why the hierarchy stopped, and the state of the base domain's vertices.
    pub stop: HierarchyStop,
    /// Seconds per stage.
    pub timings: Timings,
    /// Π and Π⁻¹ (charts over the base domain).
    pub param: Param,
    /// Name of the input mesh.
    pub name: String,
}

/// [`build_with_progress`] without progress reports.
pub fn build(mesh: &TriMesh, features: &Features, options: &MapsOptions) -> Result<Maps> {
    build_with_progress(mesh, features, options, &mut |_| {})
}

/// Build the MAPS hierarchy of `mesh` respecting `features`, reporting each level to `progress`.
///
/// Errors: those of [`check_manifold`] (empty mesh, non-finite coordinates, degenerate faces,
/// non-manifold edges or vertices), [`Error::InvalidArgument`] for λ outside [0, 1], a degree
/// limit below 3 or features that are not elements of the mesh.
pub fn build_with_progress(
    mesh: &TriMesh,
    features: &Features,
    options: &MapsOptions,
    progress: &mut dyn FnMut(LevelReport),
) -> Result<Maps> {
    let t0 = Instant::now();
    if !(0.0..=1.0).contains(&options.lambda) {
        return Err(Error::InvalidArgument(format!(
            "lambda {} is not in [0, 1]",
            options.lambda
        )));
    }
    if !(options.priority_quantile > 0.0 && options.priority_quantile <= 1.0) {
        return Err(Error::InvalidArgument(format!(
            "priority_quantile {} is not in (0, 1]",
            options.priority_quantile
        )));
    }
    if let Some(rule) = &options.shape_rule {
        if !(rule.quantile > 0.0 && rule.quantile <= 1.0) {
            return Err(Error::InvalidArgument(format!(
                "shape rule quantile {} is not in (0, 1]",
                rule.quantile
            )));
        }
        if !(rule.coarse_factor >= 0.0 && rule.coarse_factor.is_finite()) {
            return Err(Error::InvalidArgument(format!(
                "shape rule coarse factor {} is not a finite number ≥ 0",
                rule.coarse_factor
            )));
        }
    }
    if options.max_degree < 3 {
        return Err(Error::InvalidArgument(format!(
            "max_degree {} is below 3",
            options.max_degree
        )));
    }
    check_manifold(mesh)?;
    features.validate(mesh)?;
    let check = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    let mut work = Work::new(&mesh.positions, &mesh.faces, features, options.corner_turn);
    work.best_triangulation = options.best_triangulation;
    work.flattening = options.flattening;
    let mut rejects = RejectCounts::default();
    let (levels, stop) = decimate(&mut work, options, &mut rejects, progress);
    let hierarchy_time = t1.elapsed().as_secs_f64();

    let t2 = Instant::now();
    let (base_faces, base_to_face, location) = base_domain(&work);
    let base_feature_edges = work
        .feature_edges
        .iter()
        .copied()
        .filter(|&(a, b)| work.vert_alive[a as usize] && work.vert_alive[b as usize])
        .collect();
    let param = Param::new(
        &mesh.positions,
        std::mem::take(&mut work.faces),
        std::mem::take(&mut work.created_by),
        std::mem::take(&mut work.removed_by),
        std::mem::take(&mut work.records),
        base_to_face,
        mesh.faces.len(),
        location.clone(),
    );
    let param_time = t2.elapsed().as_secs_f64();
    Ok(Maps {
        positions: mesh.positions.clone(),
        input_faces: mesh.faces.clone(),
        levels,
        base_faces,
        base_feature_edges,
        features: features.clone(),
        location,
        rejects,
        stop,
        timings: Timings {
            check,
            hierarchy: hierarchy_time,
            param: param_time,
        },
        param,
        name: mesh.name.clone(),
    })
}

/// The alive faces renumbered 0.. in id order, and Π of every input vertex: a removed vertex's
/// stored location with its face renumbered; a base vertex at its corner (barycentric 1) of the
/// first base face that contains it.
fn base_domain(work: &Work) -> (Vec<[u32; 3]>, Vec<u32>, Vec<Location>) {
    let mut new_id = vec![u32::MAX; work.faces.len()];
    let mut base_faces = Vec::with_capacity(work.alive_faces);
    let mut base_to_face = Vec::with_capacity(work.alive_faces);
    for (f, tri) in work.faces.iter().enumerate() {
        if work.face_alive[f] {
            new_id[f] = base_faces.len() as u32;
            base_faces.push(*tri);
            base_to_face.push(f as u32);
        }
    }
    let mut first_face = vec![u32::MAX; work.positions.len()];
    for (f, tri) in base_faces.iter().enumerate() {
        for &v in tri {
            if first_face[v as usize] == u32::MAX {
                first_face[v as usize] = f as u32;
            }
        }
    }
    let location = (0..work.positions.len())
        .map(|v| {
            if work.vert_faces[v].is_empty() && work.loc[v].0 == u32::MAX {
                (u32::MAX, [0.0; 3]) // a vertex no face uses: not on the surface
            } else if work.vert_alive[v] {
                let f = first_face[v];
                let mut b = [0.0; 3];
                let corner = base_faces[f as usize]
                    .iter()
                    .position(|&w| w as usize == v)
                    .expect("corner");
                b[corner] = 1.0;
                (f, b)
            } else {
                let (f, b) = work.loc[v];
                (new_id[f as usize], b)
            }
        })
        .collect();
    (base_faces, base_to_face, location)
}

impl Maps {
    /// Number of levels (removal rounds) of the hierarchy.
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// The base domain as a mesh (input positions, base faces; unused vertices stay, unreferenced).
    pub fn base_mesh(&self) -> TriMesh {
        TriMesh::with_shared_indices(
            format!("{} (base domain)", self.name),
            self.positions.clone(),
            Vec::new(),
            self.base_faces.clone(),
        )
    }

    /// The base-domain point of input vertex `v` mapped into 3D: Σ b_c P(base corner c)
    /// (`None` for a vertex that no face uses).
    pub fn base_position(&self, v: usize) -> Option<Point3<f64>> {
        let (f, b) = self.location[v];
        if f == u32::MAX {
            return None;
        }
        Some(self.on_base_mesh(&BasePoint { face: f, bary: b }))
    }

    /// The base-domain point `p` in 3D, on the base mesh's flat faces: Σ b_c P(base corner c).
    /// A point on a base edge is the same seen from either face.
    pub fn on_base_mesh(&self, p: &BasePoint) -> Point3<f64> {
        let t = self.base_faces[p.face as usize];
        let mut q = Point3::origin();
        for (v, b) in t.iter().zip(p.bary) {
            q += self.positions[*v as usize].coords * b;
        }
        q
    }
}
