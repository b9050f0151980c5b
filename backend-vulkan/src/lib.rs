//! optik-vulkan: the Vulkan ray tracing backend (DESIGN.md §1, issue 6).
//!
//! Programs written once in WGSL become real ray tracing stages: naga writes SPIR-V with a
//! compute wrapper per stage and an rspirv post-pass turns it into the stage ([`program`]).
//! Acceleration structures are Vulkan's, with OptiX's per-primitive SBT records flattened into
//! geometries and OptiX's instance trees flattened into one top level (`accel`); the user's
//! OptiX-layout shader binding table is translated at launch (`sbt`). What Vulkan lacks is
//! emulated, and `docs/vulkan-backend.md` lists every decision.
//!
//! Module layout (the same names in every backend): `accel`, `program` (with
//! `program::device_api`, the device API as the Vulkan prelude's WGSL,
//! `program::traversal`, what optik's stages add to the driver's traversal: motion and
//! opacity, and `program::exceptions`, the unwinding that ends a launch index), `pipeline`,
//! `sbt`, `launch`; plus `context` (instance and device), `probe` (what each device offers),
//! `memory`, `buffer`, `texture`, `commands`, `cache` (the on-disk pipeline cache) and
//! `validation` (the validation layer's messages).
//!
//! [`VulkanDevice`] is optik-core's device over [`VulkanBackend`]: core checks every call and
//! owns the objects (buffers, textures, acceleration structures, micromap arrays, modules,
//! program groups, pipelines: the backend's associated types), lending them to the backend
//! for each call; the backend keeps under its own lock only what is no object (the Vulkan
//! device, memory, commands, samplers, scene tables, launches in flight, pipeline cache).

mod accel;
mod buffer;
mod cache;
mod commands;
pub mod context;
mod device;
mod error;
pub mod instance;
mod launch;
mod memory;
mod objects;
mod pipeline;
pub mod probe;
pub mod program;
mod sbt;
mod texture;
pub mod validation;

pub use context::VulkanOptions;
pub use device::{VulkanBackend, VulkanDevice};
pub use probe::{RayTracingExtensions, VulkanDeviceInfo, probe};

/// Opens a device of this backend with the options the environment asks for
/// ([`VulkanOptions::from_env`]): the first device with ray tracing pipelines, discrete GPUs
/// first. The error says what each device lacks when none can run optik.
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Ok(Box::new(VulkanDevice::new(VulkanBackend::open(
        &VulkanOptions::from_env(),
    )?)))
}

/// Opens a device of this backend with `options`.
pub fn open_with(options: &VulkanOptions) -> optik_api::Result<VulkanDevice> {
    VulkanBackend::open(options).map(VulkanDevice::new)
}
