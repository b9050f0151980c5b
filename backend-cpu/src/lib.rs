//! optik-cpu: the CPU backend.
//!
//! Module layout (the same names in every backend, DESIGN.md §1):
//! - `accel`: acceleration structures built with obvhs, in a layout the wgpu backend reuses;
//! - `traverse`: our own robust traversal and intersection;
//! - `program`: WGSL programs JIT-compiled with Cranelift (feature `jit`);
//! - `pipeline`, `sbt`, `launch`, `device`: the OptiX objects, the launch loop on rayon
//!   threads and [`CpuDevice`] (feature `runtime`).
//!
//! docs/cpu-backend.md records the decisions: BVH layout and build presets, handle
//! encoding, payload and exception semantics, the curve tolerance, specialisation.

pub mod accel;
pub mod program;
pub mod traverse;

#[cfg(feature = "runtime")]
mod device;
#[cfg(feature = "runtime")]
mod jit_glue;
#[cfg(feature = "runtime")]
mod launch;
#[cfg(feature = "runtime")]
pub mod pipeline;
#[cfg(feature = "runtime")]
mod sbt;

#[cfg(feature = "runtime")]
pub use device::{CpuDevice, MAX_CALLABLE_DEPTH, cpu_name};
#[cfg(feature = "runtime")]
pub use pipeline::{NativeModuleDesc, NativeProgram};

/// Opens a CPU device with one launch thread per core.
#[cfg(feature = "runtime")]
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Ok(Box::new(CpuDevice::new()?))
}

/// Opens a CPU device with `threads` launch threads (`None`: one per core).
#[cfg(feature = "runtime")]
pub fn open_with_threads(threads: Option<usize>) -> optik_api::Result<Box<dyn optik_api::Device>> {
    Ok(Box::new(CpuDevice::with_threads(threads.unwrap_or(0))?))
}

/// Without the `runtime` feature this crate only builds acceleration structures.
#[cfg(not(feature = "runtime"))]
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Err(optik_api::Error::unsupported(
        "optik-cpu was built without its `runtime` feature; enable `runtime` (or `jit`) for a device",
    ))
}

/// Without the `runtime` feature this crate only builds acceleration structures.
#[cfg(not(feature = "runtime"))]
pub fn open_with_threads(_threads: Option<usize>) -> optik_api::Result<Box<dyn optik_api::Device>> {
    open()
}
