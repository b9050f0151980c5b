//! Launches (OptiX `optixLaunch`): checks, descriptor sets, the translated SBT, the per-launch
//! state buffer, and `vkCmdTraceRaysKHR`. Launches are asynchronous: the host goes on, and
//! reads, writes, builds and `synchronize` wait for them.
//!
//! A launch larger than one `vkCmdTraceRaysKHR` may be (per dimension `maxComputeWorkGroupCount
//! × maxComputeWorkGroupSize`, in all `maxRayDispatchInvocationCount`, and with per-index state
//! no more indices than `maxStorageBufferRange / 16`) is split into tiles ([`plan_dispatches`]),
//! recorded in one command buffer. Each tile's constants carry its origin and the user's launch
//! size, so `rt_launch_index` and `rt_launch_dimensions` are the user's; the state buffer is
//! sized for one tile and reused, with a barrier between tiles.

use crate::accel::scene_features;
use crate::commands::Submission;
use crate::device::Inner;
use crate::error::VkResultExt;
use crate::memory::{GpuBuffer, Location};
use crate::objects::{Accels, Objects};
use crate::program::LoweringConfig;
use crate::sbt::TranslatedSbt;
use ash::vk;
use optik_api::*;
use optik_core::frontend::BindingKind;
use std::sync::Arc;

/// A launch the host has not waited for, with what it holds.
pub struct InFlight {
    /// The submitted command buffer.
    pub submission: Submission,
    pool: vk::DescriptorPool,
    buffers: Vec<GpuBuffer>,
    sbt: Arc<TranslatedSbt>,
}

/// Bytes of per-launch-index state (device_api.rs: one `vec4<u32>`).
const STATE_BYTES: u64 = 16;

/// Bytes of one dispatch's constants (device_api.rs `_OptikLaunch`).
const CONSTANT_BYTES: u64 = 48;

/// One `vkCmdTraceRaysKHR` of a launch: where its tile starts in the user's launch and its
/// size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dispatch {
    /// The launch index of the tile's first invocation.
    pub origin: [u32; 3],
    /// The tile's width, height and depth.
    pub extent: [u32; 3],
}

/// The most dispatches one launch is split into (each has its own descriptor set); real
/// devices' limits need a few hundred at most for the largest launch optik allows.
pub const MAX_DISPATCHES: u64 = 1 << 16;

/// The tile a launch of `size` is split into: at most `max_dims` per dimension and
/// `max_invocations` in all (each at least 1), as wide as allowed first, so that a launch
/// that fits is one tile.
pub fn tile(size: [u32; 3], max_dims: [u64; 3], max_invocations: u64) -> [u32; 3] {
    let size = size.map(|s| s.max(1) as u64);
    let max_invocations = max_invocations.max(1);
    let tw = size[0].min(max_dims[0].max(1)).min(max_invocations);
    let th = size[1]
        .min(max_dims[1].max(1))
        .min((max_invocations / tw).max(1));
    let td = size[2]
        .min(max_dims[2].max(1))
        .min((max_invocations / (tw * th)).max(1));
    [tw as u32, th as u32, td as u32]
}

/// How many tiles of [`tile`]'s size cover a launch of `size`.
pub fn tile_count(size: [u32; 3], tile: [u32; 3]) -> u64 {
    (0..3)
        .map(|k| (size[k] as u64).div_ceil(tile[k].max(1) as u64))
        .product()
}

/// Splits a launch of `size` into tiles of `tile`'s size (clipped at the edges), covering
/// every launch index once, in order of depth, then height, then width.
pub fn plan_dispatches(size: [u32; 3], tile: [u32; 3]) -> Vec<Dispatch> {
    if size.contains(&0) {
        return Vec::new();
    }
    let tile = tile.map(|t| t.max(1));
    let mut out = Vec::new();
    for z in (0..size[2]).step_by(tile[2] as usize) {
        for y in (0..size[1]).step_by(tile[1] as usize) {
            for x in (0..size[0]).step_by(tile[0] as usize) {
                let origin = [x, y, z];
                out.push(Dispatch {
                    origin,
                    extent: std::array::from_fn(|k| tile[k].min(size[k] - origin[k])),
                });
            }
        }
    }
    out
}

impl Inner {
    /// Frees a finished launch's resources.
    pub fn retire(&mut self, f: InFlight) {
        self.commands.release(&self.ctx, f.submission);
        // SAFETY: the launch is done.
        unsafe { self.ctx.device.destroy_descriptor_pool(f.pool, None) };
        for b in f.buffers {
            b.destroy(&self.ctx, &mut self.alloc);
        }
        // The pipeline's cache may have let go of the table meanwhile.
        if let Ok(t) = Arc::try_unwrap(f.sbt) {
            t.destroy(&self.ctx, &mut self.alloc);
        }
    }

    /// The table buffers, uploaded if the scene changed.
    fn table_buffers(&mut self) -> Result<[vk::Buffer; 3]> {
        if self.tables.needs_upload() {
            self.wait_launches()?;
        }
        let ctx = self.ctx.clone();
        let mut copies: Vec<(vk::Buffer, Vec<u8>)> = Vec::new();
        let buffers = self.tables.device_buffers(&ctx, &mut self.alloc, |_, c| {
            copies = c.to_vec();
            Ok(())
        })?;
        for (b, data) in copies {
            self.upload(b, 0, &data)?;
        }
        Ok(buffers)
    }

    fn host_buffer(&mut self, data: &[u8], usage: vk::BufferUsageFlags) -> Result<GpuBuffer> {
        let size = (data.len() as u64).max(16).div_ceil(16) * 16;
        let b = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            size,
            usage,
            Location::HostVisible,
            16,
        )?;
        if let Err(e) = b.write(0, data) {
            b.destroy(&self.ctx, &mut self.alloc);
            return Err(e);
        }
        Ok(b)
    }

    pub fn launch(
        &mut self,
        objects: &mut Objects,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        table: &ShaderBindingTable,
        size: LaunchSize,
    ) -> Result<()> {
        // optik-core checked the pipeline, the size, the SBT's layout and the bindings; the
        // limits below are this device's own (launches past one dispatch are split, below).
        let p = objects.pipelines.get(pipeline)?;
        if params.len() as u64 > self.ctx.info.max_uniform_buffer_range as u64 {
            return Err(Error::limit(format!(
                "params is {} bytes; this device's uniform buffers (maxUniformBufferRange) hold {}; put large data in a storage buffer",
                params.len(),
                self.ctx.info.max_uniform_buffer_range
            )));
        }
        let align = self.ctx.info.min_storage_buffer_offset_alignment.max(1);
        for r in resources {
            if let Resource::Buffer {
                binding,
                buffer,
                offset,
                size,
            } = r
            {
                let total = objects.buffers.get(*buffer)?.gpu.size;
                let bound = size.unwrap_or(total.saturating_sub(*offset));
                if bound > self.ctx.info.max_storage_buffer_range as u64 {
                    return Err(Error::limit(format!(
                        "the buffer at binding {binding} binds {bound} bytes; this device binds at most {} bytes per storage buffer (maxStorageBufferRange): bind a range",
                        self.ctx.info.max_storage_buffer_range
                    )));
                }
            }
            match r {
                Resource::Buffer {
                    binding, offset, ..
                } if offset % align != 0 => {
                    return Err(Error::invalid(format!(
                        "the buffer at binding {binding} starts at byte {offset}; this device binds storage buffers at multiples of {align} (use multiples of 256 everywhere)"
                    )));
                }
                Resource::Texture { texture, .. } => {
                    objects.textures.get(*texture)?;
                }
                _ => {}
            }
        }
        self.check_pipeline_serves_scene(&objects.accels, &p.config)?;
        let uses_state = p.config.uses_state();
        let bindings = p.bindings.clone();
        if size.is_empty() {
            return Ok(());
        }
        self.reap_launches()?;
        let mut max_invocations = self.ctx.dispatch_invocations;
        if uses_state {
            // The state of every index of a tile is bound at once.
            max_invocations =
                max_invocations.min(self.ctx.info.max_storage_buffer_range as u64 / STATE_BYTES);
        }
        let dims = [size.width, size.height, size.depth];
        let tile = tile(dims, self.ctx.info.max_launch_dimensions, max_invocations);
        let count = tile_count(dims, tile);
        if count > MAX_DISPATCHES {
            return Err(Error::limit(format!(
                "a {}x{}x{} launch needs {count} dispatches of at most {}x{}x{} on this device (maxComputeWorkGroupCount x maxComputeWorkGroupSize, maxRayDispatchInvocationCount{}); optik splits a launch into at most {MAX_DISPATCHES}: launch in parts",
                size.width,
                size.height,
                size.depth,
                tile[0],
                tile[1],
                tile[2],
                if uses_state {
                    ", and maxStorageBufferRange / 16 for this pipeline's per-index state"
                } else {
                    ""
                }
            )));
        }
        let dispatches = plan_dispatches(dims, tile);
        let sbt = self.translate_sbt(objects, pipeline, table)?;
        let max_range = self.ctx.info.max_storage_buffer_range as u64;
        if let Some(bytes) = self.tables.sizes().into_iter().find(|b| *b > max_range) {
            return Err(Error::limit(format!(
                "the scene's tables (triangle vertices, remaps, motion keys and micromaps of every live acceleration structure) need {bytes} bytes in one storage buffer; this device binds at most {max_range} (maxStorageBufferRange): destroy unused structures or use TriangleTest::Driver, which keeps no vertices"
            )));
        }
        let tables = self.table_buffers()?;

        let mut held: Vec<GpuBuffer> = Vec::new();
        let result = self.record_launch(
            objects,
            pipeline,
            params,
            resources,
            &bindings,
            &sbt,
            tables,
            size,
            &dispatches,
            uses_state,
            &mut held,
        );
        match result {
            Ok((submission, pool)) => {
                // Buffers the programs may write are new for cached SBT translations.
                for r in resources {
                    if let Resource::Buffer {
                        binding, buffer, ..
                    } = r
                        && bindings.iter().any(|b| {
                            b.binding == *binding
                                && matches!(
                                    b.kind,
                                    BindingKind::StorageBuffer {
                                        read_only: false,
                                        ..
                                    }
                                )
                        })
                    {
                        let g = self.generation();
                        if let Ok(b) = objects.buffers.get_mut(*buffer) {
                            b.generation = g;
                        }
                    }
                }
                self.in_flight.push(InFlight {
                    submission,
                    pool,
                    buffers: held,
                    sbt,
                });
                Ok(())
            }
            Err(e) => {
                for b in held {
                    b.destroy(&self.ctx, &mut self.alloc);
                }
                Err(e)
            }
        }
    }

    /// Checks that a pipeline was compiled for what the live scene holds: the scene's
    /// triangles built for its triangle test, its motion and its micromaps (a pipeline
    /// created before them lacks the code that reads them).
    fn check_pipeline_serves_scene(&self, accels: &Accels, config: &LoweringConfig) -> Result<()> {
        let Some(scene) = scene_features(accels) else {
            return Ok(());
        };
        let recreate = "create the pipeline again (pipelines are compiled for the structures alive when they are created)";
        if scene.primitive_types.contains(PrimitiveTypeFlags::TRIANGLE)
            && config.triangles.emulated() != self.emulates_triangles()
        {
            return Err(Error::invalid(format!(
                "the pipeline intersects triangles {}, but the live triangle structures were built for {}: {recreate}",
                if config.triangles.emulated() {
                    "with optik's triangle test"
                } else {
                    "with the driver's (TriangleTest::Driver)"
                },
                if self.emulates_triangles() {
                    "optik's triangle test"
                } else {
                    "TriangleTest::Driver"
                },
            )));
        }
        let mixed = self.mixes_triangles() && config.intersects(PrimitiveTypeFlags::TRIANGLE);
        if scene.primitive_types.contains(PrimitiveTypeFlags::TRIANGLE)
            && config.mixed_triangles != mixed
        {
            return Err(Error::invalid(format!(
                "the pipeline was compiled for a device that {} the driver's triangles with optik's, and this device {} (VulkanDevice::set_driver_triangles or the accuracy changed since): {recreate}",
                if config.mixed_triangles {
                    "mixes"
                } else {
                    "does not mix"
                },
                if mixed { "does" } else { "does not" },
            )));
        }
        if scene.motion.any() && !config.motion_structures {
            return Err(Error::invalid(format!(
                "live acceleration structures have motion, which this pipeline was not compiled for: {recreate}"
            )));
        }
        if scene.opacity_micromaps && !config.micromaps {
            return Err(Error::invalid(format!(
                "live acceleration structures have opacity micromaps, which this pipeline was not compiled for: {recreate}"
            )));
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn record_launch(
        &mut self,
        objects: &Objects,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        bindings: &[optik_core::frontend::BindingInfo],
        sbt: &TranslatedSbt,
        tables: [vk::Buffer; 3],
        size: LaunchSize,
        dispatches: &[Dispatch],
        uses_state: bool,
        held: &mut Vec<GpuBuffer>,
    ) -> Result<(Submission, vk::DescriptorPool)> {
        let params_buffer = self.host_buffer(params, vk::BufferUsageFlags::UNIFORM_BUFFER)?;
        let params_vk = params_buffer.buffer;
        held.push(params_buffer);
        let empty = self
            .empty_tlas
            .as_ref()
            .map(|t| t.structure.address)
            .unwrap_or(0);
        // One block of constants per dispatch, at offsets the device binds uniforms at.
        let stride = CONSTANT_BYTES
            .next_multiple_of(self.ctx.info.min_uniform_buffer_offset_alignment.max(16));
        let mut constants: Vec<u8> = Vec::with_capacity(dispatches.len() * stride as usize);
        for d in dispatches {
            let words = [
                empty as u32,
                (empty >> 32) as u32,
                sbt.miss_count,
                sbt.callable_count,
                d.origin[0],
                d.origin[1],
                d.origin[2],
                0,
                size.width,
                size.height,
                size.depth,
                0,
            ];
            constants.extend(words.iter().flat_map(|w| w.to_le_bytes()));
            constants.resize(constants.len() + (stride - CONSTANT_BYTES) as usize, 0);
        }
        let constants_buffer =
            self.host_buffer(&constants, vk::BufferUsageFlags::UNIFORM_BUFFER)?;
        let constants_vk = constants_buffer.buffer;
        held.push(constants_buffer);
        let largest_tile = dispatches
            .iter()
            .map(|d| d.extent.iter().map(|&e| e as u64).product::<u64>())
            .max()
            .unwrap_or(1);
        let state_size = if uses_state {
            largest_tile * STATE_BYTES
        } else {
            STATE_BYTES
        };
        let state = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            state_size,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            Location::DeviceLocal,
            16,
        )?;
        let state_vk = state.buffer;
        held.push(state);

        // Descriptors.
        let mut image_infos: Vec<(u32, vk::DescriptorImageInfo)> = Vec::new();
        let mut buffer_infos: Vec<(u32, vk::DescriptorType, vk::DescriptorBufferInfo)> = Vec::new();
        for b in bindings {
            match b.kind {
                BindingKind::Params { .. } => buffer_infos.push((
                    b.binding,
                    vk::DescriptorType::UNIFORM_BUFFER,
                    vk::DescriptorBufferInfo {
                        buffer: params_vk,
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    },
                )),
                BindingKind::StorageBuffer { .. } => {
                    let Some(Resource::Buffer {
                        buffer,
                        offset,
                        size,
                        ..
                    }) = resources.iter().find(|r| r.binding() == b.binding)
                    else {
                        return Err(Error::invalid(format!(
                            "no buffer given for binding {}",
                            b.binding
                        )));
                    };
                    let obj = objects.buffers.get(*buffer)?;
                    let range = size.unwrap_or(obj.gpu.size - offset).max(4);
                    buffer_infos.push((
                        b.binding,
                        vk::DescriptorType::STORAGE_BUFFER,
                        vk::DescriptorBufferInfo {
                            buffer: obj.gpu.buffer,
                            offset: *offset,
                            range,
                        },
                    ));
                }
                BindingKind::Texture2d => {
                    let Some(Resource::Texture { texture, .. }) =
                        resources.iter().find(|r| r.binding() == b.binding)
                    else {
                        return Err(Error::invalid(format!(
                            "no texture given for binding {}",
                            b.binding
                        )));
                    };
                    let view = objects.textures.get(*texture)?.view;
                    image_infos.push((
                        b.binding,
                        vk::DescriptorImageInfo {
                            sampler: vk::Sampler::null(),
                            image_view: view,
                            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                        },
                    ));
                }
                BindingKind::Sampler => {
                    let Some(Resource::Sampler { sampler, .. }) =
                        resources.iter().find(|r| r.binding() == b.binding)
                    else {
                        return Err(Error::invalid(format!(
                            "no sampler given for binding {}",
                            b.binding
                        )));
                    };
                    let s = self.sampler(*sampler)?;
                    image_infos.push((
                        b.binding,
                        vk::DescriptorImageInfo {
                            sampler: s,
                            image_view: vk::ImageView::null(),
                            image_layout: vk::ImageLayout::UNDEFINED,
                        },
                    ));
                }
            }
        }
        let count = |t: vk::DescriptorType| {
            buffer_infos.iter().filter(|(_, ty, _)| *ty == t).count() as u32
        };
        let textures = bindings
            .iter()
            .filter(|b| b.kind == BindingKind::Texture2d)
            .count() as u32;
        let samplers = bindings
            .iter()
            .filter(|b| b.kind == BindingKind::Sampler)
            .count() as u32;
        // Set 0 once, set 1 (the backend's) per dispatch; launch() bounds their number.
        let n = dispatches.len() as u32;
        let mut pool_sizes = vec![
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::UNIFORM_BUFFER,
                descriptor_count: count(vk::DescriptorType::UNIFORM_BUFFER) + n,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_BUFFER,
                descriptor_count: count(vk::DescriptorType::STORAGE_BUFFER) + 5 * n,
            },
        ];
        if textures > 0 {
            pool_sizes.push(vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLED_IMAGE,
                descriptor_count: textures,
            });
        }
        if samplers > 0 {
            pool_sizes.push(vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLER,
                descriptor_count: samplers,
            });
        }
        let ctx = self.ctx.clone();
        let device = &ctx.device;
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1 + n)
            .pool_sizes(&pool_sizes);
        // SAFETY: valid create info; destroyed when the launch retires (or below).
        let pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
            .or_vk("vkCreateDescriptorPool")?;
        let recorded = (|| {
            let p = objects.pipelines.get(pipeline)?;
            let (vk_pipeline, layout, set_layouts, stack) =
                (p.pipeline, p.layout, p.set_layouts, p.stack_size);
            let mut layouts = vec![set_layouts[0]];
            layouts.extend(std::iter::repeat_n(set_layouts[1], n as usize));
            let alloc_info = vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(pool)
                .set_layouts(&layouts);
            // SAFETY: a pool sized for the user's set and one backend set per dispatch.
            let sets = unsafe { device.allocate_descriptor_sets(&alloc_info) }
                .or_vk("vkAllocateDescriptorSets")?;
            let backend_buffers: Vec<(u32, vk::DescriptorType, vk::DescriptorBufferInfo)> = vec![
                (
                    0,
                    vk::DescriptorType::UNIFORM_BUFFER,
                    vk::DescriptorBufferInfo {
                        buffer: constants_vk,
                        offset: 0,
                        range: CONSTANT_BYTES,
                    },
                ),
                (
                    1,
                    vk::DescriptorType::STORAGE_BUFFER,
                    vk::DescriptorBufferInfo {
                        buffer: state_vk,
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    },
                ),
                (
                    2,
                    vk::DescriptorType::STORAGE_BUFFER,
                    vk::DescriptorBufferInfo {
                        buffer: tables[0],
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    },
                ),
                (
                    3,
                    vk::DescriptorType::STORAGE_BUFFER,
                    vk::DescriptorBufferInfo {
                        buffer: tables[1],
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    },
                ),
                (
                    4,
                    vk::DescriptorType::STORAGE_BUFFER,
                    vk::DescriptorBufferInfo {
                        buffer: tables[2],
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    },
                ),
                (
                    5,
                    vk::DescriptorType::STORAGE_BUFFER,
                    vk::DescriptorBufferInfo {
                        buffer: sbt.callable_table.buffer,
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    },
                ),
            ];
            let mut writes: Vec<vk::WriteDescriptorSet> = Vec::new();
            for (b, ty, info) in &buffer_infos {
                writes.push(
                    vk::WriteDescriptorSet::default()
                        .dst_set(sets[0])
                        .dst_binding(*b)
                        .descriptor_type(*ty)
                        .buffer_info(std::slice::from_ref(info)),
                );
            }
            for (b, info) in &image_infos {
                let ty = if info.sampler == vk::Sampler::null() {
                    vk::DescriptorType::SAMPLED_IMAGE
                } else {
                    vk::DescriptorType::SAMPLER
                };
                writes.push(
                    vk::WriteDescriptorSet::default()
                        .dst_set(sets[0])
                        .dst_binding(*b)
                        .descriptor_type(ty)
                        .image_info(std::slice::from_ref(info)),
                );
            }
            let per_dispatch: Vec<Vec<vk::DescriptorBufferInfo>> = (0..n as u64)
                .map(|i| {
                    backend_buffers
                        .iter()
                        .map(|(b, _, info)| {
                            let mut info = *info;
                            if *b == 0 {
                                info.offset = i * stride;
                            }
                            info
                        })
                        .collect()
                })
                .collect();
            for (set, infos) in sets[1..].iter().zip(&per_dispatch) {
                for ((b, ty, _), info) in backend_buffers.iter().zip(infos) {
                    writes.push(
                        vk::WriteDescriptorSet::default()
                            .dst_set(*set)
                            .dst_binding(*b)
                            .descriptor_type(*ty)
                            .buffer_info(std::slice::from_ref(info)),
                    );
                }
            }
            // SAFETY: every write names a binding of its set's layout with live resources.
            unsafe { device.update_descriptor_sets(&writes, &[]) };
            self.submit_commands(|cmd| {
                // SAFETY: recording; the pipeline, layout and sets are live.
                unsafe {
                    device.cmd_bind_pipeline(
                        cmd,
                        vk::PipelineBindPoint::RAY_TRACING_KHR,
                        vk_pipeline,
                    );
                    device.cmd_bind_descriptor_sets(
                        cmd,
                        vk::PipelineBindPoint::RAY_TRACING_KHR,
                        layout,
                        0,
                        &sets[..1],
                        &[],
                    );
                    ctx.rt.cmd_set_ray_tracing_pipeline_stack_size(cmd, stack);
                    for (i, d) in dispatches.iter().enumerate() {
                        if i > 0 && uses_state {
                            // The next tile reuses the state slots this one wrote.
                            let barrier = vk::MemoryBarrier::default()
                                .src_access_mask(
                                    vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
                                )
                                .dst_access_mask(
                                    vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
                                );
                            device.cmd_pipeline_barrier(
                                cmd,
                                vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                                vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                                vk::DependencyFlags::empty(),
                                &[barrier],
                                &[],
                                &[],
                            );
                        }
                        device.cmd_bind_descriptor_sets(
                            cmd,
                            vk::PipelineBindPoint::RAY_TRACING_KHR,
                            layout,
                            1,
                            &sets[1 + i..2 + i],
                            &[],
                        );
                        ctx.rt.cmd_trace_rays(
                            cmd,
                            &sbt.raygen,
                            &sbt.miss,
                            &sbt.hit,
                            &sbt.callable,
                            d.extent[0],
                            d.extent[1],
                            d.extent[2],
                        );
                    }
                }
                Ok(())
            })
        })();
        match recorded {
            Ok(submission) => Ok((submission, pool)),
            Err(e) => {
                // SAFETY: nothing was submitted with the pool.
                unsafe { device.destroy_descriptor_pool(pool, None) };
                Err(e)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every launch index is in exactly one tile, tiles respect the limits, and a launch
    /// that fits is one dispatch.
    #[test]
    fn tiles_cover_a_launch_once_within_the_limits() {
        let cases: [([u32; 3], [u64; 3], u64); 6] = [
            ([7, 5, 3], [100, 100, 100], 1000),
            ([7, 5, 3], [3, 2, 2], 1000),
            ([7, 5, 3], [100, 100, 100], 4),
            ([7, 5, 3], [100, 100, 100], 1),
            ([1, 1, 40], [1, 1, 7], 1000),
            ([13, 1, 1], [100, 100, 100], 6),
        ];
        for (size, dims, inv) in cases {
            let t = tile(size, dims, inv);
            let plan = plan_dispatches(size, t);
            assert_eq!(plan.len() as u64, tile_count(size, t), "{size:?} {t:?}");
            let mut seen = vec![0u32; (size[0] * size[1] * size[2]) as usize];
            for d in &plan {
                let n: u64 = d.extent.iter().map(|&e| e as u64).product();
                assert!(n >= 1 && n <= inv, "{d:?} over {inv} invocations");
                for k in 0..3 {
                    assert!(d.extent[k] as u64 <= dims[k], "{d:?} over {dims:?}");
                }
                for z in 0..d.extent[2] {
                    for y in 0..d.extent[1] {
                        for x in 0..d.extent[0] {
                            let (x, y, z) = (x + d.origin[0], y + d.origin[1], z + d.origin[2]);
                            assert!(x < size[0] && y < size[1] && z < size[2], "{d:?}");
                            seen[(x + size[0] * (y + size[1] * z)) as usize] += 1;
                        }
                    }
                }
            }
            assert!(
                seen.iter().all(|&c| c == 1),
                "{size:?} {dims:?} {inv}: {seen:?}"
            );
        }
        assert_eq!(
            plan_dispatches([640, 480, 1], tile([640, 480, 1], [1 << 20; 3], 1 << 26)).len(),
            1
        );
        assert!(plan_dispatches([0, 4, 4], [1, 1, 1]).is_empty());
    }
}
