//! The `unwarp_lookup` crosscheck rows on lavapipe (or any adapter): the GPU's lookup
//! coordinates through the offset mip chain, trilinear and nearest level, against the f64
//! reference and the bound of `crosscheck::unwarp_lookup_bound`, on a built-in map and on the
//! three textures shipped in `reference_data/models` read as height maps (box-downsampled to
//! 64², as the demo's size, so that the short solve stays fast). Every row must pass.
//! Skipped (printing `skipped: no GPU adapter`) without an adapter unless REPARAM_REQUIRE_GPU=1.

use std::path::Path;

use reparam::crosscheck::unwarp_lookup::lookup_rows;
use reparam::crosscheck::Verdict;
use reparam::unwarp::{load_height_map, procedural, HeightMap, UnwarpOptions};
use reparam_gpu::gpu_or_skip;

fn options() -> UnwarpOptions {
    UnwarpOptions {
        scale: 0.05,
        sweeps: 6,
        ..Default::default()
    }
}

fn at_most_64(mut heights: HeightMap) -> HeightMap {
    while heights.width > 64 {
        heights = heights
            .downsampled()
            .expect("the shipped textures are powers of two");
    }
    heights
}

#[test]
fn lookup_rows_pass_on_a_built_in_map_and_the_shipped_textures() {
    let Some(gpu) = gpu_or_skip() else { return };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("reference_data/models");
    let mut inputs = vec![("cones 32²".to_string(), procedural("cones", 32).unwrap())];
    for file in [
        "spot/spot_texture.png",
        "blub/blub_texture.png",
        "bob/bob_diffuse.png",
    ] {
        let heights = at_most_64(load_height_map(&root.join(file)).unwrap());
        inputs.push((format!("{file} (64²)"), heights));
    }
    for (name, heights) in &inputs {
        let rows = lookup_rows(&gpu, name, heights, &options()).unwrap();
        assert_eq!(rows.len(), 2);
        for row in rows {
            println!(
                "{} · {}: max {:.3e} UV, worst error/bound {:.3e}, bound max {:.3e}; {}",
                row.input, row.kernel, row.errors.max_abs, row.worst_ratio, row.bound_max, row.note
            );
            assert_eq!(row.verdict, Verdict::Pass, "{} {}", row.input, row.kernel);
            assert!(row.errors.count > 0);
        }
    }
}
