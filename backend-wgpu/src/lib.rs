//! optik-wgpu: the wgpu compute backend (issue 5): software traversal in a generated WGSL
//! megakernel. The device itself is not written yet; [`probe`] lists the adapters found.

mod probe;

pub use probe::{AdapterReport, probe};

/// Opens a device of this backend.
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Err(optik_api::Error::unsupported(
        "the wgpu backend is not implemented yet (its adapters are listed by `optik info`)",
    ))
}
