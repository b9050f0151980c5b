//! The memory-bandwidth probe the traversal's traffic is compared with.
//!
//! Two compute kernels over one large buffer, timed with GPU timestamps around their
//! compute pass (wall time around submit-and-wait where the adapter has no timestamps):
//! a streaming read (every invocation XORs a grid-strided share of the buffer, as
//! traversal reads the scene) and a copy (read and write, as `memcpy` figures are usually
//! quoted). The buffer should be much larger than the GPU's last-level cache (50 MiB on
//! an H100) so the figures are device memory's, not the cache's.

use crate::device::WgpuDevice;
use optik_api::{Error, Result};
use std::time::Instant;

/// Measured bandwidth.
#[derive(Clone, Debug)]
pub struct Bandwidth {
    /// Bytes of the buffer read (and, by the copy, written).
    pub bytes: u64,
    /// Streaming read, GB/s (10⁹ bytes per second).
    pub read_gbps: f64,
    /// Copy kernel, GB/s counting bytes read plus bytes written.
    pub copy_gbps: f64,
    /// Whether the figures come from GPU timestamps (else wall time).
    pub gpu_timed: bool,
}

impl std::fmt::Display for Bandwidth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.1} GB/s read, {:.1} GB/s copy (read + write), over {} MiB, {}",
            self.read_gbps,
            self.copy_gbps,
            self.bytes >> 20,
            if self.gpu_timed {
                "GPU timestamps"
            } else {
                "wall time"
            }
        )
    }
}

const WORKGROUP: u32 = 256;

const KERNELS: &str = r#"
@group(0) @binding(0) var<storage, read> src: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> dst: array<vec4<u32>>;

// Grid-strided so that consecutive invocations read consecutive 16-byte words (coalesced).
@compute @workgroup_size(256)
fn read_all(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) n: vec3<u32>) {
    let threads = n.x * 256u;
    let len = arrayLength(&src);
    var acc = vec4<u32>(0u);
    for (var i = gid.x; i < len; i = i + threads) {
        acc = acc ^ src[i];
    }
    // Never true for the zero-filled source; keeps the reads from being optimised away.
    if acc.x == 0x9e3779b9u {
        dst[gid.x] = acc;
    }
}

@compute @workgroup_size(256)
fn copy_all(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) n: vec3<u32>) {
    let threads = n.x * 256u;
    let len = arrayLength(&src);
    for (var i = gid.x; i < len; i = i + threads) {
        dst[i] = src[i];
    }
}
"#;

/// The largest probe buffer at most `wanted` bytes that the device can bind: a multiple
/// of 16 within `max_storage_buffer_binding_size` and `max_buffer_size`.
pub fn probe_bytes(dev: &WgpuDevice, wanted: u64) -> u64 {
    let limits = dev.limits();
    let cap = wanted
        .min(limits.max_storage_buffer_binding_size)
        .min(limits.max_buffer_size);
    cap / 16 * 16
}

/// Measures streaming-read and copy bandwidth over a buffer of `bytes` (clamped by
/// [`probe_bytes`]), the median of `repeats` runs each.
pub fn measure(dev: &WgpuDevice, bytes: u64, repeats: u32) -> Result<Bandwidth> {
    let bytes = probe_bytes(dev, bytes);
    if bytes < 16 {
        return Err(Error::invalid(
            "the bandwidth probe needs a buffer of at least 16 bytes",
        ));
    }
    let gpu = dev.gpu();
    let timestamps = gpu.features.contains(wgpu::Features::TIMESTAMP_QUERY);
    let (src, dst, read_all, copy_all, layout) = gpu.scoped(
        &format!("allocating the bandwidth probe's two buffers of {bytes} bytes"),
        || {
            let buffer = |label| {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                })
            };
            let entry = |binding, read_only| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            };
            // One explicit layout, so both kernels take the same bind group.
            let layout = gpu
                .device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("optik bandwidth probe"),
                    entries: &[entry(0, true), entry(1, false)],
                });
            let pipeline_layout =
                gpu.device
                    .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some("optik bandwidth probe"),
                        bind_group_layouts: &[Some(&layout)],
                        immediate_size: 0,
                    });
            let module = gpu
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some("optik bandwidth probe"),
                    source: wgpu::ShaderSource::Wgsl(KERNELS.into()),
                });
            let pipeline = |entry| {
                gpu.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(entry),
                        layout: Some(&pipeline_layout),
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        cache: None,
                    })
            };
            let read_all = pipeline("read_all");
            let copy_all = pipeline("copy_all");
            (
                buffer("optik probe source"),
                buffer("optik probe destination"),
                read_all,
                copy_all,
                layout,
            )
        },
    )?;
    // Enough invocations to fill any GPU, few enough that each streams a long run.
    let words = bytes / 16;
    let groups = words.div_ceil(WORKGROUP as u64 * 16).clamp(
        1,
        gpu.limits.max_compute_workgroups_per_dimension.min(8192) as u64,
    ) as u32;
    let run = |pipeline: &wgpu::ComputePipeline| -> Result<f64> {
        let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("optik probe"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: src.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: dst.as_entire_binding(),
                },
            ],
        });
        let query = timestamps.then(|| {
            gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("optik probe timing"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            })
        });
        let resolve = query.as_ref().map(|_| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("optik probe timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        });
        let start = Instant::now();
        gpu.scoped("running the bandwidth probe", || {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("optik probe"),
                    timestamp_writes: query.as_ref().map(|q| wgpu::ComputePassTimestampWrites {
                        query_set: q,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }),
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.dispatch_workgroups(groups, 1, 1);
            }
            if let (Some(q), Some(r)) = (&query, &resolve) {
                encoder.resolve_query_set(q, 0..2, r, 0);
            }
            gpu.queue.submit([encoder.finish()]);
        })?;
        gpu.wait()?;
        let wall = start.elapsed().as_secs_f64();
        match resolve {
            Some(r) => {
                let stamps = gpu.read(&r, 0, 16)?;
                let t0 = u64::from_le_bytes(stamps[0..8].try_into().unwrap_or([0; 8]));
                let t1 = u64::from_le_bytes(stamps[8..16].try_into().unwrap_or([0; 8]));
                let gpu_seconds =
                    t1.saturating_sub(t0) as f64 * gpu.queue.get_timestamp_period() as f64 * 1e-9;
                // A driver that writes equal stamps has no usable timer: wall time then.
                Ok(if gpu_seconds > 0.0 { gpu_seconds } else { wall })
            }
            None => Ok(wall),
        }
    };
    let median_of = |pipeline: &wgpu::ComputePipeline| -> Result<f64> {
        // The first run compiles lazily on some drivers and warms the page tables.
        run(pipeline)?;
        let mut times = Vec::new();
        for _ in 0..repeats.max(1) {
            times.push(run(pipeline)?);
        }
        Ok(super::median(times))
    };
    let read_seconds = median_of(&read_all)?;
    let copy_seconds = median_of(&copy_all)?;
    let gbps = |moved: u64, seconds: f64| {
        if seconds > 0.0 {
            moved as f64 / seconds / 1e9
        } else {
            0.0
        }
    };
    Ok(Bandwidth {
        bytes,
        read_gbps: gbps(bytes, read_seconds),
        copy_gbps: gbps(2 * bytes, copy_seconds),
        gpu_timed: timestamps,
    })
}
