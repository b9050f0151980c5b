//! optik-wgpu: the wgpu compute backend (issue 5). Not implemented yet: it opens no device.
