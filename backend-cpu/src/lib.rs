//! optik-cpu: the CPU backend.
//!
//! Module layout (the same names in every backend, DESIGN.md §1):
//! - `accel`: the CPU's encoding of optik-accel's structures: 4-wide nodes and triangle
//!   blocks;
//! - `traversal`: our own robust traversal and intersection;
//! - `program`: WGSL programs JIT-compiled with Cranelift (feature `jit`);
//! - `pipeline`, `sbt`: the OptiX objects;
//! - `launch`: the launch loop on rayon threads;
//! - `device_api`: the device API programs call (payload registers, attributes, traces,
//!   callables), with the fate of candidates (any-hit and intersection programs) and
//!   exceptions in its `candidates` and `exceptions` modules;
//! - `device`: [`CpuDevice`].
//!
//! docs/cpu-backend.md records the decisions: BVH layout and build presets, handle
//! encoding, payload and exception semantics, the curve tolerance, specialisation.

pub mod accel;
pub mod program;
pub mod traversal;

mod device;
mod device_api;
mod jit_glue;
mod launch;
pub mod objects;
pub mod pipeline;
mod sbt;

pub use device::{CpuBackend, CpuDevice, CpuDeviceExt, MAX_CALLABLE_DEPTH, cpu_name};
pub use pipeline::{NativeModuleDesc, NativeProgram};

/// Opens a CPU device with one launch thread per core.
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Ok(Box::new(CpuBackend::new().map(CpuDevice::new)?))
}

/// Opens a CPU device with `threads` launch threads (`None`: one per core).
pub fn open_with_threads(threads: Option<usize>) -> optik_api::Result<Box<dyn optik_api::Device>> {
    Ok(Box::new(
        CpuBackend::with_threads(threads.unwrap_or(0)).map(CpuDevice::new)?,
    ))
}
