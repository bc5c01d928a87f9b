//! Properties of the `unwarp_lookup` kernel on lavapipe (or any adapter), from plain f32 inputs:
//! a lookup at a texel centre returns that texel's offset added with v flipped, the same point
//! a thousand (or 2²⁰) tiles away gives the same coordinate, the trilinear weight blends two
//! levels, the level boundaries (λ = 1, λ past the coarsest, the nearest level's ½) choose the
//! levels the rules give, wrapping and clamping at the border, a bake of zero offsets is the
//! texture, and malformed chains and colour textures are refused.
//! Skipped (printing `skipped: no GPU adapter`) without an adapter unless REPARAM_REQUIRE_GPU=1.

use reparam_gpu::unwarp::{LookupQuery, OffsetChain, UnwarpLookupKernel};
use reparam_gpu::{gpu_or_skip, GpuError};

/// A 4×4 level 0 with offset (x, y)/64 at texel (x, y) and a 2×2 level 1 of constant 1/32,
/// then a 1×1 level 2 of 0.
fn chain(periodic: bool) -> OffsetChain {
    let mut offsets: Vec<[f32; 2]> = (0..16)
        .map(|i| [(i % 4) as f32 / 64.0, (i / 4) as f32 / 64.0])
        .collect();
    offsets.extend([[1.0 / 32.0; 2]; 4]);
    offsets.push([0.0; 2]);
    OffsetChain {
        periodic,
        mipmap_linear: true,
        levels: vec![[4, 4, 0], [2, 2, 16], [1, 1, 20]],
        offsets,
    }
}

fn query(uv: [f32; 2], footprint: f32) -> LookupQuery {
    LookupQuery {
        uv,
        dx: [footprint, 0.0],
        dy: [0.0, 0.0],
    }
}

#[test]
fn lookups_add_the_level_0_offset_at_texel_centres_wrap_far_tiles_and_blend_levels() {
    let Some(gpu) = gpu_or_skip() else { return };
    let kernel = UnwarpLookupKernel::new(&gpu, &chain(true)).unwrap();
    // Texel (2, 1): u = 2.5/4, v = 1 − 1.5/4; offset (2, 1)/64, Δv = −1/64.
    let centre = [0.625, 0.625];
    let far = [centre[0] + 1000.0, centre[1] - 1000.0];
    let out = kernel
        .lookup(
            &gpu,
            &[
                query(centre, 0.0),
                query(far, 0.5),
                // Footprint √2 texels: λ = ½, half level 0 and half level 1.
                query(centre, std::f32::consts::SQRT_2),
            ],
        )
        .unwrap();
    let expected = [centre[0] + 2.0 / 64.0, centre[1] - 1.0 / 64.0];
    assert_eq!(out[0], expected);
    assert_eq!(out[1], expected);
    let blended = [
        centre[0] + 0.5 * (2.0 / 64.0 + 1.0 / 32.0),
        centre[1] - 0.5 * (1.0 / 64.0 + 1.0 / 32.0),
    ];
    for c in 0..2 {
        assert!((out[2][c] - blended[c]).abs() < 1e-6, "{:?}", out[2]);
    }
}

#[test]
fn a_bake_of_zero_offsets_is_the_texture_and_a_chain_past_its_offsets_is_refused() {
    let Some(gpu) = gpu_or_skip() else { return };
    let zero = OffsetChain {
        periodic: true,
        mipmap_linear: true,
        levels: vec![[2, 2, 0]],
        offsets: vec![[0.0; 2]; 4],
    };
    let kernel = UnwarpLookupKernel::new(&gpu, &zero).unwrap();
    let colour: Vec<u32> = (0..24u32).map(|i| i * 0x0103_0507).collect();
    let baked = kernel.bake(&gpu, &colour, 6, 4).unwrap();
    for (texel, c) in colour.iter().zip(&baked) {
        let bytes = texel.to_le_bytes().map(f32::from);
        assert_eq!(*c, bytes);
    }
    let bad = OffsetChain {
        levels: vec![[2, 2, 0], [1, 1, 4]],
        ..zero
    };
    let Err(GpuError::Input(message)) = UnwarpLookupKernel::new(&gpu, &bad) else {
        panic!("a level past the offsets was accepted");
    };
    assert!(message.contains("level 1"), "{message}");
}

/// Level boundaries: λ = 1 exactly is level 1 with weight 0 (trilinear), λ beyond the coarsest
/// level clamps to it, and the nearest level switches at λ = ½ (0.4 → level 0, 0.6 → level 1).
#[test]
fn level_boundaries_select_the_levels_the_rules_give() {
    let Some(gpu) = gpu_or_skip() else { return };
    let centre = [0.625, 0.625];
    let level0 = [centre[0] + 2.0 / 64.0, centre[1] - 1.0 / 64.0];
    let level1 = [centre[0] + 1.0 / 32.0, centre[1] - 1.0 / 32.0];
    let linear = UnwarpLookupKernel::new(&gpu, &chain(true)).unwrap();
    let out = linear
        .lookup(&gpu, &[query(centre, 2.0), query(centre, 64.0)])
        .unwrap();
    assert_eq!(out[0], level1, "λ = 1: level 1 alone");
    assert_eq!(out[1], centre, "λ = 6 clamps to level 2 (offset 0)");
    let nearest = UnwarpLookupKernel::new(
        &gpu,
        &OffsetChain {
            mipmap_linear: false,
            ..chain(true)
        },
    )
    .unwrap();
    let out = nearest
        .lookup(
            &gpu,
            &[query(centre, 2f32.powf(0.4)), query(centre, 2f32.powf(0.6))],
        )
        .unwrap();
    assert_eq!(out, vec![level0, level1]);
}

/// Wrapping: u = 1 lies half-way between the last column and the first; a fixed border
/// clamps to the edge texel and does not re-centre; a query 2²⁰ tiles away (exact in f32)
/// gives the first tile's coordinate.
#[test]
fn wrap_clamp_and_far_tiles() {
    let Some(gpu) = gpu_or_skip() else { return };
    let periodic = UnwarpLookupKernel::new(&gpu, &chain(true)).unwrap();
    let far = 1_048_576.0;
    let out = periodic
        .lookup(
            &gpu,
            &[
                query([1.0, 0.625], 0.0),
                query([far + 0.625, 0.625 - far], 0.0),
            ],
        )
        .unwrap();
    assert_eq!(out[0], [3.0 / 128.0, 0.625 - 1.0 / 64.0]);
    assert_eq!(out[1], [0.625 + 2.0 / 64.0, 0.625 - 1.0 / 64.0]);
    let fixed = UnwarpLookupKernel::new(&gpu, &chain(false)).unwrap();
    let out = fixed.lookup(&gpu, &[query([5.0, -2.0], 0.0)]).unwrap();
    // ξ = 19.5, η = 11.5: the corner texel (3, 3), offset (3, 3)/64.
    assert_eq!(out[0], [5.0 + 3.0 / 64.0, -2.0 - 3.0 / 64.0]);
}

#[test]
fn an_empty_chain_and_a_colour_of_the_wrong_size_are_refused() {
    let Some(gpu) = gpu_or_skip() else { return };
    let empty = OffsetChain {
        levels: vec![],
        ..chain(true)
    };
    let Err(GpuError::Input(message)) = UnwarpLookupKernel::new(&gpu, &empty) else {
        panic!("an empty chain was accepted");
    };
    assert!(message.contains("no level"), "{message}");
    let zero_size = OffsetChain {
        levels: vec![[0, 4, 0]],
        ..chain(true)
    };
    assert!(matches!(
        UnwarpLookupKernel::new(&gpu, &zero_size),
        Err(GpuError::Input(_))
    ));
    let kernel = UnwarpLookupKernel::new(&gpu, &chain(true)).unwrap();
    let Err(GpuError::Input(message)) = kernel.bake(&gpu, &[0; 5], 2, 2) else {
        panic!("5 texels for a 2×2 texture were accepted");
    };
    assert!(message.contains("2×2"), "{message}");
}
