//! optik-vulkan: the Vulkan ray tracing backend (issue 6). Not implemented yet: it opens no device.
