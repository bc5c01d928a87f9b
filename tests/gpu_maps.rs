//! The MAPS kernels (`maps_priority`, `maps_flatten`, `maps_inverse`, f32) against the f64
//! reference (`priority.rs`, `flatten.rs`, `Param::inverse`) on procedural meshes: a bumpy torus
//! (genus 1), a creased height field with boundary and a tagged feature line, a cone fan with a
//! valence-16 apex. Priority terms and flattening from identical f32-rounded inputs, ring by
//! ring against per-ring bounds derived in `src/crosscheck/maps_bound.rs` (the kernels' twins
//! over the WGSL accuracy table: `priority_bounds`, `flatten_bounds`); Π⁻¹ of the `uniform(maps, 2)` remesh points against the issue's
//! figures. Without an adapter these tests print `skipped: no GPU adapter` and pass; with
//! REPARAM_REQUIRE_GPU=1 they fail instead.
#![cfg(feature = "gpu")]

use reparam::crosscheck::maps::inverse_within_bounds;
use reparam::maps::gpu::{
    crosscheck_flatten, crosscheck_inverse, crosscheck_priority, inverse_gpu, inverse_tables,
    level_rings, normalise, FlattenCrosscheck, InverseCrosscheck, LevelRings, PriorityCrosscheck,
};
use reparam::maps::remesh::uniform;
use reparam::maps::{build, flatten::RingShape, BasePoint, Features, Maps, MapsOptions};
use reparam::mesh::{procedural, TriMesh};
use reparam::Error;
use reparam_gpu::gpu_or_skip;

/// The 24 × 12 torus (576 triangles) with bumps: every vertex moved away from the tube's centre
/// circle by the factor 1 + 0.15 sin 5θ cos 3φ (θ around the axis, φ around the tube).
fn bumpy_torus() -> TriMesh {
    let mut m = procedural::torus(24, 12, 1.0, 0.35);
    m.uvs.clear();
    m.uv_faces.clear();
    for p in &mut m.positions {
        let theta = p.y.atan2(p.x);
        let rxy = p.x.hypot(p.y);
        let phi = p.z.atan2(rxy - 1.0);
        let f = 1.0 + 0.15 * (5.0 * theta).sin() * (3.0 * phi).cos();
        let c = nalgebra::Vector3::new(theta.cos(), theta.sin(), 0.0);
        p.coords = c + (p.coords - c) * f;
    }
    m.name = "bumpy torus".into();
    m
}

/// The 12 × 12 height field z = 0.8|x − ½| + 0.1 sin πy on [0, 1]² (boundary; a crease along
/// x = ½ tagged as a feature line, so its vertices flatten as two half disks).
fn creased_grid() -> (TriMesh, Features) {
    let n = 12;
    let mut m = procedural::wavy_grid(n);
    m.uvs.clear();
    m.uv_faces.clear();
    for p in &mut m.positions {
        p.z = 0.8 * (p.x - 0.5).abs() + 0.1 * (std::f64::consts::PI * p.y).sin();
    }
    let mut features = Features::default();
    let column = |j: usize| (j * (n + 1) + n / 2) as u32;
    for j in 0..n {
        features.edges.insert((column(j), column(j + 1)));
    }
    m.name = "creased grid".into();
    (m, features)
}

/// The cone fan of 16 triangles (apex of valence 16, the rim a boundary).
fn cone() -> TriMesh {
    let mut m = procedural::cone_fan(16, 0.5);
    m.uvs.clear();
    m.uv_faces.clear();
    m
}

fn corner_turn() -> f64 {
    MapsOptions::default().corner_turn
}

fn built(mesh: &TriMesh, features: &Features) -> Maps {
    build(mesh, features, &MapsOptions::default()).expect("maps builds")
}

/// Level 0 (the input) and the middle level of `maps`, with their rings.
fn levels(maps: &Maps, mesh: &TriMesh) -> Vec<(String, LevelRings)> {
    let mid = maps.level_count() / 2;
    vec![
        (
            format!("{} level 0", mesh.name),
            level_rings(&mesh.positions, &mesh.faces, &maps.features, corner_turn()),
        ),
        (
            format!("{} level {mid}", mesh.name),
            level_rings(
                &mesh.positions,
                &maps.levels[mid].faces,
                &maps.features,
                corner_turn(),
            ),
        ),
    ]
}

/// Every level to compare: torus and crease at levels 0 and L/2, the cone at level 0.
fn all_levels() -> Vec<(String, TriMesh, LevelRings)> {
    let torus = bumpy_torus();
    let (grid, features) = creased_grid();
    let mut out = Vec::new();
    for (mesh, f) in [(torus, Features::default()), (grid, features)] {
        let maps = built(&mesh, &f);
        assert!(
            maps.level_count() >= 2,
            "{}: {} levels",
            mesh.name,
            maps.level_count()
        );
        for (name, rings) in levels(&maps, &mesh) {
            out.push((name, mesh.clone(), rings));
        }
    }
    let cone = cone();
    let rings = level_rings(
        &cone.positions,
        &cone.faces,
        &Features::default(),
        corner_turn(),
    );
    out.push(("cone fan level 0".into(), cone, rings));
    out
}

#[test]
fn level_rings_cover_disks_half_disks_feature_lines_and_high_valence() {
    let levels = all_levels();
    let shapes: Vec<&RingShape> = levels.iter().flat_map(|l| &l.2.shapes).collect();
    assert!(shapes.iter().any(|s| matches!(s, RingShape::Disk)));
    assert!(shapes.iter().any(|s| matches!(s, RingShape::HalfDisk)));
    assert!(shapes
        .iter()
        .any(|s| matches!(s, RingShape::FeatureLine { .. })));
    let max_degree = levels
        .iter()
        .flat_map(|l| &l.2.rings)
        .map(Vec::len)
        .max()
        .unwrap();
    assert!(max_degree >= 16, "largest ring {max_degree}");
    // Each torus vertex of level 0 is a disk of 6.
    assert!(levels[0].2.rings.iter().all(|r| r.len() == 6));
    assert_eq!(levels[0].2.vertices.len(), 288);
}

#[test]
fn priority_terms_match_the_reference_ring_by_ring() {
    let Some(gpu) = gpu_or_skip() else { return };
    for (name, mesh, rings) in all_levels() {
        let norm = normalise(&mesh.positions).unwrap();
        let r = crosscheck_priority(&gpu, &norm, &rings).unwrap();
        println!(
            "{name}: {} rings, area rel max {:.1e} (worst/bound {:.2}), κ max {:.1e}/diag \
             (worst/bound {:.1e}, {} singular)",
            r.rings,
            r.area.max_abs,
            r.area_worst_ratio,
            r.kappa.max_abs,
            r.kappa_worst_ratio,
            r.kappa_singular
        );
        // Each ring against its own derived bound (crosscheck::maps_bound::priority_bounds).
        assert_eq!(r.area_over_bound, 0, "{name}: {r:?}");
        assert_eq!(r.kappa_over_bound, 0, "{name}: {r:?}");
        assert_eq!(r.area.non_finite + r.kappa.non_finite, 0, "{name}");
        assert!(r.kappa_singular * 10 <= r.rings, "{name}: {r:?}");
    }
}

#[test]
fn flattening_matches_the_reference_ring_by_ring() {
    let Some(gpu) = gpu_or_skip() else { return };
    for (name, mesh, rings) in all_levels() {
        let norm = normalise(&mesh.positions).unwrap();
        let r = crosscheck_flatten(&gpu, &norm, &rings).unwrap();
        println!(
            "{name}: {} rings ({} rejected), θ max {:.1e} rad (worst/bound {:.2}), a rel max \
             {:.1e}, μ rel max {:.1e} (worst/bound {:.2}), {} status mismatches",
            r.rings,
            r.rejected,
            r.theta.max_abs,
            r.theta_worst_ratio,
            r.a.max_abs,
            r.mu.max_abs,
            r.mu_worst_ratio,
            r.status_mismatches
        );
        // Each slot against its own derived bound (crosscheck::maps_bound::flatten_bounds).
        assert_eq!(r.theta_over_bound, 0, "{name}: {r:?}");
        assert_eq!(r.a_over_bound, 0, "{name}: {r:?}");
        assert_eq!(r.mu_over_bound, 0, "{name}: {r:?}");
        // The rejections are exact decisions on these meshes: a single-sector side (integer
        // logic) or a·φ ≥ π, which by the triangle inequality of angles holds only for
        // degenerate rings (none here), so f32 decides as f64.
        assert_eq!(r.status_mismatches, 0, "{name}: {r:?}");
        assert!(r.mu.count > 0);
    }
}

/// The uniform:2 remesh points of `maps` (each base face quadrisected twice).
fn remesh_points(maps: &Maps) -> Vec<BasePoint> {
    uniform(maps, 2).expect("uniform remesh").params
}

fn inverse_cases() -> Vec<(String, Maps)> {
    let (grid, features) = creased_grid();
    vec![
        (
            "bumpy torus".into(),
            built(&bumpy_torus(), &Features::default()),
        ),
        ("creased grid".into(), built(&grid, &features)),
    ]
}

#[test]
fn inverse_tables_reproduce_the_base_domain() {
    for (name, maps) in inverse_cases() {
        let norm = normalise(&maps.positions).unwrap();
        let tables = inverse_tables(&maps, &norm);
        tables.check().unwrap();
        let base: Vec<[u32; 3]> = tables
            .base_to_face
            .iter()
            .map(|&f| tables.faces[f as usize].corners)
            .collect();
        assert_eq!(base, maps.base_faces, "{name}");
        assert_eq!(tables.removals.len(), maps.param.removals().len());
    }
}

#[test]
fn inverse_of_remesh_points_matches_param_inverse() {
    let Some(gpu) = gpu_or_skip() else { return };
    for (name, maps) in inverse_cases() {
        let points = remesh_points(&maps);
        let r = crosscheck_inverse(&gpu, &maps, &points).unwrap();
        println!(
            "{name}: {} levels, {} points: position max {:.1e} p99 {:.1e} of the diagonal, \
             bary max {:.1e} ({} thin), {} face mismatches (largest min b {:.1e})",
            maps.level_count(),
            r.points,
            r.position.max_abs,
            r.position.p99,
            r.bary.max_abs,
            r.thin,
            r.face_mismatches,
            r.mismatch_max_min_bary
        );
        check_inverse(&name, &r);
    }
}

/// The figures: positions to 1e-5 of the diagonal, barycentrics to 1e-5 where the input
/// triangle's smallest altitude exceeds 1e-3 of the diagonal.
///
/// Budget: the kernel replays at most L removals (L levels, ≤ 12 here); per step it rounds the
/// inputs (μ and b to f32: ≤ u relative each), forms u = Σ b_c μ_c (≤ 3u|μ|), and solves for
/// the barycentrics in the star face (three orient2d of ≈ 3 roundings, relative to the face's
/// area: ≤ 10u·κ_t with κ_t = diameter²/(2·area) ≤ 20 for the faces of these meshes), so the
/// point moves by ≤ (4u + 10u·κ_t)·diameter of that star in its plane. Mapped down to the input
/// surface each step's error is scaled by the map's stretch (≤ 2 on these smooth meshes) and
/// the star's diameter is ≤ ½ diagonal: per step ≤ 2·(4 + 200)u·½ ≈ 204u of the diagonal, L
/// steps ≤ 2500u ≈ 1.5e-4 in the worst case, and the random-walk sum is √L·204u ≈ 4e-5. The
/// issue's 1e-5 is tighter than the worst case: the measured figure must meet it (and the p99
/// is ≥ 10× below it, the typical errors being a few u per step).
///
/// The barycentrics in the final face are the position error over the face's altitude in the
/// kernel's plane, so |Δb| ≤ |Δp|/h; with h ≥ 1e-3 of the diagonal, |Δb| ≤ 1e-5 asks |Δp| ≤
/// 1e-8 diagonal: met because the last steps' errors are those of small (input-sized) stars.
///
/// A point may end in another input face than the reference only where it is within the
/// kernel's position error of that face's edge: its reference barycentric distance to an edge
/// min b_c ≤ |Δp|/h ≤ 1e-5/1e-3 = 1e-2.
fn check_inverse(name: &str, r: &InverseCrosscheck) {
    // The limits are `reparam::crosscheck::maps::INVERSE_*`, shared with the CLI.
    assert!(inverse_within_bounds(r), "{name}: {r:?}");
}

#[test]
fn gpu_results_repeat_exactly() {
    let Some(gpu) = gpu_or_skip() else { return };
    let (name, maps) = inverse_cases().remove(0);
    let norm = normalise(&maps.positions).unwrap();
    let tables = inverse_tables(&maps, &norm);
    let points = remesh_points(&maps);
    let a = inverse_gpu(&gpu, &tables, &points).unwrap();
    let b = inverse_gpu(&gpu, &tables, &points).unwrap();
    assert_eq!(a, b, "{name}");
}

#[test]
fn bad_inputs_are_typed_errors() {
    assert!(matches!(normalise(&[]), Err(Error::InvalidArgument(_))));
    let p = nalgebra::Point3::new(1.0, 2.0, 3.0);
    assert!(matches!(normalise(&[p, p]), Err(Error::InvalidArgument(_))));
    let Some(gpu) = gpu_or_skip() else { return };
    let (_, maps) = inverse_cases().remove(0);
    let far = [BasePoint {
        face: maps.base_faces.len() as u32,
        bary: [0.2, 0.3, 0.5],
    }];
    assert!(matches!(
        crosscheck_inverse(&gpu, &maps, &far),
        Err(Error::Gpu(_))
    ));
}

fn summary_line(name: &str, p: &PriorityCrosscheck, f: &FlattenCrosscheck) -> String {
    let r = |x: f64| reparam::crosscheck::round_significant(x, 1);
    format!(
        "{name}: rings {} area {:e} κ {:e}/diag θ {:e} a {:e} μ {:e} rejected {} mismatches {}",
        p.rings,
        r(p.area.max_abs),
        r(p.kappa.max_abs),
        r(f.theta.max_abs),
        r(f.a.max_abs),
        r(f.mu.max_abs),
        f.rejected,
        f.status_mismatches
    )
}

#[test]
fn error_summaries_snapshot_on_lavapipe() {
    let Some(gpu) = gpu_or_skip() else { return };
    // f32 results depend on the adapter's arithmetic: the snapshot is taken on Mesa's lavapipe
    // (llvmpipe behind Vulkan, CI's adapter; not behind OpenGL); elsewhere the assertions above still apply. One significant digit: the
    // order of magnitude of each figure is what must not drift.
    if !gpu.is_lavapipe() {
        println!("snapshot skipped on {}", gpu.adapter_summary());
        return;
    }
    let mut table = Vec::new();
    for (name, mesh, rings) in all_levels() {
        let norm = normalise(&mesh.positions).unwrap();
        let p = crosscheck_priority(&gpu, &norm, &rings).unwrap();
        let f = crosscheck_flatten(&gpu, &norm, &rings).unwrap();
        table.push(summary_line(&name, &p, &f));
    }
    for (name, maps) in inverse_cases() {
        let r = crosscheck_inverse(&gpu, &maps, &remesh_points(&maps)).unwrap();
        let s = r.position.rounded(1);
        table.push(format!(
            "{name} Π⁻¹: points {} position max {:e} p50 {:e} bary max {:e} mismatches {}",
            r.points,
            s.max_abs,
            s.p50,
            r.bary.rounded(1).max_abs,
            r.face_mismatches
        ));
    }
    insta::assert_snapshot!(table.join("\n"));
}
