//! Vulkan acceleration structure objects and builds (VK_KHR_acceleration_structure): bottom
//! levels of triangles and AABBs, top levels of instances.

use crate::device::Inner;
use crate::error::VkResultExt;
use crate::memory::{Allocator, GpuBuffer, Location};
use ash::vk;
use optik_api::{Error, Matrix3x4, Result};

/// An acceleration structure and the buffer it lives in.
pub struct AsBuffer {
    /// The structure.
    pub accel: vk::AccelerationStructureKHR,
    /// The buffer it lives in.
    pub buffer: GpuBuffer,
    /// Its device address: what instances reference, and optik's traversable handle for top
    /// levels.
    pub address: u64,
}

impl AsBuffer {
    /// Bytes of the structure.
    pub fn size(&self) -> u64 {
        self.buffer.size
    }

    /// Frees it.
    pub fn destroy(self, ctx: &crate::context::Context, alloc: &mut Allocator) {
        // SAFETY: callers wait for pending work first.
        unsafe { ctx.accel.destroy_acceleration_structure(self.accel, None) };
        self.buffer.destroy(ctx, alloc);
    }
}

/// One bottom-level geometry, its data at device addresses.
#[derive(Clone, Copy, Debug)]
pub enum VkGeometry {
    /// Indexed `f32` triangles.
    Triangles {
        vertices: u64,
        vertex_count: u32,
        indices: u64,
        triangle_count: u32,
        flags: vk::GeometryFlagsKHR,
    },
    /// Packed 24-byte AABBs.
    Aabbs {
        aabbs: u64,
        count: u32,
        flags: vk::GeometryFlagsKHR,
    },
}

/// What a build writes.
#[derive(Clone, Copy, Debug)]
pub enum BuildTarget {
    /// A new structure.
    New,
    /// Build again into an existing structure (same counts, so the same size).
    Rebuild(vk::AccelerationStructureKHR),
    /// Refit an existing structure built with `ALLOW_UPDATE`.
    Update(vk::AccelerationStructureKHR),
}

fn vk_geometry(g: &VkGeometry) -> (vk::AccelerationStructureGeometryKHR<'static>, u32) {
    match *g {
        VkGeometry::Triangles {
            vertices,
            vertex_count,
            indices,
            triangle_count,
            flags,
        } => {
            let tri = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
                .vertex_format(vk::Format::R32G32B32_SFLOAT)
                .vertex_data(vk::DeviceOrHostAddressConstKHR {
                    device_address: vertices,
                })
                .vertex_stride(12)
                .max_vertex(vertex_count.saturating_sub(1))
                .index_type(vk::IndexType::UINT32)
                .index_data(vk::DeviceOrHostAddressConstKHR {
                    device_address: indices,
                });
            (
                vk::AccelerationStructureGeometryKHR::default()
                    .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
                    .geometry(vk::AccelerationStructureGeometryDataKHR { triangles: tri })
                    .flags(flags),
                triangle_count,
            )
        }
        VkGeometry::Aabbs {
            aabbs,
            count,
            flags,
        } => {
            let data = vk::AccelerationStructureGeometryAabbsDataKHR::default()
                .data(vk::DeviceOrHostAddressConstKHR {
                    device_address: aabbs,
                })
                .stride(24);
            (
                vk::AccelerationStructureGeometryKHR::default()
                    .geometry_type(vk::GeometryTypeKHR::AABBS)
                    .geometry(vk::AccelerationStructureGeometryDataKHR { aabbs: data })
                    .flags(flags),
                count,
            )
        }
    }
}

fn instances_geometry(address: u64) -> vk::AccelerationStructureGeometryKHR<'static> {
    let data = vk::AccelerationStructureGeometryInstancesDataKHR::default()
        .array_of_pointers(false)
        .data(vk::DeviceOrHostAddressConstKHR {
            device_address: address,
        });
    vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::INSTANCES)
        .geometry(vk::AccelerationStructureGeometryDataKHR { instances: data })
}

/// One instance of a top level, in Vulkan's layout.
pub fn vk_instance(
    transform: &Matrix3x4,
    custom_index: u32,
    mask: u8,
    sbt_offset: u32,
    flags: u8,
    blas: u64,
) -> vk::AccelerationStructureInstanceKHR {
    vk::AccelerationStructureInstanceKHR {
        transform: vk::TransformMatrixKHR { matrix: *transform },
        instance_custom_index_and_mask: vk::Packed24_8::new(custom_index, mask),
        instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
            sbt_offset, flags,
        ),
        acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
            device_handle: blas,
        },
    }
}

/// Bytes of one Vulkan instance.
pub const INSTANCE_SIZE: u64 = std::mem::size_of::<vk::AccelerationStructureInstanceKHR>() as u64;

impl Inner {
    /// The sizes a build needs: (structure, build scratch, update scratch).
    pub fn build_sizes(
        &self,
        ty: vk::AccelerationStructureTypeKHR,
        geometries: &[VkGeometry],
        instance_count: Option<u32>,
        flags: vk::BuildAccelerationStructureFlagsKHR,
    ) -> (u64, u64, u64) {
        let (geoms, counts): (Vec<_>, Vec<u32>) = match instance_count {
            Some(n) => (vec![instances_geometry(0)], vec![n]),
            None => geometries.iter().map(vk_geometry).unzip(),
        };
        let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(ty)
            .flags(flags)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&geoms);
        let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
        // SAFETY: valid build info whose geometry count matches `counts`.
        unsafe {
            self.ctx.accel.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &info,
                &counts,
                &mut sizes,
            )
        };
        (
            sizes.acceleration_structure_size,
            sizes.build_scratch_size,
            sizes.update_scratch_size,
        )
    }

    /// Creates an empty structure of `size` bytes.
    fn create_as(&mut self, ty: vk::AccelerationStructureTypeKHR, size: u64) -> Result<AsBuffer> {
        let buffer = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            size,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR,
            Location::DeviceLocal,
            256,
        )?;
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(buffer.buffer)
            .size(size)
            .ty(ty);
        // SAFETY: the buffer has acceleration structure storage usage and `size` bytes.
        let accel = match unsafe { self.ctx.accel.create_acceleration_structure(&info, None) } {
            Ok(a) => a,
            Err(e) => {
                buffer.destroy(&self.ctx, &mut self.alloc);
                return Err(crate::error::vk_error(
                    "vkCreateAccelerationStructureKHR",
                    e,
                ));
            }
        };
        let address_info =
            vk::AccelerationStructureDeviceAddressInfoKHR::default().acceleration_structure(accel);
        // SAFETY: a live structure of this device.
        let address = unsafe {
            self.ctx
                .accel
                .get_acceleration_structure_device_address(&address_info)
        };
        Ok(AsBuffer {
            accel,
            buffer,
            address,
        })
    }

    /// Builds, rebuilds or refits a structure of `geometries` (bottom level) or of
    /// `instance_count` instances at `instances` (top level). Returns the new structure for
    /// [`BuildTarget::New`].
    pub fn build_as(
        &mut self,
        ty: vk::AccelerationStructureTypeKHR,
        geometries: &[VkGeometry],
        instances: Option<(u64, u32)>,
        flags: vk::BuildAccelerationStructureFlagsKHR,
        target: BuildTarget,
    ) -> Result<Option<AsBuffer>> {
        let (structure_size, build_scratch, update_scratch) =
            self.build_sizes(ty, geometries, instances.map(|(_, n)| n), flags);
        let (created, dst, src, scratch_size, mode) = match target {
            BuildTarget::New => {
                let created = self.create_as(ty, structure_size)?;
                let dst = created.accel;
                (
                    Some(created),
                    dst,
                    vk::AccelerationStructureKHR::null(),
                    build_scratch,
                    vk::BuildAccelerationStructureModeKHR::BUILD,
                )
            }
            BuildTarget::Rebuild(a) => (
                None,
                a,
                vk::AccelerationStructureKHR::null(),
                build_scratch,
                vk::BuildAccelerationStructureModeKHR::BUILD,
            ),
            BuildTarget::Update(a) => (
                None,
                a,
                a,
                update_scratch,
                vk::BuildAccelerationStructureModeKHR::UPDATE,
            ),
        };
        let scratch_align = self.ctx.info.min_scratch_offset_alignment.max(1) as u64;
        let scratch = match GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            scratch_size.max(16),
            vk::BufferUsageFlags::STORAGE_BUFFER,
            Location::DeviceLocal,
            scratch_align,
        ) {
            Ok(s) => s,
            Err(e) => {
                if let Some(c) = created {
                    c.destroy(&self.ctx, &mut self.alloc);
                }
                return Err(e);
            }
        };
        if scratch.address % scratch_align != 0 {
            return Err(Error::backend(
                "scratch buffer address is not aligned to minAccelerationStructureScratchOffsetAlignment",
            ));
        }
        let (geoms, counts): (Vec<_>, Vec<u32>) = match instances {
            Some((address, n)) => (vec![instances_geometry(address)], vec![n]),
            None => geometries.iter().map(vk_geometry).unzip(),
        };
        let ranges: Vec<vk::AccelerationStructureBuildRangeInfoKHR> = counts
            .iter()
            .map(|&n| vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(n))
            .collect();
        let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(ty)
            .flags(flags)
            .mode(mode)
            .src_acceleration_structure(src)
            .dst_acceleration_structure(dst)
            .geometries(&geoms)
            .scratch_data(vk::DeviceOrHostAddressKHR {
                device_address: scratch.address,
            });
        let ctx = self.ctx.clone();
        let result = self.run_commands(|cmd| {
            // SAFETY: recording; every address points into live buffers with the right usage.
            unsafe {
                ctx.accel
                    .cmd_build_acceleration_structures(cmd, &[info], &[&ranges])
            };
            Ok(())
        });
        scratch.destroy(&self.ctx, &mut self.alloc);
        match result {
            Ok(()) => Ok(created),
            Err(e) => {
                if let Some(c) = created {
                    c.destroy(&self.ctx, &mut self.alloc);
                }
                Err(e)
            }
        }
    }

    /// A compacted copy of a bottom level built with `ALLOW_COMPACTION`.
    pub fn compact_as(&mut self, source: vk::AccelerationStructureKHR) -> Result<AsBuffer> {
        let ctx = self.ctx.clone();
        let pool_info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR)
            .query_count(1);
        // SAFETY: valid create info; destroyed below.
        let pool =
            unsafe { ctx.device.create_query_pool(&pool_info, None) }.or_vk("vkCreateQueryPool")?;
        let queried = self.run_commands(|cmd| {
            // SAFETY: recording; the structure was built with ALLOW_COMPACTION.
            unsafe {
                ctx.device.cmd_reset_query_pool(cmd, pool, 0, 1);
                ctx.accel.cmd_write_acceleration_structures_properties(
                    cmd,
                    &[source],
                    vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
                    pool,
                    0,
                );
            }
            Ok(())
        });
        let mut size = [0u64; 1];
        let read = queried.and_then(|_| {
            // SAFETY: the query was written by the finished command buffer.
            unsafe {
                ctx.device.get_query_pool_results(
                    pool,
                    0,
                    &mut size,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .or_vk("vkGetQueryPoolResults")
        });
        // SAFETY: no pending use.
        unsafe { ctx.device.destroy_query_pool(pool, None) };
        read?;
        let compacted = self.create_as(
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            size[0].max(16),
        )?;
        let dst = compacted.accel;
        let copied = self.run_commands(|cmd| {
            let info = vk::CopyAccelerationStructureInfoKHR::default()
                .src(source)
                .dst(dst)
                .mode(vk::CopyAccelerationStructureModeKHR::COMPACT);
            // SAFETY: recording; `dst` is at least the compacted size.
            unsafe { ctx.accel.cmd_copy_acceleration_structure(cmd, &info) };
            Ok(())
        });
        match copied {
            Ok(()) => Ok(compacted),
            Err(e) => {
                compacted.destroy(&self.ctx, &mut self.alloc);
                Err(e)
            }
        }
    }
}
