//! The twins run over a kernel's conformance-vector inputs: the candidate array a conforming GPU under a given arithmetic model would hand to verify.

pub mod maps_flatten;
pub mod maps_priority;
pub mod maps_rings;
