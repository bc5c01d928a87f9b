//! Beyond the paper (issue #53): the removal rule of the coarse levels that keeps the shape's
//! parts.
//!
//! The paper orders each level's removals by w(λ, i), the 1-ring's area and curvature at the
//! current level ([`super::priority`]). Once the mesh is coarse that order no longer sees what a
//! removal does to the shape: a coarsely sampled dome or a thin limb loses its last vertices
//! while a removal elsewhere would cost the shape less (a skull scan's cranium at 96 base faces,
//! a body's legs). On the coarse levels this rule orders the removals instead by the error the
//! retriangulated star leaves for the input points it re-stores, and removes only the cheaper
//! part of each level:
//!
//! - **the shape error** of removing vertex i ([`removal_error`]): the points stored in i's star
//!   and i itself are re-stored in the new triangles with barycentrics b (the bookkeeping of
//!   [`super::hierarchy`]); each then has the image q = Σ_c b_c P(corner_c) on the coarser mesh,
//!   and the error is max |p − q| over them: the one-sided parametric Hausdorff distance from
//!   the input points to the level's mesh within the star, the distance Π would move them by if
//!   the level were the base domain. It is at least their distance to the new triangles, and
//!   also counts a point slid along the surface.
//! - **the order**: the level's maximal independent set is taken in increasing shape error (the
//!   vertex index breaks ties), so the removals that keep the shape go first;
//! - **the deferral**: a selected vertex whose shape error is above the `quantile` of the
//!   level's candidates' errors is left for a later level ([`super::Level::deferred`]), where
//!   its error is measured again on the coarser mesh. The lowest-error vertex is always
//!   removed, so every level that has a removable candidate removes one. The coarse end then
//!   takes more levels, each removing the vertices the shape misses least, like a greedy
//!   error-driven simplification.
//!
//! The rule applies to the levels that start with at most `coarse_factor` × `base_size` faces
//! (and only when a base size is asked for); the finer levels keep the paper's priority.

/// Beyond the paper (issue #53): the shape-keeping removal rule of the coarse levels (module
/// docs). `None` in [`super::MapsOptions::shape_rule`] is the paper's priority at every level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeRule {
    /// The rule orders the levels that start with at most `coarse_factor` × `base_size` faces.
    /// Default 16.
    pub coarse_factor: f64,
    /// A selected vertex whose shape error is above this quantile of the level's candidates'
    /// errors waits for a later level. 1: none waits (the order alone). Default 0.5.
    pub quantile: f64,
}

impl Default for ShapeRule {
    fn default() -> Self {
        ShapeRule {
            coarse_factor: 16.0,
            quantile: 0.5,
        }
    }
}

impl ShapeRule {
    /// Whether a level that starts with `faces` faces, towards `base_size`, is a coarse level
    /// ordered by this rule (never when `base_size` is 0: the paper's rule to the coarsest
    /// base).
    pub fn applies(&self, faces: usize, base_size: usize) -> bool {
        base_size > 0 && (faces as f64) <= self.coarse_factor * base_size as f64
    }
}

/// The shape error of a removal (module docs): max over the re-stored points (p, n, b) of
/// |P(p) − Σ_c b_c P(ring\[tris\[n\]\[c\]\])|, `tris` the hole's triangles as ring positions, `moved`
/// (point, triangle index, barycentrics) as [`super::hierarchy`]'s relocation returns them
/// (the removed vertex among them). 0 when nothing is re-stored.
pub fn removal_error(
    positions: &[nalgebra::Point3<f64>],
    ring: &[u32],
    tris: &[[usize; 3]],
    moved: &[(u32, usize, [f64; 3])],
) -> f64 {
    moved
        .iter()
        .map(|&(p, n, b)| {
            let corners = tris[n].map(|m| positions[ring[m] as usize].coords);
            let image = corners[0] * b[0] + corners[1] * b[1] + corners[2] * b[2];
            (positions[p as usize].coords - image).norm()
        })
        .fold(0.0, f64::max)
}

/// The deferral threshold of a level: the `q`-quantile of the finite shape errors of its
/// candidates (∞ when none is finite or `q` ≥ 1, so that nothing waits).
pub fn deferral_threshold(errors: &[f64], q: f64) -> f64 {
    if q >= 1.0 {
        return f64::INFINITY;
    }
    let mut finite: Vec<f64> = errors.iter().copied().filter(|e| e.is_finite()).collect();
    if finite.is_empty() {
        return f64::INFINITY;
    }
    finite.sort_by(f64::total_cmp);
    super::distortion::quantile(&finite, q.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    #[test]
    fn a_flat_star_costs_nothing_and_a_tip_its_height() {
        // A square ring around a centre: flat, the centre re-stored exactly on the new
        // triangles (barycentrics ½, 0, ½ of the diagonal's ends) has no error; lifted by h,
        // its error is h.
        let ring = [0u32, 1, 2, 3];
        let tris = [[0usize, 1, 2], [0, 2, 3]];
        for h in [0.0, 0.25] {
            let positions = vec![
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
                Point3::new(-1.0, 0.0, 0.0),
                Point3::new(0.0, -1.0, 0.0),
                Point3::new(0.0, 0.0, h),
            ];
            let moved = [(4u32, 0usize, [0.5, 0.0, 0.5])];
            let e = removal_error(&positions, &ring, &tris, &moved);
            assert!((e - h).abs() < 1e-15, "h {h}: {e}");
        }
    }

    #[test]
    fn a_slid_point_counts_even_on_the_surface() {
        // The centre of a flat ring re-stored at the wrong place of the plane: its error is the
        // distance slid (0.5), though it lies on the new triangles.
        let positions = vec![
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(-1.0, 0.0, 0.0),
            Point3::new(0.0, -1.0, 0.0),
            Point3::new(0.0, 0.0, 0.0),
        ];
        let moved = [(4u32, 0usize, [0.75, 0.0, 0.25])];
        let e = removal_error(&positions, &[0, 1, 2, 3], &[[0, 1, 2], [0, 2, 3]], &moved);
        assert!((e - 0.5).abs() < 1e-15, "{e}");
    }

    #[test]
    fn the_threshold_is_the_quantile_of_the_finite_errors() {
        let e = [3.0, f64::INFINITY, 1.0, 2.0, 4.0];
        assert_eq!(deferral_threshold(&e, 1.0), f64::INFINITY);
        assert_eq!(deferral_threshold(&[f64::INFINITY], 0.5), f64::INFINITY);
        let t = deferral_threshold(&e, 0.5);
        assert!((2.0..=3.0).contains(&t), "{t}");
        assert_eq!(deferral_threshold(&e, 0.0), 1.0);
    }

    #[test]
    fn coarse_levels_only_and_never_without_a_base_size() {
        let rule = ShapeRule::default();
        assert!(rule.applies(1536, 96));
        assert!(!rule.applies(1537, 96));
        assert!(!rule.applies(10, 0));
    }
}
