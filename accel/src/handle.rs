//! Traversable handles and the table that resolves them.
//!
//! A [`TraversableHandle`] is 64 bits (DESIGN.md §2) that users copy into launch parameters
//! and instances, so it must be checkable without trusting it. optik packs three fields:
//!
//! | bits | field |
//! |---|---|
//! | 0..24 | slot + 1 (never 0, so no live handle is the null handle) |
//! | 24..48 | the slot's generation, low 24 bits |
//! | 48..64 | the device id, low 16 bits |
//!
//! Resolving a handle checks all three against the [`SceneTable`]: a handle of another
//! device, of a destroyed structure (its slot's generation moved on) or random bits
//! resolves to [`Resolved::Invalid`], which traversal treats as a miss (or raises
//! `INVALID_TRAVERSABLE` under debug exceptions). Aliasing needs 2^24 destroys of one slot
//! between a handle's creation and its use, or two live devices whose ids agree in 16 bits
//! and whose slot and generation agree too.

use super::{GasEncoding, Traversable};
use optik_api::{DeviceId, TraversableHandle};
use std::sync::Arc;

/// Most traversables one device can hold at once.
pub const MAX_SLOTS: u32 = (1 << 24) - 1;
const FIELD: u64 = (1 << 24) - 1;

/// The fields of a traversable handle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct HandleParts {
    /// Low 16 bits of the device id.
    pub device: u16,
    /// The slot in the device's table.
    pub slot: u32,
    /// Low 24 bits of the slot's generation.
    pub generation: u32,
}

/// Packs a handle; `slot` must be below [`MAX_SLOTS`].
pub fn encode(device: DeviceId, slot: u32, generation: u32) -> TraversableHandle {
    debug_assert!(slot < MAX_SLOTS);
    TraversableHandle(
        (slot as u64 + 1)
            | ((generation as u64 & FIELD) << 24)
            | ((device.0 as u64 & 0xFFFF) << 48),
    )
}

/// Unpacks a handle; `None` for the null handle and for handles with slot field 0.
pub fn decode(handle: TraversableHandle) -> Option<HandleParts> {
    let slot_field = handle.0 & FIELD;
    if slot_field == 0 {
        return None;
    }
    Some(HandleParts {
        device: (handle.0 >> 48) as u16,
        slot: (slot_field - 1) as u32,
        generation: ((handle.0 >> 24) & FIELD) as u32,
    })
}

/// What a handle names.
#[derive(Clone, Copy, Debug)]
pub enum Resolved<'a, E: GasEncoding = ()> {
    /// The null handle (0): every ray misses.
    Null,
    /// Not a live traversable of this table: destroyed, foreign or garbage.
    Invalid,
    /// A live traversable.
    Live(&'a Arc<Traversable<E>>),
}

#[derive(Clone)]
struct Entry<E: GasEncoding> {
    generation: u32,
    traversable: Arc<Traversable<E>>,
}

/// The live traversables of one device by slot: what handles resolve against, at build
/// time (instance children, transform children) and at trace time (a launch takes a
/// snapshot, a cheap clone of `Arc`s).
#[derive(Clone)]
pub struct SceneTable<E: GasEncoding = ()> {
    device: DeviceId,
    entries: Vec<Option<Entry<E>>>,
}

impl<E: GasEncoding> SceneTable<E> {
    /// An empty table for `device`'s handles.
    pub fn new(device: DeviceId) -> SceneTable<E> {
        SceneTable {
            device,
            entries: Vec::new(),
        }
    }

    /// The device whose handles this table resolves.
    pub fn device(&self) -> DeviceId {
        self.device
    }

    /// Stores (or replaces) the traversable of `slot` at `generation`; returns its handle.
    pub fn set(
        &mut self,
        slot: u32,
        generation: u32,
        traversable: Arc<Traversable<E>>,
    ) -> TraversableHandle {
        let i = slot as usize;
        if self.entries.len() <= i {
            self.entries.resize(i + 1, None);
        }
        self.entries[i] = Some(Entry {
            generation: generation & FIELD as u32,
            traversable,
        });
        encode(self.device, slot, generation)
    }

    /// Forgets `slot`: handles to it become invalid.
    pub fn remove(&mut self, slot: u32) {
        if let Some(e) = self.entries.get_mut(slot as usize) {
            *e = None;
        }
    }

    /// Resolves a handle.
    pub fn resolve(&self, handle: TraversableHandle) -> Resolved<'_, E> {
        let Some(parts) = decode(handle) else {
            return if handle.0 == 0 {
                Resolved::Null
            } else {
                Resolved::Invalid
            };
        };
        if parts.device != (self.device.0 & 0xFFFF) as u16 {
            return Resolved::Invalid;
        }
        match self.entries.get(parts.slot as usize) {
            Some(Some(e)) if e.generation == parts.generation => Resolved::Live(&e.traversable),
            _ => Resolved::Invalid,
        }
    }

    /// The live traversables.
    pub fn iter(&self) -> impl Iterator<Item = &Arc<Traversable<E>>> {
        self.entries
            .iter()
            .filter_map(|e| e.as_ref().map(|e| &e.traversable))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn handles_round_trip_and_never_null() {
        let d = DeviceId(0x1_2345);
        for (slot, generation) in [(0, 0), (5, 7), (MAX_SLOTS - 1, 0xFF_FFFF), (3, 0x1_000_002)] {
            let h = encode(d, slot, generation);
            assert_ne!(h.0, 0);
            let p = decode(h).unwrap();
            assert_eq!(
                p,
                HandleParts {
                    device: 0x2345,
                    slot,
                    generation: generation & 0xFF_FFFF
                }
            );
        }
        assert_eq!(decode(TraversableHandle::NULL), None);
        assert_eq!(decode(TraversableHandle(1 << 30)), None);
    }
}
