//! maps vectors: the priority terms of a batch of 1-rings (`maps_priority`), their conformal
//! flattening (`maps_flatten.points`, `maps_flatten.rings`), Π⁻¹ of base points
//! (`maps_inverse`), from the hierarchy's tables as the kernel receives them, against the f64
//! reference ([`crate::maps::priority`], [`crate::maps::flatten`],
//! [`crate::maps::Param::inverse`]; MAPS §3, seed 002), each element held to the cross-check's
//! own bound ([`crate::crosscheck::maps_bound`], [`crate::crosscheck::maps_inverse_bound`]).

use nalgebra::Point3;

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::maps::compared_rings;
use crate::crosscheck::maps_bound::{
    flatten_bounds, flatten_reference, kind_of, priority_bounds, priority_reference, FlattenBounds,
    FlattenReference,
};
use crate::crosscheck::maps_inverse_bound::{inverse_position_bound, FlatTables};
use crate::error::{Error, Result};
use crate::maps::flatten::RingShape;
use crate::maps::gpu::{
    base_queries, flatten_gpu, inverse_gpu, inverse_tables, normalise, priority_terms_gpu,
    rings_batch, LevelRings,
};
use crate::maps::param::BasePoint;
use crate::maps::{Maps, MapsOptions};
use crate::twin::maps_flatten::{STATUS_DEGENERATE, STATUS_FLIPPED_FAN, STATUS_OK};

/// `maps_inverse` for the manifest, step by step (issue #33: an implementer must be able to
/// write a passing candidate from the manifest alone; `tests/vectors_manifest_maps.rs` does).
const INVERSE_FORMULA: &str = "Π⁻¹ of base points (MAPS §3.3). Per query (base face q, \
    barycentrics b): face = base_to_face[q]. While face_created_by[face] ≠ 4294967295 (not an \
    input face): r = face_created_by[face]; u = Σ_c b_c μ_c with μ_c = (charts[face][2c], \
    charts[face][2c + 1]) (the face's corners in r's plane); over the faces f of \
    old_faces[removals[r][0] .. removals[r][0] + removals[r][1]] in that order, with their \
    corners ν_c = (charts[f][6 + 2c], charts[f][7 + 2c]) in r's plane, λ = barycentric(u, ν): \
    take the first f with min λ ≥ 0, else the f with the largest min λ (the first on ties); \
    face = f, b = max(λ, 0) / Σ max(λ, 0). At an input face: position = Σ_c b_c \
    positions[face_corners[face][c]] (x, y, z). barycentric(u, a, b, c) = (o(u, b, c), \
    o(a, u, c), o(a, b, u)) / s with o(p, q, r) = (q.x − p.x)(r.y − p.y) − (q.y − p.y)(r.x − p.x) \
    and s the sum of the three (o(a, b, c) if that sum is 0)";

/// The vectors of Π⁻¹ at `points` (base face, barycentrics) of `maps`, positions in the
/// normalised frame (centred on the bounding box, divided by its diagonal), and with a GPU
/// reparam's own kernel's output as the candidate.
pub fn vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    maps: &Maps,
    points: &[BasePoint],
) -> Result<VectorsAndCandidates> {
    let norm = normalise(&maps.positions)?;
    let tables = inverse_tables(maps, &norm);
    let queries = base_queries(points);
    let expected = points
        .iter()
        .map(|p| {
            let c = maps.param.inverse(p).ok_or_else(|| {
                Error::InvalidArgument(format!("base point in face {} out of range", p.face))
            })?;
            let q = norm.apply(&c.position);
            Ok([q.x, q.y, q.z])
        })
        .collect::<Result<Vec<_>>>()?;
    let n = points.len();
    let f = tables.faces.len();
    let flat = FlatTables::of(&tables);
    let bounds: Vec<f64> = queries
        .iter()
        .zip(&expected)
        .map(|(q, e)| inverse_position_bound(&flat.tables(), q, *e))
        .collect();
    let inputs: Vec<(String, String, Array)> = vec![
        (
            "positions".into(),
            "per input vertex (0-based), f32: x, y, z in the normalised frame (centred on the \
             bounding box, divided by its diagonal), 0"
                .into(),
            Array::f32(&[tables.positions.len(), 4], tables.positions.iter().flatten().copied().collect()),
        ),
        (
            "face_corners".into(),
            "per decimation face (input faces first, then each removal's new faces), u32: 3 vertices"
                .into(),
            Array::u32(&[f, 3], tables.faces.iter().flat_map(|d| d.corners).collect()),
        ),
        (
            "face_created_by".into(),
            "per decimation face, u32: the removal that created it (4294967295: an input face)".into(),
            Array::u32(&[f], tables.faces.iter().map(|d| d.created_by).collect()),
        ),
        (
            "charts".into(),
            "per decimation face, f32: μ of its 3 corners (x, y each) in the plane of the removal \
             that created it, then in that of the removal that deleted it (the removed vertex at \
             0; zeros where the chart does not apply)"
                .into(),
            Array::f32(
                &[f, 12],
                tables
                    .charts
                    .iter()
                    .flat_map(|c| c.created.iter().chain(&c.removed).flatten().copied().collect::<Vec<_>>())
                    .collect(),
            ),
        ),
        (
            "removals".into(),
            "per removal (hierarchy order), u32: first index into old_faces, count".into(),
            Array::u32(&[tables.removals.len(), 2], tables.removals.iter().flatten().copied().collect()),
        ),
        ("old_faces".into(), "u32: the faces each removal deleted".into(), Array::u32(&[tables.old_faces.len()], tables.old_faces.clone())),
        ("base_to_face".into(), "per base face, u32: its decimation face".into(), Array::u32(&[tables.base_to_face.len()], tables.base_to_face.clone())),
        ("query_face".into(), "per query, u32: the base face (0-based)".into(), Array::u32(&[n], queries.iter().map(|q| q.face).collect())),
        (
            "query_bary".into(),
            "per query, f32: barycentrics in the base face's corner order".into(),
            Array::f32(&[n, 3], queries.iter().flat_map(|q| q.bary).collect()),
        ),
    ];
    let kernel = KernelData {
        name: "maps_inverse".into(),
        description: INVERSE_FORMULA.into(),
        inputs,
        expected: (
            "per query, f64: x, y, z in the normalised frame".into(),
            Array::f64(&[n, 3], expected.iter().flatten().copied().collect()),
        ),
        bound: (
            "per query, fraction of the diagonal".into(),
            Array::f64(&[n], bounds),
        ),
        metric: Metric::NormOfLastAxis {
            scale: 1.0,
            unit: "fraction of the diagonal".into(),
        },
        bound_formula:
            "d_in + 2 ‖(b_x, b_y, b_z)‖₂ per query: d_in = ‖Π⁻¹ on the f32 tables − Π⁻¹ \
            on the f64 charts‖ (computed in f64), b_c = Σᵢ |∂p_c/∂eᵢ| aᵢ the first-order effect of \
            every operation's WGSL allowance along the walk"
                .into(),
        derivation:
            "crosscheck::maps_inverse_bound::inverse_position_bound: the kernel's twin over Lin \
            (src/twin/maps_inverse.rs, src/twin/lin.rs)"
                .into(),
        per_element: vec!["query_face".into(), "query_bary".into()],
        covers: Vec::new(),
    };
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let out = inverse_gpu(gpu, &tables, points)?;
        candidates.push((
            "maps_inverse".to_string(),
            Array::f32(&[n, 3], out.iter().flat_map(|r| r.position).collect()),
        ));
    }
    Ok((vec![kernel], candidates))
}

/// The two-sided Hausdorff distance (BVH, [`crate::maps::quality::remesh_quality`]) between the
/// surface with `faces` on `points` and the input, both in the normalised frame (diagonal 1).
fn hausdorff_normalised(
    norm: &crate::maps::gpu::Normalised,
    maps: &Maps,
    points: &[nalgebra::Point3<f64>],
    faces: &[[u32; 3]],
) -> f64 {
    crate::maps::quality::remesh_quality(points, faces, &norm.cpu, &maps.input_faces, 1.0)
        .hausdorff_relative
}

/// The whole-algorithm vectors of MAPS: the base domain's counts (levels, base vertices, base
/// faces) and the two-sided Hausdorff distance between the `remesh` (its vertices Π⁻¹ of its
/// base points, MAPS §4) and the input, as a fraction of the bounding-box diagonal. With a GPU,
/// the candidate is the same hierarchy with the remesh's vertices from reparam's own
/// `maps_inverse` kernel.
pub fn run_vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    maps: &Maps,
    remesh: &crate::maps::remesh::Remesh,
) -> Result<VectorsAndCandidates> {
    let norm = normalise(&maps.positions)?;
    let cpu_points: Vec<_> = remesh
        .mesh
        .positions
        .iter()
        .map(|p| norm.apply(p))
        .collect();
    let faces = &remesh.mesh.faces;
    let counts = [
        maps.level_count() as f64,
        maps.base_mesh().positions.len() as f64,
        maps.base_faces.len() as f64,
    ];
    let h = hausdorff_normalised(&norm, maps, &cpu_points, faces);
    let expected = vec![counts[0], counts[1], counts[2], h];
    // d: the largest per-point bound of maps_inverse over the remesh's vertices.
    let flat = FlatTables::of(&inverse_tables(maps, &norm));
    let d = base_queries(&remesh.params)
        .iter()
        .zip(&cpu_points)
        .map(|(q, p)| inverse_position_bound(&flat.tables(), q, [p.x, p.y, p.z]))
        .fold(0.0, f64::max);
    let h_bound = if h > 0.0 { d / h } else { d };
    let kernel = KernelData {
        name: "maps_run".into(),
        description: "the MAPS hierarchy (§3) to its base domain and a remesh of it (§4): the \
            hierarchy's levels, the base domain's vertices and faces, and the two-sided \
            Hausdorff distance between the remesh and the input"
            .into(),
        inputs: vec![
            (
                "positions".into(),
                "per input vertex (0-based), f64: x, y, z in the normalised frame (centred on \
                 the bounding box, divided by its diagonal; values of f32)"
                    .into(),
                Array::f64(
                    &[norm.cpu.len(), 3],
                    norm.cpu.iter().flat_map(|p| [p.x, p.y, p.z]).collect(),
                ),
            ),
            (
                "faces".into(),
                "per input face, u32: three vertices (0-based, counter-clockwise)".into(),
                Array::u32(
                    &[maps.input_faces.len(), 3],
                    maps.input_faces.iter().flatten().copied().collect(),
                ),
            ),
            (
                "remesh_faces".into(),
                "per remesh face, u32: three remesh vertices, each the Π⁻¹ of the base point of \
                 the same row of `remesh_points`"
                    .into(),
                Array::u32(&[faces.len(), 3], faces.iter().flatten().copied().collect()),
            ),
            (
                "remesh_points".into(),
                "per remesh vertex, f64: base face (0-based), barycentrics of its corners 0, 1, 2"
                    .into(),
                Array::f64(
                    &[remesh.params.len(), 4],
                    remesh
                        .params
                        .iter()
                        .flat_map(|p| {
                            let b = p.bary;
                            [p.face as f64, b[0], b[1], b[2]]
                        })
                        .collect(),
                ),
            ),
        ],
        expected: (
            "f64: levels of the hierarchy, base vertices, base faces, two-sided Hausdorff \
             distance of the remesh (fraction of the diagonal)"
                .into(),
            Array::f64(&[4], expected),
        ),
        bound: (
            "per figure, relative".into(),
            Array::f64(&[4], vec![0.0, 0.0, 0.0, h_bound]),
        ),
        metric: Metric::Relative {
            unit: "relative".into(),
        },
        bound_formula: "counts: exact; Hausdorff: d / H, d the largest of maps_inverse's \
            per-point bounds over the remesh's vertices"
            .into(),
        derivation: "the counts are integers decided by the priority queue and the stopping \
            rule: an implementation of the same removals (priority λ·a/max a + (1−λ)·κ/max κ, \
            ties to the lower vertex index, the same degree limit) reproduces them exactly. \
            Moving every remesh vertex by ≤ d moves every point of the remesh by ≤ d (a convex \
            combination), so the Hausdorff distance moves by ≤ d both ways; Π⁻¹ is within \
            d of the diagonal (maps_inverse's per-point bounds, crosscheck::maps_inverse_bound)"
            .into(),
        per_element: vec![],
        covers: Vec::new(),
    };
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let tables = inverse_tables(maps, &norm);
        let out = inverse_gpu(gpu, &tables, &remesh.params)?;
        let points: Vec<_> = out
            .iter()
            .map(|r| {
                nalgebra::Point3::new(
                    r.position[0] as f64,
                    r.position[1] as f64,
                    r.position[2] as f64,
                )
            })
            .collect();
        let h_gpu = hausdorff_normalised(&norm, maps, &points, faces);
        candidates.push((
            "maps_run".to_string(),
            Array::f64(&[4], vec![counts[0], counts[1], counts[2], h_gpu]),
        ));
    }
    Ok((vec![kernel], candidates))
}

/// Every maps vector: the ring kernels on `rings` ([`ring_vectors`]), Π⁻¹ at the remesh's base
/// points ([`vectors`]) and the whole run ([`run_vectors`]).
pub fn all_vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    maps: &Maps,
    remesh: &crate::maps::remesh::Remesh,
    rings: &RingSet,
) -> Result<VectorsAndCandidates> {
    let (mut kernels, mut candidates) = ring_vectors(gpu, rings)?;
    let (inverse, inverse_candidates) = vectors(gpu, maps, &remesh.params)?;
    kernels.extend(inverse);
    candidates.extend(inverse_candidates);
    let (run, run_candidates) = run_vectors(gpu, maps, remesh)?;
    kernels.extend(run);
    candidates.extend(run_candidates);
    Ok((kernels, candidates))
}

/// The 1-rings of the ring kernels' vectors: vertex positions (any frame: [`ring_vectors`]
/// normalises them) and the rings over them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RingSet {
    pub positions: Vec<Point3<f64>>,
    pub rings: LevelRings,
}

impl RingSet {
    /// The rings `crosscheck maps` compares on `maps` ([`compared_rings`]: levels 0 and the
    /// middle one).
    pub fn of(maps: &Maps, options: &MapsOptions) -> RingSet {
        RingSet {
            positions: maps.positions.clone(),
            rings: compared_rings(maps, options),
        }
    }

    /// Add the rings `rings` over the vertices `positions` (numbered from 0 there): their
    /// vertices are appended after this set's.
    pub fn append(&mut self, positions: &[Point3<f64>], rings: &LevelRings) {
        let offset = self.positions.len() as u32;
        self.positions.extend_from_slice(positions);
        let r = &mut self.rings;
        r.vertices.extend(rings.vertices.iter().map(|v| v + offset));
        r.rings.extend(
            rings
                .rings
                .iter()
                .map(|ring| ring.iter().map(|v| v + offset).collect()),
        );
        r.stars.extend(
            rings
                .stars
                .iter()
                .map(|star| star.iter().map(|f| f.map(|v| v + offset)).collect()),
        );
        r.shapes.extend_from_slice(&rings.shapes);
    }

    /// The rings `which` of this set (same positions).
    fn subset(&self, which: &[usize]) -> RingSet {
        let r = &self.rings;
        RingSet {
            positions: self.positions.clone(),
            rings: LevelRings {
                vertices: which.iter().map(|&i| r.vertices[i]).collect(),
                rings: which.iter().map(|&i| r.rings[i].clone()).collect(),
                stars: which.iter().map(|&i| r.stars[i].clone()).collect(),
                shapes: which.iter().map(|&i| r.shapes[i]).collect(),
            },
        }
    }
}

/// What both ring kernels read (`maps_rings.wgsl`), for the manifest.
const RING_INPUTS: &str = "Inputs: positions[v] = (x, y, z, 0) (f32, the normalised frame: \
    centred on the bounding box, divided by its diagonal); rings[r] = (centre, first, count, \
    kind, s, t, 0, 0) (u32): ring r is vertex i = centre with ring vertices j_k = \
    neighbours[first + k], k = 0 … K − 1 (K = count ≥ 3, counter-clockwise), p_i = \
    positions[i].xyz, kind 0 = disk (closed ring, K sectors), 1 = half disk (a boundary vertex's \
    open ring, K − 1 sectors), 2 = feature line (closed, cut at ring positions s < t by the two \
    feature edges). Sector m joins j_m and j_{(m + 1) mod K}.";

/// `maps_priority` for the manifest, step by step.
const PRIORITY_FORMULA: &str = "MAPS priority terms (seed 002 'Constructing the Mesh \
    Hierarchies (2/5)', 'Notation (4/4)'), per ring r: [a, κ]. a = Σ over the sectors m of \
    ½|(p_{j_m} − p_i) × (p_{j_{m+1}} − p_i)|. κ: n = N/|N| with N = Σ over the sectors of \
    (p_{j_m} − p_i) × (p_{j_{m+1}} − p_i); h = (1, 0, 0) if |n_x| < 0.9 else (0, 1, 0); \
    e₁ = (n × h)/|n × h|, e₂ = n × e₁; ℓ = max_k |p_{j_k} − p_i|; for every ring vertex k \
    (all K, open rings too) d = (p_{j_k} − p_i)/ℓ, (x, y, z) = (d·e₁, d·e₂, d·n), \
    w = (x², xy, y²); M = Σ w wᵀ, b = Σ w z; (A', B', C') = M⁻¹ b; (A, B, C) = (A', B', C')/ℓ; \
    κ = |A + C + D| + |A + C − D| with D = √((A − C)² + B²) (= |κ₁| + |κ₂| of the fit \
    z = A x² + B xy + C y²; any frame in the tangent plane gives the same κ). κ = 0 when \
    |N| = 0, M is singular or κ is not finite (no such ring is in these vectors: the WGSL \
    table gives no bound there).";

/// `maps_flatten` for the manifest, step by step.
const FLATTEN_FORMULA: &str = "The conformal map z^a of each 1-ring (seed 002 'Constructing \
    the Mesh Hierarchies (4/5)'). Per sector m (K of a closed ring, K − 1 of a half disk): \
    u = p_{j_m} − p_i, v = p_{j_{m+1}} − p_i, φ_m = atan2(|u × v|, u·v) (0 when both are 0); \
    θ_0 = 0, θ_{m+1} = θ_m + φ_m; θ_total = the last (θ_K closed, θ_{K−1} half disk). \
    r_k = |p_{j_k} − p_i|. Status: 1 (degenerate) if some r_k = 0 or is not finite, or θ does \
    not strictly increase over the sectors (then μ = 0 and a = a₂ = 0); else exponents: disk \
    a = a₂ = 2π/θ_K; half disk a = a₂ = π/θ_{K−1}; feature line a = π/(θ_t − θ_s) (upper \
    side s → t), a₂ = π/(θ_K − (θ_t − θ_s)) (lower side t → s, past j_0). Status 2 (flipped \
    fan) if a side has a single sector, or a·(θ_{m+1} − θ_m) ≥ π for a sector m of the side \
    (θ_K closing a closed ring); else 0. μ is written whatever the status 0 or 2: disk \
    μ_k = r_k^a (cos aθ_k, sin aθ_k), μ_0 = (r_0^a, 0); half disk μ_k likewise for \
    0 < k < K − 1, μ_0 = (r_0^a, 0), μ_{K−1} = (−r_{K−1}^a, 0); feature line μ_k = \
    r_k^a (cos, sin)(a(θ_k − θ_s)) for s < k < t, μ_k = r_k^{a₂} (cos, sin)(π + a₂(θ_k − θ_t)) \
    for k > t, (π + a₂(θ_k + θ_K − θ_t)) for k < s, μ_s = (r_s^c, 0), μ_t = (−r_t^c, 0) with \
    c = (a + a₂)/2.";

/// The bound's derivation, shared by the three ring kernels.
const RING_DERIVATION: &str = "crosscheck::maps_bound: the kernel's f32 twin \
    (src/twin/maps_priority.rs, maps_flatten.rs) evaluated over Lin, with each operation \
    perturbed within the WGSL accuracy table (one ULP per + − ×, 2.5 per division, 4.5 per \
    sqrt, 3 + 2|x| ULP per exp2, 2⁻²¹ or 3 ULP per log2, 2⁻¹¹ per cos and sin, any order and \
    fusion of a sum): bound = 2·Σᵢ|∂y/∂eᵢ|aᵢ (first order, twice for the neglected terms) + \
    |twin's f64 value − reference| (the kernel's formula's own departure: its atan \
    polynomial), at least 2⁻¹²⁶. Rings where the table gives no bound (a singular fit, a \
    decision within rounding) are left out.";

/// The indices of the rings a kernel's vectors keep (every element's bound finite) and, per
/// kept ring, its reference and bounds.
type Kept<T> = (Vec<usize>, Vec<T>);

/// The per-ring reference and bounds of the priority terms, for the rings the table bounds.
fn priority_rings(set: &RingSet) -> Kept<([f64; 2], [f64; 2])> {
    let r = &set.rings;
    let pos = &set.positions;
    let mut kept = (Vec::new(), Vec::new());
    for i in 0..r.vertices.len() {
        let reference = priority_reference(pos, r.vertices[i], &r.rings[i], &r.stars[i]);
        let bounds = priority_bounds(pos, r.vertices[i], &r.rings[i], r.shapes[i], reference);
        if bounds.iter().all(|b| b.is_finite()) {
            kept.0.push(i);
            kept.1.push((reference, bounds));
        }
    }
    kept
}

/// The per-ring reference and bounds of the flattening, for the rings the table bounds.
fn flatten_rings(set: &RingSet) -> Kept<(FlattenReference, FlattenBounds)> {
    let r = &set.rings;
    let pos = &set.positions;
    let mut kept = (Vec::new(), Vec::new());
    for i in 0..r.vertices.len() {
        let reference = flatten_reference(pos, r.vertices[i], &r.rings[i], r.shapes[i]);
        let finite = reference.points.iter().flatten().all(|x| x.is_finite());
        if let (true, Some(b)) = (
            finite,
            flatten_bounds(pos, r.vertices[i], &r.rings[i], r.shapes[i], &reference),
        ) {
            kept.0.push(i);
            kept.1.push((reference, b));
        }
    }
    kept
}

/// The kernels' three ring inputs (positions, neighbours, rings) of `set`, prefixed for the
/// manifest.
fn ring_inputs(positions: &[[f32; 4]], set: &RingSet) -> Vec<(String, String, Array)> {
    let batch = rings_batch(positions, &set.rings);
    let headers: Vec<u32> = batch
        .rings
        .iter()
        .flat_map(|h| [h.centre, h.first, h.count, h.kind, h.s, h.t, 0, 0])
        .collect();
    vec![
        (
            "positions".into(),
            "per vertex (0-based), f32: x, y, z in the normalised frame (centred on the \
             bounding box, divided by its diagonal), 0"
                .into(),
            Array::f32(
                &[positions.len(), 4],
                positions.iter().flatten().copied().collect(),
            ),
        ),
        (
            "neighbours".into(),
            "per ring slot, u32: the ring vertex j_k (slot first + k of its ring)".into(),
            Array::u32(&[batch.neighbours.len()], batch.neighbours.clone()),
        ),
        (
            "rings".into(),
            "per ring, u32: centre, first, count, kind (0 disk, 1 half disk, 2 feature line), \
             s, t, 0, 0"
                .into(),
            Array::u32(&[batch.rings.len(), 8], headers),
        ),
    ]
}

/// "`what`: n rings" for the covers, or nothing when n = 0.
fn count_line(what: &str, n: usize) -> Option<String> {
    (n > 0).then(|| format!("{what}: {n}"))
}

/// The ring kinds among `set`'s rings, for the covers.
fn kind_lines(set: &RingSet) -> Vec<String> {
    let count = |kind: u32| {
        set.rings
            .shapes
            .iter()
            .filter(|&&s| kind_of(s).0 == kind)
            .count()
    };
    let sizes = set.rings.rings.iter().map(Vec::len);
    let (lo, hi) = (sizes.clone().min().unwrap_or(0), sizes.max().unwrap_or(0));
    [
        count_line("disk rings (K sectors)", count(0)),
        count_line(
            "half-disk rings (a boundary vertex: K − 1 sectors)",
            count(1),
        ),
        count_line("feature-line rings (K sectors, cut at s < t)", count(2)),
        Some(format!("ring sizes K = {lo} … {hi}")),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// The vectors of `maps_priority`, `maps_flatten.points` and `maps_flatten.rings` on the rings
/// of `set` the WGSL table bounds (module docs), positions normalised ([`normalise`]) and the
/// reference run on their f32 values; with a GPU, reparam's own kernels' outputs as candidates.
pub fn ring_vectors(gpu: Option<&reparam_gpu::Gpu>, set: &RingSet) -> Result<VectorsAndCandidates> {
    let norm = normalise(&set.positions)?;
    let exact = RingSet {
        positions: norm.cpu.clone(),
        rings: set.rings.clone(),
    };
    let (p_which, p_rows) = priority_rings(&exact);
    let (f_which, f_rows) = flatten_rings(&exact);
    if p_which.is_empty() || f_which.is_empty() {
        return Err(Error::InvalidArgument(
            "no ring of the mesh has bounded priority terms and flattening".into(),
        ));
    }
    let p_set = exact.subset(&p_which);
    let f_set = exact.subset(&f_which);
    let mut kernels = Vec::new();

    // maps_priority
    let helper_y = p_set
        .rings
        .stars
        .iter()
        .filter(|star| {
            let n = crate::maps::priority::star_normal(&p_set.positions, star);
            n.x.abs() >= 0.9 * n.norm()
        })
        .count();
    let rows = p_rows.len();
    let mut covers = kind_lines(&p_set);
    covers.extend(count_line(
        "frame helper (1, 0, 0) (|n_x| < 0.9)",
        rows - helper_y,
    ));
    covers.extend(count_line("frame helper (0, 1, 0) (|n_x| ≥ 0.9)", helper_y));
    kernels.push(KernelData {
        name: "maps_priority".into(),
        description: format!("{RING_INPUTS} {PRIORITY_FORMULA}"),
        inputs: ring_inputs(&norm.gpu, &p_set),
        expected: (
            "per ring, f64: a (diagonal²), κ (1/diagonal)".into(),
            Array::f64(&[rows, 2], p_rows.iter().flat_map(|(e, _)| *e).collect()),
        ),
        bound: (
            "per ring: the bounds on |Δa| and |Δκ|".into(),
            Array::f64(&[rows, 2], p_rows.iter().flat_map(|(_, b)| *b).collect()),
        ),
        metric: Metric::Absolute {
            unit: "a: diagonal², κ: 1/diagonal".into(),
        },
        bound_formula: "per ring: 2·Σᵢ|∂y/∂eᵢ|aᵢ + |twin − reference| over the WGSL table".into(),
        derivation: RING_DERIVATION.into(),
        per_element: vec!["rings".into()],
        covers,
    });

    // maps_flatten.points and maps_flatten.rings
    let statuses: Vec<u32> = f_rows.iter().map(|(r, _)| r.ring[3] as u32).collect();
    let status_count = |s: u32| statuses.iter().filter(|&&x| x == s).count();
    let wrapping = f_set
        .rings
        .shapes
        .iter()
        .filter(|s| matches!(s, RingShape::FeatureLine { s, .. } if *s > 0))
        .count();
    let mut covers = kind_lines(&f_set);
    covers.extend(count_line("status 0 (flattened)", status_count(STATUS_OK)));
    covers.extend(count_line(
        "status 1 (degenerate: a ring vertex on the centre)",
        status_count(STATUS_DEGENERATE),
    ));
    covers.extend(count_line(
        "status 2 (flipped fan: a feature-line side of a single sector)",
        status_count(STATUS_FLIPPED_FAN),
    ));
    covers.extend(count_line(
        "feature lines whose lower side wraps past j_0 (s > 0)",
        wrapping,
    ));
    let slots = f_set.rings.slot_count();
    let inputs = ring_inputs(&norm.gpu, &f_set);
    kernels.push(KernelData {
        name: "maps_flatten.points".into(),
        description: format!(
            "{RING_INPUTS} {FLATTEN_FORMULA} This kernel: per ring slot (slot first + k of ring \
             r is ring vertex k), (μ_x, μ_y, θ_k, r_k)."
        ),
        inputs: inputs.clone(),
        expected: (
            "per ring slot, f64: μ_x, μ_y (|μ| in diagonal^a), θ_k (radians), r_k (diagonal)"
                .into(),
            Array::f64(
                &[slots, 4],
                f_rows
                    .iter()
                    .flat_map(|(r, _)| r.points.iter().flatten().copied().collect::<Vec<_>>())
                    .collect(),
            ),
        ),
        bound: (
            "per ring slot: the bounds on |Δμ_x|, |Δμ_y|, |Δθ_k|, |Δr_k|".into(),
            Array::f64(
                &[slots, 4],
                f_rows
                    .iter()
                    .flat_map(|(_, b)| b.points.iter().flatten().copied().collect::<Vec<_>>())
                    .collect(),
            ),
        ),
        metric: Metric::Absolute {
            unit: "μ: diagonal^a, θ: radians, r: diagonal".into(),
        },
        bound_formula: "per value: 2·Σᵢ|∂y/∂eᵢ|aᵢ + |twin − reference| over the WGSL table".into(),
        derivation: RING_DERIVATION.into(),
        per_element: vec!["neighbours".into()],
        covers: covers.clone(),
    });
    let rows = f_rows.len();
    kernels.push(KernelData {
        name: "maps_flatten.rings".into(),
        description: format!(
            "{RING_INPUTS} {FLATTEN_FORMULA} This kernel: per ring, (a, a₂, θ_total, status)."
        ),
        inputs,
        expected: (
            "per ring, f64: a, a₂, θ_total (radians), status (0 ok, 1 degenerate, 2 flipped fan)"
                .into(),
            Array::f64(
                &[rows, 4],
                f_rows.iter().flat_map(|(r, _)| r.ring).collect(),
            ),
        ),
        bound: (
            "per ring: the bounds on |Δa|, |Δa₂|, |Δθ_total|; 0.5 on the status".into(),
            Array::f64(
                &[rows, 4],
                f_rows
                    .iter()
                    .flat_map(|(_, b)| [b.ring[0], b.ring[1], b.ring[2], 0.5])
                    .collect(),
            ),
        ),
        metric: Metric::Absolute {
            unit: "a: 1, θ: radians, status: code".into(),
        },
        bound_formula: "a, a₂, θ_total: 2·Σᵢ|∂y/∂eᵢ|aᵢ + |twin − reference| over the WGSL \
            table; status: exact (bound 0.5 on an integer code)"
            .into(),
        derivation: format!(
            "{RING_DERIVATION} The status is a decision: every one in these vectors is taken \
             farther than 16 times its bound from its threshold (or is integer logic: a \
             single-sector side), so every conforming GPU takes it alike."
        ),
        per_element: vec!["rings".into()],
        covers,
    });

    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let terms = priority_terms_gpu(gpu, &rings_batch(&norm.gpu, &p_set.rings))?;
        candidates.push((
            "maps_priority".to_string(),
            Array::f32(
                &[terms.len(), 2],
                terms.iter().flatten().map(|&x| x as f32).collect(),
            ),
        ));
        let (flat, points) = flatten_gpu(gpu, &rings_batch(&norm.gpu, &f_set.rings))?;
        candidates.push((
            "maps_flatten.points".to_string(),
            Array::f32(
                &[points.len(), 4],
                points
                    .iter()
                    .flat_map(|p| [p.mu[0], p.mu[1], p.theta, p.radius])
                    .collect(),
            ),
        ));
        candidates.push((
            "maps_flatten.rings".to_string(),
            Array::f32(
                &[flat.len(), 4],
                flat.iter()
                    .flat_map(|r| [r.a, r.a2, r.theta_total, r.status as f32])
                    .collect(),
            ),
        ));
    }
    Ok((kernels, candidates))
}
