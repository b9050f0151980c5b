//! The CPU backend's objects: what optik-core keeps in its tables for `CpuBackend` (the
//! associated types of its `optik_core::Backend`), named in one place. Buffers, textures
//! and acceleration structures are defined here; modules, groups and pipelines live beside
//! the code that makes them (`pipeline`), micromap arrays in `accel`, and are re-exported.
//! Nothing here looks at the device's state.

pub use crate::accel::MicromapArrayData;
use crate::accel::Traversable;
pub use crate::pipeline::{GroupObject, ModuleObject, PipelineObject};
use optik_api::{AccelBuildOptions, BuildInput, Error, ErrorKind, Result, TextureDesc};
use std::sync::Arc;

/// 16-byte aligned bytes: what programs read `vec4<f32>`s and the like out of.
#[repr(C, align(16))]
#[derive(Clone, Copy)]
pub(crate) struct Chunk([u8; 16]);

/// A buffer's memory.
pub struct BufferData {
    pub(crate) chunks: Vec<Chunk>,
    pub(crate) size: usize,
}

impl BufferData {
    pub(crate) fn zeroed(size: u64) -> Result<BufferData> {
        let size = usize::try_from(size).map_err(|_| {
            Error::new(
                ErrorKind::OutOfMemory,
                "buffer size exceeds the address space",
            )
        })?;
        let mut chunks = Vec::new();
        chunks.try_reserve_exact(size.div_ceil(16)).map_err(|_| {
            Error::new(
                ErrorKind::OutOfMemory,
                format!("cannot allocate a buffer of {size} bytes"),
            )
        })?;
        chunks.resize(size.div_ceil(16), Chunk([0; 16]));
        Ok(BufferData { chunks, size })
    }

    pub(crate) fn bytes(&self) -> &[u8] {
        &bytemuck_chunks(&self.chunks)[..self.size]
    }

    pub(crate) fn bytes_mut(&mut self) -> &mut [u8] {
        let size = self.size;
        &mut bytemuck_chunks_mut(&mut self.chunks)[..size]
    }
}

fn bytemuck_chunks(c: &[Chunk]) -> &[u8] {
    // SAFETY: `Chunk` is 16 plain bytes without padding.
    unsafe { std::slice::from_raw_parts(c.as_ptr() as *const u8, c.len() * 16) }
}

fn bytemuck_chunks_mut(c: &mut [Chunk]) -> &mut [u8] {
    // SAFETY: as above; the borrow is unique.
    unsafe { std::slice::from_raw_parts_mut(c.as_mut_ptr() as *mut u8, c.len() * 16) }
}

/// A texture's texels.
pub struct TextureData {
    pub(crate) desc: TextureDesc,
    pub(crate) texels: BufferData,
}

/// What an acceleration structure object was made from.
pub(crate) enum AccelOrigin {
    /// Built from inputs (kept for updates).
    Build {
        options: AccelBuildOptions,
        inputs: Vec<BuildInput>,
    },
    /// A transform.
    Transform,
}

/// An acceleration structure or transform: the traversable launches walk, and what it was
/// made from.
pub struct AccelObject {
    pub(crate) traversable: Arc<Traversable>,
    pub(crate) origin: AccelOrigin,
    pub(crate) size: u64,
}
