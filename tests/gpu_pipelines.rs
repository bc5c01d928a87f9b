//! Pipelines and shader modules are made once per GPU context: running every kernel a second
//! time (through the cross-check of each algorithm on small built-in data) compiles nothing new.
//! Without an adapter this prints `skipped: no GPU adapter` and passes; with
//! REPARAM_REQUIRE_GPU=1 it fails instead.
#![cfg(feature = "gpu")]

use reparam::crosscheck::{bpm, gridwarp, maps, skinsimp, unwarp};
use reparam_gpu::{gpu_or_skip, Gpu};

/// Every kernel of reparam-gpu once.
fn every_kernel(gpu: &Gpu) {
    let star = reparam::mesh::procedural::flat_star(12);
    bpm::bpm_rows(gpu, &star, &reparam::texture::checker(64, 4)).unwrap();
    let scene = reparam::gridwarp::scene::analytic_scene("bump", 2)
        .unwrap()
        .fields(32);
    let grid = reparam::gridwarp::Grid::uniform(4, 4);
    gridwarp::kernel_rows(gpu, "bump", &scene.rest, &grid, &scene.frames[1], (2, 2)).unwrap();
    let heights = reparam::unwarp::procedural("cones", 16).unwrap();
    unwarp::pass_row(gpu, "cones", &heights, &Default::default()).unwrap();
    let mut torus = reparam::mesh::procedural::torus(12, 6, 1.0, 0.35);
    torus.uvs.clear();
    torus.uv_faces.clear();
    let options = reparam::maps::MapsOptions::default();
    let built = reparam::maps::build(&torus, &Default::default(), &options).unwrap();
    maps::crosscheck_maps(gpu, "torus", &built, &options).unwrap();
    let model = reparam::skinsimp::tube::skinned_tube(6, 6);
    let sets = reparam::skinsimp::poses::select_poses(
        &model,
        &reparam::skinsimp::poses::PoseSelection::Uniform(2),
    )
    .unwrap();
    let input = reparam::skinsimp::poses::skinned_input(&model, &sets.training).unwrap();
    skinsimp::crosscheck_skinsimp(gpu, "tube", &input).unwrap();
}

#[test]
fn a_second_run_of_every_kernel_compiles_no_pipeline() {
    let Some(gpu) = gpu_or_skip() else { return };
    every_kernel(&gpu);
    let compiled = gpu.cached_count();
    // bpm: precompute, eval, render; gridwarp_aa; unwarp_pass; maps: priority, flatten,
    // inverse; skinsimp: lbs, plane and vertex quadrics, collapse cost.
    assert!(compiled >= 12, "{compiled} pipelines cached");
    every_kernel(&gpu);
    assert_eq!(
        gpu.cached_count(),
        compiled,
        "a kernel compiled its pipeline again"
    );
}
