//! The canonical `unwarp_pass` manifest against its data: the f64 reference descent
//! (`unwarp::pass::descend_texel`) on a problem rebuilt from the arrays alone, read as the
//! manifest says (z and pins [H, W] with node c = y·W + x, offsets [H, W, 2] as (u, v), θ,
//! R_pin and the border from `params`), reproduces the expected offsets bit for bit; `active` is
//! the manifest's phase 0 (x and y even, row-major); the start puts pinned nodes near their
//! barrier, as the manifest says; and the transposed reading of the grids (c = x·H + y) fails.
#![cfg(feature = "gpu")]

use std::path::{Path, PathBuf};

use reparam::unwarp::fixation::pin_q;
use reparam::unwarp::pass::descend_texel;
use reparam::unwarp::{Border, HeightMap, Problem, UnwarpMesh};
use reparam::vectors::unwarp::START_PIN_LEVEL;
use reparam::vectors::Array;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/vectors/unwarp")
}

fn load(name: &str) -> Array {
    Array::load(&dir().join(format!("unwarp_pass.{name}.npy"))).unwrap()
}

/// The problem and start offsets from the arrays, node (x, y) read at `at(x, y, W, H)`.
fn rebuild(at: fn(usize, usize, usize, usize) -> usize) -> (Problem, Vec<[f64; 2]>) {
    let z = load("z");
    let (h, w) = (z.shape[0], z.shape[1]);
    let (z, pins, offsets, params) = (
        z.to_f64(),
        load("pins").to_f64(),
        load("offsets").to_f64(),
        load("params").to_f64(),
    );
    let node = |i: usize| at(i % w, i / w, w, h);
    let heights: Vec<f64> = (0..w * h).map(|i| z[node(i)]).collect();
    let border = if params[3] == 1.0 {
        Border::Periodic
    } else {
        Border::Fixed
    };
    let mesh = UnwarpMesh::new(&HeightMap::new("z", w, h, heights).unwrap(), 1.0, border).unwrap();
    let problem = Problem {
        mesh,
        theta: params[0],
        pins: (0..w * h).map(|i| pins[node(i)]).collect(),
        pin_resolution: [params[1], params[2]],
    };
    let start = (0..w * h)
        .map(|i| [offsets[2 * node(i)], offsets[2 * node(i) + 1]])
        .collect();
    (problem, start)
}

fn row_major(x: usize, y: usize, w: usize, _: usize) -> usize {
    y * w + x
}

fn transposed(x: usize, y: usize, _: usize, h: usize) -> usize {
    x * h + y
}

/// The reference's new offsets of the active nodes (c = y·W + x) under a reading.
fn descend_all(at: fn(usize, usize, usize, usize) -> usize) -> Vec<f64> {
    let (problem, start) = rebuild(at);
    let w = problem.mesh.width;
    load("active")
        .to_f64()
        .iter()
        .flat_map(|&c| descend_texel(&problem, &start, c as usize % w, c as usize / w))
        .collect()
}

#[test]
fn the_manifests_reading_reproduces_the_expected_offsets_and_the_transposed_one_fails() {
    let expected = load("expected").to_f64();
    let bound = load("bound").to_f64();
    assert_eq!(descend_all(row_major), expected);
    let other = descend_all(transposed);
    let over = (0..bound.len())
        .filter(|&i| {
            let d = (other[2 * i] - expected[2 * i]).hypot(other[2 * i + 1] - expected[2 * i + 1]);
            d * 4096.0 > bound[i]
        })
        .count();
    assert!(over > bound.len() / 2, "{over} of {} over", bound.len());
}

#[test]
fn active_is_phase_0_row_major_and_pinned_nodes_start_near_their_barrier() {
    let z = load("z");
    let (h, w) = (z.shape[0], z.shape[1]);
    let phase_0: Vec<f64> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter(|&(x, y)| x % 2 == 0 && y % 2 == 0)
        .map(|(x, y)| (y * w + x) as f64)
        .collect();
    assert_eq!(load("active").to_f64(), phase_0);
    let (problem, start) = rebuild(row_major);
    let levels: Vec<f64> = start
        .iter()
        .zip(&problem.pins)
        .map(|(&o, &p)| pin_q(p, problem.pin_resolution, o).sqrt())
        .collect();
    let highest = levels.iter().cloned().fold(0.0, f64::max);
    // translated_start: every node within START_PIN_LEVEL, the highest near it (the pin terms
    // shape the step only there).
    assert!(
        highest <= START_PIN_LEVEL && highest > 0.8 * START_PIN_LEVEL,
        "highest pin level {highest}"
    );
}
