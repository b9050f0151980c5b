//! User buffers: created zero-filled, written and read with byte ranges checked, through
//! staging buffers where they live in device-local memory.

use crate::device::Inner;
use crate::memory::{GpuBuffer, Location};
use crate::objects::{Buffers, UserBuffer};
use ash::vk;
use optik_accel::decode::BufferBytes;
use optik_api::{Buffer, Error, Result};
use std::borrow::Cow;
use std::collections::HashMap;

/// Usage of user buffers: bound as storage buffers, copied to and from.
fn user_usage() -> vk::BufferUsageFlags {
    vk::BufferUsageFlags::STORAGE_BUFFER
        | vk::BufferUsageFlags::TRANSFER_SRC
        | vk::BufferUsageFlags::TRANSFER_DST
}

impl Inner {
    /// Where user buffers live.
    fn user_location(&self) -> Location {
        if self.ctx.staging {
            Location::DeviceLocal
        } else {
            Location::HostVisible
        }
    }

    pub fn create_buffer(&mut self, size: u64) -> Result<UserBuffer> {
        let location = self.user_location();
        let gpu = GpuBuffer::new(&self.ctx, &mut self.alloc, size, user_usage(), location, 16)?;
        if gpu.mapped().is_none() {
            let buffer = gpu.buffer;
            let ctx = self.ctx.clone();
            let filled = self.run_commands(|cmd| {
                // SAFETY: recording; the buffer is new.
                unsafe {
                    ctx.device
                        .cmd_fill_buffer(cmd, buffer, 0, vk::WHOLE_SIZE, 0)
                };
                Ok(())
            });
            if let Err(e) = filled {
                gpu.destroy(&self.ctx, &mut self.alloc);
                return Err(e);
            }
        }
        let generation = self.generation();
        Ok(UserBuffer { gpu, generation })
    }

    pub fn write_buffer(&mut self, b: &mut UserBuffer, offset: u64, data: &[u8]) -> Result<()> {
        if data.is_empty() {
            return Ok(());
        }
        // Launches read the buffer in the order they were made, as OptiX's stream orders
        // copies after launches.
        self.wait_launches()?;
        b.generation = self.generation();
        if b.gpu.mapped().is_some() {
            return b.gpu.write(offset, data);
        }
        let target = b.gpu.buffer;
        self.upload(target, offset, data)
    }

    pub fn read_buffer(&mut self, b: &UserBuffer, offset: u64, out: &mut [u8]) -> Result<()> {
        self.wait_launches()?;
        if out.is_empty() {
            return Ok(());
        }
        if let Some(bytes) = b.gpu.bytes() {
            out.copy_from_slice(&bytes[offset as usize..offset as usize + out.len()]);
            return Ok(());
        }
        let source = b.gpu.buffer;
        self.download(source, offset, out)
    }

    /// Copies `data` into `target` at `offset` through a staging buffer, and waits.
    pub fn upload(&mut self, target: vk::Buffer, offset: u64, data: &[u8]) -> Result<()> {
        self.upload_with(data, |device, cmd, src| {
            let region = vk::BufferCopy {
                src_offset: 0,
                dst_offset: offset,
                size: data.len() as u64,
            };
            // SAFETY: recording; both ranges lie inside their buffers.
            unsafe { device.cmd_copy_buffer(cmd, src, target, &[region]) };
        })
    }

    /// Puts `data` in a staging buffer, runs `record(device, cmd, staging)` and waits.
    pub fn upload_with(
        &mut self,
        data: &[u8],
        record: impl FnOnce(&ash::Device, vk::CommandBuffer, vk::Buffer),
    ) -> Result<()> {
        let staging = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            data.len() as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            Location::HostVisible,
            16,
        )?;
        let src = staging.buffer;
        let ctx = self.ctx.clone();
        let result = staging.write(0, data).and_then(|_| {
            self.run_commands(|cmd| {
                record(&ctx.device, cmd, src);
                Ok(())
            })
        });
        staging.destroy(&self.ctx, &mut self.alloc);
        result
    }

    /// Copies `out.len()` bytes of `source` from `offset` to the host through a staging
    /// buffer, and waits.
    pub fn download(&mut self, source: vk::Buffer, offset: u64, out: &mut [u8]) -> Result<()> {
        let staging = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            out.len() as u64,
            vk::BufferUsageFlags::TRANSFER_DST,
            Location::HostVisible,
            16,
        )?;
        let dst = staging.buffer;
        let ctx = self.ctx.clone();
        let result = self.run_commands(|cmd| {
            let region = vk::BufferCopy {
                src_offset: offset,
                dst_offset: 0,
                size: out.len() as u64,
            };
            // SAFETY: recording; both ranges lie inside their buffers.
            unsafe { ctx.device.cmd_copy_buffer(cmd, source, dst, &[region]) };
            Ok(())
        });
        if result.is_ok()
            && let Some(bytes) = staging.bytes()
        {
            out.copy_from_slice(&bytes[..out.len()]);
        }
        staging.destroy(&self.ctx, &mut self.alloc);
        result
    }

    /// Copies of `buffers` (in `table`) that are not host-visible, for [`snapshot_view`].
    /// Waits for launches first, so the bytes are current.
    pub fn download_for_snapshot(
        &mut self,
        table: &Buffers,
        buffers: &[Buffer],
    ) -> Result<HashMap<Buffer, Vec<u8>>> {
        self.wait_launches()?;
        let mut downloaded: HashMap<Buffer, Vec<u8>> = HashMap::new();
        for &b in buffers {
            let obj = table.get(b)?;
            if obj.gpu.mapped().is_none() && !downloaded.contains_key(&b) {
                let (source, size) = (obj.gpu.buffer, obj.gpu.size);
                let mut bytes = vec![0u8; size as usize];
                self.download(source, 0, &mut bytes)?;
                downloaded.insert(b, bytes);
            }
        }
        Ok(downloaded)
    }
}

/// The bytes of `buffers` (in `table`) on the host: mapped memory where it is host-visible,
/// the downloaded copies elsewhere.
pub fn snapshot_view<'a>(
    table: &'a Buffers,
    downloaded: HashMap<Buffer, Vec<u8>>,
    buffers: &[Buffer],
) -> Result<Snapshot<'a>> {
    let mut views: HashMap<Buffer, Cow<'a, [u8]>> = downloaded
        .into_iter()
        .map(|(b, v)| (b, Cow::Owned(v)))
        .collect();
    for &b in buffers {
        if let std::collections::hash_map::Entry::Vacant(e) = views.entry(b) {
            let obj = table.get(b)?;
            e.insert(Cow::Borrowed(obj.gpu.bytes().unwrap_or(&[])));
        }
    }
    Ok(Snapshot { views })
}

/// Buffer bytes on the host, for `optik_accel::decode`.
pub struct Snapshot<'a> {
    views: HashMap<Buffer, Cow<'a, [u8]>>,
}

impl BufferBytes for Snapshot<'_> {
    fn bytes(&self, buffer: Buffer) -> Result<&[u8]> {
        self.views
            .get(&buffer)
            .map(|c| c.as_ref())
            .ok_or_else(|| Error::backend(format!("buffer {:?} was not read for decoding", buffer)))
    }
}
