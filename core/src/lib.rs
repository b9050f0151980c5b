//! optik-core: the front door of every optik device, in the manner of wgpu-core over
//! wgpu-hal.
//!
//! Each backend implements [`Backend`], an unchecked trait: its methods are called only with
//! arguments [`Device`] has checked. [`Device<B>`] implements [`optik_api::Device`] once for
//! every backend, and every user misuse it can see (sizes and ranges, build inputs, updates
//! and compaction, program groups naming programs that do not exist or of another kind,
//! pipelines without a raygen group, launch sizes, SBT layouts, launch bindings) is refused
//! here, with one message whatever the backend. `conformance/tests/misuse.rs` holds every
//! backend to that.
//!
//! What every backend shares, beside the checks, also lives here, once:
//! - [`frontend`]: the WGSL program front end (prelude, parse, checks, reflection);
//! - [`validate`]: the checks of user input, each naming what was wrong and what was
//!   expected ([`Device`] calls them before any backend method);
//! - [`Objects`]: every object of a device, one checked [`HandleTable`] per kind, owned by
//!   [`Device`] under one lock; a backend's objects are its [`Backend`]'s associated types;
//! - [`sbt`]: the reader of the user's SBT record headers;
//! - [`features`]: feature resolution, from options, scene and programs ([`Device`] resolves
//!   every pipeline's features and hands them to the backend);
//! - [`unwind`]: the exception-unwinding pass on naga IR of the GPU backends;
//! - [`measure`]: how benchmarks time launches (a warm-up long enough for GPU clocks);
//! - [`vulkan_loader`]: the lock that keeps opening and dropping devices apart from calls on
//!   them, for backends that go through the system's Vulkan loader.
//!
//! What stays in the backends: what their objects are (the associated types), state that
//! is no object (the CPU scene table, the wgpu arena, the Vulkan command pool and
//! samplers, each under the backend's own lock, always taken after [`Device`]'s), the
//! records they read (through [`sbt::resolve_record_header`]), and the limits only a
//! backend knows (a driver's uniform range, a GPU's workgroup counts).

mod backend;
mod device;
pub mod features;
pub mod frontend;
mod handle_table;
pub mod measure;
mod objects;
pub mod sbt;
pub mod unwind;
pub mod validate;
pub mod vulkan_loader;

pub use backend::Backend;
pub use device::{Device, Locked};
pub use handle_table::HandleTable;
pub use objects::Objects;

/// naga, re-exported so backends lower the same IR version the front end produces.
pub use naga;
