//! optik-vulkan: the Vulkan ray tracing backend (issue 6).

pub mod program;

/// Opens a device of this backend.
pub fn open() -> optik_api::Result<Box<dyn optik_api::Device>> {
    Err(optik_api::Error::unsupported("the vulkan backend is not implemented yet"))
}
