//! Traversal and runtime semantics through the `Device` API, with native (Rust closure)
//! programs: DESIGN.md §4 rule by rule.

mod kit;

mod accel_ops;
mod anyhit;
mod basics;
mod callables;
mod custom;
mod determinism;
mod errors;
mod exceptions;
mod features;
mod flags;
mod instances;
mod motion;
mod primitives;
mod sbt;
