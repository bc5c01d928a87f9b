//! reparam: reference implementations of texture-parameterisation algorithms.

pub mod bpm;
pub mod crosscheck;
pub mod error;
pub mod mesh;
pub mod report;
pub mod raster;
pub mod texture;

pub use error::{Error, Result};
