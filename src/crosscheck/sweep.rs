//! Stability sweeps: a kernel's f32 error against one conditioning parameter, with the derived
//! bound beside it, as a table and a log–log plot ([`crate::plot`]). They show a GPU engineer
//! where f32 stops being enough, and by how much.
//!
//! | algorithm | parameter | what is measured |
//! |---|---|---|
//! | bpm | UV offset from the origin; triangle size | local and determinant fit pipelines, max error in texels |
//! | bpm | arithmetic model (f32 twins: nearest, FMA, reordered, edge of the WGSL table) | worst error / bound of the eval kernel and the local-fit pipeline |
//! | gridwarp | grid resolution (unknowns) | JᵀJ and Jᵀr, worst relative error |
//! | unwarp | height scale s | one pass's offsets, max and p99 in texels |
//! | maps | triangle aspect ratio | Π⁻¹ position, max and p99 of the diagonal |
//! | skinsimp | coordinate magnitude | source quadrics, worst relative entry error |
//! | every algorithm | arithmetic model (the kernels' f32 twins on the canonical vectors) | worst error / bound per kernel ([`twin_model_sweep`]) |

use reparam_gpu::Gpu;
use serde::Serialize;

use super::bpm_models::{bpm_model_ratios, ModelRatios};
use super::{bpm, gridwarp, maps as maps_check, skinsimp as skinsimp_check, unwarp};
use crate::error::Result;
use crate::mesh::{procedural, TriMesh};
use crate::plot::{self, LogLogPlot, Style, PALETTE};
use crate::report::sig;
use crate::texture::{Image, Rgba8};
use crate::twin::Model;

/// Dashed bound lines: dark grey, red, purple.
const BOUND_COLOURS: [Rgba8; 3] = [[90, 90, 90, 255], [214, 39, 40, 255], [148, 103, 189, 255]];

/// One series of a sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweepSeries {
    pub label: String,
    /// A bound (drawn dashed) rather than a measured error.
    pub bound: bool,
    /// (parameter, value) per sweep step.
    pub points: Vec<(f64, f64)>,
}

/// One sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Sweep {
    pub algorithm: String,
    /// File stem of the plot, e.g. `bpm_uv_offset`.
    pub name: String,
    pub title: String,
    pub parameter: String,
    pub unit: String,
    pub series: Vec<SweepSeries>,
    /// Names of the steps where the parameter is a category (the arithmetic models): the
    /// table shows them instead of the numbers; empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub step_names: Vec<String>,
}

impl Sweep {
    fn new(algorithm: &str, name: &str, title: &str, parameter: &str, unit: &str) -> Sweep {
        Sweep {
            algorithm: algorithm.into(),
            name: name.into(),
            title: title.into(),
            parameter: parameter.into(),
            unit: unit.into(),
            series: Vec::new(),
            step_names: Vec::new(),
        }
    }

    fn add(&mut self, label: &str, bound: bool, points: Vec<(f64, f64)>) {
        self.series.push(SweepSeries {
            label: label.into(),
            bound,
            points,
        });
    }

    /// The sweep as a table: the parameter, then one column per series (3 significant digits).
    pub fn table(&self) -> (Vec<String>, Vec<Vec<String>>) {
        let mut header = vec![self.parameter.clone()];
        header.extend(self.series.iter().map(|s| s.label.clone()));
        let steps = self.series.first().map_or(0, |s| s.points.len());
        let rows = (0..steps)
            .map(|k| {
                let step = self.step_names.get(k).cloned();
                let mut row = vec![step.unwrap_or_else(|| sig(self.series[0].points[k].0, 3))];
                row.extend(
                    self.series
                        .iter()
                        .map(|s| s.points.get(k).map_or("–".into(), |p| sig(p.1, 3))),
                );
                row
            })
            .collect();
        (header, rows)
    }

    /// The log–log plot (bounds dashed), `width × height`.
    pub fn plot(&self, width: usize, height: usize) -> Result<Image<Rgba8>> {
        let (mut measured, mut bounds) = (0, 0);
        let series = self
            .series
            .iter()
            .map(|s| {
                let (colour, style) = if s.bound {
                    bounds += 1;
                    (
                        BOUND_COLOURS[(bounds - 1) % BOUND_COLOURS.len()],
                        Style::Bound,
                    )
                } else {
                    measured += 1;
                    (PALETTE[(measured - 1) % PALETTE.len()], Style::Measured)
                };
                plot::Series {
                    label: s.label.clone(),
                    points: s.points.clone(),
                    colour,
                    style,
                }
            })
            .collect();
        plot::draw(
            &LogLogPlot {
                title: self.title.clone(),
                x_label: self.parameter.clone(),
                y_label: self.unit.clone(),
                series,
                // Categories (the arithmetic models 1 … n) span their own steps, not decades.
                x_range: (self.step_names.len() > 1).then_some((1.0, self.step_names.len() as f64)),
                y_range: None,
                categorical_x: self.step_names.len() > 1,
            },
            width,
            height,
        )
    }
}

/// The largest error of the row named `kernel` in `rows`.
fn max_of(rows: &[super::Row], kernel: &str) -> f64 {
    rows.iter()
        .find(|r| r.kernel == kernel)
        .map_or(f64::NAN, |r| r.errors.max_abs)
}

/// The largest per-element bound of the row named `kernel`.
fn bound_of(rows: &[super::Row], kernel: &str) -> f64 {
    rows.iter()
        .find(|r| r.kernel == kernel)
        .map_or(f64::NAN, |r| r.bound_max)
}

/// `mesh` with every UV mapped by uv ↦ c + s (uv − centre of the UVs).
fn moved_uvs(mesh: &TriMesh, c: [f64; 2], s: f64) -> TriMesh {
    let mut m = mesh.clone();
    let n = m.uvs.len().max(1) as f64;
    let centre = m
        .uvs
        .iter()
        .fold([0.0, 0.0], |a, t| [a[0] + t.x / n, a[1] + t.y / n]);
    for t in &mut m.uvs {
        t.x = c[0] + s * (t.x - centre[0]);
        t.y = c[1] + s * (t.y - centre[1]);
    }
    m
}

/// BPM: the local-fit and determinant-fit pipelines (precompute → eval on the GPU) against the
/// reference, on the wavy grid (8 × 8) with its UVs moved away from the origin (offset sweep)
/// and shrunk about (0.5, 0.5) (size sweep). The local pipeline's largest derived bound
/// (crosscheck::bpm_bound) is drawn beside them; the local fit stays below it, the determinant
/// fit (the seed's) does not: where its error passes one texel, speckles begin.
pub fn bpm_sweeps(gpu: &Gpu) -> Result<Vec<Sweep>> {
    let base = procedural::wavy_grid(8);
    let texture = crate::texture::checker(64, 4);
    let pipelines = |mesh: &TriMesh| -> Result<(f64, f64, f64)> {
        let rows = bpm::bpm_rows_with(gpu, mesh, &texture, false)?;
        Ok((
            max_of(&rows, "bpm_precompute (local fit) → bpm_eval: uv"),
            max_of(&rows, "bpm_precompute (determinant fit) → bpm_eval: uv"),
            bound_of(&rows, "bpm_precompute (local fit) → bpm_eval: uv"),
        ))
    };
    let mut offset = Sweep::new(
        "bpm",
        "bpm_uv_offset",
        "BPM: f32 error against the UV offset",
        "largest |uv| (texture widths)",
        "max error (texels of 4096²)",
    );
    let (mut local, mut det, mut bound, mut speckle) = (vec![], vec![], vec![], vec![]);
    for d in [0.5, 2.0, 8.0, 32.0, 128.0, 512.0] {
        let mesh = moved_uvs(&base, [d, d], 1.0);
        let uv_max = mesh.uvs.iter().map(|t| t.coords.norm()).fold(0.0, f64::max);
        let (l, dt, b) = pipelines(&mesh)?;
        local.push((uv_max, l));
        det.push((uv_max, dt));
        bound.push((uv_max, b));
        speckle.push((uv_max, bpm::SPECKLE_THRESHOLD));
    }
    offset.add("local fit", false, local);
    offset.add("determinant fit", false, det);
    offset.add("local pipeline bound (largest)", true, bound);
    offset.add("1 texel (speckle)", true, speckle);

    let mut size = Sweep::new(
        "bpm",
        "bpm_triangle_size",
        "BPM: f32 error against the triangle size (UVs about 0.5)",
        "triangle size (texels of 4096²)",
        "max error (texels of 4096²)",
    );
    let (mut local, mut det, mut bound, mut speckle) = (vec![], vec![], vec![], vec![]);
    for s in [1.0, 0.1, 0.01, 1e-3, 1e-4] {
        let mesh = moved_uvs(&base, [0.5, 0.5], s);
        // The grid's UV cells are 1/8 wide before scaling.
        let texels = s / 8.0 * bpm::TEXTURE_SIZE;
        let (l, dt, b) = pipelines(&mesh)?;
        local.push((texels, l));
        det.push((texels, dt));
        bound.push((texels, b));
        speckle.push((texels, bpm::SPECKLE_THRESHOLD));
    }
    size.add("local fit", false, local);
    size.add("determinant fit", false, det);
    size.add("local pipeline bound (largest)", true, bound);
    size.add("1 texel (speckle)", true, speckle);
    let models = bpm_model_sweep(&procedural::bpm_conformance())?;
    Ok(vec![offset, size, models])
}

/// The x of each model in [`bpm_model_sweep`] (1 … 7, the order of [`Model::CHECKED`]).
pub const MODEL_AXIS: &str =
    "arithmetic model: 1 nearest, 2 fma, 3 reordered, 4–5 edge-of-spec, 6–7 worst";

/// BPM under every arithmetic model a conforming GPU may use (`crosscheck::bpm_models`): per
/// model the worst error / bound of the eval kernel (BPM, linear) and of the local-fit
/// pipeline, from the kernels' f32 twins on `mesh`; the bound is the line at 1.
pub fn bpm_model_sweep(mesh: &TriMesh) -> Result<Sweep> {
    let mut sweep = Sweep::new(
        "bpm",
        "bpm_arithmetic_models",
        "BPM: worst error / bound under each conforming arithmetic",
        MODEL_AXIS,
        "worst error / derived bound",
    );
    let ratios = Model::CHECKED
        .iter()
        .map(|&m| bpm_model_ratios(mesh, m))
        .collect::<Result<Vec<_>>>()?;
    let series = |f: &dyn Fn(&ModelRatios) -> f64| -> Vec<(f64, f64)> {
        ratios
            .iter()
            .enumerate()
            .map(|(k, r)| ((k + 1) as f64, f(r)))
            .collect()
    };
    sweep.add("bpm_eval: BPM uv", false, series(&|r| r.eval_bpm));
    sweep.add("bpm_eval: linear uv", false, series(&|r| r.eval_linear));
    sweep.add("bpm_precompute → bpm_eval", false, series(&|r| r.pipeline));
    sweep.add("bound (ratio 1)", true, series(&|_| 1.0));
    sweep.step_names = Model::CHECKED.iter().map(|m| m.name()).collect();
    Ok(sweep)
}

/// gridwarp: the normal equations of the plane-stretch scene (128² fields, 4 × 4 samples per
/// cell) on uniform grids of 3 … 33 lines per axis: the worst relative error of JᵀJ and Jᵀr
/// against the largest of their derived bounds (which grow with the samples per unknown).
pub fn gridwarp_sweeps(gpu: &Gpu) -> Result<Vec<Sweep>> {
    use crate::gridwarp::scene::{disc_rigidity, plane_stretch};
    use crate::gridwarp::Grid;
    let rigidity = disc_rigidity(128, &[(0.7, 0.5, 0.12), (0.25, 0.3, 0.1)], 0.1);
    let scene = plane_stretch(128, 2, 2.0, rigidity);
    let mut sweep = Sweep::new(
        "gridwarp",
        "gridwarp_grid_resolution",
        "gridwarp: normal equations against grid resolution",
        "unknowns (interior lines)",
        "relative error (to the largest entry)",
    );
    let (mut jtj, mut jtr, mut jtj_b, mut jtr_b) = (vec![], vec![], vec![], vec![]);
    for lines in [3, 5, 9, 17, 33] {
        let grid = Grid::uniform(lines, lines);
        let unknowns = grid.unknowns() as f64;
        let rows =
            gridwarp::kernel_rows(gpu, "plane", &scene.rest, &grid, &scene.frames[1], (4, 4))?;
        let get = |k: &str| rows.iter().find(|r| r.kernel == k).cloned();
        if let (Some(a), Some(g)) = (get("gridwarp_aa: JᵀJ"), get("gridwarp_aa: Jᵀr")) {
            jtj.push((unknowns, a.errors.max_abs));
            jtr.push((unknowns, g.errors.max_abs));
            jtj_b.push((unknowns, a.bound_max));
            jtr_b.push((unknowns, g.bound_max));
        }
    }
    sweep.add("JᵀJ", false, jtj);
    sweep.add("Jᵀr", false, jtr);
    sweep.add("JᵀJ bound (largest)", true, jtj_b);
    sweep.add("Jᵀr bound (largest)", true, jtr_b);
    Ok(vec![sweep])
}

/// unwarp: one pass of the cones map (32²) from a state after two reference sweeps, for height
/// scales s = 0.01 … 0.4: the offsets' max and p99 error against the median per-texel bound.
pub fn unwarp_sweeps(gpu: &Gpu) -> Result<Vec<Sweep>> {
    use crate::unwarp::{procedural as height_map, UnwarpOptions};
    let heights = height_map("cones", 32)?;
    let mut sweep = Sweep::new(
        "unwarp",
        "unwarp_height_scale",
        "unwarp: one pass against the height scale s",
        "height scale s (texture widths)",
        "offset error (texels of 4096²)",
    );
    let (mut max, mut p99, mut bound) = (vec![], vec![], vec![]);
    for s in [0.01, 0.02, 0.05, 0.1, 0.2, 0.4] {
        let options = UnwarpOptions {
            scale: s,
            ..Default::default()
        };
        let row = unwarp::pass_row(gpu, "cones 32²", &heights, &options)?;
        max.push((s, row.errors.max_abs));
        p99.push((s, row.errors.p99));
        bound.push((s, row.bound));
    }
    sweep.add("max", false, max);
    sweep.add("p99", false, p99);
    sweep.add("per-texel bound (median)", true, bound);
    Ok(vec![sweep])
}

/// maps: Π⁻¹ of the uniform:2 remesh points of the wavy grid (12 × 12) stretched along x by
/// a = 1 … 32 (its triangles' aspect ratio ≈ a): position error max and p99, as a fraction of
/// the diagonal, against the limits 1e-5 (max) and 1e-6 (p99).
pub fn maps_sweeps(gpu: &Gpu) -> Result<Vec<Sweep>> {
    use crate::maps::gpu::crosscheck_inverse;
    use crate::maps::remesh::uniform;
    use crate::maps::{build, Features, MapsOptions};
    let mut sweep = Sweep::new(
        "maps",
        "maps_aspect_ratio",
        "maps: Π⁻¹ against triangle aspect ratio",
        "aspect ratio of the input triangles",
        "position error (fraction of the diagonal)",
    );
    let (mut max, mut p99, mut b_max, mut b_p99) = (vec![], vec![], vec![], vec![]);
    for a in [1.0, 2.0, 4.0, 8.0, 16.0, 32.0] {
        let mut mesh = procedural::wavy_grid(12);
        mesh.uvs.clear();
        mesh.uv_faces.clear();
        for p in &mut mesh.positions {
            p.x *= a;
        }
        let maps = build(&mesh, &Features::default(), &MapsOptions::default())?;
        let r = crosscheck_inverse(gpu, &maps, &uniform(&maps, 2)?.params)?;
        max.push((a, r.position.max_abs));
        p99.push((a, r.position.p99));
        b_max.push((a, maps_check::INVERSE_POSITION_MAX));
        b_p99.push((a, maps_check::INVERSE_POSITION_P99));
    }
    sweep.add("max", false, max);
    sweep.add("p99", false, p99);
    sweep.add("limit of the max", true, b_max);
    sweep.add("limit of the p99", true, b_p99);
    Ok(vec![sweep])
}

/// skinsimp: the source quadrics of the skinned tube's posed positions moved by T = 0 … 10⁴ (in
/// units of the unit box) before rounding to f32, i.e. without the unit-box normalisation the
/// cross-check applies: the worst entry error relative to the quadric's largest entry, against
/// the notes' 1e-5 and the largest derived relative bound ([`skinsimp_check::source_bound`]).
pub fn skinsimp_sweeps(gpu: &Gpu) -> Result<Vec<Sweep>> {
    use crate::skinsimp::gpu::{
        crosscheck, plane_quadrics_f64, SkinsimpKernels, QUADRIC_TOLERANCE,
    };
    use crate::skinsimp::poses::{select_poses, skinned_input, PoseSelection};
    use nalgebra::Vector3;
    let model = crate::skinsimp::tube::skinned_tube(12, 12);
    let sets = select_poses(&model, &PoseSelection::Uniform(4))?;
    let input = skinned_input(&model, &sets.training)?;
    let options = crate::skinsimp::Options::default();
    let kernels = SkinsimpKernels::new(gpu.clone())?;
    let (_, data) = crosscheck(
        &kernels,
        &input,
        options.boundary_weight,
        options.cost.max_condition,
    )?;
    let mut sweep = Sweep::new(
        "skinsimp",
        "skinsimp_coordinate_magnitude",
        "skinsimp: source quadrics against coordinate magnitude",
        "largest |coordinate| (unit box = 1)",
        "relative error (to the largest entry)",
    );
    let (mut err, mut bound, mut notes) = (vec![], vec![], vec![]);
    let p = data.sources.pose_count as usize;
    let weight = data.sources.boundary_weight as f64;
    for t in [0.0, 1.0, 10.0, 100.0, 1e3, 1e4] {
        let shift = Vector3::new(t, t, t);
        let posed: Vec<_> = data
            .posed_rounded
            .iter()
            .map(|q| (q + shift).map(|x| x as f32 as f64))
            .collect();
        let magnitude = posed.iter().map(|q| q.coords.amax()).fold(0.0, f64::max);
        let reference = plane_quadrics_f64(&posed, &data.sources, weight);
        let (gpu_quadrics, _) = kernels.quadrics(&data.sources, &posed)?;
        let (mut worst, mut worst_bound) = (0.0f64, 0.0f64);
        for (x, (r, g)) in reference.iter().zip(&gpu_quadrics).enumerate() {
            let size = r.0.iter().map(|v| v.abs()).fold(0.0, f64::max);
            if size == 0.0 {
                continue;
            }
            let e =
                r.0.iter()
                    .zip(&g.0)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
            let (src, j) = (data.sources.sources[x / p], x % p);
            let corners = src.corners.map(|c| posed[c as usize * p + j]);
            let b = skinsimp_check::source_bound(&src, corners, weight)
                .iter()
                .copied()
                .fold(0.0, f64::max);
            worst = worst.max(e / size);
            worst_bound = worst_bound.max(b / size);
        }
        err.push((magnitude, worst));
        bound.push((magnitude, worst_bound));
        notes.push((magnitude, QUADRIC_TOLERANCE));
    }
    sweep.add("source quadrics", false, err);
    sweep.add("derived bound (largest)", true, bound);
    sweep.add("notes' 1e-5", true, notes);
    Ok(vec![sweep])
}

/// Every kernel of `algorithm` whose f32 twin runs over its vectors
/// ([`crate::twin::candidate::runner`]), under every arithmetic model of [`Model::CHECKED`], on
/// the canonical vectors ([`crate::vectors::canonical`], written to a temporary folder): per
/// kernel and model the worst error / bound that `verify` reports; the bound is the line at 1.
/// `None` when no kernel of `algorithm` has a runner.
pub fn twin_model_sweep(algorithm: &str) -> Result<Option<Sweep>> {
    let (input, kernels) = crate::vectors::canonical(algorithm)?;
    let dir = std::env::temp_dir().join(format!(
        "reparam-twin-sweep-{}-{algorithm}",
        std::process::id()
    ));
    let result = crate::vectors::write_vectors(&dir, "crosscheck --sweep", &input, &kernels)
        .and_then(|manifest| twin_model_sweep_of(algorithm, &dir, &manifest));
    // The folder is scratch: a failure to remove it leaves files in the temporary folder only.
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// [`twin_model_sweep`] on the vectors `manifest` in `dir` (any input: `reparam vectors …
/// --twins` runs it on the user's own model).
pub fn twin_model_sweep_of(
    algorithm: &str,
    dir: &std::path::Path,
    manifest: &crate::vectors::Manifest,
) -> Result<Option<Sweep>> {
    use crate::twin::candidate::runner;
    use crate::vectors::verify::verify_array;
    let mut sweep = Sweep::new(
        algorithm,
        &format!("{algorithm}_arithmetic_models"),
        &format!("{algorithm}: worst error / bound of each twin under each conforming arithmetic"),
        MODEL_AXIS,
        "worst error / derived bound",
    );
    for k in &manifest.kernels {
        let Some(run) = runner(&k.name) else {
            continue;
        };
        let points = Model::CHECKED
            .iter()
            .enumerate()
            .map(|(x, &model)| {
                let candidate = run(dir, k, model)?;
                let report = verify_array(dir, k, &candidate, "twin")?;
                // A NaN fails whatever the finite elements' ratio says: ∞.
                let ratio = if report.pass || report.worst_ratio > 1.0 {
                    report.worst_ratio
                } else {
                    f64::INFINITY
                };
                Ok(((x + 1) as f64, ratio))
            })
            .collect::<Result<Vec<_>>>()?;
        sweep.add(&k.name, false, points);
    }
    if sweep.series.is_empty() {
        return Ok(None);
    }
    let ones = (1..=Model::CHECKED.len())
        .map(|x| (x as f64, 1.0))
        .collect();
    sweep.add("bound (ratio 1)", true, ones);
    sweep.step_names = Model::CHECKED.iter().map(|m| m.name()).collect();
    Ok(Some(sweep))
}

/// Whether every twin's series of `sweep` stays within its bounds (ratio ≤ 1 under every
/// model).
pub fn twins_within_bounds(sweep: &Sweep) -> bool {
    sweep
        .series
        .iter()
        .filter(|s| !s.bound)
        .all(|s| s.points.iter().all(|p| p.1 <= 1.0))
}

/// The sweeps of `algorithm` (`bpm`, `gridwarp`, `unwarp`, `maps`, `skinsimp`), the twins'
/// arithmetic-model sweep last (BPM's is [`bpm_model_sweep`], among [`bpm_sweeps`]).
pub fn sweeps_of(gpu: &Gpu, algorithm: &str) -> Result<Vec<Sweep>> {
    let mut sweeps = match algorithm {
        "bpm" => bpm_sweeps(gpu),
        "gridwarp" => gridwarp_sweeps(gpu),
        "unwarp" => unwarp_sweeps(gpu),
        "maps" => maps_sweeps(gpu),
        "skinsimp" => skinsimp_sweeps(gpu),
        other => Err(crate::error::Error::InvalidArgument(format!(
            "no sweep for '{other}'"
        ))),
    }?;
    if algorithm != "bpm" {
        sweeps.extend(twin_model_sweep(algorithm)?);
    }
    Ok(sweeps)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sweep_with(ratios: &[f64]) -> Sweep {
        let mut sweep = Sweep::new("x", "x", "x", MODEL_AXIS, "ratio");
        let points = ratios
            .iter()
            .enumerate()
            .map(|(k, &r)| ((k + 1) as f64, r))
            .collect();
        sweep.add("kernel", false, points);
        sweep.add("bound (ratio 1)", true, vec![(1.0, 1.0), (2.0, 1.0)]);
        sweep
    }

    #[test]
    fn twins_within_bounds_fails_on_a_ratio_over_1_an_infinity_or_a_nan() {
        assert!(twins_within_bounds(&sweep_with(&[0.2, 1.0])));
        assert!(!twins_within_bounds(&sweep_with(&[0.2, 1.5])));
        assert!(!twins_within_bounds(&sweep_with(&[f64::INFINITY, 0.1])));
        assert!(!twins_within_bounds(&sweep_with(&[0.1, f64::NAN])));
    }
}
