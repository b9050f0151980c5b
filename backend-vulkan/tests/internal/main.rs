//! optik-vulkan's own tests, in one binary, end to end on the machine's ray tracing device
//! (lavapipe in CI) with the Khronos validation layer on: any message it reports fails the
//! test. What only this backend has: its triangle paths (`triangle_paths`), optik's box test
//! in front of intersection programs (`aabb`), staging memory (`anyhit`), direct calls inlined
//! into intersection and any-hit stages (`callables`), the device, its features, the pipeline
//! cache (`device`), what the backend refuses and device loss (`errors`), nesting limits
//! (`instances`), launches split into dispatches (`launches`), primitive-type culling (`rays`),
//! records past the table for every primitive kind and triangle path (`sbt`), deadlines and
//! cancellation (`timeouts`), stale motion pipelines refused and children refit under motion
//! transforms (`motion`).
//!
//! The rules every backend keeps are tested once, on every backend, in optik-conformance (its
//! catalog, `tests/misuse.rs` and `tests/rules/`; conformance/README.md, "Where the backend
//! tests live").

mod aabb;
mod anyhit;
mod callables;
mod common;
mod device;
mod errors;
mod instances;
mod launches;
mod motion;
mod rays;
mod sbt;
mod timeouts;
mod triangle_paths;
