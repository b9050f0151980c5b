//! One process-wide lock between opening or dropping a device that goes through the
//! system's Vulkan loader and every other call on such a device.
//!
//! The Vulkan loader (1.3.239, Debian bookworm's, and every release up to 1.4.341 at least:
//! KhronosGroup/Vulkan-Loader#2018) keeps one process-wide list of logical devices. Its
//! readers walk it under the loader's lock: the terminator of `vkSetDebugUtilsObjectNameEXT`
//! among them, which wgpu calls for every labelled object when validation or debugging is
//! on (debug builds and tests). Its writers, `vkCreateDevice` and `vkDestroyDevice`, add and
//! free nodes without that lock. So a device opened or dropped on one thread while another
//! thread names an object (a bind group at a launch, a buffer) could make the reader follow
//! a freed node: the process died with SIGSEGV, now and then, in tests that run several
//! devices on several threads (`tests/concurrent_devices.rs` reproduces it in a few of every
//! ten runs without this lock).
//!
//! So the backends that reach the loader (wgpu, Vulkan) open and destroy their devices
//! holding [`changing_devices`], and [`crate::Device`] holds [`using`] through each of their
//! calls ([`crate::Backend::USES_VULKAN_LOADER`]): calls on different devices still run side
//! by side (the guard is shared), and only opening or dropping a device waits for them. A
//! guard is never taken while the same thread holds the other (a backend opens and drops its
//! devices outside [`crate::Device`]'s calls), and the shared one is taken once per call
//! (`Device::enter`, or `Device::objects` for a backend's extensions, never both: a second
//! shared hold would wait behind a device being opened elsewhere, which waits for the
//! first), so the lock cannot deadlock.

use std::sync::{PoisonError, RwLock, RwLockReadGuard, RwLockWriteGuard};

static DEVICES: RwLock<()> = RwLock::new(());

/// Held through a call on a device that reaches the Vulkan loader; shared by any number of
/// such calls at once.
pub fn using() -> RwLockReadGuard<'static, ()> {
    // The lock guards no data (a panic under it leaves nothing half-written).
    DEVICES.read().unwrap_or_else(PoisonError::into_inner)
}

/// Held while a device that reaches the Vulkan loader is created or destroyed: waits for
/// every call in progress, and holds the next ones back.
pub fn changing_devices() -> RwLockWriteGuard<'static, ()> {
    DEVICES.write().unwrap_or_else(PoisonError::into_inner)
}
