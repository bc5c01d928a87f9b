//! maps cross-check: the three f32 kernels `maps_priority` (a(i), κ(i)), `maps_flatten`
//! (z^a flattening: θ, a, μ) and `maps_inverse` (Π⁻¹ of base points) against the f64 MAPS
//! reference, on the rings of the input level and of the middle level of the hierarchy, and on
//! the points of a uniform:2 remesh.
//!
//! The per-ring and per-slot bounds are derived in [`super::maps_bound`] (the kernels' f32 twins
//! over the WGSL accuracy table: `priority_bounds`, `flatten_bounds`); Π⁻¹ is held to
//! [`INVERSE_POSITION_MAX`] and friends, whose budget is argued below. The tests in
//! `tests/gpu_maps.rs` use the same functions and constants.

use nalgebra::Point3;
use reparam_gpu::Gpu;

use super::bpm_bound::UNBOUNDED;
use super::timing::{time_cpu, time_gpu_warm};
use super::{Bounds, Row, Timing};
use crate::error::Result;
use crate::maps::gpu::{
    crosscheck_flatten, crosscheck_inverse, crosscheck_priority, flatten_cpu, flatten_gpu,
    inverse_gpu, inverse_tables, level_rings, normalise, priority_terms_cpu, priority_terms_gpu,
    rings_batch, InverseCrosscheck, LevelRings,
};
use crate::maps::remesh::uniform;
use crate::maps::{Maps, MapsOptions};

/// Π⁻¹: the largest position error, as a fraction of the bounding-box diagonal.
///
/// Budget: the kernel replays at most L removals; per step it rounds the inputs (μ and b to
/// f32: ≤ u relative each), forms u = Σ b_c μ_c (≤ 3u|μ|) and solves for the barycentrics in
/// the star face (three orient2d of ≈ 3 roundings, relative to the face's area: ≤ 10u·κ_t with
/// κ_t = diameter²/(2·area) ≤ 20 for well-shaped faces), so the point moves by
/// ≤ (4u + 10u·κ_t)·diameter of that star. Mapped to the input surface each step's error is
/// scaled by the map's stretch (≤ 2 on smooth meshes) and the star's diameter is ≤ ½ diagonal:
/// per step ≤ 204u of the diagonal, L ≤ 12 steps ≤ 2500u ≈ 1.5e-4 at worst, and the random-walk
/// sum √L·204u ≈ 4e-5. The target 1e-5 is tighter than the worst case, and the p99 must be ≥ 10×
/// below it ([`INVERSE_POSITION_P99`]), the typical errors being a few u per step.
pub const INVERSE_POSITION_MAX: f64 = 1e-5;
/// Π⁻¹: the 99th percentile of the position error.
pub const INVERSE_POSITION_P99: f64 = 1e-6;
/// Π⁻¹: a point may land in another input face only within the kernel's position error of that
/// face's edge, min b_c ≤ |Δp|/h ≤ 1e-5/1e-3.
pub const INVERSE_MISMATCH_MIN_BARY: f64 = 1e-2;

/// Whether `r` is within its derived bounds (each point's position and barycentrics, the face
/// mismatches) and the notes' targets above (max and p99 of the position).
pub fn inverse_within_bounds(r: &InverseCrosscheck) -> bool {
    r.position.non_finite == 0
        && position_over(r) == 0
        && r.position.max_abs <= INVERSE_POSITION_MAX
        && r.position.p99 <= INVERSE_POSITION_P99
        && bary_over(r) == 0
        && r.mismatch_max_min_bary <= INVERSE_MISMATCH_MIN_BARY
}

/// Π⁻¹'s positions over their per-point bound ([`InverseCrosscheck::position_bounds`], NaN
/// counted over).
pub fn position_over(r: &InverseCrosscheck) -> usize {
    r.position_errors
        .iter()
        .zip(&r.position_bounds)
        .filter(|(e, b)| !(e <= b))
        .count()
}

/// Π⁻¹'s barycentrics in the final input face over their per-point bound
/// ([`InverseCrosscheck::bary_bounds`]: |Δb| ≤ the point's position bound / h, h the face's
/// smallest altitude, NaN counted over).
pub fn bary_over(r: &InverseCrosscheck) -> usize {
    r.bary_errors
        .iter()
        .zip(&r.bary_bounds)
        .filter(|(e, b)| !(e <= b))
        .count()
}

/// The rings compared: every flattenable ring of the input level (level 0) and of the middle
/// level of the hierarchy, as one batch (all levels share the input's vertex positions).
pub fn compared_rings(maps: &Maps, options: &MapsOptions) -> LevelRings {
    let mut rings = level_rings(
        &maps.positions,
        &maps.input_faces,
        &maps.features,
        options.corner_turn,
    );
    let mid = maps.level_count() / 2;
    if mid > 0 {
        let more = level_rings(
            &maps.positions,
            &maps.levels[mid].faces,
            &maps.features,
            options.corner_turn,
        );
        rings.vertices.extend(more.vertices);
        rings.rings.extend(more.rings);
        rings.stars.extend(more.stars);
        rings.shapes.extend(more.shapes);
    }
    rings
}

/// The full maps table for one hierarchy.
pub fn crosscheck_maps(
    gpu: &Gpu,
    input: &str,
    maps: &Maps,
    options: &MapsOptions,
) -> Result<Vec<Row>> {
    let algorithm = "maps";
    let positions = normalise(&maps.positions)?;
    let rings = compared_rings(maps, options);
    let batch = rings_batch(&positions.gpu, &rings);

    // Times of each side alone (the comparison below runs both again).
    let (_, priority_gpu) = time_gpu_warm(gpu, || priority_terms_gpu(gpu, &batch))?;
    let (_, priority_cpu) = time_cpu(|| priority_terms_cpu(&positions.cpu, &rings));
    let (_, flatten_gpu_t) = time_gpu_warm(gpu, || flatten_gpu(gpu, &batch))?;
    let (_, flatten_cpu_ms) = time_cpu(|| flatten_cpu(&positions.cpu, &rings));

    let p = crosscheck_priority(gpu, &positions, &rings)?;
    let f = crosscheck_flatten(gpu, &positions, &rings)?;
    let levels = format!(
        "{} rings of levels 0 and {} of {}",
        p.rings,
        maps.level_count() / 2,
        maps.level_count()
    );
    let mut rows = vec![
        Row::from_summary(
            algorithm,
            "maps_priority: ring area a(i)",
            input,
            &p.area,
            p.area_over_bound,
            p.area_worst_ratio,
            "per ring: priority_bounds (the twin over the WGSL table: 2·Σ|∂a/∂eᵢ|aᵢ) / a",
        )
        .with_note(&levels)
        .with_timing(Timing {
            cpu_ms: Some(priority_cpu),
            ..priority_gpu
        }),
        Row::from_summary(
            algorithm,
            "maps_priority: curvature κ(i)",
            input,
            &p.kappa,
            p.kappa_over_bound,
            p.kappa_worst_ratio,
            "per ring: priority_bounds (the twin over the WGSL table through the fit: 2·Σ|∂κ/∂eᵢ|aᵢ)",
        )
        .with_note(&format!(
            "{} rings with a singular fit not compared",
            p.kappa_singular
        )),
        Row::from_summary(
            algorithm,
            "maps_flatten: cumulative angle θ_k",
            input,
            &f.theta,
            f.theta_over_bound,
            f.theta_worst_ratio,
            "per slot: flatten_bounds (the twin over the WGSL table, + its atan polynomial's own error)",
        )
        .with_note(&format!(
            "{} rings ({} rejected by the reference), {} status mismatches{}",
            f.rings,
            f.rejected,
            f.status_mismatches,
            if f.unbounded > 0 {
                format!(
                    "; {} rings the WGSL table cannot bound not compared",
                    f.unbounded
                )
            } else {
                String::new()
            }
        ))
        .with_timing(Timing {
            cpu_ms: Some(flatten_cpu_ms),
            ..flatten_gpu_t
        }),
        Row::from_summary(
            algorithm,
            "maps_flatten: exponent a",
            input,
            &f.a,
            f.a_over_bound,
            f.a_worst_ratio,
            "per ring: flatten_bounds (the twin over the WGSL table) / a",
        ),
        Row::from_summary(
            algorithm,
            "maps_flatten: μ_k = r^a e^{iaθ}",
            input,
            &f.mu,
            f.mu_over_bound,
            f.mu_worst_ratio,
            "per slot: flatten_bounds (the twin over the WGSL table: 2·Σ‖∂μ/∂eᵢ‖aᵢ)",
        ),
    ];
    if f.status_mismatches > 0 {
        // A ring one side rejects and the other flattens: a decision f32 cannot make alike.
        let last = rows.len() - 1;
        rows[last].note = format!("{} status mismatches", f.status_mismatches);
    }

    // Π⁻¹ of the uniform:2 remesh points.
    let points = uniform(maps, 2)?.params;
    let tables = inverse_tables(maps, &positions);
    let (_, inverse_t) = time_gpu_warm(gpu, || inverse_gpu(gpu, &tables, &points))?;
    let (_, inverse_cpu) = time_cpu(|| {
        points
            .iter()
            .map(|q| maps.param.inverse(q).map(|c| c.position))
            .collect::<Vec<Option<Point3<f64>>>>()
    });
    let r = crosscheck_inverse(gpu, maps, &points)?;
    let unbounded = r
        .position_bounds
        .iter()
        .filter(|&&b| b == UNBOUNDED)
        .count();
    let position_row = Row::compare(
        algorithm,
        "maps_inverse: position Π⁻¹(p)",
        input,
        "fraction of the diagonal",
        &r.position_errors,
        &[],
        Bounds::PerElement(r.position_bounds.clone()),
        "per point: d_in + 2‖b‖ (the f32 tables' effect computed; every operation's WGSL \
         allowance to first order along the walk, from the twin over Lin)",
    );
    // The notes' targets (max 1e-5, p99 1e-6 of the diagonal) are part of the verdict too.
    let notes_over = usize::from(
        !(r.position.max_abs <= INVERSE_POSITION_MAX && r.position.p99 <= INVERSE_POSITION_P99),
    );
    let position_row = Row {
        over: position_row.over + notes_over,
        verdict: if position_row.over + notes_over > 0 {
            super::Verdict::Fail
        } else {
            position_row.verdict
        },
        ..position_row
    }
    .with_note(&format!(
        "{} points of uniform:2 ({unbounded} without a bound from the table); {} reached another \
         input face (largest min b {:.1e} ≤ {}); notes' targets max ≤ 1e-5, p99 ≤ 1e-6: max {:.1e}, p99 {:.1e}",
        r.points, r.face_mismatches, r.mismatch_max_min_bary, INVERSE_MISMATCH_MIN_BARY,
        r.position.max_abs, r.position.p99
    ))
    .with_timing(Timing {
        cpu_ms: Some(inverse_cpu),
        ..inverse_t
    });
    let mismatch_over = usize::from(!(r.mismatch_max_min_bary <= INVERSE_MISMATCH_MIN_BARY));
    let bary_row = Row::compare(
        algorithm,
        "maps_inverse: barycentrics in the input face",
        input,
        "barycentric",
        &r.bary_errors,
        &[],
        Bounds::PerElement(r.bary_bounds.clone()),
        "per point: 1e-5 / h, h the face's smallest altitude (|Δb| ≤ |Δp|/h, Δp the position bound)",
    );
    let bary_row = Row {
        over: bary_row.over + mismatch_over,
        verdict: if bary_row.over + mismatch_over > 0 {
            super::Verdict::Fail
        } else {
            bary_row.verdict
        },
        ..bary_row
    }
    .with_note(&format!("{} thin faces not compared", r.thin));
    rows.push(position_row);
    rows.push(bary_row);
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::crosscheck::ErrorSummary;

    fn with_bary(errors: Vec<f64>, altitudes: &[f64]) -> InverseCrosscheck {
        let summary = ErrorSummary::from_errors("barycentric", &errors, &[], 0.0);
        InverseCrosscheck {
            points: errors.len(),
            position: ErrorSummary::from_errors("fraction of the diagonal", &[], &[], 0.0),
            bary: summary,
            bary_bounds: altitudes.iter().map(|h| INVERSE_POSITION_MAX / h).collect(),
            position_errors: Vec::new(),
            position_bounds: Vec::new(),
            bary_errors: errors,
            face_mismatches: 0,
            mismatch_max_min_bary: 0.0,
            thin: 0,
        }
    }

    /// The real-scan case of issue #34: 3.9e-5 in a face of altitude 0.05 is within
    /// 1e-5/0.05 = 2e-4, which the former constant 1e-5 rejected; the same error in a
    /// well-shaped face (altitude 0.5: bound 2e-5) fails, and so does a NaN.
    #[test]
    fn the_barycentric_bound_follows_the_faces_altitude() {
        assert_eq!(bary_over(&with_bary(vec![3.9e-5], &[0.05])), 0);
        assert_eq!(bary_over(&with_bary(vec![3.9e-5], &[0.5])), 1);
        assert_eq!(bary_over(&with_bary(vec![f64::NAN], &[0.5])), 1);
    }
}
