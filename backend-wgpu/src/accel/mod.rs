//! Acceleration structures, transforms and micromap arrays: built on the host, stored in
//! the scene arena, named on the GPU through the handle table.
//!
//! A traversable handle packs the object's slot + 1 (bits 0..24), its generation (24..48)
//! and the device id (48..64), so the GPU can check a handle from launch parameters or an
//! instance against the table: a destroyed, foreign or made-up handle is missed.

pub(crate) mod arena;
pub(crate) mod bvh4;
pub(crate) mod geometry;
pub(crate) mod instances;
pub(crate) mod layout;

use crate::gpu::Gpu;
use arena::Arena;
use instances::ChildInfo;
use optik_accel::Aabb;
use optik_api::{
    Accel, AccelBuildOptions, BuildInput, DeviceId, Error, Handle, Result, SceneFeatures,
    TraversableHandle,
};

/// What a built object keeps for updates.
#[derive(Clone)]
pub(crate) enum Refit {
    // Boxed: the geometry's refit state is large and most structures hold instances or none.
    Geometry(Box<geometry::RefitState>),
    Instances(instances::Bvh4WithOrder),
    None,
}

/// One acceleration structure or transform.
///
/// (Public only as `WgpuBackend`'s `optik_core::Backend::Accel`, the type optik-core's
/// device keeps; its insides stay private to this crate.)
pub struct AccelObject {
    /// Where its words live in the arena (vec4 index, count).
    pub(crate) region: (u64, u64),
    pub(crate) bounds: Aabb,
    pub(crate) stack_need: u32,
    pub(crate) levels: u32,
    pub(crate) features: SceneFeatures,
    pub(crate) options: AccelBuildOptions,
    /// The inputs it was built from (empty for transforms), for update checks.
    pub(crate) inputs: Vec<BuildInput>,
    pub(crate) refit: Refit,
    /// The GPU handle-table entry's kind word.
    pub(crate) kind_word: u32,
}

impl AccelObject {
    /// What a parent needs to know about it (`handle` is its own).
    pub(crate) fn child_info(&self, handle: Accel) -> ChildInfo {
        let raw = handle.raw();
        ChildInfo {
            slot: raw.slot,
            generation: raw.generation & FIELD24 as u32,
            bounds: self.bounds,
            stack_need: self.stack_need,
            levels: self.levels,
            features: self.features,
        }
    }
}

const FIELD24: u64 = (1 << 24) - 1;

/// The traversable handle of the object in `slot` at `generation`.
pub(crate) fn encode_handle(device: DeviceId, slot: u32, generation: u32) -> TraversableHandle {
    TraversableHandle(
        (slot as u64 + 1)
            | ((generation as u64 & FIELD24) << 24)
            | ((device.0 as u64 & 0xFFFF) << 48),
    )
}

/// The device's scene: the arena and the handle table the GPU resolves handles with.
pub(crate) struct Scene {
    pub arena: Arena,
    /// Per slot: `(generation | ALIVE, kind word, header index, 0)`.
    table: Vec<[u32; 4]>,
    /// Per slot: the live object's handle.
    owners: Vec<Option<Accel>>,
    /// The GPU copy of `table` with its entry in the device's accounting.
    table_buffer: Option<(wgpu::Buffer, crate::memory::Tracked)>,
    table_dirty: bool,
}

/// Bit set in a live handle-table entry.
pub(crate) const TABLE_ALIVE: u32 = 1 << 31;

impl Scene {
    pub fn new(gpu: &Gpu) -> Result<Scene> {
        Ok(Scene {
            arena: Arena::new(
                gpu,
                gpu.limits
                    .max_storage_buffer_binding_size
                    .min(gpu.limits.max_buffer_size),
            )?,
            table: Vec::new(),
            owners: Vec::new(),
            table_buffer: None,
            table_dirty: true,
        })
    }

    /// Records a live object in the table.
    pub fn register(&mut self, handle: Accel, object: &AccelObject) {
        let raw = handle.raw();
        let slot = raw.slot as usize;
        if self.table.len() <= slot {
            self.table.resize(slot + 1, [0; 4]);
            self.owners.resize(slot + 1, None);
        }
        self.table[slot] = [
            (raw.generation & FIELD24 as u32) | TABLE_ALIVE,
            object.kind_word,
            object.region.0 as u32,
            0,
        ];
        self.owners[slot] = Some(handle);
        self.table_dirty = true;
    }

    /// Forgets the object in `slot`: handles to it are missed from now on.
    pub fn unregister(&mut self, slot: u32) {
        if let Some(e) = self.table.get_mut(slot as usize) {
            *e = [0; 4];
            self.owners[slot as usize] = None;
            self.table_dirty = true;
        }
    }

    /// The live object a handle names: `Ok(None)` for the null handle, an error for a
    /// handle that is not a live traversable of `device`.
    pub fn resolve(&self, device: DeviceId, handle: u64) -> Result<Option<Accel>> {
        if handle == 0 {
            return Ok(None);
        }
        let slot_field = handle & FIELD24;
        let generation = ((handle >> 24) & FIELD24) as u32;
        let dev = (handle >> 48) as u32;
        let live = slot_field != 0
            && dev == (device.0 & 0xFFFF)
            && self
                .table
                .get(slot_field as usize - 1)
                .is_some_and(|e| e[0] == generation | TABLE_ALIVE);
        match live {
            true => Ok(self.owners[slot_field as usize - 1]),
            false => Err(Error::invalid(format!(
                "traversable handle {handle:#x} is not a live acceleration structure or transform of this device (destroyed, of another device, or not a handle)"
            ))),
        }
    }

    /// The GPU handle table, uploaded when it changed.
    pub fn table_buffer(&mut self, gpu: &Gpu) -> Result<&wgpu::Buffer> {
        let needed = (self.table.len().max(1) * 16) as u64;
        let fits = self
            .table_buffer
            .as_ref()
            .is_some_and(|(b, _)| b.size() >= needed);
        if !fits {
            let size = needed.next_power_of_two().max(256);
            let buffer = gpu.scoped("allocating the handle table", || {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("optik handle table"),
                    size,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })?;
            self.table_buffer = Some((buffer, gpu.memory.track(size)));
            self.table_dirty = true;
        }
        let (buffer, _) = self
            .table_buffer
            .as_ref()
            .ok_or_else(|| Error::backend("handle table missing"))?;
        if self.table_dirty {
            let mut words = self.table.clone();
            if words.is_empty() {
                words.push([0; 4]);
            }
            gpu.queue
                .write_buffer(buffer, 0, bytemuck::cast_slice(&words));
            self.table_dirty = false;
        }
        Ok(buffer)
    }
}

/// A traversable's handle from its optik handle.
pub(crate) fn handle_of(device: DeviceId, accel: Accel) -> TraversableHandle {
    let raw = accel.raw();
    encode_handle(device, raw.slot, raw.generation)
}
