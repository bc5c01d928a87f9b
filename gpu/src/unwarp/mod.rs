//! Distortion-free displacement mapping (seed 001) in f32: one phase pass of the per-texel
//! descent, and applying the correction (render-time lookup, pre-warped bake).
//!
//! | kernel | host | WGSL | what it computes |
//! |---|---|---|---|
//! | `unwarp_pass` | [`UnwarpPassKernel`] | `shaders/unwarp_pass.wgsl` | per active texel: gradient, flip-free bracket, ternary search, guard; offsets updated in place |
//! | `unwarp_lookup` | [`UnwarpLookupKernel`] | `shaders/unwarp_lookup.wgsl` | per query: the lookup coordinate through the offset mip chain (entry `main`); per colour texel: the pre-warped colour (entry `bake`) |
//!
//! The reference's twins are `descend_texel` and `pass` in `src/unwarp/pass.rs`, with the
//! energy of `src/unwarp/energy.rs` and the barrier of `src/unwarp/fixation.rs`; those of
//! `unwarp_lookup` are `lookup_coordinate` and `bake_colour` in `src/unwarp/apply.rs`.

pub mod lookup;
pub mod pass;

pub use lookup::{LookupQuery, OffsetChain, UnwarpLookupKernel};
pub use pass::{TexelResult, UnwarpGrid, UnwarpPassKernel, FLAG_BRACKET, FLAG_MOVED, STEPS_MASK};
