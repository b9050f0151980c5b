//! optik-wgpu: the wgpu compute backend (issue 5). Not implemented yet: it opens no device.

/// Opens a device of this backend.
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Err(optik_api::Error::unsupported("the wgpu backend is not implemented yet"))
}
