//! The tables behind the device functions Vulkan lacks, shared by every launch of a device
//! and bound at `@group(1)` (device_api.rs), each record two `vec4<u32>`:
//! - instances: per Vulkan instance (its custom index) `[OptiX instance id, instance index,
//!   first geometry record, instance flags of the path]` and `[motion chain or NONE, 0, 0, 0]`
//!   (the flags are OptiX's bits, combined along the path; the motion chain is the path's
//!   transforms below the Vulkan instance, when one of them moves);
//! - geometries: per geometry (= SBT record of a build input) `[primitive index offset, remap
//!   table, primitive data, info]` and `[motion keys, micromap block, primitives, 0]`, where
//!   `info` packs the curve basis (bits 0..8), the primitive kind (8..16, [`KIND_TRIANGLES`]
//!   ...) and the record's geometry flags (16..24); every offset is into the data table or
//!   NONE;
//! - data: `u32` words. Ranges are handed out in multiples of 4 words, so every range starts
//!   16-byte aligned (the shared micromap lookup reads `vec4<u32>`s).
//!
//! Acceleration structures allocate ranges when built and free them when destroyed; the
//! tables go to the device before a launch that follows a change.

use crate::context::Context;
use crate::memory::{Allocator, GpuBuffer, Location};
use ash::vk;
use optik_api::Result;

pub use crate::program::device_api::NONE;

/// A table record: two `vec4<u32>`.
pub type Record = [u32; 8];

/// The primitive kinds of a geometry record's info word (bits 8..16).
pub const KIND_TRIANGLES: u32 = 0;
/// Custom primitives.
pub const KIND_CUSTOM: u32 = 1;
/// Spheres.
pub const KIND_SPHERES: u32 = 2;
/// Curves.
pub const KIND_CURVES: u32 = 3;

/// Fields of a geometry record that hold data-table offsets (rebased when the data moves).
pub const GEOMETRY_DATA_FIELDS: [usize; 4] = [1, 2, 4, 5];

/// `words` padded with zeros to a multiple of 4, as data-table ranges are.
pub fn padded_data(mut words: Vec<u32>) -> Vec<u32> {
    words.resize(words.len().next_multiple_of(4), 0);
    words
}

/// A table of `T` with ranges handed out and returned.
#[derive(Default)]
pub struct Table<T> {
    items: Vec<T>,
    /// Free ranges (start, len), sorted.
    free: Vec<(u32, u32)>,
}

impl<T: Copy + Default> Table<T> {
    /// Stores `values` in a fresh range; returns its start.
    pub fn insert(&mut self, values: &[T]) -> u32 {
        let n = values.len() as u32;
        let start = match self.free.iter().position(|&(_, len)| len >= n) {
            Some(i) if n > 0 => {
                let (s, len) = self.free[i];
                if len == n {
                    self.free.remove(i);
                } else {
                    self.free[i] = (s + n, len - n);
                }
                s
            }
            _ => {
                let s = self.items.len() as u32;
                self.items
                    .resize(self.items.len() + values.len(), T::default());
                s
            }
        };
        self.items[start as usize..(start + n) as usize].copy_from_slice(values);
        start
    }

    /// Overwrites a range handed out by `insert`.
    pub fn write(&mut self, start: u32, values: &[T]) {
        self.items[start as usize..start as usize + values.len()].copy_from_slice(values);
    }

    /// Returns a range.
    pub fn remove(&mut self, start: u32, len: u32) {
        if len == 0 {
            return;
        }
        for v in &mut self.items[start as usize..(start + len) as usize] {
            *v = T::default();
        }
        let i = self.free.partition_point(|(s, _)| *s < start);
        self.free.insert(i, (start, len));
        if i + 1 < self.free.len() && self.free[i].0 + self.free[i].1 == self.free[i + 1].0 {
            self.free[i].1 += self.free[i + 1].1;
            self.free.remove(i + 1);
        }
        if i > 0 && self.free[i - 1].0 + self.free[i - 1].1 == self.free[i].0 {
            self.free[i - 1].1 += self.free[i].1;
            self.free.remove(i);
        }
    }

    /// Entry `i` (the default past the end).
    pub fn get(&self, i: u32) -> T {
        self.items.get(i as usize).copied().unwrap_or_default()
    }

    /// The table as bytes.
    pub fn bytes(&self) -> &[u8]
    where
        T: bytemuck::Pod,
    {
        bytemuck::cast_slice(&self.items)
    }
}

/// The three tables and their device copies.
#[derive(Default)]
pub struct SceneTables {
    /// Per Vulkan instance.
    pub instances: Table<Record>,
    /// Per geometry.
    pub geometries: Table<Record>,
    /// Remaps, vertices, spheres, curve segments, motion keys and chains, micromaps; ranges
    /// in multiples of 4 words ([`padded_data`]).
    pub data: Table<u32>,
    device: Option<[GpuBuffer; 3]>,
    dirty: bool,
}

impl SceneTables {
    /// Word `i` of the data table.
    pub fn data_word(&self, i: u32) -> u32 {
        self.data.get(i)
    }

    /// Record `i` of the geometry table.
    pub fn geometry_record(&self, i: u32) -> Record {
        self.geometries.get(i)
    }

    /// The bytes each table holds now (what a launch binds).
    pub fn sizes(&self) -> [u64; 3] {
        [
            self.instances.bytes().len() as u64,
            self.geometries.bytes().len() as u64,
            self.data.bytes().len() as u64,
        ]
    }

    /// Marks the tables changed: the next launch uploads them.
    pub fn touch(&mut self) {
        self.dirty = true;
    }

    /// The device buffers (instances, geometries, data), uploaded if changed. The caller
    /// waits for launches first when [`SceneTables::needs_upload`].
    pub fn device_buffers(
        &mut self,
        ctx: &Context,
        alloc: &mut Allocator,
        staging: impl FnOnce(&mut Allocator, &[(vk::Buffer, Vec<u8>)]) -> Result<()>,
    ) -> Result<[vk::Buffer; 3]> {
        if self.dirty || self.device.is_none() {
            if let Some(old) = self.device.take() {
                for b in old {
                    b.destroy(ctx, alloc);
                }
            }
            let contents: [Vec<u8>; 3] = [
                self.instances.bytes().to_vec(),
                self.geometries.bytes().to_vec(),
                self.data.bytes().to_vec(),
            ];
            let location = if ctx.staging {
                Location::DeviceLocal
            } else {
                Location::HostVisible
            };
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
            let mut made: Vec<GpuBuffer> = Vec::new();
            for c in &contents {
                match GpuBuffer::new(ctx, alloc, (c.len() as u64).max(16), usage, location, 16) {
                    Ok(b) => made.push(b),
                    Err(e) => {
                        for b in made {
                            b.destroy(ctx, alloc);
                        }
                        return Err(e);
                    }
                }
            }
            let mut copies = Vec::new();
            for (b, c) in made.iter().zip(contents) {
                if c.is_empty() {
                    continue;
                }
                if b.mapped().is_some() {
                    b.write(0, &c)?;
                } else {
                    copies.push((b.buffer, c));
                }
            }
            let buffers: [GpuBuffer; 3] = match made.try_into() {
                Ok(b) => b,
                Err(_) => return Err(optik_api::Error::backend("table buffers")),
            };
            self.device = Some(buffers);
            if !copies.is_empty() {
                staging(alloc, &copies)?;
            }
            self.dirty = false;
        }
        let d = self
            .device
            .as_ref()
            .map(|d| [d[0].buffer, d[1].buffer, d[2].buffer]);
        d.ok_or_else(|| optik_api::Error::backend("table buffers missing"))
    }

    /// Whether the next launch uploads the tables (so earlier launches must finish first).
    pub fn needs_upload(&self) -> bool {
        self.dirty || self.device.is_none()
    }

    /// Frees the device copies.
    pub fn destroy(&mut self, ctx: &Context, alloc: &mut Allocator) {
        if let Some(old) = self.device.take() {
            for b in old {
                b.destroy(ctx, alloc);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_are_reused_and_merged() {
        let mut t: Table<u32> = Table::default();
        let a = t.insert(&[1, 2, 3]);
        let b = t.insert(&[4, 5]);
        assert_eq!((a, b), (0, 3));
        t.remove(a, 3);
        let c = t.insert(&[9, 9]);
        assert_eq!(c, 0);
        t.remove(c, 2);
        t.remove(b, 2);
        assert_eq!(
            t.insert(&[7; 5]),
            0,
            "freed neighbours merge into one range"
        );
        assert_eq!(t.insert(&[8]), 5, "the table grew to 5 entries only");
    }
}
