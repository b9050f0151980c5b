//! optik-wgpu's own tests, in one binary: what only this backend has. The rules every
//! backend keeps are tested once, on every backend, in optik-conformance (its catalog,
//! `tests/misuse.rs` and `tests/rules/`; conformance/README.md, "Where the backend tests
//! live").
//!
//! - `specialise`: the megakernel holds only what the pipeline uses (DESIGN.md §6), the
//!   shadow-ray call site, accuracy selecting the compiled tests;
//! - `triangles`: both accuracy settings' kernels find the same clear hits;
//! - `misc`: scenes that grow after linking get bigger kernels; extensions hold the Vulkan
//!   loader;
//! - `accels`: scenes larger than one storage binding are split;
//! - `errors`: unaligned buffer copies, the adapter's limits (workgroup grid, storage
//!   bindings, graph depth), device loss, GPU memory accounting;
//! - `timeouts`: deadlines and cancellation on the GPU;
//! - `bench`: the benchmark entry points and traffic counters.

mod common;

mod accels;
mod bench;
mod errors;
mod misc;
mod specialise;
mod timeouts;
mod triangles;
