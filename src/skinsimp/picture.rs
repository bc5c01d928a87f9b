//! Pictures of a simplification (issue #6 "pictures of original vs simplified in several
//! poses", "a plot (error vs vertex count per method)"), drawn with the CPU reference
//! rasteriser ([`crate::raster`]).
//!
//! - [`pose_strip`]: the original (top row) and a level (bottom row) posed at the same example
//!   poses ([`spread_poses`]: spread over the clips), flat-shaded with every triangle edge drawn
//!   dark (a pixel is an edge pixel when its right or lower neighbour shows another face or
//!   the background), one camera framing every pose of the original.
//! - [`error_series`] / [`error_plot`]: the mean RMS distance over a pose set of levels at
//!   several vertex counts ([`level_counts`]) of each method's hierarchy, and its log–log line
//!   plot ([`crate::plot`]: axes with tick labels and a legend naming the methods in
//!   [`METHOD_COLOURS`]; the ranges are also in [`PlotAxes`]).

use nalgebra::{Point3, Vector3};

use super::evaluate::pose_set_error;
use super::poses::{joint_matrices, ExamplePose};
use super::{Hierarchy, Level, Method};
use crate::error::{Error, Result};
use crate::mesh::{SkinnedMesh, TriMesh};
use crate::raster::{rasterize, shade, Camera, FrameBuffer};
use crate::report::sig;
use crate::texture::{Image, Rgba8};

/// Background of every cell of [`pose_strip`] (pixels of this colour show no mesh).
pub const BACKGROUND: Rgba8 = [244, 244, 244, 255];
/// Colour of the white gaps between the cells of [`pose_strip`].
pub const GAP_COLOUR: Rgba8 = [255, 255, 255, 255];
/// Width in pixels of the gaps between the cells of [`pose_strip`].
pub const GAP: usize = 4;
/// Face colours of the original (top row) and of the level (bottom row).
const ORIGINAL_COLOUR: Rgba8 = [226, 200, 168, 255];
const LEVEL_COLOUR: Rgba8 = [150, 186, 232, 255];
/// Edge pixels are blended this far towards [`EDGE_COLOUR`].
const EDGE_COLOUR: Rgba8 = [25, 25, 35, 255];
const EDGE_BLEND: f64 = 0.75;
/// Largest cell side accepted (pixels).
const MAX_CELL: usize = 4096;
/// Largest width of a pose strip (pixels).
const MAX_STRIP_WIDTH: usize = 32768;

/// Size and view of [`pose_strip`].
#[derive(Clone, Debug, PartialEq)]
pub struct PoseStripOptions {
    /// Width and height of each cell in pixels (1 ..= 4096). Default 320 × 240.
    pub cell_width: usize,
    pub cell_height: usize,
    /// Direction the camera looks along; `None` (default): [`default_view`] of the model.
    pub view: Option<Vector3<f64>>,
}

impl Default for PoseStripOptions {
    fn default() -> Self {
        PoseStripOptions {
            cell_width: 320,
            cell_height: 240,
            view: None,
        }
    }
}

/// The default view direction for a model with y up: the camera looks across the longer of
/// the rest mesh's horizontal (x, z) extents, turned 30° about y towards it and 25° down, so
/// a long model (the tube along x, a walking animal) lies across the picture.
pub fn default_view(mesh: &TriMesh) -> Vector3<f64> {
    let (lo, hi) = mesh.bounding_box();
    let extent = hi - lo;
    let (along, across) = if extent.z > extent.x {
        (Vector3::z(), Vector3::x())
    } else {
        (Vector3::x(), Vector3::z())
    };
    let (turn, down) = (30f64.to_radians(), 25f64.to_radians());
    let horizontal = -across * turn.cos() - along * turn.sin();
    (horizontal * down.cos() - Vector3::y() * down.sin()).normalize()
}

/// `count` poses spread over the given clips (all clips when `animations` is empty): pose `i`
/// belongs to clip `animations[i mod c]`, and the `m` poses of one clip are at the times
/// `(j + ½)/m · T` (`T` its length, `j = 0 … m − 1`). Errors: `count == 0`, no animation, an
/// animation index out of range.
pub fn spread_poses(
    model: &SkinnedMesh,
    animations: &[usize],
    count: usize,
) -> Result<Vec<ExamplePose>> {
    if count == 0 {
        return Err(Error::InvalidArgument(
            "pose strip: the pose count must be ≥ 1".into(),
        ));
    }
    let clips: Vec<usize> = if animations.is_empty() {
        (0..model.animations.len()).collect()
    } else {
        animations.to_vec()
    };
    if clips.is_empty() {
        return Err(Error::InvalidArgument(format!(
            "{}: no animation to take poses from",
            model.mesh.name
        )));
    }
    let c = clips.len();
    (0..count)
        .map(|i| {
            let animation = clips[i % c];
            let m = count / c + usize::from(i % c < count % c);
            let j = i / c;
            let length = model.duration(animation)?;
            Ok(ExamplePose {
                animation,
                time: length * (j as f64 + 0.5) / m as f64,
            })
        })
        .collect()
}

/// Typed errors for a level that cannot be posed with `joint_count` joints.
fn check_level(level: &Level, joint_count: usize) -> Result<()> {
    let name = &level.mesh.name;
    if level.mesh.faces.is_empty() {
        return Err(Error::EmptyMesh { mesh: name.clone() });
    }
    level.mesh.validate()?;
    if level.weights.len() != level.mesh.positions.len() {
        return Err(Error::InvalidArgument(format!(
            "{name}: {} weight lists for {} vertices",
            level.weights.len(),
            level.mesh.positions.len()
        )));
    }
    if let Some(i) = level
        .weights
        .iter()
        .position(|w| w.is_empty() || w.pairs().any(|(k, _)| k as usize >= joint_count))
    {
        return Err(Error::InvalidArgument(format!(
            "{name}: vertex {i} has weights {:?}, the skeleton has {joint_count} joints",
            level.weights[i].pairs().collect::<Vec<_>>()
        )));
    }
    Ok(())
}

/// Original and level positions in each pose (errors of posing, non-finite positions).
#[allow(clippy::type_complexity)]
fn posed_pairs(
    model: &SkinnedMesh,
    level: &Level,
    poses: &[ExamplePose],
) -> Result<Vec<(Vec<Point3<f64>>, Vec<Point3<f64>>)>> {
    let mut out = Vec::with_capacity(poses.len());
    for &pose in poses {
        let mats = joint_matrices(model, pose)?;
        check_level(level, mats.len())?;
        let original = model.pose(pose.animation, pose.time)?;
        let simplified = level.posed(&mats);
        if !original
            .iter()
            .chain(&simplified)
            .all(|p| p.iter().all(|x| x.is_finite()))
        {
            return Err(Error::InvalidArgument(format!(
                "{}: a vertex is not finite in animation {} at {} s",
                model.mesh.name, pose.animation, pose.time
            )));
        }
        out.push((original, simplified));
    }
    Ok(out)
}

/// A perspective camera (30° vertical field of view) looking along `view` that frames every
/// point with 6 % margin: the target is the centre of the points' box in camera axes and the
/// distance the smallest that keeps every point inside both half fields of view.
fn fit_camera(points: &[Point3<f64>], view: Vector3<f64>, aspect: f64) -> Camera {
    let forward = view
        .try_normalize(1e-12)
        .filter(|v| v.iter().all(|x| x.is_finite()))
        .unwrap_or(-Vector3::z());
    let up_hint = if forward.y.abs() > 0.99 {
        Vector3::z()
    } else {
        Vector3::y()
    };
    let right = forward.cross(&up_hint).normalize();
    let up = right.cross(&forward);
    let axes = [right, up, forward];
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for (a, axis) in axes.iter().enumerate() {
            let x = p.coords.dot(axis);
            lo[a] = lo[a].min(x);
            hi[a] = hi[a].max(x);
        }
    }
    if points.is_empty() {
        (lo, hi) = ([-1.0; 3], [1.0; 3]);
    }
    let mid = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
    let target = Point3::from(right * mid[0] + up * mid[1] + forward * mid[2]);
    let fov_y_degrees: f64 = 30.0;
    let tan_y = (fov_y_degrees.to_radians() / 2.0).tan();
    let tan_x = aspect * tan_y;
    let margin = 1.06;
    let scale = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max).max(1e-9);
    let mut distance: f64 = 0.0;
    for p in points {
        let d = p - target;
        let (x, y, z) = (d.dot(&right), d.dot(&up), d.dot(&forward));
        distance = distance
            .max(margin * x.abs() / tan_x - z)
            .max(margin * y.abs() / tan_y - z);
    }
    let nearest = -(0.5 * (hi[2] - lo[2]));
    let distance = distance.max(1.5 * -nearest).max(0.05 * scale);
    Camera {
        eye: target - forward * distance,
        target,
        up,
        fov_y_degrees,
        near: 0.5 * (distance + nearest),
        far: 2.0 * (distance + 0.5 * (hi[2] - lo[2])) + scale,
        aspect,
    }
}

/// One cell: `positions` with `faces` seen by `camera`, flat Lambert shading (two-sided, light
/// from the upper left of the camera) in `colour`, edges drawn dark.
fn render_cell(
    positions: Vec<Point3<f64>>,
    faces: &[[u32; 3]],
    camera: &Camera,
    width: usize,
    height: usize,
    colour: Rgba8,
) -> Image<Rgba8> {
    let mesh = TriMesh::with_shared_indices("pose", positions, Vec::new(), faces.to_vec());
    let fb = rasterize(&mesh, &camera.view_proj(), width, height);
    let forward = (camera.target - camera.eye).normalize();
    let right = forward.cross(&camera.up).normalize();
    let light = (-forward + 0.45 * camera.up - 0.35 * right).normalize();
    let normals: Vec<Vector3<f64>> = (0..mesh.faces.len())
        .map(|f| {
            let [p, q, r] = mesh.face_positions(f);
            (q - p)
                .cross(&(r - p))
                .try_normalize(1e-300)
                .unwrap_or(-forward)
        })
        .collect();
    let mut img = shade(&fb, BACKGROUND, |f, _| {
        let k = 0.3 + 0.7 * normals[f as usize].dot(&light).abs();
        let c = |i: usize| (colour[i] as f64 * k).round().min(255.0) as u8;
        [c(0), c(1), c(2), 255]
    });
    draw_face_edges(&mut img, &fb);
    img
}

/// Darken every covered pixel whose right or lower neighbour shows another face or nothing.
fn draw_face_edges(img: &mut Image<Rgba8>, fb: &FrameBuffer) {
    let face = |x: usize, y: usize| fb.fragment(x, y).map(|f| f.face);
    for y in 0..fb.height {
        for x in 0..fb.width {
            let Some(here) = face(x, y) else { continue };
            let differs = |n: Option<u32>| n != Some(here);
            let edge = (x + 1 < fb.width && differs(face(x + 1, y)))
                || (y + 1 < fb.height && differs(face(x, y + 1)))
                || (x > 0 && face(x - 1, y).is_none())
                || (y > 0 && face(x, y - 1).is_none());
            if edge {
                let p = img.get(x, y);
                let mix = |i: usize| {
                    (p[i] as f64 * (1.0 - EDGE_BLEND) + EDGE_COLOUR[i] as f64 * EDGE_BLEND).round()
                        as u8
                };
                img.set(x, y, [mix(0), mix(1), mix(2), 255]);
            }
        }
    }
}

/// Copy `cell` into `out` with its top-left corner at `(left, top)`.
fn blit(out: &mut Image<Rgba8>, cell: &Image<Rgba8>, left: usize, top: usize) {
    for y in 0..cell.height {
        let row = &cell.pixels[y * cell.width..(y + 1) * cell.width];
        let start = (top + y) * out.width + left;
        out.pixels[start..start + cell.width].copy_from_slice(row);
    }
}

/// The original `model` (top row, sand) and `level` (bottom row, blue) posed at each of `poses`
/// (column `i` = pose `i`; the level skinned with its own weights), one camera framing the
/// original in every pose, flat-shaded with the triangle edges dark (module docs). The picture
/// is `n·W + (n − 1)·GAP` × `2·H + GAP` pixels (`W × H` the cell size, [`GAP`] white between
/// cells, [`BACKGROUND`] where a cell shows no mesh).
///
/// Errors: no pose, a cell size of 0 or above 4096, a strip wider than 32768 pixels, a model
/// without skin or an animation index out of range, a level without faces
/// ([`Error::EmptyMesh`]), weights that do not fit the level or the skeleton, non-finite posed
/// positions.
pub fn pose_strip(
    model: &SkinnedMesh,
    level: &Level,
    poses: &[ExamplePose],
    options: &PoseStripOptions,
) -> Result<Image<Rgba8>> {
    let (w, h) = (options.cell_width, options.cell_height);
    if poses.is_empty() {
        return Err(Error::InvalidArgument("pose strip: no pose given".into()));
    }
    if !(1..=MAX_CELL).contains(&w) || !(1..=MAX_CELL).contains(&h) {
        return Err(Error::InvalidArgument(format!(
            "pose strip: cell size {w}×{h} must be within 1..={MAX_CELL} pixels"
        )));
    }
    if poses.len() * (w + GAP) > MAX_STRIP_WIDTH {
        return Err(Error::InvalidArgument(format!(
            "pose strip: {} poses of {w} pixels exceed {MAX_STRIP_WIDTH} pixels",
            poses.len()
        )));
    }
    if model.mesh.faces.is_empty() {
        return Err(Error::EmptyMesh {
            mesh: model.mesh.name.clone(),
        });
    }
    model.mesh.validate()?;
    let pairs = posed_pairs(model, level, poses)?;
    let all: Vec<Point3<f64>> = pairs.iter().flat_map(|(o, _)| o.iter().copied()).collect();
    let view = options.view.unwrap_or_else(|| default_view(&model.mesh));
    let camera = fit_camera(&all, view, w as f64 / h as f64);
    let n = poses.len();
    let mut out = Image::new(n * w + (n - 1) * GAP, 2 * h + GAP, GAP_COLOUR);
    for (i, (original, simplified)) in pairs.into_iter().enumerate() {
        let left = i * (w + GAP);
        let top = render_cell(original, &model.mesh.faces, &camera, w, h, ORIGINAL_COLOUR);
        blit(&mut out, &top, left, 0);
        let bottom = render_cell(simplified, &level.mesh.faces, &camera, w, h, LEVEL_COLOUR);
        blit(&mut out, &bottom, left, h + GAP);
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Error versus vertex count

/// Line colours of the methods in [`error_plot`]: rest red, mohr orange, full blue.
pub const METHOD_COLOURS: [(Method, Rgba8); 3] = [
    (Method::Rest, [214, 39, 40, 255]),
    (Method::Mohr, [240, 150, 20, 255]),
    (Method::Full, [31, 100, 200, 255]),
];

/// One level of one method's hierarchy and its error over the pose set.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ErrorPoint {
    /// The requested vertex count.
    pub target: usize,
    /// Vertices and faces of the extracted level (more than `target` when the simplification
    /// stopped earlier).
    pub vertices: usize,
    pub faces: usize,
    /// Mean over the poses of the per-pose RMS distance, and the largest per-pose RMS.
    pub rms_mean: f64,
    pub rms_max: f64,
    /// Largest per-pose sampled Hausdorff distance.
    pub hausdorff_max: f64,
}

/// A method's points, in the order of the requested counts.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ErrorSeries {
    pub method: &'static str,
    pub points: Vec<ErrorPoint>,
}

/// `levels` vertex counts from `input_vertices` down to `smallest`, geometrically spaced
/// (`n_i = round(N · (s/N)^{i/(levels−1)})`), strictly decreasing (repeats dropped), the first
/// `N` (the unsimplified level) and the last `s`. Errors: `levels < 2`, `smallest` not in
/// `1 ..= N − 1`.
pub fn level_counts(input_vertices: usize, smallest: usize, levels: usize) -> Result<Vec<usize>> {
    if levels < 2 || smallest == 0 || smallest >= input_vertices {
        return Err(Error::InvalidArgument(format!(
            "level counts: need ≥ 2 levels and 1 ≤ smallest ({smallest}) < input vertices \
             ({input_vertices}); got {levels} levels"
        )));
    }
    let ratio = smallest as f64 / input_vertices as f64;
    let mut counts: Vec<usize> = (0..levels)
        .map(|i| {
            let t = i as f64 / (levels - 1) as f64;
            (input_vertices as f64 * ratio.powf(t)).round() as usize
        })
        .collect();
    counts[0] = input_vertices;
    counts[levels - 1] = smallest;
    counts.dedup();
    Ok(counts)
}

/// For every hierarchy (one per method) and every count of `counts`, the level with at most
/// that many vertices ([`Hierarchy::collapses_for`]) and its [`pose_set_error`] against
/// `model` over `poses`. Errors: no hierarchy, pose or count; a level without faces; the
/// errors of [`pose_set_error`]; a non-finite error.
pub fn error_series(
    model: &SkinnedMesh,
    hierarchies: &[&Hierarchy],
    poses: &[ExamplePose],
    counts: &[usize],
) -> Result<Vec<ErrorSeries>> {
    if hierarchies.is_empty() || poses.is_empty() || counts.is_empty() {
        return Err(Error::InvalidArgument(format!(
            "error plot: need hierarchies ({}), poses ({}) and vertex counts ({})",
            hierarchies.len(),
            poses.len(),
            counts.len()
        )));
    }
    let joint_count = joint_matrices(model, poses[0])?.len();
    hierarchies
        .iter()
        .map(|h| {
            let points = counts
                .iter()
                .map(|&target| {
                    let level = h.level(h.collapses_for(target));
                    check_level(&level, joint_count)?;
                    let e = pose_set_error(model, &level, poses)?;
                    if ![e.rms_mean, e.rms_max, e.hausdorff_max]
                        .iter()
                        .all(|x| x.is_finite())
                    {
                        return Err(Error::InvalidArgument(format!(
                            "{}: non-finite error at {} vertices",
                            level.mesh.name,
                            level.mesh.positions.len()
                        )));
                    }
                    Ok(ErrorPoint {
                        target,
                        vertices: level.mesh.positions.len(),
                        faces: level.mesh.faces.len(),
                        rms_mean: e.rms_mean,
                        rms_max: e.rms_max,
                        hausdorff_max: e.hausdorff_max,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(ErrorSeries {
                method: h.method.name(),
                points,
            })
        })
        .collect()
}

/// The ranges of [`error_plot`]'s axes (both logarithmic), for a caption.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PlotAxes {
    /// Vertex count at the left and right edge of the plot area.
    pub x_min: f64,
    pub x_max: f64,
    /// RMS at the bottom and top edge (whole decades). Points with RMS 0 (at most
    /// [`ZERO_RELATIVE`] of the largest) sit on the bottom edge.
    pub y_min: f64,
    pub y_max: f64,
}

impl PlotAxes {
    /// One sentence describing the axes (the picture labels them too).
    pub fn caption(&self) -> String {
        format!(
            "x: vertex count, log scale from {} to {}; y: mean RMS distance, log scale from {} \
             (bottom) to {} (top); RMS 0 and RMS below 10⁻⁶ of the largest are not drawn",
            sig(self.x_min, 3),
            sig(self.x_max, 3),
            sig(self.y_min, 3),
            sig(self.y_max, 3)
        )
    }
}

/// An error plot and the numbers it shows.
#[derive(Clone, Debug)]
pub struct ErrorPlot {
    pub image: Image<Rgba8>,
    pub series: Vec<ErrorSeries>,
    pub axes: PlotAxes,
}

impl ErrorPlot {
    /// The plotted numbers as a table: one row per requested count, per method the level's
    /// vertex count and mean RMS (3 significant digits).
    pub fn table(&self) -> (Vec<String>, Vec<Vec<String>>) {
        table_of(&self.series)
    }
}

/// The table of [`ErrorPlot::table`] for any series.
pub fn table_of(series: &[ErrorSeries]) -> (Vec<String>, Vec<Vec<String>>) {
    let mut header = vec!["target vertices".to_string()];
    for s in series {
        header.push(format!("{} vertices", s.method));
        header.push(format!("{} RMS", s.method));
    }
    let rows = series.first().map_or(0, |s| s.points.len());
    let rows = (0..rows)
        .map(|r| {
            let mut row = vec![series[0].points[r].target.to_string()];
            for s in series {
                match s.points.get(r) {
                    Some(p) => {
                        row.push(p.vertices.to_string());
                        row.push(sig(p.rms_mean, 3));
                    }
                    None => row.extend(["–".to_string(), "–".to_string()]),
                }
            }
            row
        })
        .collect();
    (header, rows)
}

/// [`error_series`] of the hierarchies, drawn by [`draw_error_plot`].
pub fn error_plot(
    model: &SkinnedMesh,
    hierarchies: &[&Hierarchy],
    poses: &[ExamplePose],
    counts: &[usize],
    width: usize,
    height: usize,
) -> Result<ErrorPlot> {
    let series = error_series(model, hierarchies, poses, counts)?;
    let (image, axes) = draw_error_plot(&series, width, height)?;
    Ok(ErrorPlot {
        image,
        series,
        axes,
    })
}

/// A `width × height` log–log line plot of mean RMS (y) against vertex count (x), drawn with
/// [`crate::plot`] (plotters): one line with markers per series in its [`METHOD_COLOURS`]
/// colour (grey for an unknown method), axes with tick labels, a grid and a legend naming the
/// methods. The x range is the vertex counts' ±10 % (log); the y range the enclosing whole
/// decades of the RMS values above [`ZERO_RELATIVE`] of the largest; smaller ones (the
/// unsimplified level, rounding only) are not drawn (the table lists them).
/// Errors: no point, a size below 120 × 90 or above 4096, non-finite values.
pub fn draw_error_plot(
    series: &[ErrorSeries],
    width: usize,
    height: usize,
) -> Result<(Image<Rgba8>, PlotAxes)> {
    if !(120..=MAX_CELL).contains(&width) || !(90..=MAX_CELL).contains(&height) {
        return Err(Error::InvalidArgument(format!(
            "error plot: size {width}×{height} must be within 120×90 ..= {MAX_CELL}×{MAX_CELL}"
        )));
    }
    let points: Vec<&ErrorPoint> = series.iter().flat_map(|s| &s.points).collect();
    if points.is_empty() {
        return Err(Error::InvalidArgument(
            "error plot: no point to draw".into(),
        ));
    }
    if let Some(p) = points
        .iter()
        .find(|p| !(p.rms_mean.is_finite() && p.rms_mean >= 0.0) || p.vertices == 0)
    {
        return Err(Error::InvalidArgument(format!(
            "error plot: point at {} vertices has RMS {}",
            p.vertices, p.rms_mean
        )));
    }
    let v_lo = points.iter().map(|p| p.vertices).min().unwrap_or(1) as f64;
    let v_hi = points.iter().map(|p| p.vertices).max().unwrap_or(1) as f64;
    let (x_min, x_max) = (v_lo / 1.1, v_hi * 1.1);
    let largest = points.iter().map(|p| p.rms_mean).fold(0.0, f64::max);
    let zero = ZERO_RELATIVE * largest;
    let positive: Vec<f64> = points
        .iter()
        .map(|p| p.rms_mean)
        .filter(|&r| r > zero)
        .collect();
    let (y_min, y_max) = if positive.is_empty() {
        (1e-3, 1.0)
    } else {
        let lo = positive.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = positive.iter().copied().fold(0.0, f64::max);
        let (a, b) = (lo.log10().floor(), hi.log10().ceil());
        (10f64.powf(a), 10f64.powf(if b > a { b } else { a + 1.0 }))
    };
    let axes = PlotAxes {
        x_min,
        x_max,
        y_min,
        y_max,
    };
    let lines = series
        .iter()
        .map(|s| crate::plot::Series {
            label: format!("{} (mean RMS)", s.method),
            points: s
                .points
                .iter()
                // RMS 0 (the unsimplified level: rounding only) has no place on a log axis: not
                // drawn; the table and the JSON list it.
                .filter(|p| p.rms_mean > zero)
                .map(|p| (p.vertices as f64, p.rms_mean))
                .collect(),
            colour: method_colour(s.method),
            style: crate::plot::Style::Measured,
        })
        .collect();
    let image = crate::plot::draw(
        &crate::plot::LogLogPlot {
            title: "held-out mean RMS against vertex count".into(),
            x_label: "vertices".into(),
            y_label: "mean RMS distance".into(),
            series: lines,
            x_range: Some((x_min, x_max)),
            y_range: Some((y_min, y_max)),
            categorical_x: false,
        },
        width,
        height,
    )?;
    Ok((image, axes))
}

/// RMS values at most this fraction of the largest count as 0 in [`draw_error_plot`] (the
/// unsimplified level's error is rounding, ~1e-15 of the model size).
pub const ZERO_RELATIVE: f64 = 1e-6;

/// The colour of a method name in [`METHOD_COLOURS`] (grey if unknown).
fn method_colour(name: &str) -> Rgba8 {
    METHOD_COLOURS
        .iter()
        .find(|(m, _)| m.name() == name)
        .map_or([120, 120, 120, 255], |c| c.1)
}
