//! End-to-end tests of the Vulkan backend on the machine's ray tracing device (lavapipe in
//! CI), with the Khronos validation layer on: any message it reports fails the test.

mod aabb;
mod anyhit;
mod builtins;
mod callables;
mod common;
mod device;
mod errors;
mod exceptions;
mod geometry;
mod instances;
mod launches;
mod micromaps;
mod motion;
mod rays;
mod sbt;
mod timeouts;
mod triangle_paths;
mod triangles;
