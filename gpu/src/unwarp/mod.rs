//! Distortion-free displacement mapping (seed 001) in f32: one phase pass of the per-texel
//! descent.
//!
//! | kernel | host | WGSL | what it computes |
//! |---|---|---|---|
//! | `unwarp_pass` | [`UnwarpPassKernel`] | `shaders/unwarp_pass.wgsl` | per active texel: gradient, flip-free bracket, ternary search, guard; offsets updated in place |
//!
//! The reference's twins are `descend_texel` and `pass` in `src/unwarp/pass.rs`, with the
//! energy of `src/unwarp/energy.rs` and the barrier of `src/unwarp/fixation.rs`.

pub mod pass;

pub use pass::{TexelResult, UnwarpGrid, UnwarpPassKernel, FLAG_BRACKET, FLAG_MOVED, STEPS_MASK};
