//! The Vulkan backend's objects: what optik-core keeps in its tables for `VulkanBackend`
//! (the associated types of its `optik_core::Backend`), named in one place. Buffers are
//! defined here; the others live beside the code that makes them (`TextureObject` in
//! `texture`, `AccelObject` in `accel`, `ModuleObject`, `GroupObject` and `PipelineObject`
//! in `pipeline`) and are re-exported. Nothing here looks at the device's state.

pub use crate::accel::AccelObject;
use crate::context::Context;
use crate::device::VulkanBackend;
use crate::memory::{Allocator, GpuBuffer};
pub use crate::pipeline::{GroupObject, ModuleObject, PipelineObject};
pub use crate::texture::TextureObject;
use optik_api::{Accel, Buffer, OpacityMicromapArrayDesc};
use optik_core::HandleTable;
use std::sync::Arc;

/// An opacity micromap array: its states, copied into the structures that use it.
pub type MicromapArrayObject = Arc<OpacityMicromapArrayDesc>;

/// A user buffer.
pub struct UserBuffer {
    /// The Vulkan buffer.
    pub gpu: GpuBuffer,
    /// Bumped on every write (host writes, and launches that bind it writable), so cached
    /// SBT translations know when to read it again.
    pub generation: u64,
}

/// The objects of a Vulkan device, owned by optik-core.
pub type Objects = optik_core::Objects<VulkanBackend>;
/// The user buffers of [`Objects`].
pub type Buffers = HandleTable<Buffer, UserBuffer>;
/// The acceleration structures and transforms of [`Objects`].
pub type Accels = HandleTable<Accel, AccelObject>;

/// An object core handed back to be freed while the device could not free it (it was lost,
/// or waiting for the launches that may use it failed): kept until the device is dropped,
/// which waits for its work and then frees it.
pub enum Unfreed {
    /// A user buffer.
    Buffer(UserBuffer),
    /// A texture.
    Texture(TextureObject),
    /// An acceleration structure or transform.
    Accel(AccelObject),
    /// A pipeline.
    Pipeline(PipelineObject),
}

impl Unfreed {
    /// Frees it (on an idle device).
    pub fn destroy(self, ctx: &Context, alloc: &mut Allocator) {
        match self {
            Unfreed::Buffer(b) => b.gpu.destroy(ctx, alloc),
            Unfreed::Texture(t) => t.destroy(ctx, alloc),
            Unfreed::Accel(a) => a.destroy(ctx, alloc),
            Unfreed::Pipeline(p) => p.destroy(ctx, alloc),
        }
    }
}
