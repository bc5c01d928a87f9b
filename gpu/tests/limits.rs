//! Inputs too large for the device's limits, tested by lowering the limits the context requests
//! ([`Gpu::with_limits`]) rather than by allocating gigabytes: kernels that can split their work
//! (bpm_precompute, bpm_eval, bpm_render, every `run_per_item` kernel) give results identical to
//! one unsplit run; kernels that bind a whole input refuse it with [`GpuError::ExceedsLimit`]
//! naming the kernel, the size and the limit, before wgpu validates (and panics on) anything.
//! Skipped (printing `skipped: no GPU adapter`) without an adapter unless REPARAM_REQUIRE_GPU=1.

mod support;

use reparam_gpu::bpm::{bpm_eval, bpm_precompute, bpm_render, Fit, Interp, RenderInput, Sample};
use reparam_gpu::skinsimp::{Influences, LbsInput, LbsKernel};
use reparam_gpu::{gpu_or_skip, Gpu, GpuError};
use support::{barycentric_grid, planar_star, Mesh, C};

/// Bindings of 16 KiB (78 BPM faces), buffers of 1 MiB, 4 × 4 workgroups (1024 invocations)
/// per dispatch.
fn small_limits() -> wgpu::Limits {
    wgpu::Limits {
        max_storage_buffer_binding_size: 16 << 10,
        max_buffer_size: 1 << 20,
        max_compute_workgroups_per_dimension: 4,
        ..wgpu::Limits::default()
    }
}

fn small_gpu() -> Option<Gpu> {
    gpu_or_skip()?;
    Some(Gpu::with_limits(&small_limits()).expect("a device with lowered limits"))
}

/// The planar star of `support` with UVs (x + 0.3 y + 0.2 x², 0.5 y), its 4 faces repeated
/// `copies` times (stars are independent items, so this is a large input of known content).
fn many_stars(copies: usize) -> Mesh {
    let (positions, faces, xy) = planar_star(1.0);
    let uv = |v: usize| {
        C(
            xy[v].0 + 0.3 * xy[v].1 + 0.2 * xy[v].0 * xy[v].0,
            0.5 * xy[v].1,
        )
    };
    let n = positions.len();
    Mesh {
        positions: (0..copies).flat_map(|_| positions.clone()).collect(),
        faces: (0..copies)
            .flat_map(|c| faces.iter().map(move |f| f.map(|v| v + c * n)))
            .collect(),
        uvs: (0..copies)
            .flat_map(|_| faces.iter().map(|f| f.map(uv)))
            .collect(),
    }
}

#[test]
fn lowered_limits_are_what_the_device_reports() {
    let Some(small) = small_gpu() else { return };
    let l = small.limits();
    assert_eq!(l.max_storage_buffer_binding_size, 16 << 10);
    assert_eq!(l.max_buffer_size, 1 << 20);
    assert_eq!(l.max_compute_workgroups_per_dimension, 4);
}

/// 1 200 faces (250 KB of maps, 15 bindings' worth) and 33 600 samples (33 dispatches of
/// 1 024): split into windows and chunks, bit-identical to the unsplit run.
#[test]
fn bpm_split_across_dispatches_equals_the_unsplit_run() {
    let Some(gpu) = gpu_or_skip() else { return };
    let Some(small) = small_gpu() else { return };
    let mesh = many_stars(300);
    let stars = mesh.stars();
    let maps = bpm_precompute::run(&gpu, &stars, Fit::Local).unwrap();
    assert_eq!(
        bpm_precompute::run(&small, &stars, Fit::Local).unwrap(),
        maps
    );
    let samples: Vec<Sample> = (0..mesh.faces.len())
        .flat_map(|f| {
            barycentric_grid(6)
                .into_iter()
                .map(move |b| Sample::new(f as u32, b[1] as f32, b[2] as f32))
        })
        .collect();
    assert!(samples.len() > 30 * 1024);
    small.start_clock();
    let split = bpm_eval::run(&small, &maps, &samples, Interp::Bpm).unwrap();
    let dispatches = small.stop_clock().submissions;
    gpu.start_clock();
    let whole = bpm_eval::run(&gpu, &maps, &samples, Interp::Bpm).unwrap();
    assert_eq!(gpu.stop_clock().submissions, 1);
    // 16 windows of ≤ 78 faces, each ≤ 2 184 samples in ≤ 3 dispatches of 1 024.
    assert!(dispatches >= 33, "{dispatches} dispatches");
    assert_eq!(split, whole);
}

/// The render draws in windows of faces; the picture's readback and the texture are checked
/// against the buffer and texture limits.
#[test]
fn bpm_render_splits_its_faces_and_refuses_a_picture_beyond_the_limits() {
    let Some(gpu) = gpu_or_skip() else { return };
    let Some(small) = small_gpu() else { return };
    let mesh = many_stars(100);
    let maps = bpm_precompute::run(&gpu, &mesh.stars(), Fit::Local).unwrap();
    let corners: Vec<[f32; 4]> = mesh
        .faces
        .iter()
        .flat_map(|f| {
            f.map(|v| {
                let p = mesh.positions[v];
                [0.5 * p[0] as f32, 0.5 * p[1] as f32, 0.5, 1.0]
            })
        })
        .collect();
    let texture: Vec<u8> = (0..16 * 16 * 4).map(|i| (i * 7 % 256) as u8).collect();
    let input = |size: u32| RenderInput {
        width: size,
        height: size,
        view_proj: [
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ],
        corners: &corners,
        maps: &maps,
        texture_width: 16,
        texture_height: 16,
        texture: &texture,
        interp: Interp::Bpm,
        background: [10, 20, 30, 255],
    };
    assert_eq!(
        bpm_render::run(&small, &input(64)).unwrap(),
        bpm_render::run(&gpu, &input(64)).unwrap()
    );
    // 1024 rows of 4 KiB: 4 MiB to read back, the device's buffers hold 1 MiB.
    assert_eq!(
        bpm_render::run(&small, &input(1024)).unwrap_err(),
        GpuError::ExceedsLimit {
            kernel: "bpm_render readback".into(),
            limit: "max_buffer_size",
            needed: 4 << 20,
            allowed: 1 << 20,
        }
    );
    let limit = small.limits().max_texture_dimension_2d;
    let big = vec![0u8; 4 * (limit as usize + 1)];
    let input_big = RenderInput {
        texture_width: limit + 1,
        texture_height: 1,
        texture: &big,
        ..input(64)
    };
    let e = bpm_render::run(&small, &input_big).unwrap_err();
    assert!(
        matches!(&e, GpuError::ExceedsLimit { kernel, limit: "max_texture_dimension_2d", .. }
            if kernel == "bpm_render texture"),
        "{e}"
    );
}

/// LBS binds all rest positions at once and runs one invocation per (vertex, pose): too many
/// for one binding, or for one dispatch, is a typed error naming the kernel and the limit.
#[test]
fn a_kernel_that_cannot_split_refuses_with_the_kernel_size_and_limit() {
    let Some(gpu) = gpu_or_skip() else { return };
    let few_groups = Gpu::with_limits(&wgpu::Limits {
        max_compute_workgroups_per_dimension: 4,
        ..wgpu::Limits::default()
    })
    .unwrap();
    let lbs = LbsKernel::new(&few_groups).unwrap();
    let input = |vertices: usize| LbsInput {
        rest: vec![[1.0, 2.0, 3.0]; vertices],
        influences: vec![
            Influences {
                joints: [0; 4],
                weights: [1.0, 0.0, 0.0, 0.0],
            };
            vertices
        ],
        joint_count: 1,
        joints: vec![[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]],
    };
    // 1024 invocations fit 4 × 4 workgroups of 64.
    assert_eq!(lbs.skin(&few_groups, &input(1024)).unwrap().len(), 1024);
    let e = lbs.skin(&few_groups, &input(1025)).unwrap_err();
    assert_eq!(
        e,
        GpuError::ExceedsLimit {
            kernel: "skinsimp_lbs".into(),
            limit: "max_compute_workgroups_per_dimension (squared: workgroups per dispatch)",
            needed: 17,
            allowed: 16,
        }
    );
    assert_eq!(e.to_string().lines().count(), 1);
    assert!(e.to_string().contains("skinsimp_lbs needs 17"), "{e}");

    // Same kernel, a device with room for the dispatch but 16 KiB bindings: 2 000 rest
    // positions are 24 000 bytes.
    let narrow = Gpu::with_limits(&wgpu::Limits {
        max_storage_buffer_binding_size: 16 << 10,
        max_compute_workgroups_per_dimension: gpu.limits().max_compute_workgroups_per_dimension,
        ..wgpu::Limits::default()
    })
    .unwrap();
    let lbs = LbsKernel::new(&narrow).unwrap();
    let e = lbs.skin(&narrow, &input(2000)).unwrap_err();
    assert_eq!(
        e,
        GpuError::ExceedsLimit {
            kernel: "skinsimp_lbs".into(),
            limit: "max_storage_buffer_binding_size",
            needed: 24_000,
            allowed: 16 << 10,
        }
    );
    // A buffer beyond max_buffer_size is refused before it is created.
    let Some(small) = small_gpu() else { return };
    let e = small
        .upload_storage("too big", &vec![0u32; (1 << 18) + 1])
        .unwrap_err();
    assert_eq!(
        e,
        GpuError::ExceedsLimit {
            kernel: "too big".into(),
            limit: "max_buffer_size",
            needed: (1 << 20) + 4,
            allowed: 1 << 20,
        }
    );
}
