//! How conformal the input map is, measured by cross-ratios (issue #36): the assumption BPM
//! rests on, reported beside its QC figures.
//!
//! BPM fits one Möbius map per triangle and blends the neighbours' maps across each edge
//! through the log of their ratio δ_e = M_t⁻¹ M_e (seed 004 steps 3–5, SPEC.md § 5). A
//! Möbius map preserves complex cross-ratios, so δ_e is the identity exactly when the edge's
//! quad (t's three corners and the neighbour's apex, laid out flat) has the same cross-ratio in
//! the layout and in UV, i.e. when the input map is discrete conformal across the edge. In
//! general δ_e fixes the edge's two ends and multiplies by m = CR_w / CR_z about them, so
//! Tr(δ_e)² = m + 2 + 1/m (SPEC.md § 11) and l_e = log δ_e has eigenvalues ±½ log m:
//! |log m| is the size of what BPM blends across the edge.
//!
//! The paper (Rorberg, Vaxman, Ben-Chen 2023) claims lower quasi-conformal distortion than
//! piecewise-linear interpolation on its inputs, which are discrete conformal
//! parameterisations (the authors' repository, shirrorbe/BPM, generates them with BFF and
//! the CETM benchmark, `External/Generate_Input`, `External/CETMBenchmark-main`). The seed
//! (004) does not name the assumption, but its §3 ("Speckling") meets the consequence: "under
//! conditions of large distortion" the blended maps "map the inside of triangles to the outside
//! of their targets". On artist UVs (spot, blub) the mismatch is large over much of the surface
//! and BPM is worse than linear there (spot: 27% of the area has s ≥ 1, BPM's mean QC 4.95
//! against linear's 3.38 there): see [`s_distribution`] and the warning `reparam bpm qc`
//! prints ([`needs_warning`]).

use num_complex::Complex64 as C;
use rayon::prelude::*;

use super::precompute::{gather_stars, star_layout, Star, Unfold};
use crate::error::Result;
use crate::mesh::{Adjacency, TriMesh, EDGE_CORNERS};

/// Upper ends of the s bins of [`SDistribution`]: s < 0.5, 0.5–1, 1–2, 2–4, ≥ 4.
pub const S_BIN_EDGES: [f64; 4] = [0.5, 1.0, 2.0, 4.0];

/// Human-readable labels of the five s bins, in order.
pub const S_BIN_LABELS: [&str; 5] = ["s < 0.5", "0.5 ≤ s < 1", "1 ≤ s < 2", "2 ≤ s < 4", "s ≥ 4"];

/// Options of the conformality report. `Default`: warn when at least 1% of the measured area
/// has s ≥ 1.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ConformalityOptions {
    /// s at and above which a face counts as far from conformal (|log m| = 1: the cross-ratio
    /// off by a factor e in modulus, or by one radian in angle).
    pub s_threshold: f64,
    /// Share of the measured area with s ≥ `s_threshold` at and above which the report warns.
    pub warn_area_share: f64,
}

impl Default for ConformalityOptions {
    fn default() -> Self {
        ConformalityOptions {
            s_threshold: 1.0,
            warn_area_share: 0.01,
        }
    }
}

/// The cross-ratio mismatches of a mesh's UV map.
#[derive(Clone, Debug, PartialEq)]
pub struct Conformality {
    /// `edge[f][e]`: |log(CR_w / CR_z)| of local edge e of face f ([`edge_mismatch`]); the
    /// larger of the two faces' values (they differ only where exactly one of the two faces is
    /// mirrored in UV); NaN where there is no interior, non-degenerate neighbour (or the
    /// quad cannot be normalised, see [`edge_mismatch`]).
    pub edge: Vec<[f64; 3]>,
    /// Per face s = max over its edges (0 for a face without a measured edge, NaN for a
    /// degenerate face, which BPM interpolates linearly).
    pub face_s: Vec<f64>,
    /// Per face 3D area (the QC protocol's weights).
    pub face_area: Vec<f64>,
}

/// The complex cross-ratio CR(a, b; c, d) = ((d − a)(c − b)) / ((d − b)(c − a)).
///
/// With this convention, for the Möbius map δ that fixes a and b and takes the layout of a
/// neighbour's apex d to where t's map sends its UV (δ_e of the seed's step 5), the multiplier
/// of δ about its fixed points is m = CR(w) / CR(z).
pub fn cross_ratio(a: C, b: C, c: C, d: C) -> C {
    ((d - a) * (c - b)) / ((d - b) * (c - a))
}

/// Cross-ratio mismatch of an edge's quad: |log(CR(w_a, w_b; w_c, w_d) / CR(z_a, z_b; z_c,
/// z_d))| with the principal log, i.e. √(ln²|m| + arg²m), arg ∈ (−π, π]. The quad is the edge
/// a→b, t's third corner c and the neighbour's apex d, in the flat layout z (the isometric
/// unfolding, seed step 2) and in UV w. 0 for a discrete conformal map; symmetric under
/// m ↦ 1/m, so the order of a, b and of c, d does not matter. Each quad is first moved to a
/// at the origin and scaled to unit size (`unit_quad`; the cross-ratio is invariant under
/// both), so coordinates of any finite size give finite products; then ln|CR_w| − ln|CR_z| and
/// arg(CR_w · conj CR_z), without forming the quotient. NaN when a quad cannot be normalised
/// (coinciding or overflowing points).
pub fn edge_mismatch(z: [C; 4], w: [C; 4]) -> f64 {
    let (Some(z), Some(w)) = (unit_quad(z), unit_quad(w)) else {
        return f64::NAN;
    };
    let cr_z = cross_ratio(z[0], z[1], z[2], z[3]);
    let cr_w = cross_ratio(w[0], w[1], w[2], w[3]);
    let log_modulus = cr_w.norm().ln() - cr_z.norm().ln();
    let angle = (cr_w * cr_z.conj()).arg();
    let m = log_modulus.hypot(angle);
    if m.is_finite() {
        m
    } else {
        f64::NAN
    }
}

/// (q_k − q_0) / max_k |q_k − q_0|: the quad translated and scaled to unit size; `None` when
/// that size is zero or not finite.
fn unit_quad(q: [C; 4]) -> Option<[C; 4]> {
    let d = q.map(|p| p - q[0]);
    let size = d.iter().map(|p| p.norm()).fold(0.0, f64::max);
    (size > 0.0 && size.is_finite()).then(|| d.map(|p| p / size))
}

/// The three edge mismatches of one star ([`edge_mismatch`] on edges ij, jk, ki with t's
/// third corner and the neighbour's apex), in t's own layout (the correct unfolding, mirrored
/// with t's UV orientation as BPM lays it out); NaN where the star has no neighbour or t is
/// degenerate.
pub fn star_mismatches(star: &Star) -> [f64; 3] {
    let uv_t = [star.w[0], star.w[1], star.w[2]];
    let (z, _) = star_layout(&star.p, uv_t, Unfold::Correct);
    std::array::from_fn(|e| {
        if star.degenerate || !star.neighbour[e] {
            return f64::NAN;
        }
        let [a, b] = EDGE_CORNERS[e];
        let c = (e + 2) % 3;
        let quad = [a, b, c, 3 + e];
        edge_mismatch(quad.map(|k| z[k]), quad.map(|k| star.w[k]))
    })
}

/// Measure the cross-ratio mismatch of every interior edge and s of every face of `mesh`
/// (which must have UVs). Seams, boundaries and degenerate neighbours have no mismatch (BPM
/// blends nothing there).
pub fn conformality(mesh: &TriMesh) -> Result<Conformality> {
    mesh.validate_with_uvs()?;
    let adjacency = Adjacency::new(mesh);
    let stars = gather_stars(mesh, &adjacency);
    let own: Vec<[f64; 3]> = stars.par_iter().map(star_mismatches).collect();
    let edge: Vec<[f64; 3]> = (0..stars.len())
        .map(|f| {
            std::array::from_fn(|e| match adjacency.neighbour(f, e) {
                Some((g, eg)) => larger(own[f][e], own[g][eg]),
                None => own[f][e],
            })
        })
        .collect();
    let face_s = edge
        .iter()
        .zip(&stars)
        .map(|(m, star)| face_s(m, star.degenerate))
        .collect();
    let face_area = (0..mesh.face_count())
        .map(|f| {
            let [a, b, c] = mesh.face_positions(f);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .collect();
    Ok(Conformality {
        edge,
        face_s,
        face_area,
    })
}

/// The larger of two mismatches, ignoring NaN (no value) unless both are.
fn larger(a: f64, b: f64) -> f64 {
    match (a.is_nan(), b.is_nan()) {
        (true, _) => b,
        (_, true) => a,
        _ => a.max(b),
    }
}

/// s of a face: the max of its measured edge mismatches; 0 without any; NaN when degenerate.
fn face_s(edges: &[f64; 3], degenerate: bool) -> f64 {
    if degenerate {
        return f64::NAN;
    }
    edges
        .iter()
        .filter(|m| !m.is_nan())
        .fold(0.0, |acc, &m| acc.max(m))
}

/// The bin of `s` in [`S_BIN_EDGES`] (0 ..= 4); `None` for NaN.
pub fn s_bin(s: f64) -> Option<usize> {
    if s.is_nan() {
        return None;
    }
    Some(S_BIN_EDGES.iter().take_while(|&&edge| s >= edge).count())
}

/// How the area is spread over the s bins.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SDistribution {
    /// Upper ends of the bins ([`S_BIN_EDGES`]).
    pub bin_edges: [f64; 4],
    /// Share of the measured (non-degenerate) 3D area in each bin: s < 0.5, 0.5–1, 1–2, 2–4, ≥ 4.
    pub area_share: [f64; 5],
    /// Number of faces in each bin.
    pub faces: [usize; 5],
    /// Degenerate faces (no s, left out of the shares).
    pub unmeasured_faces: usize,
    /// Area-weighted mean s and the largest s (0 when nothing is measured).
    pub mean: f64,
    pub max: f64,
}

/// Area shares of the s bins (seed-independent; issue #36): Σ area(f) over faces f with s_f in
/// the bin, divided by the measured area.
pub fn s_distribution(c: &Conformality) -> SDistribution {
    let mut area = [0.0; 5];
    let mut faces = [0; 5];
    let (mut unmeasured_faces, mut weighted, mut max) = (0, 0.0, 0.0f64);
    for (&s, &a) in c.face_s.iter().zip(&c.face_area) {
        match s_bin(s) {
            Some(bin) => {
                area[bin] += a;
                faces[bin] += 1;
                weighted += s * a;
                max = max.max(s);
            }
            None => unmeasured_faces += 1,
        }
    }
    let total: f64 = area.iter().sum();
    // No measured area (every face degenerate) or areas beyond f64's range: 0, never NaN.
    let per_area = |x: f64| match x / total {
        r if r.is_finite() => r,
        _ => 0.0,
    };
    SDistribution {
        bin_edges: S_BIN_EDGES,
        area_share: area.map(per_area),
        faces,
        unmeasured_faces,
        mean: per_area(weighted),
        max,
    }
}

/// Share of the measured area with s ≥ `threshold` (0 when nothing is measured).
pub fn area_share_at_least(c: &Conformality, threshold: f64) -> f64 {
    let (mut above, mut total) = (0.0, 0.0);
    for (&s, &a) in c.face_s.iter().zip(&c.face_area) {
        if s.is_nan() {
            continue;
        }
        total += a;
        if s >= threshold {
            above += a;
        }
    }
    match above / total {
        r if r.is_finite() => r,
        _ => 0.0,
    }
}

/// Whether the report should warn that BPM's assumption does not hold: the share of the
/// measured area with s ≥ `options.s_threshold` is at least `options.warn_area_share`.
pub fn needs_warning(c: &Conformality, options: &ConformalityOptions) -> bool {
    area_share_at_least(c, options.s_threshold) >= options.warn_area_share
}

/// The QC figures of one s bin: the protocol's area-weighted mean over the faces in the bin.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BinQc {
    pub bin: &'static str,
    pub area_share: f64,
    pub faces: usize,
    /// BPM's and linear interpolation's area-weighted mean QC over the bin's faces (`None` for
    /// an empty bin).
    pub bpm_mean: Option<f64>,
    pub linear_mean: Option<f64>,
}

/// The warning of [`needs_warning`], with the figures it quotes.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ConformalityWarning {
    /// Share of the measured area with s ≥ the threshold.
    pub area_share: f64,
    pub s_threshold: f64,
    /// Area-weighted mean QC there, BPM and linear; `None` when the QC was not run.
    pub bpm_mean: Option<f64>,
    pub linear_mean: Option<f64>,
    pub message: String,
}

/// Everything `bpm qc` and `bpm render` report about the input map's conformality.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ConformalityReport {
    pub distribution: SDistribution,
    /// Per s bin, BPM's and linear's QC (empty when the QC was not run).
    pub by_bin: Vec<BinQc>,
    pub warning: Option<ConformalityWarning>,
}

/// Per-face QC means of both interpolants, to split by s (see [`conformality_report`]).
pub struct FaceMeans<'a> {
    pub bpm: &'a [super::quality::FaceQc],
    pub linear: &'a [super::quality::FaceQc],
}

/// The conformality report: the s distribution ([`s_distribution`]); with the per-face QC
/// (`faces`), each bin's BPM and linear mean QC ([`super::quality::mean_over_faces`]); and,
/// when [`needs_warning`], a warning quoting the area with s ≥ the threshold and BPM's
/// against linear's mean QC there.
pub fn conformality_report(
    c: &Conformality,
    faces: Option<FaceMeans>,
    options: &ConformalityOptions,
) -> ConformalityReport {
    use super::quality::mean_over_faces;
    let distribution = s_distribution(c);
    let by_bin = match &faces {
        None => Vec::new(),
        Some(q) => (0..5)
            .map(|bin| {
                let in_bin = |f: usize| s_bin(c.face_s[f]) == Some(bin);
                BinQc {
                    bin: S_BIN_LABELS[bin],
                    area_share: distribution.area_share[bin],
                    faces: distribution.faces[bin],
                    bpm_mean: finite(mean_over_faces(q.bpm, in_bin)),
                    linear_mean: finite(mean_over_faces(q.linear, in_bin)),
                }
            })
            .collect(),
    };
    let warning = needs_warning(c, options).then(|| {
        let above = |f: usize| c.face_s[f] >= options.s_threshold;
        let means = faces.as_ref().and_then(|q| {
            let (bpm, linear) = (
                mean_over_faces(q.bpm, above),
                mean_over_faces(q.linear, above),
            );
            Some((finite(bpm)?, finite(linear)?))
        });
        warning_of(
            area_share_at_least(c, options.s_threshold),
            options.s_threshold,
            means,
        )
    });
    ConformalityReport {
        distribution,
        by_bin,
        warning,
    }
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

fn warning_of(area_share: f64, s_threshold: f64, means: Option<(f64, f64)>) -> ConformalityWarning {
    use crate::report::sig;
    let figures = match means {
        Some((bpm, linear)) => format!(
            "; there BPM's area-average QC is {} against linear's {} ({})",
            sig(bpm, 4),
            sig(linear, 4),
            if bpm > linear {
                "BPM is worse"
            } else {
                "BPM is better"
            }
        ),
        None => "; run `reparam bpm qc` for BPM's and linear's QC there".to_string(),
    };
    let message = format!(
        "BPM assumes a near-conformal input map (its per-triangle Möbius maps agree across an \
         edge only where the edge's quad keeps its cross-ratio); this map is not: {}% of the \
         area has s ≥ {}{}",
        crate::report::sig(100.0 * area_share, 3),
        s_threshold,
        figures
    );
    ConformalityWarning {
        area_share,
        s_threshold,
        bpm_mean: means.map(|m| m.0),
        linear_mean: means.map(|m| m.1),
        message,
    }
}
