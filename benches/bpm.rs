//! BPM benchmarks (issue #2): precompute throughput on a ≥ 1M-triangle mesh, evaluation
//! throughput (f64 CPU with 1 and 2 threads, f32 GPU), the BPM/linear cost ratio, and the QC
//! protocol on spot (`reference_data/models/spot`).
//!
//! Run: `cargo bench --bench bpm`. Figures go in the issue notes; CI only compiles this.

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use reparam::bpm::{face_samples, precompute, qc_protocol, BpmOptions, Interp};
use reparam::mesh::{io::load_obj, procedural, TriMesh};

/// torus(1024, 512) = 1,048,576 triangles.
fn big_mesh() -> TriMesh {
    procedural::torus(1024, 512, 1.0, 0.35)
}

fn in_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

fn bench_precompute(c: &mut Criterion) {
    let mesh = big_mesh();
    let mut group = c.benchmark_group("bpm_precompute");
    group.sample_size(10);
    group.throughput(Throughput::Elements(mesh.face_count() as u64));
    for threads in [1, 2] {
        group.bench_function(format!("torus_1M_f64_{threads}threads"), |b| {
            b.iter(|| {
                in_pool(threads, || {
                    black_box(precompute(&mesh, BpmOptions::default()).unwrap())
                })
            })
        });
    }
    group.finish();
}

fn bench_eval(c: &mut Criterion) {
    let mesh = procedural::torus(256, 128, 1.0, 0.35);
    let bpm = precompute(&mesh, BpmOptions::default()).unwrap();
    let samples = face_samples(bpm.maps.len(), false);
    let mut group = c.benchmark_group("bpm_eval");
    group.sample_size(10);
    group.throughput(Throughput::Elements(samples.len() as u64));
    for threads in [1, 2] {
        for interp in [Interp::Bpm, Interp::Linear] {
            group.bench_function(
                format!("{interp:?}_f64_{threads}threads").to_lowercase(),
                |b| b.iter(|| in_pool(threads, || black_box(bpm.eval_many(&samples, interp)))),
            );
        }
    }
    #[cfg(feature = "gpu")]
    if let Ok(gpu) = reparam::bpm::gpu::context() {
        let maps = reparam::bpm::gpu::maps_to_gpu(&bpm);
        let gpu_samples = reparam::bpm::gpu::samples_to_gpu(&samples);
        for interp in [Interp::Bpm, Interp::Linear] {
            group.bench_function(format!("{interp:?}_f32_gpu").to_lowercase(), |b| {
                b.iter(|| {
                    black_box(
                        reparam::bpm::gpu::eval_gpu(&gpu, &maps, &gpu_samples, interp).unwrap(),
                    )
                })
            });
        }
    }
    group.finish();
}

fn bench_qc(c: &mut Criterion) {
    let spot = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/reference_data/models/spot/spot_triangulated.obj"
    ));
    let (name, mesh) = (
        "spot",
        load_obj(spot).expect("reference_data/models/spot loads"),
    );
    let bpm = precompute(&mesh, BpmOptions::default()).unwrap();
    let mut group = c.benchmark_group("bpm_qc");
    group.sample_size(10);
    for interp in [Interp::Bpm, Interp::Linear] {
        group.bench_function(format!("{name}_subdiv4_{interp:?}").to_lowercase(), |b| {
            b.iter(|| black_box(qc_protocol(&bpm, interp, 4)))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_precompute, bench_eval, bench_qc);
criterion_main!(benches);
