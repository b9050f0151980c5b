//! optik-cpu: the CPU backend.
//!
//! Module layout (the same names in every backend, DESIGN.md §1):
//! - `accel`: acceleration structures built with obvhs;
//! - `traverse`: our own robust traversal and intersection;
//! - `program`: WGSL programs JIT-compiled with Cranelift;
//! - `pipeline`, `sbt`, `launch`: the OptiX objects and the launch loop on rayon threads.

pub mod program;

/// Opens a device of this backend.
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Err(optik_api::Error::unsupported(
        "the cpu backend is not implemented yet",
    ))
}

/// Opens a device of this backend with `threads` worker threads (`None`: one per core).
pub fn open_with_threads(_threads: Option<usize>) -> optik_api::Result<Box<dyn optik_api::Device>> {
    open()
}
