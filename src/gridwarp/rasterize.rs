//! From triangle meshes to the gridwarp fields (seed §3.1, §7): the stretch lengths ‖O_s‖,
//! ‖O_t‖ (rest mesh), ‖D_s‖, ‖D_t‖ (each deformed frame) and the rigidity map R over a
//! texture-space region of interest.
//!
//! **ROI.** [`Roi`] is the UV rectangle [u0, u1] × [v0, v1] ⊂ [0, 1]² mapped to the unit square,
//! s = (u − u0)/(u1 − u0), t = (v − v0)/(v1 − v0) (OBJ convention: v = 0 at the bottom of the
//! image, so row 0 of a field, t = 0, is the ROI's bottom edge).
//!
//! **Rasteriser.** Every texel centre ((x + ½)/W, (y + ½)/H) of the ROI is mapped to UV and
//! located in the UV triangles whose bounding box overlaps the ROI (faces binned by texel row,
//! rows processed in parallel with rayon; the result does not depend on the thread count).
//! Containment uses edge functions evaluated with the edge's endpoints in a canonical
//! (lexicographic) order, so two triangles sharing an edge — also across a UV seam with equal
//! coordinates — compute bit-identical values there; a centre exactly on an edge belongs to the
//! side a perturbation (−ε², ε) moves it to. A centre in a partition of the plane therefore lies
//! in exactly one triangle. Where UV triangles overlap (mirrored or stacked charts) the lowest
//! face id wins and the texel is counted in [`Coverage::overlapping_texels`].
//!
//! **Derivatives.** On face (p0, p1, p2) with UVs (w0, w1, w2) the map UV → 3D is linear:
//! [e1 e2] = [X_u X_v]·[w1−w0  w2−w0], so [X_u X_v] = [e1 e2]·[w1−w0  w2−w0]⁻¹, and in ROI
//! coordinates X_s = X_u (u1 − u0), X_t = X_v (v1 − v0). The fields store ‖X_s‖, ‖X_t‖ —
//! constant per triangle (notes, "Analytic Jacobian").
//!
//! **Uncovered texels** (outside every UV chart) take the triangle of the nearest covered texel
//! (Euclidean distance between texel indices, exact distance transform; ties broken
//! deterministically), so that the fields stay continuous-ish and positive; the covered fraction
//! is reported in [`Coverage`]. A ROI without any covered texel is an error.
//!
//! **Rigidity.** [`rigidity_from_image`] resamples a grey image bilinearly at the texel centres.

use std::path::Path;

use nalgebra::{Point2, Vector3};
use rayon::prelude::*;

use super::energy::DeformedFields;
use super::energy_naa::{DeformedJacobian, VectorField};
use super::field::Field;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::texture::load_gray_f32;

/// Sentinel for "no face".
const NONE: u32 = u32::MAX;

/// An axis-aligned texture-space rectangle [u0, u1] × [v0, v1] mapped to the unit square.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roi {
    pub u0: f64,
    pub u1: f64,
    pub v0: f64,
    pub v1: f64,
}

impl Roi {
    /// The ROI [u0, u1] × [v0, v1]. Errors ([`Error::InvalidArgument`], naming the values): a
    /// non-finite bound, a bound outside [0, 1], or a non-positive width or height.
    pub fn new(u0: f64, u1: f64, v0: f64, v1: f64) -> Result<Roi> {
        let describe = || format!("ROI u [{u0}, {u1}] x v [{v0}, {v1}]");
        for (name, value) in [("u0", u0), ("u1", u1), ("v0", v0), ("v1", v1)] {
            if !value.is_finite() || !(0.0..=1.0).contains(&value) {
                return Err(Error::InvalidArgument(format!(
                    "{}: {name} = {value} is outside the texture square [0, 1]",
                    describe()
                )));
            }
        }
        if u1 <= u0 || v1 <= v0 {
            return Err(Error::InvalidArgument(format!(
                "{}: the ROI must have a positive size (width {}, height {})",
                describe(),
                u1 - u0,
                v1 - v0
            )));
        }
        Ok(Roi { u0, u1, v0, v1 })
    }

    /// The whole texture square [0, 1]².
    pub fn full() -> Roi {
        Roi {
            u0: 0.0,
            u1: 1.0,
            v0: 0.0,
            v1: 1.0,
        }
    }

    /// (u1 − u0, v1 − v0).
    pub fn size(&self) -> (f64, f64) {
        (self.u1 - self.u0, self.v1 - self.v0)
    }

    /// The UV point of ROI coordinates (s, t).
    pub fn uv(&self, s: f64, t: f64) -> Point2<f64> {
        Point2::new(
            self.u0 + s * (self.u1 - self.u0),
            self.v0 + t * (self.v1 - self.v0),
        )
    }

    /// Whether the UV point lies in the closed rectangle.
    pub fn contains(&self, uv: [f64; 2]) -> bool {
        (self.u0..=self.u1).contains(&uv[0]) && (self.v0..=self.v1).contains(&uv[1])
    }

    /// Whether this is the whole texture square [0, 1]².
    pub fn is_full(&self) -> bool {
        *self == Roi::full()
    }

    /// The ROI coordinates (s, t) of a UV point.
    pub fn st(&self, uv: Point2<f64>) -> (f64, f64) {
        (
            (uv.x - self.u0) / (self.u1 - self.u0),
            (uv.y - self.v0) / (self.v1 - self.v0),
        )
    }
}

/// What the rasteriser found.
#[derive(Clone, Debug, PartialEq)]
pub struct Coverage {
    /// Texels whose centre lies in a UV triangle.
    pub covered: usize,
    /// W·H.
    pub total: usize,
    /// covered / total.
    pub fraction: f64,
    /// Texels whose centre lies in more than one UV triangle (lowest face id used).
    pub overlapping_texels: usize,
    /// Distinct faces that own at least one covered texel.
    pub faces: usize,
}

/// Which face every texel of the field reads (after filling uncovered texels).
#[derive(Clone, Debug)]
pub struct TexelMap {
    pub width: usize,
    pub height: usize,
    /// Row-major, row 0 at t = 0: the face whose derivatives the texel stores.
    pub face: Vec<u32>,
    /// Whether the texel centre lies in that face (false: filled from the nearest covered texel).
    pub covered: Vec<bool>,
    pub coverage: Coverage,
}

/// The rest stretch fields, every frame's deformed fields (lengths for the axis-aligned energy,
/// vectors for the non-axis-aligned one), and the coverage of the ROI.
#[derive(Clone, Debug)]
pub struct MeshFields {
    pub o_s: Field,
    pub o_t: Field,
    pub frames: Vec<DeformedFields>,
    /// D_s, D_t of every frame as vectors (the same texel → face map as `frames`).
    pub jacobians: Vec<DeformedJacobian>,
    pub coverage: Coverage,
}

impl MeshFields {
    /// The rest fields with a rigidity map.
    pub fn rest_fields(&self, rigidity: Field) -> super::energy::RestFields {
        super::energy::RestFields {
            o_s: self.o_s.clone(),
            o_t: self.o_t.clone(),
            rigidity,
        }
    }
}

/// ‖X_s‖, ‖X_t‖ of `mesh` over `roi` on a `size` = (W, H) field, and the coverage.
///
/// Errors: invalid mesh or no UVs (see [`TriMesh::validate_with_uvs`]); a zero field size
/// ([`Error::InvalidArgument`]); a degenerate (zero-area) UV triangle whose bounding box meets
/// the ROI ([`Error::DegenerateFace`], naming the mesh and face); no covered texel
/// ([`Error::InvalidArgument`]).
pub fn rasterize_fields(
    mesh: &TriMesh,
    roi: &Roi,
    size: (usize, usize),
) -> Result<(Field, Field, Coverage)> {
    let map = texel_map(mesh, roi, size)?;
    let (s, t) = stretch_from_map(mesh, roi, &map);
    Ok((s, t, map.coverage))
}

/// Rest and deformed fields of a mesh sequence sharing connectivity and UVs. The texel → face
/// assignment is computed once on the rest mesh and reused for every frame.
///
/// Errors: those of [`rasterize_fields`]; a frame whose face count, position indices, UV indices
/// or corner UVs differ from the rest mesh ([`Error::InvalidArgument`] naming the frame index,
/// the frame's mesh name and the first differing face); an invalid frame mesh.
pub fn frames_fields(
    rest: &TriMesh,
    frames: &[TriMesh],
    roi: &Roi,
    size: (usize, usize),
) -> Result<MeshFields> {
    for (k, frame) in frames.iter().enumerate() {
        check_same_layout(rest, frame, k)?;
    }
    let map = texel_map(rest, roi, size)?;
    check_rest_partials(rest, &map)?;
    let (o_s, o_t) = stretch_from_map(rest, roi, &map);
    let jacobians = frames
        .iter()
        .map(|frame| jacobian_from_map(frame, roi, &map))
        .collect();
    let frames = frames
        .iter()
        .map(|frame| {
            let (d_s, d_t) = stretch_from_map(frame, roi, &map);
            DeformedFields { d_s, d_t }
        })
        .collect();
    Ok(MeshFields {
        o_s,
        o_t,
        frames,
        jacobians,
        coverage: map.coverage,
    })
}

/// Every rest face under a texel of the map has non-zero, finite 3D partials X_u and X_v.
///
/// The rest stretch O_s = ‖X_u‖, O_t = ‖X_v‖ divides every stretch ratio (energy and the
/// rigid-stretch figure), so a rest triangle with coincident vertices along u or v would turn
/// them into NaN or infinity (written as `null` in `--json`). Such a face is an error naming
/// the rest mesh and the face, rather than a silent NaN.
fn check_rest_partials(rest: &TriMesh, map: &TexelMap) -> Result<()> {
    let mut checked = vec![false; rest.faces.len()];
    for &f in &map.face {
        let f = f as usize;
        if std::mem::replace(&mut checked[f], true) {
            continue;
        }
        let (xu, xv) = face_partials(rest, f);
        let usable = |x: Vector3<f64>| x.norm() > 0.0 && x.norm().is_finite();
        if !(usable(xu) && usable(xv)) {
            let [a, b, c] = rest.faces[f];
            return Err(Error::DegenerateFace {
                mesh: rest.name.clone(),
                face: f,
                reason: format!(
                    "in the rest frame its 3D triangle (vertices {a}, {b}, {c}) has zero length \
                     along u or v (coincident vertices), so the texture stretch there is \
                     undefined; separate or merge the vertices, or choose a --roi without it"
                ),
            });
        }
    }
    Ok(())
}

fn check_same_layout(rest: &TriMesh, frame: &TriMesh, k: usize) -> Result<()> {
    let fail = |what: String| {
        Err(Error::InvalidArgument(format!(
            "frame {k} ({}): {what} (rest mesh {})",
            frame.name, rest.name
        )))
    };
    if let Err(e) = frame.validate_with_uvs() {
        return fail(format!("invalid mesh: {e}"));
    }
    if frame.faces.len() != rest.faces.len() {
        return fail(format!(
            "has {} faces, the rest mesh {}",
            frame.faces.len(),
            rest.faces.len()
        ));
    }
    for f in 0..rest.faces.len() {
        if frame.faces[f] != rest.faces[f] {
            return fail(format!(
                "face {f} has vertices {:?}, the rest mesh {:?}",
                frame.faces[f], rest.faces[f]
            ));
        }
        if frame.uv_faces.get(f) != rest.uv_faces.get(f) {
            return fail(format!(
                "face {f} has texture coordinates {:?}, the rest mesh {:?}",
                frame.uv_faces.get(f),
                rest.uv_faces.get(f)
            ));
        }
        if rest.has_uvs() && frame.face_uvs(f) != rest.face_uvs(f) {
            return fail(format!(
                "face {f} has UVs {:?}, the rest mesh {:?}",
                frame.face_uvs(f),
                rest.face_uvs(f)
            ));
        }
    }
    Ok(())
}

/// ‖X_s‖, ‖X_t‖ of every face (in ROI coordinates), computed lazily for the faces the map uses.
fn stretch_from_map(mesh: &TriMesh, roi: &Roi, map: &TexelMap) -> (Field, Field) {
    let (du, dv) = roi.size();
    let mut per_face: Vec<Option<(f64, f64)>> = vec![None; mesh.faces.len()];
    for &f in &map.face {
        let slot = &mut per_face[f as usize];
        if slot.is_none() {
            let (xu, xv) = face_partials(mesh, f as usize);
            *slot = Some(((xu * du).norm(), (xv * dv).norm()));
        }
    }
    let (mut s, mut t) = (
        Vec::with_capacity(map.face.len()),
        Vec::with_capacity(map.face.len()),
    );
    for &f in &map.face {
        let (a, b) = per_face[f as usize].expect("computed above");
        s.push(a);
        t.push(b);
    }
    let field = |values| Field {
        width: map.width,
        height: map.height,
        values,
    };
    (field(s), field(t))
}

/// (X_s, X_t) of one face.
type FacePartials = (Vector3<f64>, Vector3<f64>);

/// The vectors X_s = X_u (u1 − u0), X_t = X_v (v1 − v0) of every texel's face (the
/// non-axis-aligned energy's D_s, D_t, seed §8), mirroring the length fields: constant per
/// triangle, each component a [`Field`] on the map's texels.
pub fn jacobian_from_map(mesh: &TriMesh, roi: &Roi, map: &TexelMap) -> DeformedJacobian {
    let (du, dv) = roi.size();
    let mut per_face: Vec<Option<FacePartials>> = vec![None; mesh.faces.len()];
    for &f in &map.face {
        let slot = &mut per_face[f as usize];
        if slot.is_none() {
            let (xu, xv) = face_partials(mesh, f as usize);
            *slot = Some((xu * du, xv * dv));
        }
    }
    let component = |pick: &dyn Fn(&FacePartials) -> f64| Field {
        width: map.width,
        height: map.height,
        values: map
            .face
            .iter()
            .map(|&f| pick(per_face[f as usize].as_ref().expect("computed above")))
            .collect(),
    };
    DeformedJacobian {
        d_s: VectorField {
            x: component(&|p| p.0.x),
            y: component(&|p| p.0.y),
            z: component(&|p| p.0.z),
        },
        d_t: VectorField {
            x: component(&|p| p.1.x),
            y: component(&|p| p.1.y),
            z: component(&|p| p.1.z),
        },
    }
}

/// (X_u, X_v) of face `f`: [X_u X_v] = [e1 e2]·[w1−w0  w2−w0]⁻¹ (non-degenerate UVs).
pub fn face_partials(mesh: &TriMesh, f: usize) -> (Vector3<f64>, Vector3<f64>) {
    let [p0, p1, p2] = mesh.face_positions(f);
    let [w0, w1, w2] = mesh.face_uvs(f);
    let (e1, e2) = (p1 - p0, p2 - p0);
    let (a, b) = (w1 - w0, w2 - w0);
    let det = a.x * b.y - b.x * a.y;
    let xu = (e1 * b.y - e2 * a.y) / det;
    let xv = (e2 * a.x - e1 * b.x) / det;
    (xu, xv)
}

/// Twice the signed UV area of face `f` and its longest squared edge.
fn uv_area2(w: &[Point2<f64>; 3]) -> (f64, f64) {
    let (a, b) = (w[1] - w[0], w[2] - w[0]);
    let longest = a
        .norm_squared()
        .max(b.norm_squared())
        .max((w[2] - w[1]).norm_squared());
    (a.x * b.y - b.x * a.y, longest)
}

/// A UV triangle prepared for point location.
struct Tri {
    face: u32,
    /// Canonical edges (a, b) with a < b lexicographically, and the sign of the edge function at
    /// the opposite corner.
    edges: [(Point2<f64>, Point2<f64>, bool); 3],
    umin: f64,
    umax: f64,
}

impl Tri {
    fn new(face: u32, w: [Point2<f64>; 3]) -> Tri {
        let edge = |i: usize| {
            let (p, q, r) = (w[i], w[(i + 1) % 3], w[(i + 2) % 3]);
            let (a, b) = if (p.x, p.y) < (q.x, q.y) {
                (p, q)
            } else {
                (q, p)
            };
            (a, b, edge_fn(a, b, r) > 0.0)
        };
        Tri {
            face,
            edges: [edge(0), edge(1), edge(2)],
            umin: w[0].x.min(w[1].x).min(w[2].x),
            umax: w[0].x.max(w[1].x).max(w[2].x),
        }
    }

    /// Whether `p` lies in the triangle (tie rule in the module docs).
    fn contains(&self, p: Point2<f64>) -> bool {
        self.edges.iter().all(|&(a, b, positive)| {
            let e = edge_fn(a, b, p);
            // e == 0: on the edge; the perturbation (−ε², ε) makes the canonical value positive.
            (e >= 0.0) == positive
        })
    }
}

fn edge_fn(a: Point2<f64>, b: Point2<f64>, p: Point2<f64>) -> f64 {
    (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
}

/// The texel → face assignment of `mesh` over `roi` (module docs).
pub fn texel_map(mesh: &TriMesh, roi: &Roi, size: (usize, usize)) -> Result<TexelMap> {
    let (w, h) = size;
    if w == 0 || h == 0 {
        return Err(Error::InvalidArgument(format!(
            "{}: field size {w}x{h} must be at least 1x1",
            mesh.name
        )));
    }
    mesh.validate_with_uvs()?;
    let us: Vec<f64> = (0..w)
        .map(|x| roi.uv((x as f64 + 0.5) / w as f64, 0.0).x)
        .collect();
    let vs: Vec<f64> = (0..h)
        .map(|y| roi.uv(0.0, (y as f64 + 0.5) / h as f64).y)
        .collect();
    let (du, dv) = roi.size();

    // Bin the faces overlapping the ROI by texel row, in face order.
    let mut tris: Vec<Tri> = Vec::new();
    let mut rows: Vec<Vec<u32>> = vec![Vec::new(); h];
    for f in 0..mesh.faces.len() {
        let uv = mesh.face_uvs(f);
        let (vmin, vmax) = (
            uv[0].y.min(uv[1].y).min(uv[2].y),
            uv[0].y.max(uv[1].y).max(uv[2].y),
        );
        let (umin, umax) = (
            uv[0].x.min(uv[1].x).min(uv[2].x),
            uv[0].x.max(uv[1].x).max(uv[2].x),
        );
        if umax < roi.u0 || umin > roi.u1 || vmax < roi.v0 || vmin > roi.v1 {
            continue;
        }
        let (area2, longest) = uv_area2(&uv);
        if area2.abs() <= 1e-12 * longest || longest == 0.0 {
            return Err(Error::DegenerateFace {
                mesh: mesh.name.clone(),
                face: f,
                reason: format!(
                    "its UV triangle {:?} has zero area and overlaps the ROI u [{}, {}] x v [{}, {}]",
                    uv.map(|p| (p.x, p.y)),
                    roi.u0,
                    roi.u1,
                    roi.v0,
                    roi.v1
                ),
            });
        }
        // Rows whose centre t lies in [tmin, tmax], widened by one (the test is exact).
        let y_lo = (((vmin - roi.v0) / dv * h as f64 - 0.5).floor() - 1.0).max(0.0) as usize;
        let y_hi = (((vmax - roi.v0) / dv * h as f64 - 0.5).ceil() + 1.0).min(h as f64 - 1.0);
        if y_hi < 0.0 {
            continue;
        }
        let index = tris.len() as u32;
        tris.push(Tri::new(f as u32, uv));
        for row in rows.iter_mut().take(y_hi as usize + 1).skip(y_lo) {
            row.push(index);
        }
    }

    // Locate every texel centre, row by row.
    let located: Vec<(Vec<u32>, usize)> = rows
        .par_iter()
        .enumerate()
        .map(|(y, row)| {
            let mut faces = vec![NONE; w];
            let mut hits = vec![0u8; w];
            // Faces in ascending id: the first to claim a texel keeps it.
            for &i in row {
                let tri = &tris[i as usize];
                let x_lo = (((tri.umin - roi.u0) / du * w as f64 - 0.5).floor() - 1.0).max(0.0);
                let x_hi =
                    (((tri.umax - roi.u0) / du * w as f64 - 0.5).ceil() + 1.0).min(w as f64 - 1.0);
                if x_hi < x_lo {
                    continue;
                }
                for x in x_lo as usize..=x_hi as usize {
                    if tri.contains(Point2::new(us[x], vs[y])) {
                        if hits[x] == 0 {
                            faces[x] = tri.face;
                        }
                        hits[x] = hits[x].saturating_add(1);
                    }
                }
            }
            let overlaps = hits.iter().filter(|&&n| n > 1).count();
            (faces, overlaps)
        })
        .collect();
    let mut face = Vec::with_capacity(w * h);
    let mut overlapping_texels = 0;
    for (row, overlaps) in located {
        face.extend(row);
        overlapping_texels += overlaps;
    }
    let covered: Vec<bool> = face.iter().map(|&f| f != NONE).collect();
    let covered_count = covered.iter().filter(|&&c| c).count();
    if covered_count == 0 {
        return Err(Error::InvalidArgument(format!(
            "{}: no UV triangle covers a texel centre of the ROI u [{}, {}] x v [{}, {}] ({w}x{h} texels)",
            mesh.name, roi.u0, roi.u1, roi.v0, roi.v1
        )));
    }
    let mut distinct: Vec<u32> = face.iter().copied().filter(|&f| f != NONE).collect();
    distinct.sort_unstable();
    distinct.dedup();
    let source = nearest_covered(&covered, w, h);
    let filled: Vec<u32> = source.iter().map(|&i| face[i]).collect();
    Ok(TexelMap {
        width: w,
        height: h,
        face: filled,
        covered,
        coverage: Coverage {
            covered: covered_count,
            total: w * h,
            fraction: covered_count as f64 / (w * h) as f64,
            overlapping_texels,
            faces: distinct.len(),
        },
    })
}

/// For every texel, the index of the nearest covered texel (itself if covered): exact Euclidean
/// distance transform (a column pass, then the lower envelope of parabolas along rows,
/// Felzenszwalb & Huttenlocher 2012). At least one texel must be covered.
fn nearest_covered(covered: &[bool], w: usize, h: usize) -> Vec<usize> {
    // Column pass: for each (x, y), the nearest covered row y' in column x (or none).
    let columns: Vec<Vec<Option<usize>>> = (0..w)
        .into_par_iter()
        .map(|x| {
            let mut best = vec![None; h];
            let mut last = None;
            for y in 0..h {
                if covered[y * w + x] {
                    last = Some(y);
                }
                best[y] = last;
            }
            let mut next = None;
            for y in (0..h).rev() {
                if covered[y * w + x] {
                    next = Some(y);
                }
                best[y] = match (best[y], next) {
                    (Some(a), Some(b)) => Some(if y - a <= b - y { a } else { b }),
                    (a, b) => a.or(b),
                };
            }
            best
        })
        .collect();
    // Row pass: minimise (x − x')² + g(x')² over the columns x' with a covered texel.
    let rows: Vec<Vec<usize>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let f = |x: usize| -> Option<f64> {
                columns[x][y].map(|yy| {
                    let d = yy.abs_diff(y) as f64;
                    d * d
                })
            };
            // Lower envelope of the parabolas (x − q)² + f(q).
            let mut v: Vec<usize> = Vec::with_capacity(w);
            let mut z: Vec<f64> = Vec::with_capacity(w + 1);
            for q in 0..w {
                let Some(fq) = f(q) else { continue };
                loop {
                    let Some(&p) = v.last() else {
                        v.push(q);
                        z.clear();
                        z.push(f64::NEG_INFINITY);
                        break;
                    };
                    let fp = f(p).expect("in envelope");
                    let (qf, pf) = (q as f64, p as f64);
                    let s = ((fq + qf * qf) - (fp + pf * pf)) / (2.0 * (qf - pf));
                    if s <= *z.last().expect("z") {
                        v.pop();
                        z.pop();
                        if v.is_empty() {
                            continue;
                        }
                    } else {
                        v.push(q);
                        z.push(s);
                        break;
                    }
                }
            }
            let mut out = vec![0; w];
            if v.is_empty() {
                // Rows with no covered texel in any column cannot happen (at least one covered
                // texel exists, and every column pass spreads it to all rows of its column).
                return out;
            }
            let mut k = 0;
            for (x, o) in out.iter_mut().enumerate() {
                while k + 1 < v.len() && z[k + 1] < x as f64 {
                    k += 1;
                }
                let q = v[k];
                *o = columns[q][y].expect("in envelope") * w + q;
            }
            out
        })
        .collect();
    rows.concat()
}

/// A rigidity map R over `roi` (the whole texture when `None`) on a `size` = (W, H) field, from
/// a grey image read with [`load_gray_f32`] (PNG 8/16-bit as x/255 or x/65535, EXR raw values).
///
/// Each field texel is the bilinear sample of the image at the texel centre's UV, with the OBJ
/// convention (v = 0 is the bottom row of the image), pixel centres at half-integers and
/// clamp-to-edge addressing; any image size works (it is resampled — a much larger image is
/// point-sampled by the bilinear filter, so pre-filter it if it has fine detail). Values are
/// clamped to [0, 1]; NaN becomes 0.
///
/// Errors: an unreadable or undecodable file ([`Error::Io`] / [`Error::Image`] naming it); an
/// empty image or a zero field size.
pub fn rigidity_from_image(path: &Path, roi: Option<&Roi>, size: (usize, usize)) -> Result<Field> {
    let (w, h) = size;
    if w == 0 || h == 0 {
        return Err(Error::InvalidArgument(format!(
            "{}: rigidity field size {w}x{h} must be at least 1x1",
            path.display()
        )));
    }
    let image = load_gray_f32(path)?;
    if image.width == 0 || image.height == 0 || image.pixels.len() < image.width * image.height {
        return Err(Error::Image {
            path: path.to_path_buf(),
            message: format!("empty rigidity map ({}x{})", image.width, image.height),
        });
    }
    let roi = roi.copied().unwrap_or_else(Roi::full);
    let (iw, ih) = (image.width, image.height);
    let px = |x: usize, y: usize| image.pixels[y * iw + x] as f64;
    Ok(Field::from_fn(w, h, |s, t| {
        let uv = roi.uv(s, t);
        let fx = (uv.x * iw as f64 - 0.5).clamp(0.0, (iw - 1) as f64);
        let fy = ((1.0 - uv.y) * ih as f64 - 0.5).clamp(0.0, (ih - 1) as f64);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(iw - 1), (y0 + 1).min(ih - 1));
        let (a, b) = (fx - x0 as f64, fy - y0 as f64);
        let value = (1.0 - a) * (1.0 - b) * px(x0, y0)
            + a * (1.0 - b) * px(x1, y0)
            + (1.0 - a) * b * px(x0, y1)
            + a * b * px(x1, y1);
        if value.is_nan() {
            0.0
        } else {
            value.clamp(0.0, 1.0)
        }
    }))
}

/// [`rigidity_from_image`] for a map that must have `expected` = (W, H) pixels, up to `slack`
/// pixels per axis (a map painted over a ROI rectangle of a W_tex × H_tex texture has
/// (u1 − u0)·W_tex × (v1 − v0)·H_tex pixels, rounded either way: slack 1). A map of another size
/// was painted for another texture or region; resampling it would misplace every feature.
///
/// Errors: those of [`rigidity_from_image`]; a size outside the slack ([`Error::Image`] naming
/// the file, its size and the expected one).
pub fn rigidity_from_image_of_size(
    path: &Path,
    roi: Option<&Roi>,
    size: (usize, usize),
    expected: (usize, usize),
    slack: usize,
) -> Result<Field> {
    let image = load_gray_f32(path)?;
    let (w, h) = (image.width, image.height);
    if w.abs_diff(expected.0) > slack || h.abs_diff(expected.1) > slack {
        return Err(Error::Image {
            path: path.to_path_buf(),
            message: format!(
                "rigidity map is {w}x{h} pixels, expected {}x{} (±{slack}) for the region it covers",
                expected.0, expected.1
            ),
        });
    }
    rigidity_from_image(path, roi, size)
}
