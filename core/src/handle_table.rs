//! [`HandleTable`]: a device's objects of one kind, addressed by checked handles.
//!
//! A destroyed handle, or one from another device, is an `InvalidHandle` error worded here
//! once, whatever the backend.

use optik_api::{DeviceId, Error, ErrorKind, Handle, RawHandle, Result};

struct Slot<T> {
    generation: u32,
    value: Option<T>,
}

/// A device's objects of one kind, addressed by checked handles.
pub struct HandleTable<H: Handle, T> {
    device: DeviceId,
    slots: Vec<Slot<T>>,
    free: Vec<u32>,
    _kind: std::marker::PhantomData<H>,
}

impl<H: Handle, T> HandleTable<H, T> {
    /// An empty table for objects of `device`.
    pub fn new(device: DeviceId) -> Self {
        Self {
            device,
            slots: Vec::new(),
            free: Vec::new(),
            _kind: std::marker::PhantomData,
        }
    }

    /// Stores `value` and returns its handle.
    pub fn insert(&mut self, value: T) -> H {
        let slot = match self.free.pop() {
            Some(slot) => {
                let s = &mut self.slots[slot as usize];
                s.value = Some(value);
                slot
            }
            None => {
                self.slots.push(Slot {
                    generation: 0,
                    value: Some(value),
                });
                (self.slots.len() - 1) as u32
            }
        };
        let generation = self.slots[slot as usize].generation;
        H::from_raw(RawHandle {
            device: self.device,
            slot,
            generation,
        })
    }

    /// The handle the next [`HandleTable::insert`] returns: backends that index their own
    /// data by handle (a traversable handle made from the slot) learn it before the object
    /// exists, and nothing is inserted if they fail.
    pub fn next_handle(&self) -> H {
        let (slot, generation) = match self.free.last() {
            Some(&slot) => (slot, self.slots[slot as usize].generation),
            None => (self.slots.len() as u32, 0),
        };
        H::from_raw(RawHandle {
            device: self.device,
            slot,
            generation,
        })
    }

    /// Removes every object, live ones first to last (a device hands them back to its
    /// backend when it is dropped).
    pub fn drain(&mut self) -> Vec<(H, T)> {
        let device = self.device;
        let mut out = Vec::new();
        for (i, s) in self.slots.iter_mut().enumerate() {
            if let Some(v) = s.value.take() {
                let handle = H::from_raw(RawHandle {
                    device,
                    slot: i as u32,
                    generation: s.generation,
                });
                s.generation = s.generation.wrapping_add(1);
                self.free.push(i as u32);
                out.push((handle, v));
            }
        }
        out
    }

    /// Checks that `handle` is this device's and alive.
    fn check(&self, handle: H) -> Result<usize> {
        let raw = handle.raw();
        if raw.device != self.device {
            return Err(Error::new(
                ErrorKind::InvalidHandle,
                format!(
                    "{} handle {:?} belongs to {}, not to this device ({}); objects cannot be shared between devices",
                    H::KIND,
                    raw,
                    raw.device,
                    self.device
                ),
            ));
        }
        match self.slots.get(raw.slot as usize) {
            Some(s) if s.generation == raw.generation && s.value.is_some() => Ok(raw.slot as usize),
            _ => Err(Error::new(
                ErrorKind::InvalidHandle,
                format!(
                    "{} handle {:?} was destroyed and cannot be used",
                    H::KIND,
                    raw
                ),
            )),
        }
    }

    /// The object named by `handle`.
    pub fn get(&self, handle: H) -> Result<&T> {
        let i = self.check(handle)?;
        Ok(self.slots[i]
            .value
            .as_ref()
            .expect("checked slot is occupied"))
    }

    /// The object named by `handle`, mutably.
    pub fn get_mut(&mut self, handle: H) -> Result<&mut T> {
        let i = self.check(handle)?;
        Ok(self.slots[i]
            .value
            .as_mut()
            .expect("checked slot is occupied"))
    }

    /// Removes and returns the object; the handle (and copies of it) become invalid.
    pub fn remove(&mut self, handle: H) -> Result<T> {
        let i = self.check(handle)?;
        let slot = &mut self.slots[i];
        slot.generation = slot.generation.wrapping_add(1);
        self.free.push(i as u32);
        Ok(slot.value.take().expect("checked slot is occupied"))
    }

    /// The live objects with their handles.
    pub fn iter(&self) -> impl Iterator<Item = (H, &T)> {
        let device = self.device;
        self.slots.iter().enumerate().filter_map(move |(i, s)| {
            s.value.as_ref().map(|v| {
                (
                    H::from_raw(RawHandle {
                        device,
                        slot: i as u32,
                        generation: s.generation,
                    }),
                    v,
                )
            })
        })
    }

    /// Number of live objects.
    pub fn len(&self) -> usize {
        self.slots.len() - self.free.len()
    }

    /// Whether no object is alive.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use optik_api::Buffer;

    #[test]
    fn stale_and_foreign_handles_are_errors() {
        let mut a: HandleTable<Buffer, u32> = HandleTable::new(DeviceId::next());
        let mut b: HandleTable<Buffer, u32> = HandleTable::new(DeviceId::next());
        let h = a.insert(7);
        assert_eq!(*a.get(h).unwrap(), 7);
        let foreign = b.get(h).unwrap_err();
        assert_eq!(foreign.kind(), ErrorKind::InvalidHandle);
        assert!(
            foreign.message().contains("belongs to device"),
            "{}",
            foreign.message()
        );
        assert_eq!(a.remove(h).unwrap(), 7);
        let stale = a.get(h).unwrap_err();
        assert!(stale.message().contains("destroyed"), "{}", stale.message());
        // The slot is reused with a new generation; the old handle stays invalid.
        let next = a.next_handle();
        let h2 = a.insert(9);
        assert_eq!(next, h2);
        assert_eq!(h2.raw().slot, h.raw().slot);
        assert!(a.get(h).is_err());
        assert_eq!(*a.get(h2).unwrap(), 9);
        assert_eq!(a.len(), 1);
        assert_eq!(a.next_handle(), a.insert(3));
        let drained: Vec<u32> = a.drain().into_iter().map(|(_, v)| v).collect();
        assert_eq!(drained, [9, 3]);
        assert!(a.is_empty() && a.get(h2).is_err());
        let _ = b.insert(1);
    }
}
