//! Properties of the `unwarp_pass` kernel on lavapipe (or any adapter), from plain f32 inputs:
//! input validation, a flat map barely moving, a phase touching only its texels, and repeat
//! runs being identical. Skipped (printing `skipped: no GPU adapter`) without an adapter unless
//! REPARAM_REQUIRE_GPU=1.

use reparam_gpu::unwarp::{UnwarpGrid, UnwarpPassKernel, FLAG_MOVED};
use reparam_gpu::{gpu_or_skip, GpuError};

/// An n×n periodic grid with heights `z(x, y)`, no pins, four phases p = (x & 1) + 2 (y & 1).
fn grid(n: u32, z: impl Fn(u32, u32) -> f32) -> UnwarpGrid {
    let mut phases = vec![Vec::new(); 4];
    for y in 0..n {
        for x in 0..n {
            phases[((x & 1) + 2 * (y & 1)) as usize].push(y * n + x);
        }
    }
    UnwarpGrid {
        width: n,
        height: n,
        periodic: true,
        theta: 5.0,
        pin_resolution: [n as f32; 2],
        z: (0..n * n).map(|i| z(i % n, i / n)).collect(),
        pins: vec![0.0; (n * n) as usize],
        phases,
    }
}

/// A bump of height 0.1 (texture-width units) in the middle of the unit square.
fn bump(n: u32) -> impl Fn(u32, u32) -> f32 {
    move |x, y| {
        let (u, v) = (
            (x as f32 + 0.5) / n as f32 - 0.5,
            (y as f32 + 0.5) / n as f32 - 0.5,
        );
        0.1 * (-(u * u + v * v) / 0.02).exp()
    }
}

#[test]
fn bad_inputs_are_errors() {
    let Some(gpu) = gpu_or_skip() else { return };
    let mut g = grid(4, |_, _| 0.0);
    g.z.pop();
    assert!(matches!(
        UnwarpPassKernel::new(&gpu, g, &[[0.0; 2]; 16]),
        Err(GpuError::Input(_))
    ));
    let mut g = grid(4, |_, _| 0.0);
    g.phases[0].push(99);
    assert!(matches!(
        UnwarpPassKernel::new(&gpu, g, &[[0.0; 2]; 16]),
        Err(GpuError::Input(_))
    ));
    let kernel = UnwarpPassKernel::new(&gpu, grid(4, |_, _| 0.0), &[[0.0; 2]; 16]).unwrap();
    assert!(matches!(kernel.pass(&gpu, 4), Err(GpuError::Input(_))));
    let mut kernel = kernel;
    assert!(matches!(
        kernel.set_offsets(&gpu, &[[0.0; 2]; 3]),
        Err(GpuError::Input(_))
    ));
}

#[test]
fn a_flat_map_stays_within_the_search_resolution_of_zero() {
    let Some(gpu) = gpu_or_skip() else { return };
    let n = 8;
    let kernel = UnwarpPassKernel::new(&gpu, grid(n, |_, _| 0.25), &vec![[0.0; 2]; 64]).unwrap();
    kernel.passes(&gpu, &[0, 1, 2, 3, 0, 1, 2, 3]).unwrap();
    // In f64 the offsets stay exactly 0 (the guard rejects the rounding-level step). In f32 the
    // comparisons F(t1) > F(t2) and F(t) < F(0) are noise once F differs by less than 2ηF
    // (η ≈ 30u ≈ 1.8e-6, a fan energy's f32 relative error), i.e. within ½F''δ² ≤ 2ηF of the
    // minimum: δ ≤ 2√(ηF/F''). Moving the centre by one texel folds a triangle, so the
    // curvature is at least F per texel² (F''/F ≥ 1): δ ≤ 2√η ≈ 2.7e-3 texels per update, two
    // updates in two sweeps: ≤ 5.4e-3 texels.
    let worst = kernel
        .offsets(&gpu)
        .unwrap()
        .iter()
        .map(|o| (o[0] * n as f32).hypot(o[1] * n as f32))
        .fold(0.0f32, f32::max);
    assert!(worst <= 5.4e-3, "flat map moved {worst} texels");
    println!("flat map: largest f32 offset {worst:e} texels");
}

#[test]
fn a_pass_changes_only_its_phase_and_repeats_exactly() {
    let Some(gpu) = gpu_or_skip() else { return };
    let n = 16;
    let start = vec![[0.0f32; 2]; 256];
    let run = || {
        let kernel = UnwarpPassKernel::new(&gpu, grid(n, bump(n)), &start).unwrap();
        let results = kernel.pass(&gpu, 1).unwrap();
        (kernel.offsets(&gpu).unwrap(), results)
    };
    let (a, results) = run();
    let (b, _) = run();
    assert_eq!(a, b, "two runs differ");
    let mut moved = 0;
    for (i, o) in a.iter().enumerate() {
        let (x, y) = (i as u32 % n, i as u32 / n);
        if *o != [0.0, 0.0] {
            assert_eq!(
                (x & 1, y & 1),
                (1, 0),
                "texel ({x},{y}) of another phase moved"
            );
            moved += 1;
        }
    }
    assert!(moved > 10, "only {moved} texels moved on the bump");
    assert_eq!(
        results.iter().filter(|r| r.flags & FLAG_MOVED != 0).count(),
        moved
    );
}
