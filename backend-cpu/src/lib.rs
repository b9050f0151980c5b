//! optik-cpu: the CPU backend.
//!
//! Module layout (the same names in every backend, DESIGN.md §1):
//! - `accel`: acceleration structures built with obvhs, in a layout the wgpu backend reuses;
//! - `traverse`: our own robust traversal and intersection;
//! - `program`: WGSL programs JIT-compiled with Cranelift;
//! - `pipeline`, `sbt`, `launch`: the OptiX objects and the launch loop on rayon threads.

pub mod accel;
pub mod program;
pub mod traverse;

/// Opens a device of this backend.
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Err(optik_api::Error::unsupported(
        "the cpu backend is not implemented yet",
    ))
}
