//! Acceleration structures and transforms (OptiX `optixAccelBuild`, `optixConvert...`).
//!
//! - A geometry acceleration structure (GAS) is one or two Vulkan bottom levels (two when
//!   some of its triangle records disable face culling and others do not: Vulkan culls per
//!   instance, so those records go to a second bottom level whose instances carry
//!   `TRIANGLE_FACING_CULL_DISABLE`; both keep every geometry index, the other part's
//!   geometries empty). Spheres and curves are AABBs intersected by optik's stages.
//! - Every traversable is traced through a Vulkan top level: an instance acceleration
//!   structure (IAS) is its flattened top level ([`flatten`]); a GAS and a transform get a
//!   top level of their own flat list. The traversable handle is that top level's device
//!   address, which programs convert with `OpConvertUToAccelerationStructureKHR`.
//! - When a traversable is destroyed or refit, the top levels that contain it are built again
//!   in place (same instance count, so the same handle): instances that name a destroyed
//!   traversable become inactive Vulkan instances and miss, and no top level keeps a stale
//!   bottom level.

pub mod flatten;
pub mod geometry;
pub mod motion;
pub mod tables;
pub mod transform;
pub mod vkas;

pub use tables::SceneTables;
pub use transform::{Proxy, Transform};

use crate::buffer::snapshot_view;
use crate::device::Inner;
use crate::memory::{Allocator, GpuBuffer, Location};
use crate::objects::{Accels, Buffers, Objects, Unfreed};
use ash::vk;
use flatten::{FlatInstance, FlatSource, vk_flags};
use geometry::{DecodedGas, DecodedGeometry, GasKind};
use optik_api::*;
use std::collections::HashSet;
use std::hash::{Hash, Hasher};
use vkas::{AsBuffer, BuildTarget, INSTANCE_SIZE, VkGeometry};

/// How a device builds triangles: the driver's (`TriangleTest::Driver`), optik's triangle
/// stage (the other tests), or both (where the driver passed optik's check: the driver's
/// triangles wherever they can serve, §2.4; Möller–Trumbore too, which there would only be
/// slower than the default it is meant to undercut).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriangleBuild {
    /// Native Vulkan triangles only.
    Driver,
    /// AABBs with optik's triangle stage only.
    Optik,
    /// Native triangles for static structures without micromaps or face-culling records,
    /// optik's stage for the rest and under motion transforms.
    Mixed,
}

impl TriangleBuild {
    /// The build for triangle test `test` on a device that does (`driver_triangles`) or does
    /// not trust its driver's triangles.
    pub fn of(test: TriangleTest, driver_triangles: bool) -> TriangleBuild {
        match test {
            TriangleTest::Driver => TriangleBuild::Driver,
            TriangleTest::Watertight | TriangleTest::MollerTrumbore if driver_triangles => {
                TriangleBuild::Mixed
            }
            _ => TriangleBuild::Optik,
        }
    }
}

/// A Vulkan top level with its instance buffer and its range of the instance table.
pub struct Tlas {
    /// The top level.
    pub structure: AsBuffer,
    instances: GpuBuffer,
    /// Vulkan instances.
    pub count: u32,
    /// First entry of its instances in the instance table (the custom index of instance 0).
    pub table_start: u32,
    flags: vk::BuildAccelerationStructureFlagsKHR,
    /// The largest hit record index a ray through it can select, before the offset of
    /// paths over boxes on a device that mixes triangle kinds (§2.4).
    pub sbt_reach: u64,
    /// The same for its paths over boxes; `None` without such paths.
    pub box_reach: Option<u64>,
}

impl Tlas {
    /// The largest hit record index the paths of `flat` select, and that of its paths over
    /// boxes (`sbt_reach`, `box_reach`).
    fn reaches(flat: &[FlatInstance]) -> (u64, Option<u64>) {
        let all = flat.iter().map(FlatInstance::sbt_reach).max().unwrap_or(0);
        let boxes = flat
            .iter()
            .filter(|f| f.boxes)
            .map(FlatInstance::sbt_reach)
            .max();
        (all, boxes)
    }

    /// Frees it (its table range is the caller's to return).
    pub fn destroy(self, ctx: &crate::context::Context, alloc: &mut Allocator) {
        self.structure.destroy(ctx, alloc);
        self.instances.destroy(ctx, alloc);
    }
}

/// A geometry acceleration structure.
pub struct Gas {
    /// Bottom levels and the instance flags their instances carry.
    parts: Vec<(AsBuffer, u32)>,
    /// Per part, which geometries it holds.
    part_geometries: Vec<Vec<bool>>,
    wrapper: Tlas,
    geometry_start: u32,
    geometry_count: u32,
    data_start: u32,
    data_len: u32,
    kind: GasKind,
    /// Whether Vulkan sees its triangles as triangles (the driver's test).
    native_triangles: bool,
    /// Per geometry, the Vulkan geometry flags and (for AABB geometries) its boxes: what
    /// motion transforms bound again.
    geometry_boxes: Vec<(vk::GeometryFlagsKHR, Vec<[f32; 6]>)>,
    options: AccelBuildOptions,
    inputs: Vec<BuildInput>,
    partition: Vec<Vec<u32>>,
    /// Which primitives are active (a hash): Vulkan refits keep active primitives active.
    activity: u64,
    compacted: bool,
    features: SceneFeatures,
}

/// An instance acceleration structure.
pub struct Ias {
    tlas: Tlas,
    instances: Vec<Instance>,
    children: Vec<Option<Accel>>,
    /// Flat instances each OptiX instance contributes (fixed for the structure's life).
    counts: Vec<u32>,
    flat: Vec<FlatInstance>,
    options: AccelBuildOptions,
    inputs: Vec<BuildInput>,
    features: SceneFeatures,
}

/// A traversable object.
pub enum AccelObject {
    /// Geometry.
    Gas(Gas),
    /// Instances.
    Ias(Ias),
    /// A static or motion transform.
    Transform(Transform),
}

impl AccelObject {
    fn tlas(&self) -> &Tlas {
        match self {
            AccelObject::Gas(g) => &g.wrapper,
            AccelObject::Ias(i) => &i.tlas,
            AccelObject::Transform(t) => &t.tlas,
        }
    }

    /// The traversable handle: the top level's device address.
    pub fn handle(&self) -> u64 {
        self.tlas().structure.address
    }

    /// Bytes of its Vulkan structures.
    pub fn size(&self) -> u64 {
        match self {
            AccelObject::Gas(g) => {
                g.parts.iter().map(|(p, _)| p.size()).sum::<u64>() + g.wrapper.structure.size()
            }
            AccelObject::Ias(i) => i.tlas.structure.size(),
            AccelObject::Transform(t) => t.tlas.structure.size(),
        }
    }

    /// What the structure and everything below it contain.
    pub fn features(&self) -> SceneFeatures {
        match self {
            AccelObject::Gas(g) => g.features,
            AccelObject::Ias(i) => i.features,
            AccelObject::Transform(t) => t.features,
        }
    }

    /// Its flat list (one entry per path to a bottom level).
    pub fn flat(&self) -> Vec<FlatInstance> {
        match self {
            AccelObject::Gas(g) => gas_paths(
                &g.parts,
                g.geometry_start,
                g.geometry_count,
                g.kind,
                g.native_triangles,
            ),
            AccelObject::Ias(i) => i.flat.clone(),
            AccelObject::Transform(t) => t.flat.clone(),
        }
    }

    fn children(&self) -> Vec<Accel> {
        match self {
            AccelObject::Gas(_) => Vec::new(),
            AccelObject::Ias(i) => i.children.iter().flatten().copied().collect(),
            AccelObject::Transform(t) => t.child.into_iter().collect(),
        }
    }

    /// The options and inputs of its last build or update; `None` for a transform.
    pub fn build_record(&self) -> Option<(AccelBuildOptions, Vec<BuildInput>)> {
        match self {
            AccelObject::Gas(g) => Some((g.options, g.inputs.clone())),
            AccelObject::Ias(i) => Some((i.options, i.inputs.clone())),
            AccelObject::Transform(_) => None,
        }
    }

    /// Whether it is a geometry structure of triangles (built for the device's triangle
    /// test).
    pub fn has_triangles(&self) -> bool {
        matches!(self, AccelObject::Gas(g) if g.kind == GasKind::Triangles)
    }

    /// The largest hit record index a ray traced against it can select (before the offset
    /// of paths over boxes where a device mixes triangle kinds).
    pub fn sbt_reach(&self) -> u64 {
        self.tlas().sbt_reach
    }

    /// The same for its paths over boxes, if it has any.
    pub fn box_reach(&self) -> Option<u64> {
        self.tlas().box_reach
    }

    /// Frees its Vulkan objects (table ranges are returned by the caller).
    pub fn destroy(self, ctx: &crate::context::Context, alloc: &mut Allocator) {
        match self {
            AccelObject::Gas(g) => {
                for (p, _) in g.parts {
                    p.destroy(ctx, alloc);
                }
                g.wrapper.destroy(ctx, alloc);
            }
            AccelObject::Ias(i) => i.tlas.destroy(ctx, alloc),
            AccelObject::Transform(t) => t.tlas.destroy(ctx, alloc),
        }
    }
}

fn vk_build_flags(f: BuildFlags) -> vk::BuildAccelerationStructureFlagsKHR {
    let mut out = vk::BuildAccelerationStructureFlagsKHR::empty();
    if f.contains(BuildFlags::ALLOW_UPDATE) {
        out |= vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE;
    }
    if f.contains(BuildFlags::ALLOW_COMPACTION) {
        out |= vk::BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION;
    }
    // Vulkan forbids both preferences; tracing speed wins.
    if f.contains(BuildFlags::PREFER_FAST_TRACE) {
        out |= vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE;
    } else if f.contains(BuildFlags::PREFER_FAST_BUILD) {
        out |= vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_BUILD;
    }
    out
}

fn vk_geometry_flags(g: &DecodedGeometry) -> vk::GeometryFlagsKHR {
    let mut out = vk::GeometryFlagsKHR::empty();
    if g.vk_opaque() {
        out |= vk::GeometryFlagsKHR::OPAQUE;
    }
    if g.flags.contains(GeometryFlags::REQUIRE_SINGLE_ANYHIT_CALL) {
        out |= vk::GeometryFlagsKHR::NO_DUPLICATE_ANY_HIT_INVOCATION;
    }
    out
}

/// The buffers an input reads.
fn input_buffers(input: &BuildInput) -> Vec<Buffer> {
    let mut v = Vec::new();
    match input {
        BuildInput::Triangles(t) => {
            v.extend(t.vertex_buffers.iter().map(|b| b.buffer));
            v.extend(t.indices.iter().map(|i| i.buffer.buffer));
            v.extend(t.sbt_index_offsets.iter().map(|o| o.buffer.buffer));
            v.extend(t.pre_transform.iter().map(|p| p.buffer));
            v.extend(
                t.opacity_micromap
                    .iter()
                    .filter_map(|o| o.index_buffer.map(|b| b.buffer)),
            );
        }
        BuildInput::CustomPrimitives(c) => {
            v.extend(c.aabb_buffers.iter().map(|b| b.buffer));
            v.extend(c.sbt_index_offsets.iter().map(|o| o.buffer.buffer));
        }
        BuildInput::Spheres(s) => {
            v.extend(s.vertex_buffers.iter().map(|b| b.buffer));
            v.extend(s.radius_buffers.iter().map(|b| b.buffer));
            v.extend(s.sbt_index_offsets.iter().map(|o| o.buffer.buffer));
        }
        BuildInput::Curves(c) => {
            v.extend(c.vertex_buffers.iter().map(|b| b.buffer));
            v.extend(c.width_buffers.iter().map(|b| b.buffer));
            v.push(c.index_buffer.buffer);
        }
        BuildInput::Instances(i) => v.push(i.instances.buffer),
    }
    v
}

/// The paths of a GAS's bottom levels (`parts`: each with the instance flags its
/// instances carry).
fn gas_paths(
    parts: &[(AsBuffer, u32)],
    geometry_start: u32,
    geometry_count: u32,
    kind: GasKind,
    native_triangles: bool,
) -> Vec<FlatInstance> {
    parts
        .iter()
        .map(|(p, flags)| {
            FlatInstance::bottom(p.address, *flags, geometry_start, geometry_count)
                .over_boxes(kind != GasKind::Triangles || !native_triangles)
        })
        .collect()
}

/// The error for what native Vulkan triangles (`TriangleTest::Driver`) cannot carry.
fn native_triangles_cannot(what: &str, input: usize) -> Error {
    Error::unsupported(format!(
        "build_inputs[{input}] has {what}, which Vulkan triangles cannot carry: the device's triangle test is TriangleTest::Driver (native triangles); set TriangleTest::Watertight or TriangleTest::MollerTrumbore (optik's own triangle test, the default) before building"
    ))
}

/// Which geometries each bottom level holds, and the instance flags of its instances. Only
/// native triangles split (optik's triangle stage reads the geometry flags itself).
fn parts_of(decoded: &DecodedGas) -> Vec<(Vec<bool>, u32)> {
    let no_cull: Vec<bool> = decoded
        .geometries
        .iter()
        .map(|g| {
            decoded.native_triangles
                && g.flags
                    .contains(GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING)
        })
        .collect();
    let n = no_cull.len();
    if no_cull.iter().all(|c| *c) {
        vec![(vec![true; n], vk_flags::CULL_DISABLE)]
    } else if no_cull.iter().any(|c| *c) {
        vec![
            (no_cull.iter().map(|c| !c).collect(), 0),
            (no_cull, vk_flags::CULL_DISABLE),
        ]
    } else {
        vec![(vec![true; n], 0)]
    }
}

/// Vulkan geometries of one part, with data at `base` (the input buffer's address).
fn part_geometries(decoded: &DecodedGas, holds: &[bool], base: u64) -> Vec<VkGeometry> {
    decoded
        .geometries
        .iter()
        .zip(holds)
        .map(|(g, &held)| {
            let count = if held { g.count } else { 0 };
            let flags = vk_geometry_flags(g);
            if decoded.native_triangles {
                VkGeometry::Triangles {
                    vertices: base + g.data_offset,
                    vertex_count: g.vertex_count,
                    indices: base + g.index_offset,
                    triangle_count: count,
                    flags,
                }
            } else {
                VkGeometry::Aabbs {
                    aabbs: base + g.data_offset,
                    count,
                    flags,
                }
            }
        })
        .collect()
}

/// A hash of what a refit must keep: each geometry's primitive count and triangle indices
/// (Vulkan refits move vertices and boxes, nothing else).
fn activity_of(decoded: &DecodedGas) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    decoded.native_triangles.hash(&mut h);
    for g in &decoded.geometries {
        g.count.hash(&mut h);
        if decoded.native_triangles {
            decoded.bytes[g.index_offset as usize..g.index_offset as usize + g.count as usize * 12]
                .hash(&mut h);
        }
    }
    h.finish()
}

/// A geometry record with its data-table offsets moved by `rebase`.
fn rebase_record(r: &tables::Record, rebase: impl Fn(u32) -> u32) -> tables::Record {
    let mut out = *r;
    for f in tables::GEOMETRY_DATA_FIELDS {
        if out[f] != tables::NONE {
            out[f] = rebase(out[f]);
        }
    }
    out
}

/// The union of every live structure's features (pipelines serve all of them).
pub fn scene_features(accels: &Accels) -> Option<SceneFeatures> {
    accels
        .iter()
        .map(|(_, a)| a.features())
        .reduce(SceneFeatures::union)
}

impl Inner {
    /// The acceleration structure with no instances (null handles, continuation calls).
    pub fn create_empty_tlas(&mut self) -> Result<()> {
        let tlas = self.build_tlas(
            None,
            &[],
            vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE,
        )?;
        self.empty_tlas = Some(tlas);
        Ok(())
    }

    fn instance_entries(flat: &[FlatInstance]) -> Vec<tables::Record> {
        flat.iter()
            .map(|f| {
                [
                    f.instance_id,
                    f.instance_index,
                    f.geometry_base,
                    f.flags,
                    f.chain,
                    0,
                    0,
                    0,
                ]
            })
            .collect()
    }

    fn vk_instances(
        flat: &[FlatInstance],
        table_start: u32,
        box_offset: u32,
    ) -> Vec<vk::AccelerationStructureInstanceKHR> {
        flat.iter()
            .enumerate()
            .map(|(k, f)| {
                let offset = if f.boxes { box_offset } else { 0 };
                vkas::vk_instance(
                    &f.transform,
                    table_start + k as u32,
                    f.mask,
                    f.sbt_offset + offset,
                    f.vk_flags() as u8,
                    f.blas,
                )
            })
            .collect()
    }

    fn write_instances(
        buffer: &GpuBuffer,
        instances: &[vk::AccelerationStructureInstanceKHR],
    ) -> Result<()> {
        // SAFETY: the Vulkan instance struct is plain data of INSTANCE_SIZE bytes.
        let bytes = unsafe {
            std::slice::from_raw_parts(
                instances.as_ptr() as *const u8,
                instances.len() * INSTANCE_SIZE as usize,
            )
        };
        buffer.write(0, bytes)
    }

    /// The SBT offset added to paths over boxes: the start of the hit records' second half
    /// where the device mixes triangle kinds (§2.4), else 0.
    pub fn box_offset(&self) -> u32 {
        if self.mixes_triangles() {
            self.hit_half
        } else {
            0
        }
    }

    /// Keeps the second half of the hit records past every index a path of `flat` (or of a
    /// live top level) can select without the offset, where the device mixes triangle kinds:
    /// when it must grow, the live top levels with paths over boxes are built again with
    /// the new offset (in place, same handles).
    fn ensure_hit_half(&mut self, accels: &Accels, flat: &[FlatInstance]) -> Result<()> {
        if !self.mixes_triangles() {
            return Ok(());
        }
        let (reach, boxes) = Tlas::reaches(flat);
        if reach < self.hit_half as u64 {
            return self.check_box_offset(boxes);
        }
        let half = (reach + 1).next_power_of_two().max(16);
        let largest = accels.iter().filter_map(|(_, a)| a.box_reach()).max();
        self.hit_half = u32::try_from(half).unwrap_or(u32::MAX);
        self.check_box_offset(boxes.max(largest))?;
        for (_, a) in accels.iter() {
            if a.box_reach().is_some() {
                self.write_tlas(a.tlas(), &a.flat())?;
            }
        }
        Ok(())
    }

    /// Errors when a path over boxes with `reach` would select records past the
    /// 24 bits of a Vulkan instance's SBT offset once moved to the second half.
    fn check_box_offset(&self, reach: Option<u64>) -> Result<()> {
        match reach {
            Some(r) if r + self.hit_half as u64 >= 1 << 24 => Err(Error::limit(format!(
                "a path over boxes (custom primitives, spheres, curves or optik's triangles) selects hit records up to {r}; on a device that mixes the driver's triangles with optik's (docs/vulkan-backend.md §2.4) those paths select records {} further, past the 24 bits of a Vulkan instance's SBT offset: use smaller SBT offsets, or TriangleTest::MollerTrumbore or VulkanOptions::driver_triangles = false",
                self.hit_half
            ))),
            _ => Ok(()),
        }
    }

    /// Writes `flat`'s Vulkan instances into top level `t` and builds it again in place.
    fn write_tlas(&mut self, t: &Tlas, flat: &[FlatInstance]) -> Result<()> {
        self.tables
            .instances
            .write(t.table_start, &Self::instance_entries(flat));
        self.tables.touch();
        Self::write_instances(
            &t.instances,
            &Self::vk_instances(flat, t.table_start, self.box_offset()),
        )?;
        self.build_as(
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            &[],
            Some((t.instances.address, t.count)),
            t.flags,
            BuildTarget::Rebuild(t.structure.accel),
        )?;
        Ok(())
    }

    /// A new top level over `flat` (`accels`: the live structures, whose top levels may be
    /// built again when the hit records' second half moves, §2.4).
    fn build_tlas(
        &mut self,
        accels: Option<&Accels>,
        flat: &[FlatInstance],
        flags: vk::BuildAccelerationStructureFlagsKHR,
    ) -> Result<Tlas> {
        if let Some(accels) = accels {
            self.ensure_hit_half(accels, flat)?;
        }
        if flat.len() as u64 > self.ctx.info.max_instance_count {
            return Err(Error::limit(format!(
                "the flattened instance tree has {} Vulkan instances; this device allows {}",
                flat.len(),
                self.ctx.info.max_instance_count
            )));
        }
        let table_start = self.tables.instances.insert(&Self::instance_entries(flat));
        if table_start as u64 + flat.len() as u64 > (1 << 24) {
            self.tables.instances.remove(table_start, flat.len() as u32);
            return Err(Error::limit(
                "more than 2^24 Vulkan instances are alive on this device (the custom index has 24 bits)",
            ));
        }
        self.tables.touch();
        let result = (|| {
            let instances = GpuBuffer::new(
                &self.ctx,
                &mut self.alloc,
                (flat.len() as u64 * INSTANCE_SIZE).max(INSTANCE_SIZE),
                vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
                Location::HostVisible,
                16,
            )?;
            if let Err(e) = Self::write_instances(
                &instances,
                &Self::vk_instances(flat, table_start, self.box_offset()),
            ) {
                instances.destroy(&self.ctx, &mut self.alloc);
                return Err(e);
            }
            let built = self.build_as(
                vk::AccelerationStructureTypeKHR::TOP_LEVEL,
                &[],
                Some((instances.address, flat.len() as u32)),
                flags,
                BuildTarget::New,
            );
            match built {
                Ok(Some(structure)) => {
                    let (sbt_reach, box_reach) = Tlas::reaches(flat);
                    Ok(Tlas {
                        structure,
                        instances,
                        count: flat.len() as u32,
                        table_start,
                        flags,
                        sbt_reach,
                        box_reach,
                    })
                }
                Ok(None) => Err(Error::backend("top level build returned nothing")),
                Err(e) => {
                    instances.destroy(&self.ctx, &mut self.alloc);
                    Err(e)
                }
            }
        })();
        if result.is_err() {
            self.tables.instances.remove(table_start, flat.len() as u32);
        }
        result
    }

    /// Builds `accel`'s top level again over `flat` (same count).
    fn rebuild_tlas(
        &mut self,
        accels: &mut Accels,
        accel: Accel,
        flat: &[FlatInstance],
    ) -> Result<()> {
        let count = accels.get(accel)?.tlas().count;
        if flat.len() as u32 != count {
            return Err(Error::invalid(format!(
                "the flattened instance tree changed from {count} to {} Vulkan instances; Vulkan top levels keep their instance count, so rebuild the structure instead",
                flat.len()
            )));
        }
        self.ensure_hit_half(accels, flat)?;
        self.write_tlas(accels.get(accel)?.tlas(), flat)?;
        let t = match accels.get_mut(accel)? {
            AccelObject::Gas(g) => &mut g.wrapper,
            AccelObject::Ias(i) => &mut i.tlas,
            AccelObject::Transform(t) => &mut t.tlas,
        };
        (t.sbt_reach, t.box_reach) = Tlas::reaches(flat);
        Ok(())
    }

    /// The flat list of an instance structure's instances over its children as they are now.
    fn flatten_instances(
        accels: &Accels,
        instances: &[Instance],
        children: &[Option<Accel>],
        previous: Option<(&[u32], &[FlatInstance])>,
    ) -> Result<(Vec<FlatInstance>, Vec<u32>)> {
        let mut flat = Vec::new();
        let mut counts = Vec::with_capacity(instances.len());
        let mut at = 0usize;
        for (i, (inst, child)) in instances.iter().zip(children).enumerate() {
            let live = child.filter(|c| accels.get(*c).is_ok());
            let entries = match child.map(|c| accels.get(c)) {
                Some(Ok(_)) => {
                    let child_flat = match live {
                        Some(c) => transform::flat_of(accels, c)?,
                        None => Vec::new(),
                    };
                    flatten::through_instance(inst, i as u32, &child_flat)
                        .map_err(|e| e.context(format!("instance {i}")))?
                }
                // A destroyed child: its paths stay, inactive.
                Some(Err(_)) => match previous {
                    Some((counts, flat)) => flat[at..at + counts[i] as usize]
                        .iter()
                        .map(|f| f.inactive())
                        .collect(),
                    None => Vec::new(),
                },
                None => Vec::new(),
            };
            if let Some((prev_counts, _)) = previous {
                at += prev_counts[i] as usize;
            }
            counts.push(entries.len() as u32);
            flat.extend(entries);
        }
        Ok((flat, counts))
    }

    /// The flat list of an instance structure (as [`Inner::flatten_instances`]), where paths
    /// whose instances disable face culling over the driver's triangles go through the
    /// geometry's box twin instead: a ray culling both faces carries `SkipTrianglesKHR`,
    /// which would skip those triangles too, while optik's triangle stage follows the
    /// path's flags (§2.4).
    fn flatten_paths(
        &mut self,
        accels: &Accels,
        instances: &[Instance],
        children: &[Option<Accel>],
        previous: Option<(&[u32], &[FlatInstance])>,
    ) -> Result<(Vec<FlatInstance>, Vec<u32>)> {
        let (mut flat, counts) = Self::flatten_instances(accels, instances, children, previous)?;
        if self.mixes_triangles() {
            let unculled = InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING.0;
            for f in flat
                .iter_mut()
                .filter(|f| f.flags & unculled != 0 && !f.boxes)
            {
                if let Some(FlatSource::Gas(g)) = f.source
                    && f.blas != 0
                {
                    f.blas = self.box_twin(accels, g)?;
                    f.boxes = true;
                }
            }
        }
        Ok((flat, counts))
    }

    /// The box twin of geometry structure `accel` (built with the driver's triangles): an
    /// AABB bottom level of its padded triangle boxes, over the same tables, built when a
    /// path first needs it and freed with the structure or when a refit moves its boxes.
    fn box_twin(&mut self, accels: &Accels, accel: Accel) -> Result<u64> {
        if let Some(t) = self.box_twins.get(&accel) {
            return Ok(t.address);
        }
        let AccelObject::Gas(g) = accels.get(accel)? else {
            return Err(Error::backend("a path's geometry is not a geometry"));
        };
        let twin = self.build_proxy(&g.geometry_boxes)?;
        let address = twin.address;
        self.box_twins.insert(accel, twin);
        Ok(address)
    }

    /// Builds every top level that contains `changed` again, upwards.
    fn refresh_dependents(&mut self, accels: &mut Accels, changed: Accel) -> Result<()> {
        let mut queue = vec![changed];
        let mut done = HashSet::new();
        while let Some(x) = queue.pop() {
            let parents: Vec<Accel> = accels
                .iter()
                .filter(|(_, o)| o.children().contains(&x))
                .map(|(h, _)| h)
                .collect();
            for p in parents {
                if !done.insert(p) {
                    continue;
                }
                self.refresh(accels, p)?;
                queue.push(p);
            }
        }
        let retired = std::mem::take(&mut self.retired_proxies);
        self.free_proxies(&retired);
        Ok(())
    }

    /// Builds an instance structure's or transform's top level again from its children.
    fn refresh(&mut self, accels: &mut Accels, accel: Accel) -> Result<()> {
        let flat = match accels.get(accel)? {
            AccelObject::Ias(ias) => {
                let (flat, counts) = self.flatten_paths(
                    accels,
                    &ias.instances,
                    &ias.children,
                    Some((&ias.counts, &ias.flat)),
                )?;
                if counts != ias.counts {
                    return Err(Error::backend("a child's flat instance count changed"));
                }
                flat
            }
            AccelObject::Transform(_) => return self.refresh_transform(accels, accel),
            AccelObject::Gas(_) => return Ok(()),
        };
        self.rebuild_tlas(accels, accel, &flat)?;
        match accels.get_mut(accel)? {
            AccelObject::Ias(i) => i.flat = flat,
            AccelObject::Transform(t) => t.flat = flat,
            AccelObject::Gas(_) => {}
        }
        Ok(())
    }

    /// Files a new structure under its traversable handle (and among those with the
    /// driver's triangles).
    fn name(&mut self, obj: &AccelObject, handle: Accel) {
        self.by_handle.insert(obj.handle(), handle);
        if matches!(obj, AccelObject::Gas(g) if g.kind == GasKind::Triangles && g.native_triangles)
        {
            self.driver_triangle_structures.insert(obj.handle());
        }
    }

    /// How the device builds triangles for its accuracy (§1, §2.4).
    pub fn triangle_build(&self) -> TriangleBuild {
        TriangleBuild::of(self.accuracy.triangle, self.mixable())
    }

    /// Whether the default may mix the driver's triangles in: the driver passed optik's
    /// check, and the device has `rayTraversalPrimitiveCulling`, so a ray culling both faces
    /// can skip the driver's triangles (`SkipTrianglesKHR`) as optik's semantics ask.
    pub fn mixable(&self) -> bool {
        self.driver_triangles && self.ctx.info.primitive_culling
    }

    /// Whether optik's triangle stage intersects (some) triangles: every triangle test but
    /// `TriangleTest::Driver`.
    pub fn emulates_triangles(&self) -> bool {
        self.triangle_build() != TriangleBuild::Driver
    }

    /// Whether triangles are the driver's where they can be and optik's where they cannot
    /// (the watertight test on a device whose driver passed optik's check, §2.4).
    pub fn mixes_triangles(&self) -> bool {
        self.triangle_build() == TriangleBuild::Mixed
    }

    /// What native Vulkan triangles cannot carry (optik-core has checked the rest).
    fn check_buildable(
        &self,
        objects: &Objects,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        let keys = options
            .motion
            .filter(|m| m.num_keys >= 2)
            .map_or(1, |m| m.num_keys as usize);
        let emulated = self.emulates_triangles();
        for (i, input) in inputs.iter().enumerate() {
            let BuildInput::Triangles(t) = input else {
                continue;
            };
            if keys > 1 && !emulated {
                return Err(native_triangles_cannot("motion keys", i));
            }
            if let Some(omm) = &t.opacity_micromap {
                if !emulated {
                    return Err(native_triangles_cannot("an opacity micromap", i));
                }
                objects
                    .micromaps
                    .get(omm.array)
                    .map_err(|e| e.context(format!("build_inputs[{i}].opacity_micromap.array")))?;
            }
        }
        let geometries: u64 = inputs.iter().map(|i| i.num_sbt_records() as u64).sum();
        if geometries > self.ctx.info.max_geometry_count {
            return Err(Error::limit(format!(
                "the build inputs have {geometries} SBT records in all; each is a Vulkan geometry and this device allows {} per structure",
                self.ctx.info.max_geometry_count
            )));
        }
        Ok(())
    }

    fn decode(
        &mut self,
        objects: &Objects,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<DecodedGas> {
        let buffers: Vec<Buffer> = inputs.iter().flat_map(input_buffers).collect();
        let downloaded = self.download_for_snapshot(&objects.buffers, &buffers)?;
        let snapshot = snapshot_view(&objects.buffers, downloaded, &buffers)?;
        let arrays = &objects.micromaps;
        let lookup = |a: MicromapArray| arrays.get(a).cloned();
        let mut decoded = geometry::decode_gas(
            options,
            inputs,
            &snapshot,
            self.emulates_triangles(),
            &lookup,
        )?;
        if self.mixes_triangles()
            && geometry::gas_kind(inputs)? == GasKind::Triangles
            && geometry::driver_can_serve(options, &decoded)
        {
            geometry::add_driver_triangles(&mut decoded);
        }
        Ok(decoded)
    }

    fn decode_instances(
        &mut self,
        buffers: &Buffers,
        ia: &InstanceArray,
    ) -> Result<(Vec<Instance>, Vec<Option<Accel>>)> {
        let downloaded = self.download_for_snapshot(buffers, &[ia.instances.buffer])?;
        let instances = optik_accel::decode::instances(
            ia,
            &snapshot_view(buffers, downloaded, &[ia.instances.buffer])?,
        )?;
        let mut children = Vec::with_capacity(instances.len());
        for (i, inst) in instances.iter().enumerate() {
            if inst.traversable_handle == 0 {
                children.push(None);
                continue;
            }
            let child = self.by_handle.get(&inst.traversable_handle).copied().ok_or_else(|| {
                Error::invalid(format!(
                    "instance {i} names traversable handle {:#x}, which is no live acceleration structure or transform of this device (destroyed, or from another device?)",
                    inst.traversable_handle
                ))
            })?;
            children.push(Some(child));
        }
        Ok((instances, children))
    }

    pub fn accel_memory_usage(
        &mut self,
        objects: &Objects,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<AccelBufferSizes> {
        self.check_buildable(objects, options, inputs)?;
        let tlas_sizes = |me: &Self, n: u32| {
            me.build_sizes(
                vk::AccelerationStructureTypeKHR::TOP_LEVEL,
                &[],
                Some(n),
                vk_build_flags(options.flags),
            )
        };
        if let BuildInput::Instances(ia) = &inputs[0] {
            let (instances, children) = self.decode_instances(&objects.buffers, ia)?;
            let (flat, _) = Self::flatten_instances(&objects.accels, &instances, &children, None)?;
            let (size, build, update) = tlas_sizes(self, flat.len() as u32);
            return Ok(AccelBufferSizes {
                output_size_in_bytes: size,
                temp_size_in_bytes: build,
                temp_update_size_in_bytes: update,
            });
        }
        geometry::gas_kind(inputs)?;
        let decoded = self.decode(objects, options, inputs)?;
        let mut sizes = AccelBufferSizes::default();
        for (holds, _) in parts_of(&decoded) {
            let geoms = part_geometries(&decoded, &holds, 0);
            let (size, build, update) = self.build_sizes(
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                &geoms,
                None,
                vk_build_flags(options.flags),
            );
            sizes.output_size_in_bytes += size;
            sizes.temp_size_in_bytes = sizes.temp_size_in_bytes.max(build);
            sizes.temp_update_size_in_bytes = sizes.temp_update_size_in_bytes.max(update);
        }
        sizes.output_size_in_bytes += tlas_sizes(self, 2).0;
        Ok(sizes)
    }

    /// Builds a structure that core stores under `handle`.
    pub fn accel_build(
        &mut self,
        objects: &Objects,
        handle: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<AccelObject> {
        self.check_buildable(objects, options, inputs)?;
        let accel = match &inputs[0] {
            BuildInput::Instances(ia) => self.build_ias(objects, options, inputs, ia)?,
            _ => self.build_gas(objects, options, inputs)?,
        };
        self.name(&accel, handle);
        Ok(accel)
    }

    /// Uploads a decoded GAS's input bytes for a build.
    fn input_buffer(&mut self, decoded: &DecodedGas) -> Result<GpuBuffer> {
        let buffer = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            decoded.bytes.len() as u64,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
            Location::HostVisible,
            16,
        )?;
        if let Err(e) = buffer.write(0, &decoded.bytes) {
            buffer.destroy(&self.ctx, &mut self.alloc);
            return Err(e);
        }
        Ok(buffer)
    }

    fn build_gas(
        &mut self,
        objects: &Objects,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<AccelObject> {
        let kind = geometry::gas_kind(inputs)?;
        let decoded = self.decode(objects, options, inputs)?;
        let input = self.input_buffer(&decoded)?;
        let flags = vk_build_flags(options.flags);
        let mut parts: Vec<(AsBuffer, u32)> = Vec::new();
        let mut part_geometries_held = Vec::new();
        let mut failure = None;
        for (holds, instance_flags) in parts_of(&decoded) {
            let geoms = part_geometries(&decoded, &holds, input.address);
            match self.build_as(
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                &geoms,
                None,
                flags,
                BuildTarget::New,
            ) {
                Ok(Some(part)) => {
                    parts.push((part, instance_flags));
                    part_geometries_held.push(holds);
                }
                Ok(None) => failure = Some(Error::backend("bottom level build returned nothing")),
                Err(e) => failure = Some(e),
            }
            if failure.is_some() {
                break;
            }
        }
        input.destroy(&self.ctx, &mut self.alloc);
        if let Some(e) = failure {
            for (p, _) in parts {
                p.destroy(&self.ctx, &mut self.alloc);
            }
            return Err(e);
        }
        let data_start = self.tables.data.insert(&decoded.data);
        let records: Vec<tables::Record> = decoded
            .records
            .iter()
            .map(|r| rebase_record(r, |v| v + data_start))
            .collect();
        let geometry_start = self.tables.geometries.insert(&records);
        self.tables.touch();
        let flat = gas_paths(
            &parts,
            geometry_start,
            records.len() as u32,
            kind,
            decoded.native_triangles,
        );
        let wrapper = match self.build_tlas(
            Some(&objects.accels),
            &flat,
            vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE,
        ) {
            Ok(w) => w,
            Err(e) => {
                for (p, _) in parts {
                    p.destroy(&self.ctx, &mut self.alloc);
                }
                self.tables
                    .data
                    .remove(data_start, decoded.data.len() as u32);
                self.tables
                    .geometries
                    .remove(geometry_start, records.len() as u32);
                return Err(e);
            }
        };
        let features = SceneFeatures::of_geometry(options, inputs);
        Ok(AccelObject::Gas(Gas {
            parts,
            part_geometries: part_geometries_held,
            wrapper,
            geometry_start,
            geometry_count: records.len() as u32,
            data_start,
            data_len: decoded.data.len() as u32,
            kind,
            native_triangles: decoded.native_triangles,
            geometry_boxes: decoded
                .geometries
                .iter()
                .zip(&decoded.boxes)
                .map(|(g, b)| (vk_geometry_flags(g), b.clone()))
                .collect(),
            options: *options,
            inputs: inputs.to_vec(),
            partition: decoded.partition.clone(),
            activity: activity_of(&decoded),
            compacted: false,
            features,
        }))
    }

    fn build_ias(
        &mut self,
        objects: &Objects,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        ia: &InstanceArray,
    ) -> Result<AccelObject> {
        let (instances, children) = self.decode_instances(&objects.buffers, ia)?;
        let (flat, counts) = self.flatten_paths(&objects.accels, &instances, &children, None)?;
        let child_features: Vec<SceneFeatures> = children
            .iter()
            .flatten()
            .filter_map(|c| objects.accels.get(*c).ok())
            .map(|o| o.features())
            .collect();
        let features = SceneFeatures::of_parent(&child_features, MotionKinds::default(), false);
        let tlas = self.build_tlas(Some(&objects.accels), &flat, vk_build_flags(options.flags))?;
        Ok(AccelObject::Ias(Ias {
            tlas,
            instances,
            children,
            counts,
            flat,
            options: *options,
            inputs: inputs.to_vec(),
            features,
        }))
    }

    pub fn accel_update(
        &mut self,
        objects: &mut Objects,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        self.check_buildable(objects, options, inputs)?;
        match &inputs[0] {
            BuildInput::Instances(ia) => {
                let (instances, children) = self.decode_instances(&objects.buffers, ia)?;
                let (flat, counts) =
                    self.flatten_paths(&objects.accels, &instances, &children, None)?;
                let old_counts = match objects.accels.get(accel)? {
                    AccelObject::Ias(i) => i.counts.clone(),
                    _ => Vec::new(),
                };
                if counts != old_counts {
                    return Err(Error::invalid(
                        "the update changes how many Vulkan instances some instance flattens to (its child has a different instance tree); Vulkan top levels keep their instance count, so build a new structure instead",
                    ));
                }
                self.rebuild_tlas(&mut objects.accels, accel, &flat)?;
                if let AccelObject::Ias(i) = objects.accels.get_mut(accel)? {
                    i.instances = instances;
                    i.children = children;
                    i.flat = flat;
                    i.inputs = inputs.to_vec();
                }
            }
            _ => {
                // The twin's boxes go stale: the paths above build a new one.
                let stale = self.box_twins.remove(&accel);
                let updated = self
                    .update_gas(objects, accel, options, inputs)
                    .and_then(|_| self.refresh_dependents(&mut objects.accels, accel));
                if let Some(t) = stale {
                    t.destroy(&self.ctx, &mut self.alloc);
                }
                return updated;
            }
        }
        self.refresh_dependents(&mut objects.accels, accel)
    }

    fn update_gas(
        &mut self,
        objects: &mut Objects,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        let decoded = self.decode(objects, options, inputs)?;
        let (parts, holds, partition, activity, flags, data_len) =
            match objects.accels.get(accel)? {
                AccelObject::Gas(g) => (
                    g.parts.iter().map(|(p, _)| p.accel).collect::<Vec<_>>(),
                    g.part_geometries.clone(),
                    g.partition.clone(),
                    g.activity,
                    vk_build_flags(g.options.flags),
                    g.data_len,
                ),
                _ => return Err(Error::backend("not a geometry structure")),
            };
        if decoded.partition != partition {
            return Err(Error::invalid(
                "the update changes which SBT record some primitive uses (sbt_index_offsets); updates keep them, so build a new structure instead",
            ));
        }
        if activity_of(&decoded) != activity || decoded.data.len() as u32 != data_len {
            // Primitives became usable or unusable (or triangle indices changed): Vulkan
            // refits cannot follow, so the bottom levels are built anew under the same handle.
            return self.rebuild_gas(objects, accel, options, inputs);
        }
        let input = self.input_buffer(&decoded)?;
        let mut result = Ok(());
        for (structure, held) in parts.iter().zip(&holds) {
            let geoms = part_geometries(&decoded, held, input.address);
            if let Err(e) = self.build_as(
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                &geoms,
                None,
                flags,
                BuildTarget::Update(*structure),
            ) {
                result = Err(e);
                break;
            }
        }
        input.destroy(&self.ctx, &mut self.alloc);
        result?;
        if let AccelObject::Gas(g) = objects.accels.get(accel)? {
            let start = g.data_start;
            self.tables.data.write(start, &decoded.data);
            self.tables.touch();
        }
        let flat = objects.accels.get(accel)?.flat();
        self.rebuild_tlas(&mut objects.accels, accel, &flat)?;
        if let AccelObject::Gas(g) = objects.accels.get_mut(accel)? {
            g.inputs = inputs.to_vec();
            for ((_, boxes), new) in g.geometry_boxes.iter_mut().zip(decoded.boxes) {
                *boxes = new;
            }
        }
        Ok(())
    }

    /// Replaces a GAS's bottom levels and tables with new ones built from `decoded`, keeping
    /// its handle (its top level is built again in place, as are the top levels above it).
    fn rebuild_gas(
        &mut self,
        objects: &mut Objects,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        let AccelObject::Gas(mut new) = self.build_gas(objects, options, inputs)? else {
            return Err(Error::backend("a geometry build made something else"));
        };
        // The new object's own top level goes; the old one stays and keeps the handle.
        let new_wrapper_handle = new.wrapper.structure.address;
        self.by_handle.remove(&new_wrapper_handle);
        self.tables
            .instances
            .remove(new.wrapper.table_start, new.wrapper.count);
        let AccelObject::Gas(old) = objects.accels.get_mut(accel)? else {
            return Err(Error::backend("not a geometry structure"));
        };
        let old_parts = std::mem::replace(&mut old.parts, std::mem::take(&mut new.parts));
        old.part_geometries = new.part_geometries.clone();
        let (old_g, old_gn, old_d, old_dn) = (
            old.geometry_start,
            old.geometry_count,
            old.data_start,
            old.data_len,
        );
        old.geometry_start = new.geometry_start;
        old.geometry_count = new.geometry_count;
        old.data_start = new.data_start;
        old.data_len = new.data_len;
        old.inputs = inputs.to_vec();
        old.activity = new.activity;
        old.compacted = false;
        old.native_triangles = new.native_triangles;
        old.geometry_boxes = std::mem::take(&mut new.geometry_boxes);
        self.tables.geometries.remove(old_g, old_gn);
        self.tables.data.remove(old_d, old_dn);
        self.tables.touch();
        new.wrapper.destroy(&self.ctx, &mut self.alloc);
        let flat = objects.accels.get(accel)?.flat();
        self.rebuild_tlas(&mut objects.accels, accel, &flat)?;
        self.refresh_dependents(&mut objects.accels, accel)?;
        for (p, _) in old_parts {
            p.destroy(&self.ctx, &mut self.alloc);
        }
        Ok(())
    }

    /// A compacted copy of `accel` that core stores under `handle`.
    pub fn accel_compact(
        &mut self,
        accels: &Accels,
        accel: Accel,
        handle: Accel,
    ) -> Result<AccelObject> {
        let copy = match accels.get(accel)? {
            AccelObject::Gas(g) => {
                let parts: Vec<(vk::AccelerationStructureKHR, u32)> =
                    g.parts.iter().map(|(p, f)| (p.accel, *f)).collect();
                let records_range = (g.geometry_start, g.geometry_count, g.data_start, g.data_len);
                let template = (
                    g.part_geometries.clone(),
                    (g.kind, g.native_triangles, g.geometry_boxes.clone()),
                    g.options,
                    g.inputs.clone(),
                    g.partition.clone(),
                    g.activity,
                    g.features,
                );
                let mut compacted = Vec::new();
                for (p, f) in parts {
                    match self.compact_as(p) {
                        Ok(c) => compacted.push((c, f)),
                        Err(e) => {
                            for (c, _) in compacted {
                                c.destroy(&self.ctx, &mut self.alloc);
                            }
                            return Err(e);
                        }
                    }
                }
                let (g_start, g_count, d_start, d_len) = records_range;
                let data: Vec<u32> = (0..d_len)
                    .map(|k| self.tables.data_word(d_start + k))
                    .collect();
                let data_start = self.tables.data.insert(&data);
                let records: Vec<tables::Record> = (0..g_count)
                    .map(|k| {
                        let r = self.tables.geometry_record(g_start + k);
                        rebase_record(&r, |v| v - d_start + data_start)
                    })
                    .collect();
                let geometry_start = self.tables.geometries.insert(&records);
                self.tables.touch();
                let flat = gas_paths(
                    &compacted,
                    geometry_start,
                    g_count,
                    template.1.0,
                    template.1.1,
                );
                let wrapper = self.build_tlas(
                    Some(accels),
                    &flat,
                    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE,
                )?;
                let (
                    part_geometries_held,
                    (kind, native_triangles, geometry_boxes),
                    options,
                    inputs,
                    partition,
                    activity,
                    features,
                ) = template;
                AccelObject::Gas(Gas {
                    parts: compacted,
                    part_geometries: part_geometries_held,
                    wrapper,
                    geometry_start,
                    geometry_count: g_count,
                    data_start,
                    data_len: d_len,
                    kind,
                    native_triangles,
                    geometry_boxes,
                    options,
                    inputs,
                    partition,
                    activity,
                    compacted: true,
                    features,
                })
            }
            // Top levels are small and must stay rebuildable in place (when a child goes),
            // so "compacting" one copies it at full size.
            AccelObject::Ias(i) => {
                let (instances, children, counts, flat, options, inputs, features) = (
                    i.instances.clone(),
                    i.children.clone(),
                    i.counts.clone(),
                    i.flat.clone(),
                    i.options,
                    i.inputs.clone(),
                    i.features,
                );
                let tlas = self.build_tlas(Some(accels), &flat, vk_build_flags(options.flags))?;
                AccelObject::Ias(Ias {
                    tlas,
                    instances,
                    children,
                    counts,
                    flat,
                    options,
                    inputs,
                    features,
                })
            }
            AccelObject::Transform(_) => {
                return Err(Error::backend("accel_compact was given a transform"));
            }
        };
        self.name(&copy, handle);
        Ok(copy)
    }

    /// Frees `obj`, which core has taken out of `accels` (its handle was `accel`), after
    /// the launches that may trace it; the top levels above it are built again without it.
    pub fn destroy_accel(
        &mut self,
        accels: &mut Accels,
        accel: Accel,
        obj: AccelObject,
    ) -> Result<()> {
        if let Err(e) = self.wait_launches() {
            self.keep(Unfreed::Accel(obj));
            return Err(e);
        }
        self.by_handle.remove(&obj.handle());
        self.driver_triangle_structures.remove(&obj.handle());
        let t = obj.tlas();
        self.tables.instances.remove(t.table_start, t.count);
        if let AccelObject::Gas(g) = &obj {
            self.tables
                .geometries
                .remove(g.geometry_start, g.geometry_count);
            self.tables.data.remove(g.data_start, g.data_len);
        }
        self.tables.touch();
        // Parents drop their paths into it before its bottom levels go.
        let refreshed = self.refresh_dependents(accels, accel);
        if let AccelObject::Transform(t) = &obj {
            self.free_proxies(&t.proxies);
        }
        if let Some(t) = self.box_twins.remove(&accel) {
            t.destroy(&self.ctx, &mut self.alloc);
        }
        obj.destroy(&self.ctx, &mut self.alloc);
        refreshed
    }
}
