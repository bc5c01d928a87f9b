//! The texture lookup of a warp (src/gridwarp/remap.rs): the inverse bilinear lookup of the
//! non-axis-aligned grid (seed §8), boundary blending (seed §10.2), several ROIs per atlas.

use reparam::gridwarp::energy_naa::VertexGrid;
use reparam::gridwarp::rasterize::Roi;
use reparam::gridwarp::remap::{bilinear, check_disjoint, inverse, inverse_bilinear};
use reparam::gridwarp::{AtlasRemap, Grid, Remap, Warped};
use reparam::Error;

fn rest() -> Grid {
    Grid::new(vec![0.0, 0.2, 0.55, 0.8, 1.0], vec![0.0, 0.3, 0.6, 1.0]).unwrap()
}

/// The rest grid's vertices with the interior ones moved by a smooth, small displacement (every
/// cell stays convex).
fn bent_vertices(grid: &Grid) -> VertexGrid {
    let mut v = VertexGrid::from_grid(grid);
    for a in 1..v.m - 1 {
        for b in 1..v.n - 1 {
            let p = v.points[a * v.n + b];
            v.points[a * v.n + b] = [
                p[0] + 0.04 * (3.0 * p[1]).sin(),
                p[1] - 0.05 * (2.0 * p[0]).cos(),
            ];
        }
    }
    assert!(v.is_valid());
    v
}

/// A lattice of points over the unit square, including its outline.
fn lattice(n: usize) -> Vec<[f64; 2]> {
    (0..=n)
        .flat_map(|i| (0..=n).map(move |j| [i as f64 / n as f64, j as f64 / n as f64]))
        .collect()
}

#[test]
fn inverse_bilinear_inverts_the_bilinear_map() {
    // A general convex quad (non-zero twist) and a parallelogram (the linear case f × g = 0).
    let quads = [
        [[0.1, 0.0], [1.0, 0.2], [0.0, 0.9], [1.2, 1.1]],
        [[0.0, 0.0], [1.0, 0.5], [0.2, 1.0], [1.2, 1.5]],
    ];
    for q in &quads {
        for i in 0..=10 {
            for j in 0..=10 {
                let (a, b) = (i as f64 / 10.0, j as f64 / 10.0);
                let p = bilinear(q, a, b);
                let ab = inverse_bilinear(q, p).unwrap();
                // Coordinates O(1), a closed form plus one Newton step: a few ulps of 1; 1e-13
                // leaves room for the conditioning (the quads' Jacobians are ≈ 1).
                assert!(
                    (ab[0] - a).abs() < 1e-13 && (ab[1] - b).abs() < 1e-13,
                    "{q:?} ({a}, {b}) → {ab:?}"
                );
            }
        }
    }
}

#[test]
fn naa_lookup_on_an_axis_aligned_vertex_grid_is_the_aa_lookup() {
    let rest = rest();
    let warped = Grid::new(vec![0.0, 0.25, 0.5, 0.85, 1.0], vec![0.0, 0.2, 0.65, 1.0]).unwrap();
    let aa = Remap::new(rest.clone(), Warped::Lines(warped.clone()));
    let naa = Remap::new(
        rest.clone(),
        Warped::Vertices(VertexGrid::from_grid(&warped)),
    );
    for p in lattice(37) {
        let (x, y, z) = (aa.lookup(p), naa.lookup(p), inverse(&rest, &warped, p));
        assert_eq!(x, z);
        // Same formula through the closed-form quadratic (linear here: rectangles): rounding only.
        assert!(
            (x[0] - y[0]).abs() < 1e-14 && (x[1] - y[1]).abs() < 1e-14,
            "{p:?}: {x:?} vs {y:?}"
        );
    }
}

#[test]
fn naa_lookup_inverts_the_forward_warp() {
    let rest = rest();
    let remap = Remap::new(rest.clone(), Warped::Vertices(bent_vertices(&rest)));
    for st in lattice(29) {
        let back = remap.lookup(remap.forward(st));
        // One inverse bilinear solve of an O(1) quad: 1e-12 (see the test above, ×10 for the
        // cell search's edge cases at shared edges).
        assert!(
            (back[0] - st[0]).abs() < 1e-12 && (back[1] - st[1]).abs() < 1e-12,
            "{st:?} → {back:?}"
        );
    }
}

#[test]
fn boundary_blend_is_the_identity_on_the_outline_and_changes_nothing_inside() {
    let rest = rest();
    let lines = Grid::new(vec![0.0, 0.15, 0.6, 0.85, 1.0], vec![0.0, 0.4, 0.7, 1.0]).unwrap();
    for warped in [
        Warped::Lines(lines.clone()),
        Warped::Vertices(bent_vertices(&rest).with_sliding_border(true)),
    ] {
        let plain = Remap::new(rest.clone(), warped.clone());
        let blended = plain.clone().with_boundary_blend(true);
        let mut seam = 0.0f64;
        for k in 0..=200 {
            let x = k as f64 / 200.0;
            for p in [[x, 0.0], [x, 1.0], [0.0, x], [1.0, x]] {
                // Continuity with the unwarped texture outside: exactly the original UV.
                assert_eq!(blended.lookup(p), p, "{warped:?} at {p:?}");
                let q = plain.lookup(p);
                seam = seam.max((q[0] - p[0]).abs().max((q[1] - p[1]).abs()));
            }
        }
        // Without blending the AA lookup moves points along the outline (the seam of §10.2).
        if matches!(warped, Warped::Lines(_)) {
            assert!(seam > 0.01, "no seam to remove: {seam}");
        }
        for p in lattice(41) {
            let at = plain.locate(p).unwrap();
            let (i, j) = at.cell;
            let interior = i > 0 && i < rest.s.len() - 2 && j > 0 && j < rest.t.len() - 2;
            if interior {
                assert_eq!(blended.lookup(p), plain.lookup(p), "{p:?}");
            }
        }
        // Continuous across the inner side of a boundary cell: the weight tends to 0 there.
        if let Warped::Lines(g) = &warped {
            let s1 = g.s[1];
            for t in [0.45, 0.5, 0.55] {
                let (a, b) = (
                    blended.lookup([s1 - 1e-9, t]),
                    blended.lookup([s1 + 1e-9, t]),
                );
                // F⁻¹ has slopes O(1): 1e-9 steps move it by O(1e-9).
                assert!((a[0] - b[0]).abs() < 1e-8 && (a[1] - b[1]).abs() < 1e-8);
            }
        }
    }
}

#[test]
fn fixed_border_naa_needs_no_blending_on_the_outline() {
    // Border vertices fixed at their rest places: the outline maps onto itself pointwise.
    let rest = rest();
    let remap = Remap::new(rest.clone(), Warped::Vertices(bent_vertices(&rest)));
    for k in 0..=50 {
        let x = k as f64 / 50.0;
        for p in [[x, 0.0], [x, 1.0], [0.0, x], [1.0, x]] {
            let q = remap.lookup(p);
            assert!((q[0] - p[0]).abs() < 1e-14 && (q[1] - p[1]).abs() < 1e-14);
        }
    }
}

#[test]
fn several_rois_remap_inside_their_own_rectangle_and_must_not_overlap() {
    let rest = Grid::new(vec![0.0, 0.5, 1.0], vec![0.0, 0.5, 1.0]).unwrap();
    let warped = Grid::new(vec![0.0, 0.7, 1.0], vec![0.0, 0.3, 1.0]).unwrap();
    let a = Roi::new(0.0, 0.4, 0.0, 0.4).unwrap();
    let b = Roi::new(0.5, 1.0, 0.5, 1.0).unwrap();
    let remap = Remap::new(rest.clone(), Warped::Lines(warped));
    let atlas =
        AtlasRemap::new(vec![(a, remap.clone()), (b, Remap::identity(rest.clone()))]).unwrap();
    // In ROI a: roi.uv(F⁻¹(roi.st(uv))); ROI a's centre (0.2, 0.2) is at (s, t) = (½, ½).
    let got = atlas.lookup_uv([0.2, 0.2]);
    let [s, t] = remap.lookup([0.5, 0.5]);
    assert_eq!(got, [0.4 * s, 0.4 * t]);
    assert!((got[0] - 0.2).abs() > 0.01);
    // In ROI b (identity) and outside both: unchanged.
    assert_eq!(atlas.lookup_uv([0.75, 0.6]), [0.75, 0.6]);
    assert_eq!(atlas.lookup_uv([0.45, 0.9]), [0.45, 0.9]);

    // Overlaps are typed errors naming both ROIs; touching edges are fine.
    let c = Roi::new(0.3, 0.6, 0.3, 0.6).unwrap();
    let e = AtlasRemap::new(vec![
        (a, Remap::identity(rest.clone())),
        (c, Remap::identity(rest.clone())),
    ])
    .unwrap_err();
    assert!(matches!(e, Error::InvalidArgument(_)));
    assert!(
        e.to_string().contains("ROI 0") && e.to_string().contains("ROI 1"),
        "{e}"
    );
    let touching = Roi::new(0.4, 0.5, 0.0, 0.4).unwrap();
    assert!(check_disjoint(&[a, touching, b]).is_ok());
    assert!(check_disjoint(&[a, b, c]).is_err());
}

#[test]
fn mesh_uvs_on_a_blended_roi_outline_stay_put() {
    use nalgebra::{Point2, Point3};
    use reparam::gridwarp::picture::remap_mesh_uvs;
    use reparam::mesh::TriMesh;
    // A 10×10 UV grid; the ROI u [0.2, 0.8] × v [0.1, 0.7] has its outline on mesh vertices.
    let n = 10;
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            positions.push(Point3::new(u, v, 0.0));
            uvs.push(Point2::new(u, v));
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let faces: Vec<[u32; 3]> = (0..n)
        .flat_map(|j| (0..n).map(move |i| [id(i, j), id(i + 1, j), id(i + 1, j + 1)]))
        .collect();
    let mesh = TriMesh::with_shared_indices("uv grid", positions, uvs, faces);
    let roi = Roi::new(0.2, 0.8, 0.1, 0.7).unwrap();
    let rest = Grid::new(vec![0.0, 0.25, 0.75, 1.0], vec![0.0, 0.3, 0.6, 1.0]).unwrap();
    let warped = Grid::new(vec![0.0, 0.35, 0.6, 1.0], vec![0.0, 0.2, 0.7, 1.0]).unwrap();
    let remap = Remap::new(rest, Warped::Lines(warped));
    let plain = remap_mesh_uvs(&mesh, &AtlasRemap::new(vec![(roi, remap.clone())]).unwrap());
    let blended = remap_mesh_uvs(
        &mesh,
        &AtlasRemap::new(vec![(roi, remap.with_boundary_blend(true))]).unwrap(),
    );
    let mut moved_on_outline = 0;
    for (k, uv) in mesh.uvs.iter().enumerate() {
        let (s, t) = roi.st(*uv);
        let on_outline = (0.0..=1.0).contains(&s)
            && (0.0..=1.0).contains(&t)
            && (s.abs() < 1e-12
                || (s - 1.0).abs() < 1e-12
                || t.abs() < 1e-12
                || (t - 1.0).abs() < 1e-12);
        if on_outline {
            // roi.uv(roi.st(uv)) round-trips an O(1) value through two affine maps: 1e-15.
            assert!(
                (blended.uvs[k] - uv).norm() < 1e-15,
                "{uv:?} → {:?}",
                blended.uvs[k]
            );
            moved_on_outline += usize::from((plain.uvs[k] - uv).norm() > 1e-3);
        }
        if !roi.contains([uv.x, uv.y]) {
            assert_eq!(blended.uvs[k], *uv);
        }
    }
    // Without blending the outline vertices do move: the seam the blending removes.
    assert!(moved_on_outline > 4, "{moved_on_outline}");
}

#[test]
fn the_pictures_zoom_on_the_faces_under_rigid_content() {
    use nalgebra::{Point2, Point3};
    use reparam::gridwarp::field::Field;
    use reparam::gridwarp::picture::{faces_in_rois, rigid_faces};
    use reparam::gridwarp::scene::disc_rigidity;
    use reparam::mesh::TriMesh;
    // 8×8 quads over UV [0, 1]², position = (u, v, 0).
    let n = 8;
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            positions.push(Point3::new(u, v, 0.0));
            uvs.push(Point2::new(u, v));
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let faces: Vec<[u32; 3]> = (0..n)
        .flat_map(|j| {
            (0..n).flat_map(move |i| {
                [
                    [id(i, j), id(i + 1, j), id(i + 1, j + 1)],
                    [id(i, j), id(i + 1, j + 1), id(i, j + 1)],
                ]
            })
        })
        .collect();
    let mesh = TriMesh::with_shared_indices("quads", positions, uvs, faces);
    let roi = Roi::new(0.5, 1.0, 0.5, 1.0).unwrap();
    // One small rigid disc at ROI (½, ½) = UV (0.75, 0.75): only the faces around it, and only
    // their positions (the bounding sphere a camera frames).
    let disc = disc_rigidity(32, &[(0.5, 0.5, 0.1)], 0.1);
    let zoom = rigid_faces(&mesh, &[(roi, &disc)]);
    assert!(
        !zoom.faces.is_empty() && zoom.faces.len() <= 8,
        "{}",
        zoom.faces.len()
    );
    for p in &zoom.positions {
        assert!((p.x - 0.75).abs() <= 0.125 + 1e-12 && (p.y - 0.75).abs() <= 0.125 + 1e-12);
    }
    // An all-rigid map (R ≡ 1): the ROI's faces, i.e. those with a UV corner in it.
    let all = rigid_faces(&mesh, &[(roi, &Field::constant(1.0))]);
    assert_eq!(all.faces.len(), faces_in_rois(&mesh, &[roi]).faces.len());
    assert!(all.positions.iter().all(|p| p.x >= 0.375 && p.y >= 0.375));
}

#[test]
fn the_cell_count_is_the_binary_search_and_both_roots_occur() {
    use reparam::gridwarp::remap::{cell_of, choose_root, quadratic, roots};
    let lines = [0.0, 0.1, 0.35, 0.36, 0.8, 1.0];
    for k in -20..=220 {
        let x = k as f64 / 200.0;
        let search = lines.partition_point(|&v| v <= x).clamp(1, lines.len() - 1) - 1;
        assert_eq!(cell_of(&lines, x), search, "{x}");
    }
    assert_eq!(cell_of(&lines, f64::NAN), 0);
    // A trapezoid takes the near root c/q at these points; a strongly twisted cell (P11 pulled
    // far out along the diagonal, the kernel test's `naa_both_roots` cell) takes the far root
    // q/a at (0.5, 0.5) and (0.25, 0.75) (β = 0.5, 0.75, the near roots −0.34, −0.45 lie
    // outside [0, 1]) and the near one at (0.75, 0.125); every point inverts the bilinear map.
    let q = [[0.0, 0.0], [1.0, 0.0], [0.2, 1.0], [0.7, 0.8]];
    let twisted = [
        [0.0, 0.0],
        [0.25, 0.09375],
        [0.046875, 0.25],
        [0.703125, 0.3125],
    ];
    let mut taken = [0, 0];
    for quad in [q, twisted] {
        for (a, b) in [
            (0.3, 0.6),
            (0.8, 0.2),
            (0.5, 0.5),
            (0.25, 0.75),
            (0.75, 0.125),
        ] {
            let p = bilinear(&quad, a, b);
            let k = quadratic(&quad, p);
            let (near, far) = roots(&k);
            taken[choose_root(near, far)] += 1;
            let ab = inverse_bilinear(&quad, p).unwrap();
            assert!((ab[0] - a).abs() < 1e-13 && (ab[1] - b).abs() < 1e-13);
        }
    }
    assert!(taken[0] > 0 && taken[1] > 0, "{taken:?}");
}
