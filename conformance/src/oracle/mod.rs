//! The oracle: an independent brute-force `f64` tracer (no BVH) with exact orientation tests.

pub mod exact;
