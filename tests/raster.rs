//! Reference rasteriser and texture sampling: coverage, barycentrics, z-buffer, determinism.

use approx::assert_relative_eq;
use nalgebra::{Matrix4, Point3, Vector3, Vector4};
use reparam::mesh::{procedural, TriMesh};
use reparam::raster::{
    clip_positions, image_diff, rasterize, rasterize_clip, screen_triangles, shade, Camera,
};
use reparam::texture::{sample_bilinear, Image};

/// A mesh of triangles given by their corners (no UVs).
fn triangles(corners: &[[[f64; 3]; 3]]) -> TriMesh {
    let positions = corners
        .iter()
        .flatten()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect();
    let faces = (0..corners.len() as u32)
        .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
        .collect();
    TriMesh::with_shared_indices("test", positions, Vec::new(), faces)
}

#[test]
fn half_screen_triangle_covers_the_pixels_on_and_below_the_diagonal() {
    // In NDC (identity view_proj): the lower-left half x + y <= 0. Pixel centres on the
    // diagonal are on an edge and count as covered.
    let mesh = triangles(&[[[-1.0, -1.0, 0.5], [1.0, -1.0, 0.5], [-1.0, 1.0, 0.5]]]);
    let fb = rasterize(&mesh, &Matrix4::identity(), 4, 4);
    for y in 0..4 {
        for x in 0..4 {
            let fragment = fb.fragment(x, y);
            assert_eq!(fragment.is_some(), y >= x, "pixel ({x}, {y})");
            if let Some(fr) = fragment {
                let (nx, ny) = ((x as f64 + 0.5) / 2.0 - 1.0, 1.0 - (y as f64 + 0.5) / 2.0);
                let expected = [
                    1.0 - (nx + 1.0) / 2.0 - (ny + 1.0) / 2.0,
                    (nx + 1.0) / 2.0,
                    (ny + 1.0) / 2.0,
                ];
                for k in 0..3 {
                    assert_relative_eq!(fr.bary[k], expected[k], epsilon = 1e-12);
                }
                assert_relative_eq!(fr.bary.iter().sum::<f64>(), 1.0, epsilon = 1e-12);
                assert_eq!(fb.depth[y * 4 + x], 0.5);
            }
        }
    }
    assert_eq!(fb.covered_pixels(), 10);
}

#[test]
fn barycentrics_are_perspective_correct() {
    // A slanted triangle seen in perspective: the 3D point Σ bᵢ Pᵢ must project onto the
    // pixel centre it was found at.
    let mesh = triangles(&[[[-1.0, -1.0, 0.0], [1.5, -0.5, -3.0], [-0.5, 1.0, -1.0]]]);
    let camera = Camera {
        eye: Point3::new(0.0, 0.0, 3.0),
        ..Camera::default()
    };
    let (w, h) = (40, 30);
    let vp = Camera {
        aspect: w as f64 / h as f64,
        ..camera
    }
    .view_proj();
    let fb = rasterize(&mesh, &vp, w, h);
    assert!(fb.covered_pixels() > 100);
    let p = mesh.face_positions(0);
    for y in 0..h {
        for x in 0..w {
            let Some(fr) = fb.fragment(x, y) else {
                continue;
            };
            let point =
                p[0].coords * fr.bary[0] + p[1].coords * fr.bary[1] + p[2].coords * fr.bary[2];
            let clip: Vector4<f64> = vp * point.push(1.0);
            let pixel = reparam::raster::ndc_to_pixel(clip.x / clip.w, clip.y / clip.w, w, h);
            assert_relative_eq!(pixel[0], x as f64 + 0.5, epsilon = 1e-9);
            assert_relative_eq!(pixel[1], y as f64 + 0.5, epsilon = 1e-9);
            assert_relative_eq!(fb.depth[y * w + x], clip.z / clip.w, epsilon = 1e-12);
        }
    }
}

#[test]
fn front_triangle_hides_back_one_whatever_the_order() {
    let back = [[-1.0, -1.0, 0.8], [1.0, -1.0, 0.8], [-1.0, 1.0, 0.8]];
    let front = [[-1.0, -1.0, 0.3], [1.0, -1.0, 0.3], [-1.0, 1.0, 0.3]];
    for (order, front_face) in [([back, front], 1), ([front, back], 0)] {
        let fb = rasterize(&triangles(&order), &Matrix4::identity(), 8, 8);
        assert_eq!(fb.fragment(0, 7).unwrap().face, front_face);
        assert_eq!(fb.depth[7 * 8], 0.3);
    }
    // Equal depth: the lower face index wins.
    let fb = rasterize(&triangles(&[front, front]), &Matrix4::identity(), 8, 8);
    assert_eq!(fb.fragment(0, 7).unwrap().face, 0);
}

#[test]
fn triangles_in_front_of_the_near_plane_are_skipped() {
    let mesh = triangles(&[[[-1.0, -1.0, -0.1], [1.0, -1.0, 0.5], [-1.0, 1.0, 0.5]]]);
    assert_eq!(
        rasterize(&mesh, &Matrix4::identity(), 8, 8).covered_pixels(),
        0
    );
}

#[test]
fn projection_maps_near_to_0_and_far_to_1() {
    let camera = Camera {
        near: 0.5,
        far: 20.0,
        ..Camera::default()
    };
    let depth = |z: f64| {
        let c = camera.projection() * Vector4::new(0.0, 0.0, z, 1.0);
        c.z / c.w
    };
    assert_relative_eq!(depth(-0.5), 0.0, epsilon = 1e-15);
    assert_relative_eq!(depth(-20.0), 1.0, epsilon = 1e-15);
}

#[test]
fn framed_mesh_is_entirely_visible() {
    let mesh = procedural::torus(16, 8, 1.0, 0.4);
    for view in [
        Vector3::new(0.3, -1.0, -0.6),
        Vector3::new(0.0, 1.0, 0.0),
        Vector3::zeros(),
    ] {
        let camera = Camera::frame_mesh(&mesh, view, 16.0 / 9.0);
        let vp = camera.view_proj();
        for p in &mesh.positions {
            let c = vp * p.to_homogeneous();
            let ndc = c.xyz() / c.w;
            assert!(
                ndc.x.abs() < 1.0 && ndc.y.abs() < 1.0 && ndc.z > 0.0 && ndc.z < 1.0,
                "{ndc:?}"
            );
        }
    }
}

#[test]
fn same_result_with_one_and_two_threads() {
    let mesh = procedural::torus(48, 24, 1.0, 0.4);
    let vp = Camera::frame_mesh(&mesh, Vector3::new(0.2, -1.0, -0.7), 1.5).view_proj();
    let render = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| rasterize(&mesh, &vp, 120, 80))
    };
    let (one, two) = (render(1), render(2));
    assert!(one.covered_pixels() > 1000);
    assert_eq!(one, two);
}

#[test]
fn shade_and_diff() {
    let mesh = triangles(&[[[-1.0, -1.0, 0.5], [1.0, -1.0, 0.5], [-1.0, 1.0, 0.5]]]);
    let fb = rasterize(&mesh, &Matrix4::identity(), 4, 4);
    let image = shade(&fb, [0, 0, 0, 255], |face, _| [200, face as u8, 0, 255]);
    assert_eq!(image.get(0, 3), [200, 0, 0, 255]);
    assert_eq!(image.get(3, 0), [0, 0, 0, 255]);

    let same = image_diff(&image, &image).unwrap();
    assert_eq!(
        (same.psnr_db, same.fraction_over_1_of_255, same.max_abs),
        (f64::INFINITY, 0.0, 0)
    );
    let mut changed = image.clone();
    changed.set(1, 1, [202, 0, 0, 255]);
    changed.set(2, 2, [201, 0, 0, 0]);
    let diff = image_diff(&image, &changed).unwrap();
    assert_eq!(diff.max_abs, 2);
    assert_eq!(diff.fraction_over_1_of_255, 1.0 / 16.0);
    assert!(diff.psnr_db > 40.0 && diff.psnr_db.is_finite());
    assert!(image_diff(&image, &Image::new(2, 2, [0; 4])).is_err());
}

/// A 3 × 2 image with distinct texels.
fn small_texture() -> Image<[u8; 4]> {
    Image::from_fn(3, 2, |x, y| [(10 * x + 100 * y) as u8, 7, 0, 255])
}

/// The UV of texel (x, y)'s centre: (u, v) = ((x + ½)/W, 1 − (y + ½)/H).
fn texel_centre_uv(x: usize, y: usize) -> [f64; 2] {
    [(x as f64 + 0.5) / 3.0, 1.0 - (y as f64 + 0.5) / 2.0]
}

#[test]
fn bilinear_sampling_at_texel_centres_returns_the_texels() {
    let texture = small_texture();
    for y in 0..2 {
        for x in 0..3 {
            let expected = texture.get(x, y).map(f64::from);
            for shift in [0.0, 1.0, -3.0] {
                let [u, v] = texel_centre_uv(x, y);
                let sample = sample_bilinear(&texture, [u + shift, v - shift]);
                for c in 0..4 {
                    assert_relative_eq!(sample[c], expected[c], epsilon = 1e-9);
                }
            }
        }
    }
}

#[test]
fn bilinear_sampling_wraps_around_the_edges() {
    let texture = small_texture();
    let value = |x, y| texture.get(x, y)[0] as f64;
    // u = 0 lies halfway between the last and the first column (REPEAT).
    let [_, v] = texel_centre_uv(0, 1);
    assert_relative_eq!(
        sample_bilinear(&texture, [0.0, v])[0],
        0.5 * (value(2, 1) + value(0, 1)),
        epsilon = 1e-9
    );
    // v = 0 (the bottom edge) lies halfway between the bottom and the top row.
    let [u, _] = texel_centre_uv(1, 0);
    assert_relative_eq!(
        sample_bilinear(&texture, [u, 0.0])[0],
        0.5 * (value(1, 1) + value(1, 0)),
        epsilon = 1e-9
    );
    // The corner mixes the four corner texels equally.
    let corner = 0.25 * (value(0, 0) + value(2, 0) + value(0, 1) + value(2, 1));
    assert_relative_eq!(
        sample_bilinear(&texture, [0.0, 0.0])[0],
        corner,
        epsilon = 1e-9
    );
    assert_relative_eq!(
        sample_bilinear(&texture, [5.0, -2.0])[0],
        corner,
        epsilon = 1e-9
    );
}

#[test]
fn uv_grid_and_checker_textures_have_the_requested_size() {
    let grid = reparam::texture::uv_grid_texture(256);
    assert_eq!((grid.width, grid.height), (256, 256));
    let checker = reparam::texture::checker(64, 4);
    assert_eq!(checker.get(0, 0), [255, 255, 255, 255]);
    assert_eq!(checker.get(16, 0), [0, 0, 0, 255]);
    let both = reparam::texture::side_by_side(&[&grid, &checker], 5);
    assert_eq!((both.width, both.height), (256 + 5 + 64, 256));
    assert_eq!(both.get(261, 0), checker.get(0, 0));
}

#[test]
fn screen_triangles_measure_distance_depth_and_barycentrics_in_pixels() {
    // The lower-left half of an 8 × 8 picture (identity view_proj): corners at pixel (0, 8),
    // (8, 8), (0, 0); depth 0.25 + 0.5 · (ndc x + 1) / 2 along x.
    let mesh = triangles(&[[[-1.0, -1.0, 0.25], [1.0, -1.0, 0.75], [-1.0, 1.0, 0.25]]]);
    let clip = clip_positions(&mesh, &Matrix4::identity());
    let tris = screen_triangles(&mesh, &clip, 8, 8, 0.0);
    assert_eq!(tris.len(), 1);
    let t = &tris[0];
    assert_eq!(t.face(), 0);
    // Inside, 1 px from the bottom edge and 2 px from the left one: the nearer counts.
    assert_relative_eq!(t.signed_distance([2.0, 7.0]), 1.0, epsilon = 1e-12);
    // Outside, beyond the diagonal x = y (pixel coordinates, y down) by √2 / 2.
    assert_relative_eq!(
        t.signed_distance([5.0, 4.0]),
        -0.5f64.sqrt(),
        epsilon = 1e-12
    );
    assert_relative_eq!(t.depth_at([4.0, 6.0]), 0.5, epsilon = 1e-12);
    assert_relative_eq!(t.depth_slope(), 0.5 / 8.0, epsilon = 1e-12);
    let b = t.barycentrics_at([4.0, 6.0]);
    assert_relative_eq!(b[1], 0.5, epsilon = 1e-12);
    assert_relative_eq!(b[2], 0.25, epsilon = 1e-12);
    // A snapped raster moves coverage: the identity snap reproduces `rasterize`.
    let exact = rasterize(&mesh, &Matrix4::identity(), 8, 8);
    assert_eq!(rasterize_clip(&mesh, &clip, 8, 8, |p| p), exact);
    let shifted = rasterize_clip(&mesh, &clip, 8, 8, |p| [p[0] + 0.75, p[1]]);
    assert_ne!(shifted.covered_pixels(), 0);
    assert_ne!(shifted, exact);
}
