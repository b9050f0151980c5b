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
//! What stays in the backends: handle tables and locking (each checks the handles it is
//! given: a destroyed or foreign handle is an `InvalidHandle` error from
//! `optik_api::HandleTable`, which words it one way), the SBT record headers (read where the
//! backend reads records, through `optik_api::sbt::resolve_record_header`), and the limits
//! only a backend knows (a driver's uniform range, a GPU's workgroup counts).

mod backend;
mod device;

pub use backend::Backend;
pub use device::Device;
