//! Checked opaque handles.
//!
//! Every object a device creates is named by a small `Copy` handle that records the device it
//! came from, a slot and a generation. Using a handle from another device, or one whose object
//! was destroyed, is an [`ErrorKind::InvalidHandle`] error, never undefined behaviour. Each
//! backend stores its objects in a [`HandleTable`], which does these checks in one place.

use crate::error::{Error, ErrorKind, Result};
use std::fmt;
use std::sync::atomic::{AtomicU32, Ordering};

/// Identifies one device for the lifetime of the process. Never reused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DeviceId(pub u32);

impl DeviceId {
    /// A fresh id, distinct from every other device's in this process.
    pub fn next() -> Self {
        static NEXT: AtomicU32 = AtomicU32::new(1);
        DeviceId(NEXT.fetch_add(1, Ordering::Relaxed))
    }
}

impl fmt::Display for DeviceId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "device #{}", self.0)
    }
}

/// The fields every handle carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RawHandle {
    /// The device that created the object.
    pub device: DeviceId,
    /// Index of the object's slot in its device's table.
    pub slot: u32,
    /// Generation of the slot when the object was created.
    pub generation: u32,
}

/// A typed handle; implemented by [`Buffer`], [`Texture`], [`Module`], [`ProgramGroup`],
/// [`Pipeline`], [`Accel`] and [`MicromapArray`].
pub trait Handle: Copy + fmt::Debug {
    /// The object kind's name, used in error messages ("buffer", "pipeline").
    const KIND: &'static str;
    /// Wraps raw fields.
    fn from_raw(raw: RawHandle) -> Self;
    /// The raw fields.
    fn raw(&self) -> RawHandle;
}

macro_rules! handle_type {
    ($(#[$doc:meta])* $name:ident, $kind:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(RawHandle);

        impl Handle for $name {
            const KIND: &'static str = $kind;
            fn from_raw(raw: RawHandle) -> Self {
                Self(raw)
            }
            fn raw(&self) -> RawHandle {
                self.0
            }
        }

        impl $name {
            /// The device this handle belongs to.
            pub fn device(&self) -> DeviceId {
                self.0.device
            }
        }
    };
}

handle_type!(
    /// A byte buffer owned by a device (OptiX: a `CUdeviceptr` allocation).
    Buffer, "buffer");
handle_type!(
    /// A 2D texture owned by a device.
    Texture, "texture");
handle_type!(
    /// A compiled WGSL module (OptiX: `OptixModule`).
    Module, "module");
handle_type!(
    /// A program group (OptiX: `OptixProgramGroup`).
    ProgramGroup, "program group");
handle_type!(
    /// A linked pipeline (OptiX: `OptixPipeline`).
    Pipeline, "pipeline");
handle_type!(
    /// A traversable object: a geometry or instance acceleration structure, or a transform.
    Accel, "acceleration structure");
handle_type!(
    /// An opacity micromap array (OptiX: `optixOpacityMicromapArrayBuild`'s output).
    MicromapArray, "opacity micromap array");

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
        let h2 = a.insert(9);
        assert_eq!(h2.raw().slot, h.raw().slot);
        assert!(a.get(h).is_err());
        assert_eq!(*a.get(h2).unwrap(), 9);
        assert_eq!(a.len(), 1);
        let _ = b.insert(1);
    }
}
