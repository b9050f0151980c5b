//! Traversal and runtime semantics through the `Device` API, with native (Rust closure)
//! programs: DESIGN.md §4 rule by rule.

mod kit;

mod basics;
