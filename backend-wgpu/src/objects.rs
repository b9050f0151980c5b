//! The wgpu backend's objects: what optik-core keeps in its tables for `WgpuBackend` (the
//! associated types of its `optik_core::Backend`), named in one place. Buffers and textures
//! are defined here; the others live beside the code that makes them (`AccelObject` in
//! `accel`, `ModuleObject` and `GroupObject` in `program`, `PipelineObject` in `pipeline`)
//! and are re-exported. Nothing here looks at the device's state.
//!
//! A user buffer is a wgpu storage buffer plus a host copy of its bytes. Acceleration structures are built on the host and the SBT is decoded on the host, from
//! bytes users wrote with `write_buffer`. Keeping a host copy makes those reads free; it
//! becomes stale only when a launch binds the buffer for writing, and is then refreshed by
//! reading the GPU buffer back when the host needs it.

pub use crate::accel::AccelObject;
use crate::gpu::Gpu;
use crate::memory::Tracked;
pub use crate::pipeline::PipelineObject;
pub use crate::program::{GroupObject, ModuleObject};
pub use optik_accel::MicromapArrayData;
use optik_api::{Error, Result};

/// One user buffer.
///
/// (Public only as `WgpuBackend`'s `optik_core::Backend::Buffer`, the type optik-core's
/// device keeps; its insides stay private to this crate.)
pub struct BufferObject {
    pub(crate) gpu: wgpu::Buffer,
    pub(crate) size: u64,
    host: Vec<u8>,
    /// Whether `host` equals the GPU contents (false after a launch that may write).
    host_valid: bool,
    _tracked: Tracked,
}

impl Drop for BufferObject {
    /// Frees the GPU memory now rather than when wgpu drops its last reference (wgpu
    /// still waits for submitted work that uses it).
    fn drop(&mut self) {
        self.gpu.destroy();
    }
}

impl BufferObject {
    /// A zero-filled buffer of `size` bytes.
    pub(crate) fn create(gpu: &Gpu, size: u64) -> Result<BufferObject> {
        // wgpu copies and maps in 4-byte units; a zero-sized binding is invalid.
        let gpu_size = size.max(4).div_ceil(4) * 4;
        let buffer = gpu.scoped(&format!("creating a buffer of {size} bytes"), || {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("optik buffer"),
                size: gpu_size,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        let mut host = Vec::new();
        host.try_reserve_exact(size as usize).map_err(|_| {
            Error::new(
                optik_api::ErrorKind::OutOfMemory,
                format!("creating a buffer of {size} bytes: host memory for its copy is exhausted"),
            )
        })?;
        host.resize(size as usize, 0);
        Ok(BufferObject {
            gpu: buffer,
            size,
            host,
            host_valid: true,
            _tracked: gpu.memory.track(gpu_size),
        })
    }

    /// Writes `data` at `offset` (range already checked).
    pub(crate) fn write(&mut self, gpu: &Gpu, offset: u64, data: &[u8]) -> Result<()> {
        if data.is_empty() {
            return Ok(());
        }
        let end = offset + data.len() as u64;
        let start4 = offset & !3;
        let end4 = end.div_ceil(4) * 4;
        if (start4 != offset || end4 != end) && !self.host_valid {
            // The bytes around an unaligned write are only on the GPU.
            self.refresh(gpu)?;
        }
        self.host[offset as usize..end as usize].copy_from_slice(data);
        if start4 == offset && end4 == end {
            gpu.queue.write_buffer(&self.gpu, offset, data);
        } else {
            // wgpu writes whole words: widen to them from the host copy.
            let mut words = vec![0u8; (end4 - start4) as usize];
            let host_end = end4.min(self.size);
            words[..(host_end - start4) as usize]
                .copy_from_slice(&self.host[start4 as usize..host_end as usize]);
            gpu.queue.write_buffer(&self.gpu, start4, &words);
        }
        gpu.check()
    }

    /// Reads `out.len()` bytes at `offset` (range already checked), after earlier launches.
    pub(crate) fn read(&self, gpu: &Gpu, offset: u64, out: &mut [u8]) -> Result<()> {
        if self.host_valid {
            // Nothing on the GPU may have written it; launches still run in order.
            out.copy_from_slice(&self.host[offset as usize..offset as usize + out.len()]);
            return gpu.check();
        }
        let bytes = gpu.read(&self.gpu, offset, out.len() as u64)?;
        out.copy_from_slice(&bytes);
        Ok(())
    }

    /// Marks the host copy stale: a launch bound the buffer for writing.
    pub(crate) fn mark_written_by_gpu(&mut self) {
        self.host_valid = false;
    }

    /// The whole contents, read back from the GPU first when the host copy is stale.
    pub(crate) fn bytes(&mut self, gpu: &Gpu) -> Result<&[u8]> {
        if !self.host_valid {
            self.refresh(gpu)?;
        }
        Ok(&self.host)
    }

    /// The host copy, when it is current.
    pub(crate) fn host_bytes(&self) -> Option<&[u8]> {
        self.host_valid.then_some(&self.host[..])
    }

    fn refresh(&mut self, gpu: &Gpu) -> Result<()> {
        let bytes = gpu.read(&self.gpu, 0, self.size)?;
        self.host.copy_from_slice(&bytes);
        self.host_valid = true;
        Ok(())
    }
}

/// One user texture.
///
/// (Public only as `WgpuBackend`'s `optik_core::Backend::Texture`, the type optik-core's
/// device keeps; its insides stay private to this crate.)
pub struct TextureObject {
    pub(crate) texture: wgpu::Texture,
    pub(crate) view: wgpu::TextureView,
    pub(crate) desc: optik_api::TextureDesc,
    _tracked: Tracked,
}

impl Drop for TextureObject {
    /// Frees the GPU memory now (see `BufferObject`'s `Drop`).
    fn drop(&mut self) {
        self.texture.destroy();
    }
}

impl TextureObject {
    /// A zero-filled texture.
    pub(crate) fn create(gpu: &Gpu, desc: &optik_api::TextureDesc) -> Result<TextureObject> {
        let texture = gpu.scoped(
            &format!("creating a {}x{} texture", desc.width, desc.height),
            || {
                gpu.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("optik texture"),
                    size: wgpu::Extent3d {
                        width: desc.width,
                        height: desc.height,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: texture_format(desc.format),
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                })
            },
        )?;
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let bytes = desc.width as u64 * desc.height as u64 * desc.format.texel_size() as u64;
        Ok(TextureObject {
            texture,
            view,
            desc: *desc,
            _tracked: gpu.memory.track(bytes),
        })
    }

    /// Writes all texels (size already checked).
    pub(crate) fn write(&self, gpu: &Gpu, data: &[u8]) -> Result<()> {
        gpu.queue.write_texture(
            self.texture.as_image_copy(),
            data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(self.desc.width * self.desc.format.texel_size()),
                rows_per_image: Some(self.desc.height),
            },
            wgpu::Extent3d {
                width: self.desc.width,
                height: self.desc.height,
                depth_or_array_layers: 1,
            },
        );
        gpu.check()
    }
}

/// The wgpu format of an optik texture format.
pub(crate) fn texture_format(f: optik_api::TextureFormat) -> wgpu::TextureFormat {
    match f {
        optik_api::TextureFormat::Rgba8Unorm => wgpu::TextureFormat::Rgba8Unorm,
        optik_api::TextureFormat::Rgba32Float => wgpu::TextureFormat::Rgba32Float,
        optik_api::TextureFormat::R32Float => wgpu::TextureFormat::R32Float,
    }
}
