//! CPU f64 reference rasteriser: a camera, a z-buffer of (face, barycentrics) per pixel, and
//! shading of that buffer into a picture.
//!
//! Conventions are wgpu's, so that a GPU render with the same matrix (as f32) lines up pixel for
//! pixel: right-handed view space looking down −z; clip-space depth in [0, 1] (not OpenGL's
//! [−1, 1]); NDC y up; pixel (0, 0) at the top-left with
//! `x_pix = (ndc.x + 1) / 2 · W`, `y_pix = (1 − ndc.y) / 2 · H`, pixel centres at `+0.5`.

use nalgebra::{Matrix4, Point3, Vector3, Vector4};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::texture::{Image, Rgba8};

// ---------------------------------------------------------------------------------------------
// Camera

/// A perspective camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: Point3<f64>,
    pub target: Point3<f64>,
    /// Approximate up direction (need not be orthogonal to the view direction).
    pub up: Vector3<f64>,
    /// Full vertical field of view.
    pub fov_y_degrees: f64,
    /// Distances to the near and far planes (`0 < near < far`).
    pub near: f64,
    pub far: f64,
    /// Width / height of the picture.
    pub aspect: f64,
}

impl Default for Camera {
    /// Looking from (0, 0, 3) at the origin, y up, 45° vertical field of view, square picture.
    fn default() -> Self {
        Camera {
            eye: Point3::new(0.0, 0.0, 3.0),
            target: Point3::origin(),
            up: Vector3::y(),
            fov_y_degrees: 45.0,
            near: 0.1,
            far: 100.0,
            aspect: 1.0,
        }
    }
}

/// Extra room around the bounding sphere when framing a mesh (1.05 = 5 %).
const FRAME_MARGIN: f64 = 1.05;

impl Camera {
    /// A camera with the default 45° field of view looking along `view_dir` at the centre of
    /// `mesh`'s bounding sphere (centre = bounding-box centre, radius = farthest vertex), at the
    /// distance `d = 1.05 · radius / sin(α)` where α is the smaller of the vertical and
    /// horizontal half fields of view, so the whole sphere is visible. Near and far planes
    /// enclose the sphere: `near = (d − radius) / 2`, `far = 2 (d + radius)`.
    /// Up is +y, or +z when looking (nearly) along y.
    ///
    /// A zero or non-finite `view_dir` is replaced by −z; an empty mesh frames the unit sphere.
    pub fn frame_mesh(mesh: &TriMesh, view_dir: Vector3<f64>, aspect: f64) -> Camera {
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        let view_dir = view_dir
            .try_normalize(1e-12)
            .filter(|v| v.iter().all(|x| x.is_finite()))
            .unwrap_or(-Vector3::z());
        let (centre, radius) = bounding_sphere(mesh);
        let fov_y_degrees = Camera::default().fov_y_degrees;
        let half_y = fov_y_degrees.to_radians() / 2.0;
        let half_x = (aspect * half_y.tan()).atan();
        let distance = FRAME_MARGIN * radius / half_y.min(half_x).sin();
        let up = if view_dir.y.abs() > 0.99 {
            Vector3::z()
        } else {
            Vector3::y()
        };
        Camera {
            eye: centre - view_dir * distance,
            target: centre,
            up,
            fov_y_degrees,
            near: (distance - radius) / 2.0,
            far: 2.0 * (distance + radius),
            aspect,
        }
    }

    /// The right-handed look-at view matrix (camera at `eye` looking down its −z axis).
    pub fn view(&self) -> Matrix4<f64> {
        Matrix4::look_at_rh(&self.eye, &self.target, &self.up)
    }

    /// Perspective projection with depth in [0, 1] (wgpu), `f = 1 / tan(fov_y / 2)`:
    /// ```text
    /// [ f/aspect  0   0            0               ]
    /// [ 0         f   0            0               ]
    /// [ 0         0   far/(n−far)  n·far/(n−far)   ]   (n = near)
    /// [ 0         0   −1           0               ]
    /// ```
    /// View-space z = −near maps to depth 0, z = −far to depth 1.
    pub fn projection(&self) -> Matrix4<f64> {
        let f = 1.0 / (self.fov_y_degrees.to_radians() / 2.0).tan();
        let (n, far) = (self.near, self.far);
        #[rustfmt::skip]
        let m = Matrix4::new(
            f / self.aspect, 0.0, 0.0,             0.0,
            0.0,             f,   0.0,             0.0,
            0.0,             0.0, far / (n - far), n * far / (n - far),
            0.0,             0.0, -1.0,            0.0,
        );
        m
    }

    /// `projection · view`: world position (homogeneous) to clip space, wgpu convention.
    pub fn view_proj(&self) -> Matrix4<f64> {
        self.projection() * self.view()
    }
}

/// Centre (bounding-box centre) and radius (farthest vertex from it) of the mesh's positions;
/// the unit sphere for an empty mesh or non-finite coordinates, radius 1 for a single point.
fn bounding_sphere(mesh: &TriMesh) -> (Point3<f64>, f64) {
    if mesh.positions.is_empty() {
        return (Point3::origin(), 1.0);
    }
    let (lo, hi) = mesh.bounding_box();
    let centre = nalgebra::center(&lo, &hi);
    let radius = mesh
        .positions
        .iter()
        .map(|p| (p - centre).norm())
        .fold(0.0, f64::max);
    if !(centre.iter().all(|x| x.is_finite()) && radius.is_finite()) {
        return (Point3::origin(), 1.0);
    }
    (centre, if radius > 0.0 { radius } else { 1.0 })
}

/// Pixel coordinates of an NDC point: `x = (ndc.x + 1) / 2 · W`, `y = (1 − ndc.y) / 2 · H`
/// (origin at the top-left corner of the picture; pixel (i, j) has its centre at (i + ½, j + ½)).
pub fn ndc_to_pixel(ndc_x: f64, ndc_y: f64, width: usize, height: usize) -> [f64; 2] {
    [
        (ndc_x + 1.0) / 2.0 * width as f64,
        (1.0 - ndc_y) / 2.0 * height as f64,
    ]
}

// ---------------------------------------------------------------------------------------------
// Rasterisation

/// What is seen at one pixel centre: a face and the perspective-correct barycentric
/// coordinates of the point on it, weights of the face's corners 0, 1, 2 (summing to 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    pub face: u32,
    pub bary: [f64; 3],
}

/// The result of [`rasterize`]: per pixel (row-major, top row first) the nearest fragment and
/// its depth (NDC z in [0, 1]; `f64::INFINITY` where nothing was drawn).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameBuffer {
    pub width: usize,
    pub height: usize,
    pub fragments: Vec<Option<Fragment>>,
    pub depth: Vec<f64>,
}

impl FrameBuffer {
    /// The fragment at pixel (x, y), if any.
    pub fn fragment(&self, x: usize, y: usize) -> Option<Fragment> {
        self.fragments[y * self.width + x]
    }

    /// Number of pixels where some face was drawn.
    pub fn covered_pixels(&self) -> usize {
        self.fragments.iter().filter(|f| f.is_some()).count()
    }
}

/// Rows per band: the unit of parallel work in [`rasterize`].
const BAND_ROWS: usize = 16;

/// Rasterise `mesh` seen through `view_proj` (see [`Camera::view_proj`]) into a
/// `width × height` frame buffer.
///
/// - A pixel is covered when its centre lies inside the triangle or on an edge (so shared
///   edges leave no gaps). Screen-space barycentrics `λᵢ` come from edge functions; the stored
///   perspective-correct ones are `bᵢ = (λᵢ / wᵢ) / Σⱼ (λⱼ / wⱼ)` (w = clip-space w), and the
///   depth is the screen-linear `Σ λᵢ zᵢ / wᵢ`, as on a GPU.
/// - Z-buffer: the smallest depth wins; equal depths go to the lower face index. Fragments
///   with depth outside [0, 1] are discarded (the GPU's depth clipping).
/// - Triangles with a corner in front of the near plane (clip z < 0), behind the eye (w ≤ 0)
///   or non-finite are skipped whole, not clipped: keep the mesh inside the view volume
///   ([`Camera::frame_mesh`] does). Zero-area triangles are skipped, and so are exact repeats
///   of an earlier face (which could never win a pixel, see `repeated_faces`). No back-face
///   culling.
/// - Parallel over bands of 16 rows; the result does not depend on the number of threads.
///
/// The mesh's indices must be in range (see [`TriMesh::validate`]); otherwise this panics.
pub fn rasterize(
    mesh: &TriMesh,
    view_proj: &Matrix4<f64>,
    width: usize,
    height: usize,
) -> FrameBuffer {
    rasterize_clip(mesh, &clip_positions(mesh, view_proj), width, height, |p| p)
}

/// Every vertex of `mesh` in clip space, `view_proj · (p, 1)`.
pub fn clip_positions(mesh: &TriMesh, view_proj: &Matrix4<f64>) -> Vec<Vector4<f64>> {
    mesh.positions
        .par_iter()
        .map(|p| view_proj * p.to_homogeneous())
        .collect()
}

/// [`rasterize`] from the vertices' clip-space positions `clip` (one per vertex of `mesh`), with
/// each projected corner passed through `snap` (pixel coordinates in, pixel coordinates out)
/// before the edge functions are set up: the identity for the reference, a rounding to the
/// sub-pixel grid to model a GPU's fixed-function rasteriser (`twin::bpm_render`).
pub fn rasterize_clip(
    mesh: &TriMesh,
    clip: &[Vector4<f64>],
    width: usize,
    height: usize,
    snap: impl Fn([f64; 2]) -> [f64; 2] + Sync,
) -> FrameBuffer {
    let triangles = screen_triangles_with(mesh, clip, width, height, 0.0, &snap);
    let bins = bin_by_band(&triangles, height);

    let mut fb = FrameBuffer {
        width,
        height,
        fragments: vec![None; width * height],
        depth: vec![f64::INFINITY; width * height],
    };
    let band_len = (BAND_ROWS * width).max(1);
    fb.fragments
        .par_chunks_mut(band_len)
        .zip(fb.depth.par_chunks_mut(band_len))
        .zip(bins.par_iter())
        .enumerate()
        .for_each(|(band, ((fragments, depth), members))| {
            let mut target = BandTarget {
                first_row: band * BAND_ROWS,
                width,
                fragments,
                depth,
            };
            for &t in members {
                target.draw(&triangles[t as usize]);
            }
        });
    fb
}

/// The drawable faces of `mesh` set up for rasterisation (see [`rasterize`] for which are
/// skipped), with each pixel box widened by `margin` pixels on every side: a face is kept when
/// some pixel centre lies within its corners' box widened so.
pub fn screen_triangles(
    mesh: &TriMesh,
    clip: &[Vector4<f64>],
    width: usize,
    height: usize,
    margin: f64,
) -> Vec<ScreenTriangle> {
    screen_triangles_with(mesh, clip, width, height, margin, &|p| p)
}

fn screen_triangles_with(
    mesh: &TriMesh,
    clip: &[Vector4<f64>],
    width: usize,
    height: usize,
    margin: f64,
    snap: &(impl Fn([f64; 2]) -> [f64; 2] + Sync),
) -> Vec<ScreenTriangle> {
    let repeated = repeated_faces(mesh);
    mesh.faces
        .par_iter()
        .enumerate()
        .filter(|&(f, _)| !repeated[f])
        .filter_map(|(f, tri)| {
            let corners = tri.map(|v| clip[v as usize]);
            ScreenTriangle::new(f as u32, &corners, width, height, margin, snap)
        })
        .collect()
}

/// `repeated[f]`: face `f` has the same corners in the same order as an earlier face.
///
/// Such a face can never be drawn: its depth at every pixel is computed from the same numbers in
/// the same order as the earlier face's, so it ties, and ties go to the lower face index. Leaving
/// it out changes no pixel, and keeps a file of one triangle repeated 66 000 times (a polygon
/// of 200 000 corners over three vertices, issue #25) from costing 66 000 full overdraws.
/// O(F) expected, sequential (the first occurrence is kept whatever the thread count).
fn repeated_faces(mesh: &TriMesh) -> Vec<bool> {
    let mut seen = std::collections::HashSet::with_capacity(mesh.faces.len());
    mesh.faces.iter().map(|&tri| !seen.insert(tri)).collect()
}

/// A triangle set up for rasterisation: pixel-space corners, clip data and its pixel box.
pub struct ScreenTriangle {
    face: u32,
    /// Corners in pixel coordinates.
    corners: [[f64; 2]; 3],
    /// `1 / w` of each corner (perspective correction).
    inv_w: [f64; 3],
    /// NDC depth `z / w` of each corner.
    depth: [f64; 3],
    /// Twice the signed pixel-space area (non-zero).
    area2: f64,
    /// Inclusive pixel ranges whose centres may be inside.
    columns: (usize, usize),
    rows: (usize, usize),
}

impl ScreenTriangle {
    /// Project the clip-space corners (then `snap` them); `None` when the triangle is skipped
    /// (see [`rasterize`]) or no pixel centre of the picture lies within `margin` pixels of
    /// its box.
    fn new(
        face: u32,
        clip: &[Vector4<f64>; 3],
        width: usize,
        height: usize,
        margin: f64,
        snap: &impl Fn([f64; 2]) -> [f64; 2],
    ) -> Option<Self> {
        let drawable =
            |c: &Vector4<f64>| c.iter().all(|x| x.is_finite()) && c.w > 0.0 && c.z >= 0.0;
        if !clip.iter().all(drawable) {
            return None;
        }
        let corners = clip.map(|c| snap(ndc_to_pixel(c.x / c.w, c.y / c.w, width, height)));
        let area2 = edge_function(corners[0], corners[1], corners[2]);
        if area2 == 0.0 {
            return None;
        }
        let columns = pixel_range(corners.map(|p| p[0]), width, margin)?;
        let rows = pixel_range(corners.map(|p| p[1]), height, margin)?;
        Some(ScreenTriangle {
            face,
            corners,
            inv_w: clip.map(|c| 1.0 / c.w),
            depth: clip.map(|c| c.z / c.w),
            area2,
            columns,
            rows,
        })
    }

    /// The mesh face this triangle draws.
    pub fn face(&self) -> u32 {
        self.face
    }

    /// Inclusive ranges of pixel columns and rows whose centres may lie within the box (and
    /// its margin).
    pub fn pixel_box(&self) -> ((usize, usize), (usize, usize)) {
        (self.columns, self.rows)
    }

    /// Screen-space barycentrics `λ` of a point, `λᵢ = (edge opposite corner i)(p) / area2`.
    fn screen_barycentrics(&self, p: [f64; 2]) -> [f64; 3] {
        let [a, b, c] = self.corners;
        [
            edge_function(b, c, p) / self.area2,
            edge_function(c, a, p) / self.area2,
            edge_function(a, b, p) / self.area2,
        ]
    }

    /// Signed distance (pixels) from `p` to the triangle's boundary, positive inside:
    /// `minᵢ λᵢ(p) · hᵢ`, hᵢ the height over the edge opposite corner i (exact inside and
    /// near an edge; outside near a corner, a lower bound on the distance's magnitude).
    pub fn signed_distance(&self, p: [f64; 2]) -> f64 {
        let lambda = self.screen_barycentrics(p);
        (0..3)
            .map(|i| {
                let (a, b) = (self.corners[(i + 1) % 3], self.corners[(i + 2) % 3]);
                let length = (b[0] - a[0]).hypot(b[1] - a[1]);
                lambda[i] * self.area2.abs() / length
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The screen-linear depth `Σ λᵢ zᵢ / wᵢ` at `p` (extrapolated outside the triangle).
    pub fn depth_at(&self, p: [f64; 2]) -> f64 {
        self.depth_of(self.screen_barycentrics(p))
    }

    fn depth_of(&self, lambda: [f64; 3]) -> f64 {
        (0..3).map(|i| lambda[i] * self.depth[i]).sum()
    }

    /// |∇ depth| in depth units per pixel (the depth is linear in screen space).
    pub fn depth_slope(&self) -> f64 {
        let at = |p| self.depth_at(p);
        let o = [0.0, 0.0];
        (at([1.0, 0.0]) - at(o)).hypot(at([0.0, 1.0]) - at(o))
    }

    /// Perspective-correct barycentrics `bᵢ = (λᵢ / wᵢ) / Σⱼ (λⱼ / wⱼ)` at `p`, inside the
    /// triangle or (extrapolated) near it.
    pub fn barycentrics_at(&self, p: [f64; 2]) -> [f64; 3] {
        self.barycentrics_of(self.screen_barycentrics(p))
    }

    fn barycentrics_of(&self, lambda: [f64; 3]) -> [f64; 3] {
        let weighted = [0, 1, 2].map(|i| lambda[i] * self.inv_w[i]);
        let total: f64 = weighted.iter().sum();
        weighted.map(|x| x / total)
    }

    /// The fragment and depth at a pixel centre inside the triangle and the depth range.
    fn fragment_at(&self, centre: [f64; 2]) -> Option<(Fragment, f64)> {
        let lambda = self.screen_barycentrics(centre);
        if lambda.iter().any(|&l| l < 0.0) {
            return None;
        }
        let depth = self.depth_of(lambda);
        if !(0.0..=1.0).contains(&depth) {
            return None;
        }
        Some((
            Fragment {
                face: self.face,
                bary: self.barycentrics_of(lambda),
            },
            depth,
        ))
    }
}

/// Twice the signed area of the triangle (a, b, p): `(b − a) × (p − a)`.
fn edge_function(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Pixels `i` in `0..size` whose centres `i + ½` lie in `[min − margin, max + margin]` of the
/// given coordinates.
fn pixel_range(coords: [f64; 3], size: usize, margin: f64) -> Option<(usize, usize)> {
    let lo = coords.iter().copied().fold(f64::INFINITY, f64::min) - margin;
    let hi = coords.iter().copied().fold(f64::NEG_INFINITY, f64::max) + margin;
    let first = (lo - 0.5).ceil().max(0.0);
    let last = (hi - 0.5).floor().min(size as f64 - 1.0);
    (first <= last).then_some((first as usize, last as usize))
}

/// For each band of [`BAND_ROWS`] rows, the indices of the triangles whose rows reach it, in
/// face order.
fn bin_by_band(triangles: &[ScreenTriangle], height: usize) -> Vec<Vec<u32>> {
    let mut bins = vec![Vec::new(); height.div_ceil(BAND_ROWS)];
    for (t, tri) in triangles.iter().enumerate() {
        for bin in &mut bins[tri.rows.0 / BAND_ROWS..=tri.rows.1 / BAND_ROWS] {
            bin.push(t as u32);
        }
    }
    bins
}

/// The rows of one band of the frame buffer.
struct BandTarget<'a> {
    first_row: usize,
    width: usize,
    fragments: &'a mut [Option<Fragment>],
    depth: &'a mut [f64],
}

impl BandTarget<'_> {
    /// Z-test and write every pixel of this band covered by `tri`.
    fn draw(&mut self, tri: &ScreenTriangle) {
        let rows_here = self.fragments.len() / self.width.max(1);
        let first = tri.rows.0.max(self.first_row);
        let last = tri.rows.1.min(self.first_row + rows_here - 1);
        for y in first..=last {
            for x in tri.columns.0..=tri.columns.1 {
                let centre = [x as f64 + 0.5, y as f64 + 0.5];
                if let Some((fragment, depth)) = tri.fragment_at(centre) {
                    self.z_test_and_write((y - self.first_row) * self.width + x, fragment, depth);
                }
            }
        }
    }

    /// Keep the nearer fragment; on equal depth, the one of the lower face index.
    fn z_test_and_write(&mut self, i: usize, fragment: Fragment, depth: f64) {
        let nearer = match self.fragments[i] {
            None => true,
            Some(old) => {
                depth < self.depth[i] || (depth == self.depth[i] && fragment.face < old.face)
            }
        };
        if nearer {
            self.fragments[i] = Some(fragment);
            self.depth[i] = depth;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Pictures

/// Colour each pixel: `f(face, bary)` where a fragment was drawn, `background` elsewhere.
pub fn shade(
    fb: &FrameBuffer,
    background: Rgba8,
    f: impl Fn(u32, [f64; 3]) -> Rgba8 + Sync,
) -> Image<Rgba8> {
    let pixels = fb
        .fragments
        .par_iter()
        .map(|fragment| fragment.map_or(background, |fr| f(fr.face, fr.bary)))
        .collect();
    Image {
        width: fb.width,
        height: fb.height,
        pixels,
    }
}

/// How different two renders are, over the R, G, B channels (alpha ignored).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct DiffStats {
    /// Peak signal-to-noise ratio `10 log₁₀(255² / MSE)` in dB (infinite for identical images).
    pub psnr_db: f64,
    /// Fraction of pixels where some channel differs by more than 1 (of 255).
    pub fraction_over_1_of_255: f64,
    /// Largest absolute channel difference.
    pub max_abs: u8,
}

/// Compare two images of the same size (see [`DiffStats`]); an error if the sizes differ.
pub fn image_diff(a: &Image<Rgba8>, b: &Image<Rgba8>) -> Result<DiffStats> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::InvalidArgument(format!(
            "cannot compare a {}x{} image with a {}x{} image",
            a.width, a.height, b.width, b.height
        )));
    }
    let mut squared_sum = 0.0;
    let (mut over, mut max_abs) = (0usize, 0u8);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let diffs = [0, 1, 2].map(|c| p[c].abs_diff(q[c]));
        squared_sum += diffs.iter().map(|&d| (d as f64).powi(2)).sum::<f64>();
        let largest = *diffs.iter().max().unwrap_or(&0);
        over += usize::from(largest > 1);
        max_abs = max_abs.max(largest);
    }
    let pixels = a.pixels.len().max(1) as f64;
    let mse = squared_sum / (3.0 * pixels);
    Ok(DiffStats {
        psnr_db: 10.0 * (255.0f64.powi(2) / mse).log10(),
        fraction_over_1_of_255: over as f64 / pixels,
        max_abs,
    })
}
