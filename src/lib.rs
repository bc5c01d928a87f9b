//! reparam: reference implementations of texture-parameterisation algorithms.

pub mod bpm;
pub mod crosscheck;
pub mod error;
pub mod gridwarp;
pub mod lm;
pub mod mesh;
pub mod raster;
pub mod reference_data;
pub mod report;
pub mod texture;

pub use error::{Error, Result};
