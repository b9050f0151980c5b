//! Checked opaque handles.
//!
//! Every object a device creates is named by a small `Copy` handle that records the device it
//! came from, a slot and a generation. Using a handle from another device, or one whose object
//! was destroyed, is an [`ErrorKind::InvalidHandle`] error, never undefined behaviour. Each
//! backend stores its objects in an `optik_core::HandleTable`, which does these checks in one
//! place.
//!
//! [`ErrorKind::InvalidHandle`]: crate::ErrorKind::InvalidHandle

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
