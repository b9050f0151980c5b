//! [`Objects`]: a device's objects, one [`HandleTable`] per kind, owned by
//! [`crate::Device`] and lent to its [`Backend`] under one lock.

use crate::{Backend, HandleTable};
use optik_api::{
    Accel, Buffer, DeviceId, MicromapArray, Module, Pipeline, ProgramGroup, Result, Texture,
};

/// Every object of one device, of backend `B`.
pub struct Objects<B: Backend> {
    /// Buffers.
    pub buffers: HandleTable<Buffer, B::Buffer>,
    /// Textures.
    pub textures: HandleTable<Texture, B::Texture>,
    /// Acceleration structures and transforms.
    pub accels: HandleTable<Accel, B::Accel>,
    /// Opacity micromap arrays.
    pub micromaps: HandleTable<MicromapArray, B::MicromapArray>,
    /// Compiled modules.
    pub modules: HandleTable<Module, B::Module>,
    /// Program groups.
    pub groups: HandleTable<ProgramGroup, B::ProgramGroup>,
    /// Linked pipelines.
    pub pipelines: HandleTable<Pipeline, B::Pipeline>,
}

impl<B: Backend> Objects<B> {
    /// No objects yet, of device `device`.
    pub fn new(device: DeviceId) -> Self {
        Self {
            buffers: HandleTable::new(device),
            textures: HandleTable::new(device),
            accels: HandleTable::new(device),
            micromaps: HandleTable::new(device),
            modules: HandleTable::new(device),
            groups: HandleTable::new(device),
            pipelines: HandleTable::new(device),
        }
    }

    /// The groups named by `groups`, each error naming its index in the list.
    pub fn groups_of(&self, groups: &[ProgramGroup]) -> Result<Vec<&B::ProgramGroup>> {
        groups
            .iter()
            .enumerate()
            .map(|(i, g)| {
                self.groups
                    .get(*g)
                    .map_err(|e| e.context(format!("groups[{i}]")))
            })
            .collect()
    }
}
