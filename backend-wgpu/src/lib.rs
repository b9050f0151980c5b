//! optik-wgpu: the wgpu compute backend. Programs and traversal run in one generated WGSL
//! compute megakernel per pipeline (docs/wgpu-backend.md):
//!
//! - `accel`: acceleration structures built on the host and stored in a GPU arena in a
//!   four-wide BVH layout with f32 watertight triangle data;
//! - `program`: modules, program groups, and the lowering of programs into per-context
//!   copies at the naga IR level;
//! - `kernel`: the generated WGSL (state, device API, traversal, dispatch, entry point),
//!   specialised to the pipeline's features;
//! - `pipeline`, `sbt`, `launch`: the OptiX objects over wgpu compute;
//! - `device`: the backend ([`WgpuBackend`]) behind optik-core's checks ([`WgpuDevice`],
//!   which owns the objects), and [`WgpuDeviceExt`], the wgpu calls that read them;
//! - `memory`: the accounting of live GPU allocations ([`MemoryTracker`]);
//! - [`bench`](mod@bench): a timing entry point for the GPU machine.

mod accel;
pub mod bench;
mod device;
mod gpu;
mod kernel;
mod launch;
mod memory;
mod objects;
mod pipeline;
mod probe;
mod program;
mod sbt;

pub use device::{KERNEL_DIR_ENV, WgpuBackend, WgpuDevice, WgpuDeviceExt, WgpuOptions};
pub use gpu::ADAPTER_ENV;
pub use memory::MemoryTracker;
pub use probe::{AdapterReport, probe};

/// Opens a device of this backend on the adapter named by [`ADAPTER_ENV`], or else the
/// best adapter wgpu finds (discrete, integrated, virtual, then CPU).
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Ok(Box::new(WgpuBackend::new().map(WgpuDevice::new)?))
}
