//! Device resources the renderer creates, freed when dropped (errors on free are ignored:
//! the device frees everything it owns when it drops anyway).

use crate::error::{Context, RenderError};
use optik::{Accel, Buffer, Device, Module, Pipeline, ProgramGroup};

/// Everything one render or probe created on a device.
pub struct Owned<'d> {
    device: &'d dyn Device,
    buffers: Vec<Buffer>,
    accels: Vec<Accel>,
    modules: Vec<Module>,
    groups: Vec<ProgramGroup>,
    pipelines: Vec<Pipeline>,
}

impl<'d> Owned<'d> {
    /// Nothing owned yet.
    pub fn new(device: &'d dyn Device) -> Self {
        Owned {
            device,
            buffers: Vec::new(),
            accels: Vec::new(),
            modules: Vec::new(),
            groups: Vec::new(),
            pipelines: Vec::new(),
        }
    }

    /// A buffer holding `bytes` (at least 16 bytes, zero-padded: bindings need a size).
    pub fn upload(&mut self, bytes: &[u8], what: &str) -> Result<Buffer, RenderError> {
        let b = self.zeroed(bytes.len() as u64, what)?;
        if !bytes.is_empty() {
            self.device
                .write_buffer(b, 0, bytes)
                .during(&format!("uploading {what}"))?;
        }
        Ok(b)
    }

    /// A zero-filled buffer of at least `size` bytes.
    pub fn zeroed(&mut self, size: u64, what: &str) -> Result<Buffer, RenderError> {
        let b = self
            .device
            .create_buffer(size.max(16))
            .during(&format!("creating {what}"))?;
        self.buffers.push(b);
        Ok(b)
    }

    /// Keeps `accel` until drop.
    pub fn accel(&mut self, accel: Accel) -> Accel {
        self.accels.push(accel);
        accel
    }

    /// Keeps `module` until drop.
    pub fn module(&mut self, module: Module) -> Module {
        self.modules.push(module);
        module
    }

    /// Keeps `groups` until drop.
    pub fn groups(&mut self, groups: Vec<ProgramGroup>) -> Vec<ProgramGroup> {
        self.groups.extend(groups.iter().copied());
        groups
    }

    /// Keeps `pipeline` until drop.
    pub fn pipeline(&mut self, pipeline: Pipeline) -> Pipeline {
        self.pipelines.push(pipeline);
        pipeline
    }
}

impl Drop for Owned<'_> {
    fn drop(&mut self) {
        let d = self.device;
        for p in self.pipelines.drain(..) {
            let _ = d.destroy_pipeline(p);
        }
        for g in self.groups.drain(..) {
            let _ = d.destroy_program_group(g);
        }
        for m in self.modules.drain(..) {
            let _ = d.destroy_module(m);
        }
        for a in self.accels.drain(..).rev() {
            let _ = d.destroy_accel(a);
        }
        for b in self.buffers.drain(..) {
            let _ = d.destroy_buffer(b);
        }
    }
}

/// Bytes of a uniform block written field by field in WGSL layout order.
#[derive(Default)]
pub struct Std140(pub Vec<u8>);

impl Std140 {
    /// Appends a u32.
    pub fn u(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// Appends an f32.
    pub fn f(&mut self, v: f32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
}
