//! Launches (OptiX `optixLaunch`): checks, descriptor sets, the translated SBT, the per-launch
//! state buffer, and `vkCmdTraceRaysKHR`. Launches are asynchronous: the host goes on, and
//! reads, writes, builds and `synchronize` wait for them.

use crate::commands::Submission;
use crate::device::Inner;
use crate::error::VkResultExt;
use crate::memory::{GpuBuffer, Location};
use crate::program::LoweringConfig;
use crate::sbt::TranslatedSbt;
use ash::vk;
use optik_api::frontend::BindingKind;
use optik_api::*;
use std::sync::Arc;

/// A launch the host has not waited for, with what it holds.
pub struct InFlight {
    /// The submitted command buffer.
    pub submission: Submission,
    pool: vk::DescriptorPool,
    buffers: Vec<GpuBuffer>,
    sbt: Arc<TranslatedSbt>,
}

/// Bytes of per-launch-index state (prelude.rs: one `vec4<u32>`).
const STATE_BYTES: u64 = 16;

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
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        table: &ShaderBindingTable,
        size: LaunchSize,
    ) -> Result<()> {
        // optik-core checked the pipeline, the size, the SBT's layout and the bindings; the
        // limits below are this device's own.
        let p = self.pipelines.get(pipeline)?;
        let dims = [size.width, size.height, size.depth];
        for (k, name) in ["width", "height", "depth"].iter().enumerate() {
            if dims[k] as u64 > self.ctx.info.max_launch_dimensions[k] {
                return Err(Error::limit(format!(
                    "launch {name} {} exceeds this device's {} (maxComputeWorkGroupCount x maxComputeWorkGroupSize)",
                    dims[k], self.ctx.info.max_launch_dimensions[k]
                )));
            }
        }
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
                let total = self.buffers.get(*buffer)?.gpu.size;
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
                    self.textures.get(*texture)?;
                }
                _ => {}
            }
        }
        self.check_pipeline_serves_scene(&p.config)?;
        let p = self.pipelines.get(pipeline)?;
        let uses_state = p.config.uses_state();
        let bindings = p.bindings.clone();
        if size.is_empty() {
            return Ok(());
        }
        self.reap_launches()?;
        let state_bytes = size.count() * STATE_BYTES;
        if uses_state && state_bytes > self.ctx.info.max_storage_buffer_range as u64 {
            return Err(Error::limit(format!(
                "this pipeline keeps {STATE_BYTES} bytes of state per launch index (exceptions, depth, ray time or flags): a {}x{}x{} launch needs {state_bytes} bytes, more than this device's maxStorageBufferRange {}; launch in smaller tiles",
                size.width, size.height, size.depth, self.ctx.info.max_storage_buffer_range
            )));
        }
        let sbt = self.translate_sbt(pipeline, table)?;
        let max_range = self.ctx.info.max_storage_buffer_range as u64;
        if let Some(bytes) = self.tables.sizes().into_iter().find(|b| *b > max_range) {
            return Err(Error::limit(format!(
                "the scene's tables (triangle vertices, remaps, motion keys and micromaps of every live acceleration structure) need {bytes} bytes in one storage buffer; this device binds at most {max_range} (maxStorageBufferRange): destroy unused structures or use TriangleTest::Driver, which keeps no vertices"
            )));
        }
        let tables = self.table_buffers()?;

        let mut held: Vec<GpuBuffer> = Vec::new();
        let result = self.record_launch(
            pipeline, params, resources, &bindings, &sbt, tables, size, uses_state, &mut held,
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
                        if let Ok(b) = self.buffers.get_mut(*buffer) {
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
    fn check_pipeline_serves_scene(&self, config: &LoweringConfig) -> Result<()> {
        let Some(scene) = self.scene_features() else {
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
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        bindings: &[frontend::BindingInfo],
        sbt: &TranslatedSbt,
        tables: [vk::Buffer; 3],
        size: LaunchSize,
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
        let constants: Vec<u8> = [
            empty as u32,
            (empty >> 32) as u32,
            sbt.miss_count,
            sbt.callable_count,
        ]
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .collect();
        let constants_buffer =
            self.host_buffer(&constants, vk::BufferUsageFlags::UNIFORM_BUFFER)?;
        let constants_vk = constants_buffer.buffer;
        held.push(constants_buffer);
        let state_size = if uses_state {
            size.count() * STATE_BYTES
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
                    let obj = self.buffers.get(*buffer)?;
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
                    let view = self.textures.get(*texture)?.view;
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
        let mut pool_sizes = vec![
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::UNIFORM_BUFFER,
                descriptor_count: count(vk::DescriptorType::UNIFORM_BUFFER) + 1,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_BUFFER,
                descriptor_count: count(vk::DescriptorType::STORAGE_BUFFER) + 5,
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
            .max_sets(2)
            .pool_sizes(&pool_sizes);
        // SAFETY: valid create info; destroyed when the launch retires (or below).
        let pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
            .or_vk("vkCreateDescriptorPool")?;
        let recorded = (|| {
            let p = self.pipelines.get(pipeline)?;
            let (vk_pipeline, layout, set_layouts, stack) =
                (p.pipeline, p.layout, p.set_layouts, p.stack_size);
            let alloc_info = vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(pool)
                .set_layouts(&set_layouts);
            // SAFETY: a pool sized for both sets.
            let sets = unsafe { device.allocate_descriptor_sets(&alloc_info) }
                .or_vk("vkAllocateDescriptorSets")?;
            let backend_buffers: Vec<(u32, vk::DescriptorType, vk::DescriptorBufferInfo)> = vec![
                (
                    0,
                    vk::DescriptorType::UNIFORM_BUFFER,
                    vk::DescriptorBufferInfo {
                        buffer: constants_vk,
                        offset: 0,
                        range: vk::WHOLE_SIZE,
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
            for (b, ty, info) in &backend_buffers {
                writes.push(
                    vk::WriteDescriptorSet::default()
                        .dst_set(sets[1])
                        .dst_binding(*b)
                        .descriptor_type(*ty)
                        .buffer_info(std::slice::from_ref(info)),
                );
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
                        &sets,
                        &[],
                    );
                    ctx.rt.cmd_set_ray_tracing_pipeline_stack_size(cmd, stack);
                    ctx.rt.cmd_trace_rays(
                        cmd,
                        &sbt.raygen,
                        &sbt.miss,
                        &sbt.hit,
                        &sbt.callable,
                        size.width,
                        size.height,
                        size.depth,
                    );
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
