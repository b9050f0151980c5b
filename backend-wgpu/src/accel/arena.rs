//! The scene arena: every acceleration structure, transform and micromap of a device lives
//! in one array of `vec4<u32>` on the GPU, so a single kernel can reach any of them.
//!
//! A storage binding may not exceed the adapter's `max_storage_buffer_binding_size` (128 MiB
//! on lavapipe), so the array is split into chunks of a power-of-two number of vec4s, each
//! its own buffer and binding; the kernel's `_optik_fetch(i)` picks the chunk with a shift.
//! Regions are allocated first-fit and may straddle chunks. Only the last chunk grows in
//! place (by copying into a bigger buffer); full chunks never move.

use crate::gpu::Gpu;
use crate::memory::{MemoryTracker, Tracked};
use optik_api::{Error, ErrorKind, Result};
use std::collections::BTreeMap;

/// Bytes of one arena element.
pub(crate) const VEC4_BYTES: u64 = 16;
/// The first chunk's size, in vec4s (16 KiB).
const INITIAL_VEC4S: u64 = 1024;

/// The chunked scene array.
pub(crate) struct Arena {
    /// Vec4s per full chunk: a power of two.
    chunk_cap: u64,
    chunks: Vec<wgpu::Buffer>,
    /// Length in vec4s of each chunk's buffer (all `chunk_cap` but the last).
    chunk_len: Vec<u64>,
    /// Free ranges (offset → length) below the capacity.
    free: BTreeMap<u64, u64>,
    /// The chunks' entries in the device's accounting, in the same order.
    tracked: Vec<Tracked>,
    memory: MemoryTracker,
}

impl Drop for Arena {
    fn drop(&mut self) {
        self.memory.set_arena_in_use(0);
    }
}

impl Arena {
    /// An arena whose chunks are at most `max_binding` bytes.
    pub fn new(gpu: &Gpu, max_binding: u64) -> Result<Arena> {
        let max_vec4s = (max_binding / VEC4_BYTES).max(INITIAL_VEC4S);
        let chunk_cap = 1u64 << (63 - max_vec4s.leading_zeros());
        let first = create_chunk(gpu, INITIAL_VEC4S)?;
        Ok(Arena {
            chunk_cap,
            chunks: vec![first],
            chunk_len: vec![INITIAL_VEC4S],
            free: BTreeMap::from([(0, INITIAL_VEC4S)]),
            tracked: vec![gpu.memory.track(INITIAL_VEC4S * VEC4_BYTES)],
            memory: gpu.memory.clone(),
        })
    }

    /// log2 of the vec4s per chunk: `_optik_fetch` splits an index with it.
    pub fn chunk_shift(&self) -> u32 {
        self.chunk_cap.trailing_zeros()
    }

    /// The chunk buffers, in order.
    pub fn chunks(&self) -> &[wgpu::Buffer] {
        &self.chunks
    }

    fn capacity(&self) -> u64 {
        self.chunk_len.iter().sum()
    }

    /// Allocates `n` vec4s; returns the first index.
    pub fn alloc(&mut self, gpu: &Gpu, n: u64) -> Result<u64> {
        let n = n.max(1);
        if n + self.capacity() > u32::MAX as u64 {
            return Err(Error::limit(format!(
                "the scene needs more than 2^32 vec4s (64 GiB) of acceleration structure data; this one needs {n} more"
            )));
        }
        loop {
            let found = self
                .free
                .iter()
                .find(|(_, len)| **len >= n)
                .map(|(&off, &len)| (off, len));
            if let Some((off, len)) = found {
                self.free.remove(&off);
                if len > n {
                    self.free.insert(off + n, len - n);
                }
                self.account();
                return Ok(off);
            }
            self.grow(gpu, n)?;
        }
    }

    /// Returns a region to the free list.
    pub fn free(&mut self, offset: u64, n: u64) {
        let n = n.max(1);
        let mut start = offset;
        let mut len = n;
        if let Some((&prev, &plen)) = self.free.range(..offset).next_back()
            && prev + plen == offset
        {
            self.free.remove(&prev);
            start = prev;
            len += plen;
        }
        if let Some(&next_len) = self.free.get(&(offset + n)) {
            self.free.remove(&(offset + n));
            len += next_len;
        }
        self.free.insert(start, len);
        self.account();
    }

    /// Tells the device's accounting how much of the arena is in use.
    fn account(&self) {
        let free: u64 = self.free.values().sum();
        self.memory
            .set_arena_in_use((self.capacity() - free) * VEC4_BYTES);
    }

    /// Makes room for at least `n` more vec4s at the end.
    fn grow(&mut self, gpu: &Gpu, n: u64) -> Result<()> {
        let old_cap = self.capacity();
        let target = (old_cap * 2).max(old_cap + n);
        let mut remaining = target - old_cap;
        // Fill the last chunk up to a full chunk, by copying it into a bigger buffer.
        let last = self.chunks.len() - 1;
        if self.chunk_len[last] < self.chunk_cap {
            let new_len = (self.chunk_len[last] + remaining)
                .next_power_of_two()
                .min(self.chunk_cap);
            let bigger = create_chunk(gpu, new_len)?;
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
            encoder.copy_buffer_to_buffer(
                &self.chunks[last],
                0,
                &bigger,
                0,
                self.chunk_len[last] * VEC4_BYTES,
            );
            gpu.queue.submit([encoder.finish()]);
            remaining = remaining.saturating_sub(new_len - self.chunk_len[last]);
            self.chunks[last] = bigger;
            self.tracked[last] = gpu.memory.track(new_len * VEC4_BYTES);
            self.chunk_len[last] = new_len;
        }
        while remaining > 0 {
            let len = remaining.next_power_of_two().min(self.chunk_cap);
            // A chunk that is not the last must be full for the shift to address it.
            if let Some(l) = self.chunk_len.last_mut()
                && *l < self.chunk_cap
            {
                return Err(Error::backend(
                    "scene arena: a partial chunk before the last",
                ));
            }
            self.chunks.push(create_chunk(gpu, len)?);
            self.tracked.push(gpu.memory.track(len * VEC4_BYTES));
            self.chunk_len.push(len);
            remaining = remaining.saturating_sub(len);
        }
        let added = self.capacity() - old_cap;
        self.free(old_cap, added);
        Ok(())
    }

    /// Writes `words` at vec4 index `offset` (split across chunks as needed).
    pub fn write(&self, gpu: &Gpu, offset: u64, words: &[[u32; 4]]) {
        let mut at = offset;
        let mut rest = words;
        while !rest.is_empty() {
            let chunk = (at / self.chunk_cap) as usize;
            let within = at % self.chunk_cap;
            let take = rest.len().min((self.chunk_cap - within) as usize);
            gpu.queue.write_buffer(
                &self.chunks[chunk],
                within * VEC4_BYTES,
                bytemuck::cast_slice(&rest[..take]),
            );
            rest = &rest[take..];
            at += take as u64;
        }
    }

    /// Copies `n` vec4s from `from` to `to` on the GPU (regions must not overlap).
    pub fn copy(&self, gpu: &Gpu, from: u64, to: u64, n: u64) {
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        let mut done = 0;
        while done < n {
            let (src, dst) = (from + done, to + done);
            let (sc, so) = ((src / self.chunk_cap) as usize, src % self.chunk_cap);
            let (dc, doff) = ((dst / self.chunk_cap) as usize, dst % self.chunk_cap);
            let take = (n - done)
                .min(self.chunk_cap - so)
                .min(self.chunk_cap - doff);
            if sc == dc {
                // wgpu cannot copy within one buffer: go through a temporary one.
                let tmp = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("optik arena copy"),
                    size: take * VEC4_BYTES,
                    usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                encoder.copy_buffer_to_buffer(
                    &self.chunks[sc],
                    so * VEC4_BYTES,
                    &tmp,
                    0,
                    take * VEC4_BYTES,
                );
                encoder.copy_buffer_to_buffer(
                    &tmp,
                    0,
                    &self.chunks[dc],
                    doff * VEC4_BYTES,
                    take * VEC4_BYTES,
                );
            } else {
                encoder.copy_buffer_to_buffer(
                    &self.chunks[sc],
                    so * VEC4_BYTES,
                    &self.chunks[dc],
                    doff * VEC4_BYTES,
                    take * VEC4_BYTES,
                );
            }
            done += take;
        }
        gpu.queue.submit([encoder.finish()]);
    }
}

fn create_chunk(gpu: &Gpu, vec4s: u64) -> Result<wgpu::Buffer> {
    gpu.scoped(
        &format!(
            "allocating {} bytes for acceleration structures",
            vec4s * VEC4_BYTES
        ),
        || {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("optik scene arena"),
                size: vec4s * VEC4_BYTES,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        },
    )
    .map_err(|e| {
        if e.kind() == ErrorKind::OutOfMemory {
            e
        } else {
            e.context("scene arena")
        }
    })
}
