//! skinsimp vectors: `skinsimp_lbs` (posed positions of V vertices in P poses, linear blend
//! skinning) and `skinsimp_quadrics` (per-pose source quadrics w q qᵀ and their per-vertex sums),
//! from the inputs the kernels receive, with the bounds of [`crate::crosscheck::skinsimp`].

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::skinsimp::{lbs_bound, lbs_bound_of, quadric_checks, CostBound};
use crate::error::Result;
use crate::skinsimp::cost::solve_position;
use crate::skinsimp::gpu::{
    crosscheck, edge_cost_position, edge_cost_quadric, endpoint_candidates, lbs_input, normalise,
    plane_quadrics_f64, position_given_weights_f64, quadric_input, round_input, skin_f64,
    vertex_quadrics_f64, CostData, CrossCheckData, EdgeCandidate, ReferenceCost, SkinsimpKernels,
};
use crate::skinsimp::{Input, Options};
use reparam_gpu::skinsimp::EdgeItem;

fn points(p: &[nalgebra::Point3<f64>]) -> Vec<f64> {
    p.iter().flat_map(|q| [q.x, q.y, q.z]).collect()
}

fn points_f32(p: &[nalgebra::Point3<f64>]) -> Vec<f32> {
    p.iter()
        .flat_map(|q| [q.x as f32, q.y as f32, q.z as f32])
        .collect()
}

fn quadrics(q: &[crate::skinsimp::quadric::Quadric]) -> Vec<f64> {
    q.iter().flat_map(|x| x.0).collect()
}

const QUADRIC_ORDER: &str = "the 10 entries of the symmetric 4×4 quadric's upper triangle, row \
    by row: (0,0), (0,1), (0,2), (0,3), (1,1), (1,2), (1,3), (2,2), (2,3), (3,3)";

/// The reference side of [`crosscheck`] without a GPU: the GPU fields hold the reference's own
/// values (only the bounds, which depend on the reference alone, are read from them).
fn reference_data(input: &Input, options: &Options) -> Result<CrossCheckData> {
    input.validate()?;
    let rounded = round_input(&normalise(input).0);
    let poses = rounded.pose_count();
    let posed_ref = skin_f64(&rounded)?;
    let posed_rounded: Vec<_> = posed_ref
        .iter()
        .map(|p| p.map(|x| x as f32 as f64))
        .collect();
    let sources = quadric_input(&rounded.mesh, poses, options.boundary_weight)?;
    let weight = sources.boundary_weight as f64;
    let plane_ref = plane_quadrics_f64(&posed_rounded, &sources, weight);
    let vertex_ref = vertex_quadrics_f64(&plane_ref, &sources);
    let cost_data = CostData::new(&rounded, vertex_ref.clone())?.rounded_quadrics();
    Ok(CrossCheckData {
        input: rounded,
        posed_gpu: posed_ref.clone(),
        posed_ref,
        posed_rounded,
        sources,
        plane_gpu: plane_ref.clone(),
        plane_ref,
        vertex_gpu: vertex_ref.clone(),
        vertex_ref,
        cost_data,
        candidates: Vec::new(),
        costs_ref: Vec::new(),
        costs_gpu: Vec::new(),
    })
}

/// The vectors of `input` (normalised to the unit box and rounded to f32, as the cross-check
/// does), and reparam's own GPU outputs as candidates when `kernels` is given.
pub fn vectors(input: &Input, kernels: Option<&SkinsimpKernels>) -> Result<VectorsAndCandidates> {
    let options = Options::default();
    let data = match kernels {
        Some(k) => {
            crosscheck(
                k,
                input,
                options.boundary_weight,
                options.cost.max_condition,
            )?
            .1
        }
        None => reference_data(input, &options)?,
    };
    let lbs = lbs_input(&data.input)?;
    let (v, p) = (lbs.rest.len(), lbs.pose_count());
    let j = lbs.joint_count as usize;
    let rest = Array::f32(&[v, 3], lbs.rest.iter().flatten().copied().collect());
    let joints = Array::u32(
        &[v, 4],
        lbs.influences.iter().flat_map(|i| i.joints).collect(),
    );
    let weights = Array::f32(
        &[v, 4],
        lbs.influences.iter().flat_map(|i| i.weights).collect(),
    );
    let matrices = Array::f32(&[p, j, 12], lbs.joints.iter().flatten().copied().collect());
    let lbs_kernel = KernelData {
        name: "skinsimp_lbs".into(),
        description: "linear blend skinning p_ij = Σ_k w_ik M_{j,k} (x_i, 1) (seed 003 §3)".into(),
        inputs: vec![
            (
                "rest".into(),
                "per vertex (0-based), f32: x, y, z in the unit box".into(),
                rest,
            ),
            (
                "joints".into(),
                "per vertex, u32: 4 joint indices (0-based; unused slots weight 0)".into(),
                joints,
            ),
            (
                "weights".into(),
                "per vertex, f32: the 4 weights, summing to 1".into(),
                weights,
            ),
            (
                "matrices".into(),
                "per pose, per joint, f32: the 3×4 top of the joint matrix, row by row".into(),
                matrices,
            ),
        ],
        expected: (
            "per vertex, per pose, f64: the posed x, y, z".into(),
            Array::f64(&[v, p, 3], points(&data.posed_ref)),
        ),
        bound: (
            "per vertex, pose and coordinate, unit box".into(),
            Array::f64(&[v, p, 3], lbs_bound(&data)?),
        ),
        metric: Metric::Absolute {
            unit: "unit box".into(),
        },
        bound_formula: "(4 + K) u Σ_k w_k Σ_c |M_k,rc h_c| per coordinate (K influences)".into(),
        derivation: "(M_k h)_r is a 4-term dot product, ≤ 4u Σ_c |M_rc h_c|; scaling by w_k and \
            summing K terms adds ≤ K u Σ_k w_k |(M_k h)_r| (crosscheck::skinsimp::lbs_bound)"
            .into(),
        per_element: vec!["rest".into(), "joints".into(), "weights".into()],
        covers: Vec::new(),
    };
    let s = &data.sources;
    let n = s.sources.len();
    let (plane_checks, vertex_checks) = quadric_checks(&data);
    let posed = Array::f32(&[v, p, 3], points_f32(&data.posed_rounded));
    let corners = Array::u32(&[n, 3], s.sources.iter().flat_map(|x| x.corners).collect());
    let kinds = Array::u32(&[n], s.sources.iter().map(|x| x.kind).collect());
    let weight = Array::f32(&[1], vec![s.boundary_weight]);
    let source_inputs =
        vec![
        ("posed".into(), "per vertex, per pose, f32: x, y, z".into(), posed),
        ("corners".into(), "per source, u32: the face's 3 vertices (0-based)".into(), corners),
        (
            "kind".into(),
            "per source, u32: 3 = the face's plane (weight: area); e = 0, 1, 2 = the constraint \
             plane through edge (corner e, corner e+1 mod 3) perpendicular to the face (weight: \
             boundary_weight · |edge|²)"
                .into(),
            kinds,
        ),
        ("boundary_weight".into(), "f32, one value".into(), weight),
    ];
    let plane_kernel = KernelData {
        name: "skinsimp_quadrics.source".into(),
        description: "per source and pose, w q qᵀ for the plane q = (n, −n·p₀) (Garland–Heckbert; \
            seed 003 §4 per pose)"
            .into(),
        inputs: source_inputs.clone(),
        expected: (
            format!("per source, per pose, f64: {QUADRIC_ORDER}"),
            Array::f64(&[n, p, 10], quadrics(&data.plane_ref)),
        ),
        bound: (
            "per entry, unit box²".into(),
            Array::f64(&[n, p, 10], plane_checks.iter().map(|c| c.bound).collect()),
        ),
        metric: Metric::Absolute {
            unit: "unit box²".into(),
        },
        bound_formula: "w(Δq_r|q_c| + |q_r|Δq_c + Δq_rΔq_c + |q_r q_c|(δ_w + 2u)), δ = 4√3κu + 3u"
            .into(),
        derivation: "crosscheck::skinsimp::source_bound: the cross product, normalisation and d = \
            −n·p₀ in f32 from f32 corners, κ = |e1||e2|/|e1 × e2|"
            .into(),
        per_element: vec!["corners".into(), "kind".into()],
        covers: Vec::new(),
    };
    let offsets = Array::u32(&[s.vertex_offsets.len()], s.vertex_offsets.clone());
    let members = Array::u32(&[s.vertex_sources.len()], s.vertex_sources.clone());
    let mut vertex_inputs = source_inputs;
    vertex_inputs.push((
        "vertex_offsets".into(),
        "u32, V + 1 CSR offsets: vertex i sums the sources vertex_sources[offsets[i]..offsets[i+1]]"
            .into(),
        offsets,
    ));
    vertex_inputs.push((
        "vertex_sources".into(),
        "u32: source ids (0-based), in summation order per vertex".into(),
        members,
    ));
    let vertex_kernel = KernelData {
        name: "skinsimp_quadrics.vertex".into(),
        description: "per vertex and pose, the sum of its sources' quadrics in the given order"
            .into(),
        inputs: vertex_inputs,
        expected: (
            format!("per vertex, per pose, f64: {QUADRIC_ORDER}"),
            Array::f64(&[v, p, 10], quadrics(&data.vertex_ref)),
        ),
        bound: (
            "per entry, unit box²".into(),
            Array::f64(&[v, p, 10], vertex_checks.iter().map(|c| c.bound).collect()),
        ),
        metric: Metric::Absolute {
            unit: "unit box²".into(),
        },
        bound_formula: "Σ_s source_bound + (n − 1) u Σ_s |K_s| (n sources)".into(),
        derivation: "recursive summation from zero of n source quadrics, each with its own bound"
            .into(),
        per_element: Vec::new(),
        covers: Vec::new(),
    };
    let candidates = if kernels.is_none() {
        Vec::new()
    } else {
        vec![
            (
                "skinsimp_lbs".to_string(),
                Array::f32(&[v, p, 3], points_f32(&data.posed_gpu)),
            ),
            (
                "skinsimp_quadrics.source".to_string(),
                Array::f32(
                    &[n, p, 10],
                    quadrics(&data.plane_gpu)
                        .iter()
                        .map(|&x| x as f32)
                        .collect(),
                ),
            ),
            (
                "skinsimp_quadrics.vertex".to_string(),
                Array::f32(
                    &[v, p, 10],
                    quadrics(&data.vertex_gpu)
                        .iter()
                        .map(|&x| x as f32)
                        .collect(),
                ),
            ),
        ]
    };
    let (collapse_kernel, collapse_candidate) = collapse_cost_vectors(&data, kernels)?;
    let mut candidates = candidates;
    candidates.extend(collapse_candidate.map(|c| ("skinsimp_collapse_cost".to_string(), c)));
    Ok((
        vec![lbs_kernel, plane_kernel, vertex_kernel, collapse_kernel],
        candidates,
    ))
}

/// Per vertex the largest displacement ‖Δp‖ ≤ √3 max_r (bound of coordinate r) that f32
/// skinning allows ([`lbs_bound_of`]), pose by pose: `[pose][vertex]`.
fn displacement_bounds(input: &Input) -> Result<Vec<Vec<f64>>> {
    let b = lbs_bound_of(input)?;
    let (v, p) = (input.mesh.positions.len(), input.pose_count());
    Ok((0..p)
        .map(|j| {
            (0..v)
                .map(|i| {
                    let x = 3 * (i * p + j);
                    3f64.sqrt() * b[x].max(b[x + 1]).max(b[x + 2])
                })
                .collect()
        })
        .collect())
}

/// The largest relative change of a face's area when every corner moves by at most `e[v]`:
/// the edge vectors move by ≤ e_a + e_b, so |Δ(e₁ × e₂)| ≤ Δ₁|e₂| + |e₁|Δ₂ + Δ₁Δ₂.
fn area_change(p: &[nalgebra::Point3<f64>], faces: &[[u32; 3]], e: &[f64]) -> f64 {
    faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| v as usize);
            let (e1, e2) = (p[b] - p[a], p[c] - p[a]);
            let (d1, d2) = (e[a] + e[b], e[a] + e[c]);
            let cross = e1.cross(&e2).norm();
            let change = d1 * e2.norm() + e1.norm() * d2 + d1 * d2;
            if cross > 0.0 {
                change / cross
            } else {
                f64::INFINITY
            }
        })
        .fold(0.0, f64::max)
}

/// A level of the hierarchy as a skinned input in the given poses' joint matrices.
fn level_input(level: &crate::skinsimp::Level, joints: &[Vec<nalgebra::Matrix4<f64>>]) -> Input {
    Input {
        mesh: level.mesh.clone(),
        deformation: crate::skinsimp::Deformation::Skinned {
            influences: level.weights.iter().map(|w| w.pairs().collect()).collect(),
            joints: joints.to_vec(),
        },
    }
}

/// The original and the level posed in each pose of `held_out` (`[pose][vertex]`), skinned by
/// `skin` (the f64 reference, or reparam's own kernel).
type Posed = Vec<Vec<nalgebra::Point3<f64>>>;

fn per_pose(flat: &[nalgebra::Point3<f64>], poses: usize) -> Posed {
    (0..poses)
        .map(|j| flat.iter().skip(j).step_by(poses.max(1)).copied().collect())
        .collect()
}

/// The whole-algorithm vectors of skinsimp: the model (rest mesh, weights), the training and
/// held-out poses' joint matrices, and per held-out pose the RMS and (sampled) Hausdorff
/// distance ([`crate::skinsimp::distance::surface_error`], notes "Tests" 8) between the model
/// and its simplification to half its vertices (default options), both linear-blend skinned.
/// With a GPU, the candidate is the same level with both meshes skinned by reparam's own
/// `skinsimp_lbs` kernel.
pub fn run_vectors(
    model: &crate::mesh::SkinnedMesh,
    sets: &crate::skinsimp::poses::PoseSets,
    kernels: Option<&SkinsimpKernels>,
) -> Result<VectorsAndCandidates> {
    use crate::skinsimp::distance::surface_error;
    use crate::skinsimp::poses::skinned_input;
    let training = skinned_input(model, &sets.training)?;
    let held = skinned_input(model, &sets.held_out)?;
    let options = Options::default();
    let hierarchy = crate::skinsimp::simplify(&training, &options)?;
    let target = model.mesh.positions.len() / 2;
    let level = hierarchy.level(hierarchy.collapses_for(target));
    let crate::skinsimp::Deformation::Skinned { joints, .. } = &held.deformation else {
        return Ok((Vec::new(), Vec::new()));
    };
    let simplified = level_input(&level, joints);
    let poses = held.pose_count();
    let figures = |a: &Posed, b: &Posed| -> Vec<f64> {
        (0..poses)
            .flat_map(|j| {
                let e = surface_error(&a[j], &held.mesh.faces, &b[j], &simplified.mesh.faces);
                [e.rms, e.hausdorff]
            })
            .collect()
    };
    let (orig, simp) = (
        per_pose(&skin_f64(&held)?, poses),
        per_pose(&skin_f64(&simplified)?, poses),
    );
    let expected = figures(&orig, &simp);
    let (eo, es) = (
        displacement_bounds(&held)?,
        displacement_bounds(&simplified)?,
    );
    let mut bounds = Vec::with_capacity(2 * poses);
    for j in 0..poses {
        let e = eo[j].iter().fold(0.0, |m: f64, x| m.max(*x))
            + es[j].iter().fold(0.0, |m: f64, x| m.max(*x));
        let omega = area_change(&orig[j], &held.mesh.faces, &eo[j]).max(area_change(
            &simp[j],
            &simplified.mesh.faces,
            &es[j],
        ));
        let (rms, h) = (expected[2 * j], expected[2 * j + 1]);
        let rms_bound = e + rms * omega / (1.0 - omega).max(f64::MIN_POSITIVE);
        let rel = |b: f64, v: f64| if v > 0.0 { b / v } else { b };
        bounds.extend([rel(rms_bound, rms), rel(e, h)]);
    }
    let matrices = |j: &[Vec<nalgebra::Matrix4<f64>>]| -> Array {
        let jc = j.first().map_or(0, |m| m.len());
        Array::f64(
            &[j.len(), jc, 4, 4],
            j.iter()
                .flatten()
                .flat_map(|m| (0..4).flat_map(move |r| (0..4).map(move |c| m[(r, c)])))
                .collect(),
        )
    };
    let crate::skinsimp::Deformation::Skinned {
        influences,
        joints: train_joints,
    } = &training.deformation
    else {
        return Ok((Vec::new(), Vec::new()));
    };
    let v = model.mesh.positions.len();
    let mut inf_joints = Vec::with_capacity(4 * v);
    let mut inf_weights = Vec::with_capacity(4 * v);
    for list in influences {
        for k in 0..4 {
            let (j, w) = list.get(k).copied().unwrap_or((0, 0.0));
            inf_joints.push(j);
            inf_weights.push(w);
        }
    }
    let kernel = KernelData {
        name: "skinsimp_run".into(),
        description: format!(
            "a whole simplification: the model simplified on its training poses to {target} \
             vertices (default options: {} cost, boundary weight {}), then per held-out pose \
             the RMS and sampled Hausdorff distance between the model and the level, both \
             linear-blend skinned (notes \"Tests\" 8: 10 samples per face both ways)",
            options.method.name(),
            options.boundary_weight
        ),
        inputs: vec![
            ("positions".into(), "per vertex (0-based), f64: the rest x, y, z".into(), Array::f64(&[v, 3], points(&model.mesh.positions))),
            (
                "faces".into(),
                "per face, u32: three vertices (0-based, counter-clockwise)".into(),
                Array::u32(&[model.mesh.faces.len(), 3], model.mesh.faces.iter().flatten().copied().collect()),
            ),
            ("influence_joints".into(), "per vertex, u32: up to 4 joints (0-based; unused slots 0 with weight 0)".into(), Array::u32(&[v, 4], inf_joints)),
            ("influence_weights".into(), "per vertex, f64: the weights of those joints (sum 1)".into(), Array::f64(&[v, 4], inf_weights)),
            ("training_joints".into(), "per training pose and joint, f64: the 4×4 skinning matrix (joint world × inverse bind), row-major".into(), matrices(train_joints)),
            ("held_out_joints".into(), "per held-out pose and joint, f64: the same".into(), matrices(joints)),
            ("target".into(), "u32: the level's vertex count".into(), Array::u32(&[1], vec![target as u32])),
        ],
        expected: (
            "per held-out pose, f64: RMS, Hausdorff (model units)".into(),
            Array::f64(&[poses, 2], expected),
        ),
        bound: ("per figure, relative".into(), Array::f64(&[poses, 2], bounds)),
        metric: Metric::Relative { unit: "relative".into() },
        bound_formula: "Hausdorff: (e_A + e_B)/H; RMS: (e_A + e_B + RMS·ω/(1 − ω))/RMS, e the \
            largest skinning displacement √3·lbs_bound of each mesh in the pose, ω the largest \
            relative change of a face's area"
            .into(),
        derivation: "the same level skinned in f32: every vertex moves by ≤ e (lbs_bound), every \
            sample (a convex combination) by ≤ e_A, the other surface by ≤ e_B, so every \
            distance and the max by ≤ e_A + e_B; the area weights change by ≤ ω relatively, \
            which moves a weighted RMS by ≤ RMS·ω/(1 − ω). A candidate that simplifies on its \
            own must make the same collapses (same costs, ties to the lower edge)"
            .into(),
        per_element: vec![],
        covers: Vec::new(),
    };
    let mut candidates = Vec::new();
    if let Some(k) = kernels {
        let (go, gs) = (
            per_pose(&k.skin(&held)?, poses),
            per_pose(&k.skin(&simplified)?, poses),
        );
        candidates.push((
            "skinsimp_run".to_string(),
            Array::f64(&[poses, 2], figures(&go, &gs)),
        ));
    }
    Ok((vec![kernel], candidates))
}

/// Every skinsimp vector: the kernels on the training poses ([`vectors`]) and the whole run
/// ([`run_vectors`]; only with held-out poses).
pub fn all_vectors(
    model: &crate::mesh::SkinnedMesh,
    sets: &crate::skinsimp::poses::PoseSets,
    kernels: Option<&SkinsimpKernels>,
) -> Result<VectorsAndCandidates> {
    let input = crate::skinsimp::poses::skinned_input(model, &sets.training)?;
    let (mut k, mut c) = vectors(&input, kernels)?;
    if !sets.held_out.is_empty() {
        let (run, run_candidates) = run_vectors(model, sets, kernels)?;
        k.extend(run);
        c.extend(run_candidates);
    }
    Ok((k, c))
}

/// The `max_condition` of the `skinsimp_collapse_cost` vectors. The simplifier's default
/// (1e10) keeps the solve wherever f32 can tell; the vectors use a small one so that the
/// fallbacks a, b and the midpoint are exercised as well (an input of the kernel like any
/// other: the solve is kept when cond_F(B) ≤ max_condition).
pub const COLLAPSE_VECTORS_MAX_CONDITION: f64 = 64.0;

/// The candidates of the `skinsimp_collapse_cost` vectors, their reference results and bounds:
/// every (edge, endpoint) of the mesh whose kept point every conforming f32 evaluation keeps
/// too ([`CostBound::decided`]: the solve's condition and the compared values are apart by
/// more than their bounds); the others are near ties whose output is not a function of the
/// inputs in f32.
fn collapse_candidates(
    cd: &CostData,
    mesh: &crate::mesh::TriMesh,
    max_condition: f64,
) -> Result<Vec<(EdgeCandidate, EdgeItem, ReferenceCost, CostBound)>> {
    let candidates = endpoint_candidates(mesh);
    let items = cd.edge_items(&candidates)?;
    Ok(candidates
        .into_iter()
        .zip(items)
        .filter_map(|(c, item)| {
            let r = position_given_weights_f64(cd, &c, max_condition);
            let bound = CostBound::new(cd, &item, &r);
            let (a, b) = (cd.rest[c.a as usize], cd.rest[c.b as usize]);
            let fallbacks = [a, b, nalgebra::Point3::from((a.coords + b.coords) * 0.5)];
            let solution = solve_position(&r.quadric, max_condition);
            bound
                .decided(&r, &fallbacks, solution, max_condition)
                .then_some((c, item, r, bound))
        })
        .collect())
}

/// The 14 values of one result: Q̃'s upper triangle row by row, v̂, E(v̂, α).
fn collapse_row(
    quadric: &nalgebra::Matrix4<f64>,
    position: &nalgebra::Point3<f64>,
    cost: f64,
) -> [f64; 14] {
    let mut row = [0.0; 14];
    let mut k = 0;
    for r in 0..4 {
        for c in r..4 {
            row[k] = quadric[(r, c)];
            k += 1;
        }
    }
    row[10..13].copy_from_slice(&[position.x, position.y, position.z]);
    row[13] = cost;
    row
}

/// The `skinsimp_collapse_cost` vectors of `data` (the cross-check's cost inputs: rest
/// positions, vertex quadrics rounded to f32, joint matrices), and reparam's own GPU output on
/// them when `kernels` is given.
fn collapse_cost_vectors(
    data: &CrossCheckData,
    kernels: Option<&SkinsimpKernels>,
) -> Result<(KernelData, Option<Array>)> {
    let cd = &data.cost_data;
    let max_condition = COLLAPSE_VECTORS_MAX_CONDITION;
    let chosen = collapse_candidates(cd, &data.input.mesh, max_condition)?;
    let input = cd.cost_input(max_condition)?;
    let (v, p, j) = (
        input.rest.len(),
        input.pose_count as usize,
        input.joint_count as usize,
    );
    let n = chosen.len();
    let mut counts = [0usize; 4];
    for (_, _, r, _) in &chosen {
        counts[r.choice as usize] += 1;
    }
    let expected: Vec<f64> = chosen
        .iter()
        .flat_map(|(_, _, r, _)| collapse_row(&r.quadric, &r.position, r.cost))
        .collect();
    let bound: Vec<f64> = chosen
        .iter()
        .flat_map(|(_, _, r, b)| {
            let mut row = [0.0; 14];
            row[..10].copy_from_slice(&b.quadric());
            row[10..13].fill(b.position(r.choice));
            row[13] = b.cost(r);
            row
        })
        .collect();
    let inputs =
        vec![
        (
            "rest".into(),
            "per vertex (0-based), f32: x, y, z of the rest position (unit box)".into(),
            Array::f32(&[v, 3], input.rest.iter().flatten().copied().collect()),
        ),
        (
            "vertex_quadrics".into(),
            format!("per vertex i, per pose j, f32: Q_i^j, {QUADRIC_ORDER}"),
            Array::f32(
                &[v, p, 10],
                input.vertex_quadrics.iter().flatten().copied().collect(),
            ),
        ),
        (
            "matrices".into(),
            "per pose j, per joint, f32: the 3×4 top of the joint matrix M, row by row (the \
             last row is (0, 0, 0, 1))"
                .into(),
            Array::f32(&[p, j, 12], input.joints.iter().flatten().copied().collect()),
        ),
        (
            "edges".into(),
            "per candidate, u32: the edge's vertices a, b (0-based)".into(),
            Array::u32(&[n, 2], chosen.iter().flat_map(|(c, ..)| [c.a, c.b]).collect()),
        ),
        (
            "bones".into(),
            "per candidate, u32: the K ≤ 8 candidate bones (joint indices) in slots 0..K, then 0"
                .into(),
            Array::u32(&[n, 8], chosen.iter().flat_map(|(_, i, ..)| i.joints).collect()),
        ),
        (
            "alpha".into(),
            "per candidate, f32: the weights α_k of the bones' slots (0 past K and for bones \
             that do not influence the endpoint; they sum to 1)"
                .into(),
            Array::f32(&[n, 8], chosen.iter().flat_map(|(_, i, ..)| i.alpha).collect()),
        ),
        (
            "max_condition".into(),
            "f32, one value: the solve is kept when cond_F(B) = ‖B‖_F ‖B⁻¹‖_F ≤ max_condition"
                .into(),
            Array::f32(&[1], vec![max_condition as f32]),
        ),
    ];
    let kernel = KernelData {
        name: "skinsimp_collapse_cost".into(),
        description: "per candidate (edge (a, b), weights α over bones k): A^j = Σ_k α_k M_k^j, \
            Q^j = Q_a^j + Q_b^j, Q̃ = Σ_j A^{jT} Q^j A^j (poses in order); with B = Q̃[0:3,0:3], \
            b = Q̃[0:3,3]: v = −B⁻¹ b if det B ≠ 0 and cond_F(B) ≤ max_condition; v̂ = the point \
            of least v̂ᵀQ̃v̂ among (v if solved, a, b, (a + b)·0.5), in that order, a later point \
            kept only when strictly less; E(v̂, α) = Σ_j (A^j v̂)ᵀ Q^j (A^j v̂) with v̂ = (v, 1) \
            homogeneous (seed 003 §5, the position step given the weights)"
            .into(),
        inputs,
        expected: (
            "per candidate, f64: Q̃'s 10 entries (upper triangle row by row: (0,0), (0,1), \
             (0,2), (0,3), (1,1), (1,2), (1,3), (2,2), (2,3), (3,3)), then the kept point v̂'s \
             x, y, z, then E(v̂, α)"
                .into(),
            Array::f64(&[n, 14], expected),
        ),
        bound: (
            "per value, unit box² for Q̃ and E, unit box for v̂".into(),
            Array::f64(&[n, 14], bound),
        ),
        metric: Metric::Absolute {
            unit: "unit box (v̂), unit box² (Q̃, E)".into(),
        },
        bound_formula: "Q̃: (30 + P) u T_Q per entry; v̂: ‖B⁻¹‖ η_Q(‖T_B‖|v| + |T_b|)/(1 − κε) + \
            u(12‖B‖²|b| + 10‖B‖³|v|)/|det B| for the solution, u|a + b|/2 for the midpoint, \
            2⁻¹²⁶ (a flushed subnormal) for a or b; E: (5u ΣPᵀTP + 30u ΣPᵀG)(1 + γ_{P−1}) + \
            γ_{P−1} E + Δvᵀ B Δv + 2|g|Δv, P = Ā|v̂|, G = |QAv̂|"
            .into(),
        derivation: "crosscheck::skinsimp::CostBound (T^j = |Q_a^j| + |Q_b^j|, Ā^j = Σ α_k \
            |M_k^j|, T_Q = Σ_j Ā^{jT} T^j Ā^j, u = 2⁻²³: WGSL rounds up or down); candidates whose kept point f32 could \
            change (cond_F near max_condition, values nearer than their bounds) are left out"
            .into(),
        per_element: vec!["edges".into(), "bones".into(), "alpha".into()],
        covers: vec![
            format!("the solve kept (cond_F(B) ≤ max_condition): {} candidates", counts[0]),
            format!("fallback a: {} candidates", counts[1]),
            format!("fallback b: {} candidates", counts[2]),
            format!("fallback midpoint (a + b)·0.5: {} candidates", counts[3]),
            format!("{p} poses (the pose sums), up to 8 bones per candidate, zero weights"),
        ],
    };
    let candidate = match kernels {
        Some(k) => {
            let candidates: Vec<EdgeCandidate> = chosen.iter().map(|(c, ..)| *c).collect();
            let out = k.costs(cd, &candidates, max_condition)?;
            Some(Array::f32(
                &[n, 14],
                out.iter()
                    .flat_map(|g| {
                        collapse_row(&edge_cost_quadric(g), &edge_cost_position(g), g.cost as f64)
                    })
                    .map(|x| x as f32)
                    .collect(),
            ))
        }
        None => None,
    };
    Ok((kernel, candidate))
}
