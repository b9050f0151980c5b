//! optik-vulkan: the Vulkan ray tracing backend (issue 6). Not implemented yet: it opens no device.

/// Opens a device of this backend.
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Err(optik_api::Error::unsupported(
        "the vulkan backend is not implemented yet",
    ))
}
