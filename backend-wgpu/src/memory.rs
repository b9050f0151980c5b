//! The backend's own accounting of its long-lived GPU allocations (user buffers,
//! textures, scene arena chunks, the handle table), so tests can check that they are freed
//! when their owner is destroyed and when the device is dropped. Transient buffers of one
//! call (readback staging, a launch's packed SBT and uniforms) die with the call and are
//! not counted.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

#[derive(Debug, Default)]
struct Live {
    allocations: AtomicU64,
    bytes: AtomicU64,
    arena_in_use: AtomicU64,
}

/// Live allocation counts of one device; a clone stays readable after the device is
/// dropped (when everything should read zero).
#[derive(Clone, Debug, Default)]
pub struct MemoryTracker(Arc<Live>);

impl MemoryTracker {
    /// wgpu buffers and textures alive.
    pub fn live_allocations(&self) -> u64 {
        self.0.allocations.load(Ordering::SeqCst)
    }

    /// Their bytes.
    pub fn live_bytes(&self) -> u64 {
        self.0.bytes.load(Ordering::SeqCst)
    }

    /// Bytes of the scene arena held by live acceleration structures, transforms and
    /// micromaps (the arena's chunks stay allocated when a structure is destroyed; its
    /// region returns to the free list and is reused).
    pub fn arena_bytes_in_use(&self) -> u64 {
        self.0.arena_in_use.load(Ordering::SeqCst)
    }

    /// Counts an allocation of `bytes` until the returned guard is dropped.
    pub(crate) fn track(&self, bytes: u64) -> Tracked {
        self.0.allocations.fetch_add(1, Ordering::SeqCst);
        self.0.bytes.fetch_add(bytes, Ordering::SeqCst);
        Tracked {
            live: self.0.clone(),
            bytes,
        }
    }

    /// Records the arena's bytes in use.
    pub(crate) fn set_arena_in_use(&self, bytes: u64) {
        self.0.arena_in_use.store(bytes, Ordering::SeqCst);
    }
}

/// One counted allocation; dropping it uncounts it. Kept next to the wgpu object it
/// stands for, so both go together.
#[derive(Debug)]
pub(crate) struct Tracked {
    live: Arc<Live>,
    bytes: u64,
}

impl Drop for Tracked {
    fn drop(&mut self) {
        self.live.allocations.fetch_sub(1, Ordering::SeqCst);
        self.live.bytes.fetch_sub(self.bytes, Ordering::SeqCst);
    }
}
