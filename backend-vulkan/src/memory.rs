//! Device memory: a small block sub-allocator (drivers cap allocations, 4096 on NVIDIA) and
//! buffers placed in it.
//!
//! Memory is device-local plus staging copies where the device has separate device memory
//! (discrete GPUs), host-visible elsewhere (lavapipe, integrated GPUs): see
//! [`crate::context::Context::staging`].

use crate::context::Context;
use crate::error::VkResultExt;
use ash::vk;
use optik_api::{Error, Result};

/// Where a buffer lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// Device-local memory, preferably not host-visible: reached through staging copies.
    DeviceLocal,
    /// Host-visible, coherent memory, mapped for the buffer's life.
    HostVisible,
}

/// Bytes of one shared memory block; larger requests get their own allocation.
const BLOCK_SIZE: u64 = 64 << 20;
const DEDICATED_ABOVE: u64 = 16 << 20;

struct Block {
    memory: vk::DeviceMemory,
    type_index: u32,
    mapped: *mut u8,
    /// Free ranges (offset, size), sorted by offset.
    free: Vec<(u64, u64)>,
    dedicated: bool,
}

/// A range of a block.
#[derive(Debug)]
pub struct Allocation {
    block: usize,
    offset: u64,
    size: u64,
    mapped: *mut u8,
}

/// The device's memory blocks.
#[derive(Default)]
pub struct Allocator {
    blocks: Vec<Option<Block>>,
}

// SAFETY: the mapped pointers refer to device memory that lives as long as the allocator,
// and every access goes through the device's lock.
unsafe impl Send for Allocator {}
// SAFETY: as above.
unsafe impl Send for Allocation {}
// SAFETY: as above.
unsafe impl Sync for Allocation {}

fn align_up(v: u64, a: u64) -> u64 {
    if a <= 1 { v } else { v.div_ceil(a) * a }
}

impl Allocator {
    fn flags_for(
        location: Location,
    ) -> (
        vk::MemoryPropertyFlags,
        vk::MemoryPropertyFlags,
        vk::MemoryPropertyFlags,
    ) {
        match location {
            Location::DeviceLocal => (
                vk::MemoryPropertyFlags::DEVICE_LOCAL,
                vk::MemoryPropertyFlags::DEVICE_LOCAL,
                vk::MemoryPropertyFlags::HOST_VISIBLE,
            ),
            Location::HostVisible => (
                vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
                vk::MemoryPropertyFlags::HOST_CACHED,
                vk::MemoryPropertyFlags::empty(),
            ),
        }
    }

    /// Allocates memory for `req` in `location`, aligned to at least `min_align`.
    pub fn allocate(
        &mut self,
        ctx: &Context,
        req: vk::MemoryRequirements,
        location: Location,
        min_align: u64,
    ) -> Result<Allocation> {
        let (required, preferred, avoided) = Self::flags_for(location);
        let type_index = ctx
            .memory_type(req.memory_type_bits, required, preferred, avoided)
            .or_else(|| {
                // Some device-local requests (acceleration structures on odd drivers) fit only
                // other memory; any allowed type will do.
                (location == Location::DeviceLocal)
                    .then(|| {
                        ctx.memory_type(
                            req.memory_type_bits,
                            vk::MemoryPropertyFlags::empty(),
                            vk::MemoryPropertyFlags::empty(),
                            vk::MemoryPropertyFlags::empty(),
                        )
                    })
                    .flatten()
            });
        let type_index = type_index.ok_or_else(|| {
            Error::backend(format!(
                "no Vulkan memory type fits a {location:?} request (type bits {:#x})",
                req.memory_type_bits
            ))
        })?;
        let align = req.alignment.max(min_align).max(1);
        let size = req.size.max(1);
        if size <= DEDICATED_ABOVE {
            for (bi, block) in self.blocks.iter_mut().enumerate() {
                let Some(b) = block else { continue };
                if b.dedicated || b.type_index != type_index {
                    continue;
                }
                if let Some(offset) = take_range(&mut b.free, size, align) {
                    return Ok(Allocation {
                        block: bi,
                        offset,
                        size,
                        mapped: offset_ptr(b.mapped, offset),
                    });
                }
            }
        }
        let dedicated = size > DEDICATED_ABOVE;
        let block_size = if dedicated { size } else { BLOCK_SIZE };
        let mut flags =
            vk::MemoryAllocateFlagsInfo::default().flags(vk::MemoryAllocateFlags::DEVICE_ADDRESS);
        let info = vk::MemoryAllocateInfo::default()
            .allocation_size(block_size)
            .memory_type_index(type_index)
            .push_next(&mut flags);
        // SAFETY: valid allocate info; freed in `free` or `destroy`.
        let memory =
            unsafe { ctx.device.allocate_memory(&info, None) }.or_vk("vkAllocateMemory")?;
        let host_visible = ctx.memory.memory_types[type_index as usize]
            .property_flags
            .contains(vk::MemoryPropertyFlags::HOST_VISIBLE);
        let mapped = if host_visible {
            // SAFETY: host-visible memory, mapped whole for the block's life.
            match unsafe {
                ctx.device
                    .map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())
            } {
                Ok(p) => p as *mut u8,
                Err(e) => {
                    // SAFETY: just allocated, unused.
                    unsafe { ctx.device.free_memory(memory, None) };
                    return Err(crate::error::vk_error("vkMapMemory", e));
                }
            }
        } else {
            std::ptr::null_mut()
        };
        let mut block = Block {
            memory,
            type_index,
            mapped,
            free: vec![(0, block_size)],
            dedicated,
        };
        let offset = take_range(&mut block.free, size, align)
            .ok_or_else(|| Error::backend("fresh memory block too small"))?;
        let alloc_mapped = offset_ptr(mapped, offset);
        let bi = match self.blocks.iter().position(|b| b.is_none()) {
            Some(i) => {
                self.blocks[i] = Some(block);
                i
            }
            None => {
                self.blocks.push(Some(block));
                self.blocks.len() - 1
            }
        };
        Ok(Allocation {
            block: bi,
            offset,
            size,
            mapped: alloc_mapped,
        })
    }

    /// Returns an allocation; dedicated blocks are freed at once.
    pub fn free(&mut self, ctx: &Context, a: Allocation) {
        let Some(Some(b)) = self.blocks.get_mut(a.block) else {
            return;
        };
        if b.dedicated {
            // SAFETY: the allocation's only user is gone.
            unsafe { ctx.device.free_memory(b.memory, None) };
            self.blocks[a.block] = None;
            return;
        }
        give_range(&mut b.free, a.offset, a.size);
    }

    /// The memory and offset to bind an allocation.
    pub fn binding(&self, a: &Allocation) -> (vk::DeviceMemory, u64) {
        let memory = self
            .blocks
            .get(a.block)
            .and_then(|b| b.as_ref())
            .map(|b| b.memory)
            .unwrap_or_default();
        (memory, a.offset)
    }

    /// Frees every block (at device destruction).
    pub fn destroy(&mut self, ctx: &Context) {
        for b in self.blocks.drain(..).flatten() {
            // SAFETY: the device is idle and every buffer is destroyed.
            unsafe { ctx.device.free_memory(b.memory, None) };
        }
    }
}

fn offset_ptr(base: *mut u8, offset: u64) -> *mut u8 {
    if base.is_null() {
        base
    } else {
        base.wrapping_add(offset as usize)
    }
}

/// First fit of `size` bytes aligned to `align` in a sorted free list.
fn take_range(free: &mut Vec<(u64, u64)>, size: u64, align: u64) -> Option<u64> {
    for i in 0..free.len() {
        let (start, len) = free[i];
        let aligned = align_up(start, align);
        let pad = aligned - start;
        if len >= pad + size {
            let mut pieces = Vec::with_capacity(2);
            if pad > 0 {
                pieces.push((start, pad));
            }
            let rest = len - pad - size;
            if rest > 0 {
                pieces.push((aligned + size, rest));
            }
            free.splice(i..=i, pieces);
            return Some(aligned);
        }
    }
    None
}

/// Returns a range to a sorted free list, merging neighbours.
fn give_range(free: &mut Vec<(u64, u64)>, offset: u64, size: u64) {
    let i = free.partition_point(|(s, _)| *s < offset);
    free.insert(i, (offset, size));
    if i + 1 < free.len() && free[i].0 + free[i].1 == free[i + 1].0 {
        free[i].1 += free[i + 1].1;
        free.remove(i + 1);
    }
    if i > 0 && free[i - 1].0 + free[i - 1].1 == free[i].0 {
        free[i - 1].1 += free[i].1;
        free.remove(i);
    }
}

/// A buffer with its memory.
#[derive(Debug)]
pub struct GpuBuffer {
    /// The Vulkan buffer.
    pub buffer: vk::Buffer,
    /// Its size in bytes as asked (the Vulkan buffer is at least 4 bytes).
    pub size: u64,
    /// Its device address (0 without `SHADER_DEVICE_ADDRESS` usage).
    pub address: u64,
    alloc: Allocation,
}

impl GpuBuffer {
    /// Creates a buffer; host-visible buffers are zero-filled, device-local ones hold whatever
    /// the memory held (callers that need zeros fill them).
    pub fn new(
        ctx: &Context,
        allocator: &mut Allocator,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: Location,
        min_align: u64,
    ) -> Result<GpuBuffer> {
        let usage = usage | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let info = vk::BufferCreateInfo::default()
            .size(size.max(4))
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info; destroyed in `destroy`.
        let buffer = unsafe { ctx.device.create_buffer(&info, None) }.or_vk("vkCreateBuffer")?;
        // SAFETY: valid buffer.
        let req = unsafe { ctx.device.get_buffer_memory_requirements(buffer) };
        let alloc = match allocator.allocate(ctx, req, location, min_align) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: unbound, unused buffer.
                unsafe { ctx.device.destroy_buffer(buffer, None) };
                return Err(e);
            }
        };
        let (memory, offset) = allocator.binding(&alloc);
        // SAFETY: memory of a type the buffer allows, at an aligned offset.
        if let Err(e) = unsafe { ctx.device.bind_buffer_memory(buffer, memory, offset) } {
            allocator.free(ctx, alloc);
            // SAFETY: unused buffer.
            unsafe { ctx.device.destroy_buffer(buffer, None) };
            return Err(crate::error::vk_error("vkBindBufferMemory", e));
        }
        // SAFETY: the buffer has device-address usage and bound memory.
        let address = unsafe {
            ctx.device
                .get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(buffer))
        };
        let buf = GpuBuffer {
            buffer,
            size,
            address,
            alloc,
        };
        if let Some(p) = buf.mapped() {
            // SAFETY: the mapping covers the allocation's `size` bytes.
            unsafe { std::ptr::write_bytes(p, 0, buf.alloc.size as usize) };
        }
        Ok(buf)
    }

    /// The mapped bytes, for host-visible buffers.
    pub fn mapped(&self) -> Option<*mut u8> {
        (!self.alloc.mapped.is_null()).then_some(self.alloc.mapped)
    }

    /// The mapped contents as a slice, for host-visible buffers. Callers make sure no device
    /// work writes the buffer meanwhile.
    pub fn bytes(&self) -> Option<&[u8]> {
        // SAFETY: the mapping covers `size` bytes and lives as long as `self`.
        self.mapped()
            .map(|p| unsafe { std::slice::from_raw_parts(p, self.size as usize) })
    }

    /// Writes `data` at `offset` of a host-visible buffer.
    pub fn write(&self, offset: u64, data: &[u8]) -> Result<()> {
        let p = self
            .mapped()
            .ok_or_else(|| Error::backend("write to a buffer that is not host-visible"))?;
        if offset + data.len() as u64 > self.alloc.size {
            return Err(Error::backend("write past the end of a mapped buffer"));
        }
        // SAFETY: bounds checked against the mapping.
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), p.add(offset as usize), data.len()) };
        Ok(())
    }

    /// Frees the buffer and its memory.
    pub fn destroy(self, ctx: &Context, allocator: &mut Allocator) {
        // SAFETY: no pending work uses the buffer (callers wait first).
        unsafe { ctx.device.destroy_buffer(self.buffer, None) };
        allocator.free(ctx, self.alloc);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_list_first_fit_and_merge() {
        let mut free = vec![(0u64, 100u64)];
        assert_eq!(take_range(&mut free, 10, 1), Some(0));
        assert_eq!(take_range(&mut free, 10, 16), Some(16));
        assert_eq!(free, vec![(10, 6), (26, 74)]);
        give_range(&mut free, 16, 10);
        assert_eq!(free, vec![(10, 90)]);
        give_range(&mut free, 0, 10);
        assert_eq!(free, vec![(0, 100)]);
        assert_eq!(take_range(&mut free, 200, 1), None);
    }
}
