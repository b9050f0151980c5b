//! Launches: check, pick the kernel variant for the scene alive now, pack the SBT, bind and
//! dispatch.
//!
//! A launch is one dispatch of `ceil(w·h·d / 64)` workgroups laid out in two dimensions,
//! so it never exceeds the per-dimension workgroup limit below 2³¹ invocations; the kernel
//! turns the workgroup position back into a launch index and drops the padding.

use crate::device::{WgpuBackend, WgpuObjects, scene_content, scene_sizes};
use crate::kernel::WORKGROUP_SIZE;
use optik_api::{
    AddressMode, Error, FilterMode, LaunchSize, Pipeline, Resource, Result, SamplerDesc,
    ShaderBindingTable,
};
use optik_core::frontend::BindingKind;

/// How the benchmark observes a launch; the default (the `Device` trait's launches) adds
/// nothing.
#[derive(Clone, Copy, Default)]
pub(crate) struct Observe<'a> {
    /// Wait for the launch and return its GPU time (timestamps around the compute pass).
    pub timed: bool,
    /// Run the instrumented kernel, adding its traffic counts to this buffer
    /// (`kernel::counters::BUFFER_BYTES`, usage STORAGE).
    pub counters: Option<&'a wgpu::Buffer>,
}

/// Runs a launch of `pipeline` (in `objects`); when `observe.timed`, waits for it and
/// returns its GPU time in seconds (when the adapter offers timestamp queries).
#[allow(clippy::too_many_arguments)]
pub(crate) fn launch(
    dev: &WgpuBackend,
    objects: &mut WgpuObjects,
    pipeline: Pipeline,
    params: &[u8],
    resources: &[Resource],
    sbt: &ShaderBindingTable,
    size: LaunchSize,
    observe: Observe<'_>,
) -> Result<Option<f64>> {
    let gpu = dev.gpu();
    let mut s = dev.lock()?;
    // optik-core checked the pipeline, the size, the SBT's layout and the bindings.
    objects.pipelines.get(pipeline)?;
    if size.is_empty() {
        return Ok(None);
    }
    let align = gpu.limits.min_storage_buffer_offset_alignment as u64;
    for r in resources {
        if let Resource::Buffer {
            binding, offset, ..
        } = r
            && offset % align != 0
        {
            return Err(Error::invalid(format!(
                "resource at binding {binding}: offset {offset} must be a multiple of {align} on this adapter"
            )));
        }
    }
    let sizes = scene_sizes(&objects.accels, &s.scene);
    let variant = objects.pipelines.get_mut(pipeline)?.variant(
        gpu,
        sizes,
        scene_content(&objects.accels),
        observe.counters.is_some(),
    )?;
    // The SBT, from the host copies of its buffers (read back if a launch wrote them).
    let packed = {
        let p = objects.pipelines.get(pipeline)?;
        let buffers = &mut objects.buffers;
        crate::sbt::pack(sbt, p, &mut |b| {
            Ok(buffers.get_mut(b)?.bytes(gpu)?.to_vec())
        })?
    };
    let r = packed.regions;
    let launch_words: [u32; 16] = [
        size.width,
        size.height,
        size.depth,
        size.count() as u32,
        r[0],
        r[1],
        r[2],
        r[3],
        r[4],
        r[5],
        r[6],
        r[7],
        r[8],
        r[9],
        r[10],
        0,
    ];
    let uniform = |label: &str, bytes: &[u8]| -> Result<wgpu::Buffer> {
        let size = (bytes.len().max(16) as u64).div_ceil(16) * 16;
        if size > gpu.limits.max_uniform_buffer_binding_size {
            return Err(Error::limit(format!(
                "{label} is {} bytes; this adapter's uniform bindings hold at most {}",
                bytes.len(),
                gpu.limits.max_uniform_buffer_binding_size
            )));
        }
        let b = gpu.scoped(&format!("allocating {label} ({size} bytes)"), || {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        let mut padded = bytes.to_vec();
        padded.resize(size as usize, 0);
        gpu.queue.write_buffer(&b, 0, &padded);
        Ok(b)
    };
    let launch_buffer = uniform("optik launch", bytemuck::cast_slice(&launch_words))?;
    let sbt_bytes: &[u8] = bytemuck::cast_slice(&packed.words);
    let sbt_size = (sbt_bytes.len().max(16) as u64).div_ceil(4) * 4;
    if sbt_size > gpu.limits.max_storage_buffer_binding_size {
        return Err(Error::limit(format!(
            "the shader binding table packs to {sbt_size} bytes; this adapter binds at most {} in one storage buffer",
            gpu.limits.max_storage_buffer_binding_size
        )));
    }
    let sbt_buffer = gpu.scoped("allocating the packed SBT", || {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("optik sbt"),
            size: sbt_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    })?;
    gpu.queue.write_buffer(&sbt_buffer, 0, sbt_bytes);
    let params_buffer = uniform("optik params", params)?;

    // Samplers are few: create each description once.
    for res in resources {
        if let Resource::Sampler { sampler, .. } = res
            && !s.samplers.iter().any(|(d, _)| d == sampler)
        {
            let made = make_sampler(gpu, *sampler);
            s.samplers.push((*sampler, made));
        }
    }
    let handles = s.scene.table_buffer(gpu)?.clone();
    let chunks: Vec<wgpu::Buffer> = s.scene.arena.chunks().to_vec();
    let p = objects.pipelines.get(pipeline)?;
    let mut written = Vec::new();
    let mut user_entries: Vec<wgpu::BindGroupEntry<'_>> = Vec::new();
    for (offset, bindings) in &p.bindings {
        for b in bindings {
            let resource = match b.kind {
                BindingKind::Params { .. } => params_buffer.as_entire_binding(),
                _ => {
                    let res = resources
                        .iter()
                        .find(|r| r.binding() == b.binding)
                        .ok_or_else(|| {
                            Error::invalid(format!("no resource for binding {}", b.binding))
                        })?;
                    match res {
                        Resource::Buffer {
                            buffer,
                            offset: at,
                            size,
                            ..
                        } => {
                            let obj = objects.buffers.get(*buffer)?;
                            if let BindingKind::StorageBuffer {
                                read_only: false, ..
                            } = b.kind
                            {
                                written.push(*buffer);
                            }
                            let bound = size.unwrap_or(obj.size - at);
                            if bound > gpu.limits.max_storage_buffer_binding_size {
                                return Err(Error::limit(format!(
                                    "binding {} binds {bound} bytes; this adapter binds at most {} bytes of a storage buffer",
                                    b.binding, gpu.limits.max_storage_buffer_binding_size
                                )));
                            }
                            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: &obj.gpu,
                                offset: *at,
                                size: std::num::NonZeroU64::new(bound.max(4)),
                            })
                        }
                        Resource::Texture { texture, .. } => wgpu::BindingResource::TextureView(
                            &objects.textures.get(*texture)?.view,
                        ),
                        Resource::Sampler { sampler, .. } => {
                            let found = s
                                .samplers
                                .iter()
                                .find(|(d, _)| d == sampler)
                                .map(|(_, smp)| smp)
                                .ok_or_else(|| Error::backend("sampler cache"))?;
                            wgpu::BindingResource::Sampler(found)
                        }
                    }
                }
            };
            user_entries.push(wgpu::BindGroupEntry {
                binding: offset + b.binding,
                resource,
            });
        }
    }
    let mut backend_entries = vec![
        wgpu::BindGroupEntry {
            binding: 0,
            resource: launch_buffer.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 1,
            resource: sbt_buffer.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 2,
            resource: handles.as_entire_binding(),
        },
    ];
    for (i, c) in chunks.iter().enumerate() {
        backend_entries.push(wgpu::BindGroupEntry {
            binding: 3 + i as u32,
            resource: c.as_entire_binding(),
        });
    }
    if let Some(counters) = observe.counters {
        backend_entries.push(wgpu::BindGroupEntry {
            binding: crate::kernel::counters::binding(chunks.len() as u32),
            resource: counters.as_entire_binding(),
        });
    }
    let total_groups = size.count().div_ceil(WORKGROUP_SIZE as u64);
    let per_dim = gpu.limits.max_compute_workgroups_per_dimension as u64;
    let x = total_groups.min(per_dim);
    let y = total_groups.div_ceil(x);
    if y > per_dim {
        return Err(Error::limit(format!(
            "a launch of {} x {} x {} = {} invocations needs {total_groups} workgroups of {WORKGROUP_SIZE}; this adapter dispatches at most {per_dim} x {per_dim} workgroups (max_compute_workgroups_per_dimension = {per_dim})",
            size.width,
            size.height,
            size.depth,
            size.count()
        )));
    }
    let timestamps = observe.timed && gpu.features.contains(wgpu::Features::TIMESTAMP_QUERY);
    let query = timestamps.then(|| {
        gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("optik launch timing"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        })
    });
    let resolve = query.as_ref().map(|_| {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("optik timestamps"),
            size: 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    });
    gpu.scoped("launching the wgpu megakernel", || {
        let user_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("optik user bindings"),
            layout: &variant.user_layout,
            entries: &user_entries,
        });
        let backend_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("optik backend bindings"),
            layout: &variant.backend_layout,
            entries: &backend_entries,
        });
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("optik launch"),
                timestamp_writes: query.as_ref().map(|q| wgpu::ComputePassTimestampWrites {
                    query_set: q,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            pass.set_pipeline(&variant.pipeline);
            pass.set_bind_group(0, &user_group, &[]);
            pass.set_bind_group(1, &backend_group, &[]);
            pass.dispatch_workgroups(x as u32, y as u32, 1);
        }
        if let (Some(q), Some(r)) = (&query, &resolve) {
            encoder.resolve_query_set(q, 0..2, r, 0);
        }
        gpu.queue.submit([encoder.finish()]);
    })?;
    drop(user_entries);
    for b in written {
        objects.buffers.get_mut(b)?.mark_written_by_gpu();
    }
    drop(s);
    match resolve {
        Some(r) => {
            let bytes = gpu.read(&r, 0, 16)?;
            let t0 = u64::from_le_bytes(bytes[0..8].try_into().unwrap_or([0; 8]));
            let t1 = u64::from_le_bytes(bytes[8..16].try_into().unwrap_or([0; 8]));
            let period = gpu.queue.get_timestamp_period() as f64;
            Ok(Some(t1.saturating_sub(t0) as f64 * period * 1e-9))
        }
        None => Ok(None),
    }
}

/// What a launch stopped by its options adds to the error: the GPU goes on, what to do.
pub(crate) const STOPPED_ON_GPU: &str = "the wgpu device goes on running the launch's dispatch until its programs end (a running shader cannot be stopped): the device stays usable, and later calls on it (reads, writes, launches, synchronize, dropping it) wait for that end. A program that never ends is stopped only by the driver's watchdog, where there is one (not on lavapipe), and that loses the device: later calls then fail with ErrorKind::DeviceLost; open a new device. To stop runaway programs at the deadline, run them on the CPU backend";

/// Waits for the submitted work until it finishes or `watch` stops the launch, looking at
/// the stop flag between waits of a few milliseconds. A GPU dispatch cannot be preempted:
/// a stopped launch returns its error at once while the device finishes the work (or its
/// driver's watchdog ends it and the device is lost, which this and later calls report as
/// `ErrorKind::DeviceLost`).
pub(crate) fn wait_watched(gpu: &crate::gpu::Gpu, watch: &optik_api::LaunchWatch) -> Result<()> {
    /// How often a wait looks at the stop flag.
    const SLICE: std::time::Duration = std::time::Duration::from_millis(5);
    loop {
        gpu.check()?;
        if watch.stopped() {
            return watch
                .check()
                .map_err(|e| Error::new(e.kind(), format!("{}; {STOPPED_ON_GPU}", e.message())));
        }
        match gpu.device.poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: Some(SLICE),
        }) {
            Ok(_) => return gpu.check(),
            Err(wgpu::PollError::Timeout) => {}
            Err(e) => {
                gpu.check()?;
                return Err(Error::backend(format!("waiting for the GPU failed: {e}")));
            }
        }
    }
}

fn make_sampler(gpu: &crate::gpu::Gpu, d: SamplerDesc) -> wgpu::Sampler {
    let filter = match d.filter {
        FilterMode::Nearest => wgpu::FilterMode::Nearest,
        FilterMode::Linear => wgpu::FilterMode::Linear,
    };
    let address = match d.address_mode {
        AddressMode::ClampToEdge => wgpu::AddressMode::ClampToEdge,
        AddressMode::Repeat => wgpu::AddressMode::Repeat,
    };
    gpu.device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("optik sampler"),
        address_mode_u: address,
        address_mode_v: address,
        address_mode_w: address,
        mag_filter: filter,
        min_filter: filter,
        ..Default::default()
    })
}
