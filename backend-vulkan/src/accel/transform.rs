//! Transform traversables: static transforms compose into their flat list; motion
//! transforms give every path a proxy bottom level and a motion chain ([`super::motion`]).

use super::flatten::{self, FlatInstance, FlatSource};
use super::motion::{self, Aabb, ChainLink};
use super::tables::{self, NONE};
use super::vkas::{AsBuffer, BuildTarget, VkGeometry};
use super::{AccelObject, Tlas};
use crate::device::Inner;
use crate::memory::{GpuBuffer, Location};
use crate::objects::Accels;
use ash::vk;
use optik_api::*;

/// A static or motion transform.
pub struct Transform {
    /// Its top level (its traversable handle).
    pub tlas: Tlas,
    /// Its own transform: static, or motion keys.
    pub link: ChainLink,
    /// The transformed traversable.
    pub child: Option<Accel>,
    /// Its flat list.
    pub flat: Vec<FlatInstance>,
    /// Motion transforms: the proxy of each flat entry (its address; 0 for an inactive one).
    pub proxies: Vec<u64>,
    /// What it and its child contain.
    pub features: SceneFeatures,
}

/// The bottom level of one path through a motion transform (the module documentation of
/// [`super::motion`]), and what a motion transform above it needs.
pub struct Proxy {
    /// The AABB bottom level.
    pub structure: AsBuffer,
    /// Per geometry (in the geometry structure's order): its Vulkan flags and its
    /// primitives' boxes over all times, in the proxy's space.
    pub geometries: Vec<(vk::GeometryFlagsKHR, Vec<Aabb>)>,
    /// The path's chain below its Vulkan instance, outermost first.
    pub links: Vec<ChainLink>,
    /// The chain's range of the data table.
    pub chain: (u32, u32),
}

/// The flat list of `accel`, its geometry structures' paths naming their owner.
pub fn flat_of(accels: &Accels, accel: Accel) -> Result<Vec<FlatInstance>> {
    let obj = accels.get(accel)?;
    let flat = obj.flat();
    Ok(match obj {
        AccelObject::Gas(_) => flat
            .into_iter()
            .map(|f| f.owned_by(FlatSource::Gas(accel)))
            .collect(),
        _ => flat,
    })
}

impl Inner {
    /// Creates a static, matrix-motion or SRT-motion transform that core stores under
    /// `handle`.
    pub fn create_transform(
        &mut self,
        accels: &Accels,
        handle: Accel,
        desc: &TransformDesc,
    ) -> Result<AccelObject> {
        let (link, kinds) = match desc {
            TransformDesc::Static {
                object_to_world, ..
            } => (ChainLink::Static(*object_to_world), MotionKinds::default()),
            TransformDesc::MatrixMotion { motion, keys, .. } => (
                ChainLink::Matrix(*motion, keys.clone()),
                MotionKinds {
                    matrix: true,
                    ..Default::default()
                },
            ),
            TransformDesc::SrtMotion { motion, keys, .. } => (
                ChainLink::Srt(*motion, keys.clone()),
                MotionKinds {
                    srt: true,
                    ..Default::default()
                },
            ),
        };
        let child = match desc.child().0 {
            0 => None,
            h => Some(self.by_handle.get(&h).copied().ok_or_else(|| {
                Error::invalid(format!("transform child {h:#x} is no live acceleration structure or transform of this device"))
            })?),
        };
        let child_features: Vec<SceneFeatures> = match child {
            Some(c) => vec![accels.get(c)?.features()],
            None => Vec::new(),
        };
        if !link.is_static()
            && !self.emulates_triangles()
            && child_features
                .iter()
                .any(|f| f.primitive_types.contains(PrimitiveTypeFlags::TRIANGLE))
        {
            return Err(Error::unsupported(
                "a motion transform over triangles needs optik's triangle test: the device's is TriangleTest::Driver (native Vulkan triangles, which cannot move); set TriangleTest::Watertight or MollerTrumbore before building",
            ));
        }
        let features = SceneFeatures::of_parent(&child_features, kinds, link.is_static());
        let child_flat = match child {
            Some(c) => flat_of(accels, c)?,
            None => Vec::new(),
        };
        let (flat, proxies) = self.transform_flat(accels, &link, &child_flat)?;
        let tlas = match self.build_tlas(
            Some(accels),
            &flat,
            vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE,
        ) {
            Ok(t) => t,
            Err(e) => {
                self.free_proxies(&proxies);
                return Err(e);
            }
        };
        self.by_handle.insert(tlas.structure.address, handle);
        Ok(AccelObject::Transform(Transform {
            tlas,
            link,
            child,
            flat,
            proxies,
            features,
        }))
    }

    /// A transform's flat list over its child's, with the proxies a motion transform makes
    /// (their addresses, 0 for inactive paths).
    fn transform_flat(
        &mut self,
        accels: &Accels,
        link: &ChainLink,
        child: &[FlatInstance],
    ) -> Result<(Vec<FlatInstance>, Vec<u64>)> {
        let ChainLink::Static(m) = link else {
            return self.motion_flat(accels, link, child);
        };
        Ok((flatten::through_transform(m, child), Vec::new()))
    }

    /// The flat list of a motion transform: a proxy and a chain per path of its child.
    fn motion_flat(
        &mut self,
        accels: &Accels,
        link: &ChainLink,
        child: &[FlatInstance],
    ) -> Result<(Vec<FlatInstance>, Vec<u64>)> {
        let mut flat = Vec::with_capacity(child.len());
        let mut proxies = Vec::with_capacity(child.len());
        for c in child {
            if c.blas == 0 {
                flat.push(FlatInstance {
                    transform: IDENTITY_3X4,
                    chain: NONE,
                    source: None,
                    ..c.inactive()
                });
                proxies.push(0);
                continue;
            }
            match self.proxy_over(accels, link, c) {
                Ok(address) => {
                    let chain = self.proxies.get(&address).map_or(NONE, |p| p.chain.0);
                    flat.push(FlatInstance {
                        transform: IDENTITY_3X4,
                        blas: address,
                        chain,
                        source: Some(FlatSource::Proxy(address)),
                        // A proxy is boxes (its triangles, if any, are optik's stage's).
                        boxes: true,
                        ..*c
                    });
                    proxies.push(address);
                }
                Err(e) => {
                    self.free_proxies(&proxies);
                    return Err(e);
                }
            }
        }
        Ok((flat, proxies))
    }

    /// Builds the proxy of path `c` seen through the motion transform `link`; its address.
    fn proxy_over(&mut self, accels: &Accels, link: &ChainLink, c: &FlatInstance) -> Result<u64> {
        let (base, below): (Vec<(vk::GeometryFlagsKHR, Vec<Aabb>)>, Vec<ChainLink>) = match c.source
        {
            Some(FlatSource::Gas(g)) => match accels.get(g)? {
                AccelObject::Gas(gas) => (gas.geometry_boxes.clone(), Vec::new()),
                _ => return Err(Error::backend("a path's geometry is not a geometry")),
            },
            Some(FlatSource::Proxy(address)) => {
                let p = self
                    .proxies
                    .get(&address)
                    .ok_or_else(|| Error::backend("a path's proxy is gone"))?;
                (p.geometries.clone(), p.links.clone())
            }
            None => return Err(Error::backend("a path without an owner")),
        };
        let mut links = vec![link.clone()];
        if c.transform != IDENTITY_3X4 {
            links.push(ChainLink::Static(c.transform));
        }
        links.extend(below);
        let through = ChainLink::Static(c.transform);
        let geometries: Vec<(vk::GeometryFlagsKHR, Vec<Aabb>)> = base
            .into_iter()
            .map(|(flags, boxes)| {
                let moved = boxes
                    .iter()
                    .map(|b| motion::bound(link, &motion::bound(&through, b)))
                    .collect();
                (flags, moved)
            })
            .collect();
        let structure = self.build_proxy(&geometries)?;
        let words = tables::padded_data(motion::chain_words(&links));
        let start = self.tables.data.insert(&words);
        self.tables.touch();
        let address = structure.address;
        self.proxies.insert(
            address,
            Proxy {
                structure,
                geometries,
                links,
                chain: (start, words.len() as u32),
            },
        );
        Ok(address)
    }

    /// An AABB bottom level of `geometries`.
    pub(super) fn build_proxy(
        &mut self,
        geometries: &[(vk::GeometryFlagsKHR, Vec<Aabb>)],
    ) -> Result<AsBuffer> {
        let mut bytes: Vec<u8> = Vec::new();
        let mut offsets = Vec::with_capacity(geometries.len());
        for (_, boxes) in geometries {
            bytes.resize(bytes.len().next_multiple_of(16), 0);
            offsets.push(bytes.len() as u64);
            bytes.extend(boxes.iter().flatten().flat_map(|v| v.to_le_bytes()));
        }
        bytes.resize(bytes.len().max(16), 0);
        let input = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            bytes.len() as u64,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
            Location::HostVisible,
            16,
        )?;
        let geoms: Vec<VkGeometry> = geometries
            .iter()
            .zip(&offsets)
            .map(|((flags, boxes), offset)| VkGeometry::Aabbs {
                aabbs: input.address + offset,
                count: boxes.len() as u32,
                flags: *flags,
            })
            .collect();
        let built = input.write(0, &bytes).and_then(|_| {
            self.build_as(
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                &geoms,
                None,
                vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE,
                BuildTarget::New,
            )
        });
        input.destroy(&self.ctx, &mut self.alloc);
        built?.ok_or_else(|| Error::backend("a proxy build returned nothing"))
    }

    /// Frees proxies (and their chains) no top level references any more.
    pub fn free_proxies(&mut self, addresses: &[u64]) {
        for a in addresses {
            if let Some(p) = self.proxies.remove(a) {
                self.tables.data.remove(p.chain.0, p.chain.1);
                p.structure.destroy(&self.ctx, &mut self.alloc);
            }
        }
        self.tables.touch();
    }

    /// A transform's flat list again, over its child as it is now (inactive when the child
    /// is gone); rebuilds its top level and retires the proxies it replaced (freed once the
    /// top levels above are refreshed too).
    pub fn refresh_transform(&mut self, accels: &mut Accels, accel: Accel) -> Result<()> {
        let (link, child, old_flat, old_proxies) = match accels.get(accel)? {
            AccelObject::Transform(t) => {
                (t.link.clone(), t.child, t.flat.clone(), t.proxies.clone())
            }
            _ => return Err(Error::backend("not a transform")),
        };
        let (flat, proxies) = match child.map(|c| flat_of(accels, c)) {
            Some(Ok(child_flat)) => self.transform_flat(accels, &link, &child_flat)?,
            _ => (
                old_flat.iter().map(|f| f.inactive()).collect(),
                vec![0; old_proxies.len()],
            ),
        };
        if let Err(e) = self.rebuild_tlas(accels, accel, &flat) {
            self.free_proxies(&proxies);
            return Err(e);
        }
        if let AccelObject::Transform(t) = accels.get_mut(accel)? {
            t.flat = flat;
            t.proxies = proxies;
        }
        // The top levels above still name the old proxies until they are refreshed too.
        self.retired_proxies.extend(old_proxies);
        Ok(())
    }
}
