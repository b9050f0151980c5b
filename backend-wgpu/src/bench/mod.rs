//! A benchmark entry point for the GPU machine: primary and incoherent rays against a
//! triangle mesh, timed with GPU timestamps around the launch's compute pass, the bytes
//! the kernel reads per ray (an instrumented kernel counts them) and the memory bandwidth
//! they are compared with (`bandwidth`).
//!
//! Rays are made in the raygen program from the launch index (a pinhole camera framing
//! the mesh, or random origins inside its box with random directions), so the timing is
//! traversal and intersection, not ray loading. Every ray's closest t is written out and
//! the hits are counted on the host as a check. The same programs run on any backend
//! through the public API ([`bench_device`], wall-clock timed), so one run compares the
//! wgpu backend with the Vulkan one. `cargo run --release -p optik-benches --example
//! bench_trace -- [mesh.obj[.gz]]` prints a report (see docs/wgpu-backend.md §12).

pub mod bandwidth;

use crate::device::{WgpuBackend, WgpuDevice, WgpuDeviceExt};
use crate::kernel::counters;
pub use crate::kernel::counters::TrafficCounts;
pub use bandwidth::Bandwidth;
use optik_api::{
    Accel, AccelBuildOptions, Accuracy, Buffer, BufferView, BuildFlags, BuildInput, Device, Error,
    GeometryFlags, LaunchSize, ModuleCompileOptions, Pipeline, PipelineCompileOptions,
    PipelineLinkOptions, ProgramGroupDesc, ProgramRef, ProgramSource, Resource, Result, SbtRecord,
    SbtRegion, ShaderBindingTable, TraversableHandle,
};
use std::time::Instant;

/// Which rays a benchmark traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// One pinhole camera ray per pixel ([`BenchConfig::camera`]).
    Primary,
    /// Origins uniform in the mesh's box, directions uniform on the sphere.
    Incoherent,
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Where the rays start.
    pub eye: [f32; 3],
    /// The direction through the image's centre (not along the world's y axis).
    pub view: [f32; 3],
    /// Field of view across the image's width, in degrees.
    pub horizontal_fov_degrees: f32,
}

impl Camera {
    /// The camera of `optik bench-report`'s camera rays (benches/src/rays.rs): outside the
    /// box `lo..hi`, looking along (-0.3, -0.25, -1) at its centre, framing its bounding
    /// sphere (1.1 × its radius at a half-height tangent of 0.5).
    pub fn framing(lo: [f32; 3], hi: [f32; 3], width: u32, height: u32) -> Camera {
        let view = [-0.3f32, -0.25, -1.0];
        let len = view.iter().map(|v| v * v).sum::<f32>().sqrt();
        let radius = 0.5 * (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f32>().sqrt();
        let distance = radius / 0.5 * 1.1;
        let aspect = width as f32 / height.max(1) as f32;
        Camera {
            eye: std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]) - view[k] / len * distance),
            view,
            horizontal_fov_degrees: 2.0 * (0.5 * aspect).atan().to_degrees(),
        }
    }
}

/// What to measure.
#[derive(Clone, Copy, Debug)]
pub struct BenchConfig {
    /// Launch width (rays per row).
    pub width: u32,
    /// Launch height.
    pub height: u32,
    /// Timed launches per ray kind (the median is reported), after untimed ones for
    /// `optik_core::measure::WARM_UP`.
    pub repeats: u32,
    /// The triangle and box tests.
    pub accuracy: Accuracy,
    /// Bytes of the bandwidth probe's buffer (clamped to what one binding holds); 0 skips
    /// the probe.
    pub bandwidth_bytes: u64,
    /// Count the kernel's memory traffic with one extra launch of the instrumented kernel
    /// per ray kind (wgpu only).
    pub traffic: bool,
    /// The primary rays' camera; `None`: [`Camera::framing`] the mesh.
    pub camera: Option<Camera>,
}

impl Default for BenchConfig {
    /// 1920×1080, 10 repeats, robust accuracy, a 1 GiB bandwidth probe, traffic counted.
    fn default() -> Self {
        BenchConfig {
            width: 1920,
            height: 1080,
            repeats: 10,
            accuracy: Accuracy::ROBUST,
            bandwidth_bytes: 1 << 30,
            traffic: true,
            camera: None,
        }
    }
}

/// Timing of one kind of rays.
#[derive(Clone, Debug)]
pub struct TraceTiming {
    /// The rays.
    pub kind: RayKind,
    /// Rays per launch.
    pub rays: u64,
    /// Median GPU time of a launch (timestamps around the compute pass), when the adapter
    /// offers timestamp queries (wgpu only).
    pub gpu_seconds: Option<f64>,
    /// Median wall time of a launch: from the call to `launch` until `synchronize`
    /// returned (the SBT packing and uploads included).
    pub wall_seconds: f64,
    /// Rays that hit the mesh.
    pub hits: u64,
    /// The kernel's memory traffic for these rays (wgpu, when counted).
    pub traffic: Option<TrafficCounts>,
}

impl TraceTiming {
    /// Seconds per launch: GPU time where there is one, else wall time.
    pub fn seconds(&self) -> f64 {
        self.gpu_seconds.unwrap_or(self.wall_seconds)
    }

    /// Million rays per second, from GPU time where there is one.
    pub fn mrays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds() / 1e6
    }

    /// Billion rays per second, from GPU time where there is one.
    pub fn grays_per_second(&self) -> f64 {
        self.mrays_per_second() / 1e3
    }

    /// Bytes read from device memory per ray (scene arena and handle table), when counted.
    pub fn bytes_per_ray(&self) -> Option<f64> {
        let t = self.traffic?;
        Some(t.memory_bytes() as f64 / self.rays.max(1) as f64)
    }

    /// The traversal's achieved bandwidth: bytes per ray × rays per second, GB/s.
    pub fn achieved_gbps(&self) -> Option<f64> {
        Some(self.bytes_per_ray()? * self.rays as f64 / self.seconds() / 1e9)
    }
}

/// A benchmark run.
#[derive(Clone, Debug)]
pub struct BenchReport {
    /// The device's name and backend.
    pub device: String,
    /// How launches were timed.
    pub timing_method: &'static str,
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Host build and upload of the acceleration structure.
    pub build_seconds: f64,
    /// Bytes of the acceleration structure on the device.
    pub accel_bytes: u64,
    /// Pipeline creation plus the first launch (which compiles the kernel on some drivers).
    pub first_launch_seconds: f64,
    /// Entries of the kernel's traversal stack (sized from the structure's depth; wgpu).
    pub stack_entries: Option<u32>,
    /// The primary rays' camera.
    pub camera: Camera,
    /// Per ray kind.
    pub timings: Vec<TraceTiming>,
    /// The memory-bandwidth probe (wgpu, when asked for).
    pub bandwidth: Option<Bandwidth>,
}

impl std::fmt::Display for BenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "device           {}", self.device)?;
        writeln!(f, "timing           {}", self.timing_method)?;
        writeln!(f, "triangles        {}", self.triangles)?;
        writeln!(
            f,
            "build            {:.3} s ({:.1} MiB on the device)",
            self.build_seconds,
            self.accel_bytes as f64 / (1 << 20) as f64
        )?;
        writeln!(f, "first launch     {:.3} s", self.first_launch_seconds)?;
        let c = &self.camera;
        writeln!(
            f,
            "camera           eye ({:.3}, {:.3}, {:.3}), view ({:.3}, {:.3}, {:.3}), {:.1} deg across",
            c.eye[0], c.eye[1], c.eye[2], c.view[0], c.view[1], c.view[2], c.horizontal_fov_degrees
        )?;
        if let Some(s) = self.stack_entries {
            writeln!(f, "traversal stack  {s} entries")?;
        }
        if let Some(b) = &self.bandwidth {
            writeln!(f, "bandwidth probe  {b}")?;
        }
        for t in &self.timings {
            let kind = format!("{:?}", t.kind).to_lowercase();
            writeln!(
                f,
                "{kind:<16} {} rays, {:.1}% hit, {} gpu, {:.3} ms wall, {:.3} Grays/s ({:.1} Mrays/s)",
                t.rays,
                100.0 * t.hits as f64 / t.rays.max(1) as f64,
                t.gpu_seconds
                    .map(|s| format!("{:.3} ms", s * 1e3))
                    .unwrap_or_else(|| "n/a".into()),
                t.wall_seconds * 1e3,
                t.grays_per_second(),
                t.mrays_per_second()
            )?;
            if let Some(c) = &t.traffic {
                let per = |v: u64| v as f64 / t.rays.max(1) as f64;
                writeln!(
                    f,
                    "  traffic        {:.0} B/ray from memory (nodes {:.0}, instances {:.0}, primitives+headers {:.0}, handles {:.0}); stack {:.0} B/ray",
                    per(c.memory_bytes()),
                    per(c.node_bytes()),
                    per(c.instance_bytes()),
                    per(c.other_arena_bytes()),
                    per(16 * c.handle_reads),
                    per(c.stack_bytes()),
                )?;
                writeln!(
                    f,
                    "                 {:.1} nodes, {:.1} primitives, {:.2} traces per ray",
                    per(c.nodes),
                    per(c.primitives),
                    per(c.traces),
                )?;
                if let Some(achieved) = t.achieved_gbps() {
                    let of = self
                        .bandwidth
                        .as_ref()
                        .filter(|b| b.read_gbps > 0.0)
                        .map(|b| {
                            format!(
                                " = {:.1}% of the probe's read bandwidth",
                                100.0 * achieved / b.read_gbps
                            )
                        })
                        .unwrap_or_default();
                    writeln!(
                        f,
                        "  achieved       {:.1} GB/s (bytes/ray x rays/s){of}",
                        achieved
                    )?;
                }
            }
        }
        Ok(())
    }
}

const PROGRAMS: &str = r#"
// eye.w: tan of half the horizontal field of view.
struct Params { scene: vec2<u32>, kind: u32, seed: u32, lo: vec4<f32>, hi: vec4<f32>, eye: vec4<f32>, view: vec4<f32> }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> hits: array<u32>;

fn hash(x0: u32) -> u32 {
    var x = x0;
    x = x ^ (x >> 16u);
    x = x * 0x7feb352du;
    x = x ^ (x >> 15u);
    x = x * 0x846ca68bu;
    return x ^ (x >> 16u);
}

fn unit(h: u32) -> f32 {
    return f32(h >> 8u) / 16777216.0;
}

fn raygen__bench() {
    let id = rt_launch_index();
    let dim = rt_launch_dimensions();
    let i = id.y * dim.x + id.x;
    let lo = params.lo.xyz;
    let hi = params.hi.xyz;
    var origin: vec3<f32>;
    var direction: vec3<f32>;
    if params.kind == 0u {
        // A pinhole camera (the host places it: Camera).
        let w = normalize(params.view.xyz);
        let u = normalize(cross(w, vec3<f32>(0.0, 1.0, 0.0)));
        let v = cross(u, w);
        origin = params.eye.xyz;
        let half_x = params.eye.w;
        let half_y = half_x * f32(dim.y) / f32(dim.x);
        let sx = ((f32(id.x) + 0.5) / f32(dim.x) * 2.0 - 1.0) * half_x;
        let sy = (1.0 - (f32(id.y) + 0.5) / f32(dim.y) * 2.0) * half_y;
        direction = normalize(w + sx * u + sy * v);
    } else {
        let h0 = hash(i * 4u + params.seed);
        let h1 = hash(h0);
        let h2 = hash(h1);
        let h3 = hash(h2);
        let h4 = hash(h3);
        origin = lo + (hi - lo) * vec3<f32>(unit(h0), unit(h1), unit(h2));
        let z = 1.0 - 2.0 * unit(h3);
        let r = sqrt(max(0.0, 1.0 - z * z));
        let phi = 6.2831853 * unit(h4);
        direction = vec3<f32>(r * cos(phi), r * sin(phi), z);
    }
    var p: RtPayload;
    p[0] = 0x7f800000u;
    rt_trace(params.scene, origin, direction, 0.0, 1e30, 0.0, 0xFFu, RT_RAY_FLAG_DISABLE_ANYHIT, 0u, 1u, 0u, &p);
    hits[i] = p[0];
}

fn closesthit__t() {
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
}
"#;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// A mesh's structure, pipeline and tables on one device, ready to launch.
struct Prepared {
    gas: Accel,
    pipeline: Pipeline,
    table: ShaderBindingTable,
    out: Buffer,
    handle: TraversableHandle,
    lo: [f32; 3],
    hi: [f32; 3],
    build_seconds: f64,
    /// When pipeline creation started (the first launch's time counts from it).
    pipeline_start: Instant,
    camera: Camera,
}

impl Prepared {
    /// The launch parameters for `kind`.
    fn params(&self, kind: RayKind) -> Vec<u8> {
        let mut words: Vec<u32> = self.handle.to_words().to_vec();
        words.extend_from_slice(&[(kind == RayKind::Incoherent) as u32, 12345]);
        words.extend(self.lo.iter().map(|v| v.to_bits()));
        words.push(0);
        words.extend(self.hi.iter().map(|v| v.to_bits()));
        words.push(0);
        let c = &self.camera;
        words.extend(c.eye.iter().map(|v| v.to_bits()));
        words.push(
            (0.5 * c.horizontal_fov_degrees)
                .to_radians()
                .tan()
                .to_bits(),
        );
        words.extend(c.view.iter().map(|v| v.to_bits()));
        words.push(0);
        bytemuck::cast_slice(&words).to_vec()
    }

    /// Rays of the last launch that hit (t written by the closest-hit program).
    fn hits(&self, dev: &dyn Device, rays: u64) -> Result<u64> {
        let mut bytes = vec![0u8; (rays * 4) as usize];
        dev.read_buffer(self.out, 0, &mut bytes)?;
        Ok(bytes
            .chunks_exact(4)
            .filter(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) != 0x7f80_0000)
            .count() as u64)
    }
}

/// Builds the mesh, the pipeline and the SBT on `dev` through the public API.
fn prepare(
    dev: &dyn Device,
    vertices: &[[f32; 3]],
    indices: &[[u32; 3]],
    config: &BenchConfig,
) -> Result<Prepared> {
    let rays = config.width as u64 * config.height as u64;
    if vertices.is_empty() || indices.is_empty() {
        return Err(Error::invalid("the benchmark needs a mesh with triangles"));
    }
    let upload = |bytes: &[u8]| -> Result<Buffer> {
        let b = dev.create_buffer(bytes.len() as u64)?;
        dev.write_buffer(b, 0, bytes)?;
        Ok(b)
    };
    let vb = upload(bytemuck::cast_slice(vertices))?;
    let ib = upload(bytemuck::cast_slice(indices))?;
    let start = Instant::now();
    let input = BuildInput::Triangles(
        optik_api::TriangleArray::new(
            BufferView::new(vb),
            vertices.len() as u32,
            GeometryFlags::DISABLE_ANYHIT,
        )
        .with_indices(BufferView::new(ib), indices.len() as u32),
    );
    let gas = dev.accel_build(
        &AccelBuildOptions {
            flags: BuildFlags::PREFER_FAST_TRACE,
            ..Default::default()
        },
        &[input],
    )?;
    dev.synchronize()?;
    let build_seconds = start.elapsed().as_secs_f64();
    let (module, _) = dev.create_module(
        &ModuleCompileOptions::default(),
        &PipelineCompileOptions::default(),
        &ProgramSource::new("bench.wgsl", PROGRAMS),
    )?;
    let groups = dev.create_program_groups(&[
        ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__bench")),
        ProgramGroupDesc::Miss(None),
        ProgramGroupDesc::closest_hit(ProgramRef::new(module, "closesthit__t")),
    ])?;
    let pipeline_start = Instant::now();
    let pipeline = dev.create_pipeline(
        &PipelineCompileOptions::default(),
        &PipelineLinkOptions::default(),
        &groups,
    )?;
    let mut sbt_bytes = Vec::new();
    for g in &groups {
        sbt_bytes.extend_from_slice(&dev.sbt_record_pack_header(*g)?);
    }
    let sbt_buffer = upload(&sbt_bytes)?;
    let region = |i: u64| SbtRegion {
        buffer: sbt_buffer,
        offset: 32 * i,
        stride: 32,
        count: 1,
    };
    let table = ShaderBindingTable {
        raygen: SbtRecord {
            buffer: sbt_buffer,
            offset: 0,
        },
        exception: None,
        miss: Some(region(1)),
        hitgroup: Some(region(2)),
        callables: None,
    };
    let (lo, hi) = vertices.iter().fold(
        ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
        |(lo, hi), v| {
            (
                std::array::from_fn(|k| lo[k].min(v[k])),
                std::array::from_fn(|k| hi[k].max(v[k])),
            )
        },
    );
    let out = dev.create_buffer(rays * 4)?;
    let handle = dev.traversable_handle(gas)?;
    Ok(Prepared {
        gas,
        pipeline,
        table,
        out,
        handle,
        lo,
        hi,
        build_seconds,
        pipeline_start,
        camera: config
            .camera
            .unwrap_or_else(|| Camera::framing(lo, hi, config.width, config.height)),
    })
}

/// The device's name with its backend.
fn device_name(dev: &dyn Device) -> String {
    format!("{} ({:?})", dev.properties().device_name, dev.backend())
}

/// Builds `vertices` / `indices` into a GAS on a fresh wgpu device and times
/// `config.repeats` launches of `width × height` primary and incoherent rays with GPU
/// timestamps; then counts the instrumented kernel's traffic and probes the bandwidth
/// as `config` asks.
pub fn bench_trace(
    vertices: &[[f32; 3]],
    indices: &[[u32; 3]],
    config: &BenchConfig,
) -> Result<BenchReport> {
    let wgpu_device = WgpuBackend::new().map(WgpuDevice::new)?;
    let dev: &dyn Device = &wgpu_device;
    dev.set_accuracy(config.accuracy)?;
    let size = LaunchSize::new(config.width, config.height, 1);
    let rays = size.count();
    let p = prepare(dev, vertices, indices, config)?;
    let launch = |params: &[u8], observe: crate::launch::Observe<'_>| {
        crate::launch::launch(
            &wgpu_device,
            &mut wgpu_device.objects(),
            p.pipeline,
            params,
            &[Resource::buffer(1, p.out)],
            &p.table,
            size,
            observe,
        )
    };
    let mut timings = Vec::new();
    let mut first_launch_seconds = 0.0;
    for kind in [RayKind::Primary, RayKind::Incoherent] {
        let params = p.params(kind);
        let mut gpu = Vec::new();
        let mut wall = Vec::new();
        for r in 0..config.repeats.max(1) + 1 {
            let t = Instant::now();
            let g = launch(
                &params,
                crate::launch::Observe {
                    timed: true,
                    counters: None,
                },
            )?;
            dev.synchronize()?;
            let elapsed = t.elapsed().as_secs_f64();
            if r == 0 {
                // The first launch compiles the kernel on drivers that compile lazily.
                if kind == RayKind::Primary {
                    first_launch_seconds = p.pipeline_start.elapsed().as_secs_f64();
                }
                optik_core::measure::warm_up(|| {
                    launch(&params, crate::launch::Observe::default())?;
                    dev.synchronize()
                })?;
                continue;
            }
            wall.push(elapsed);
            gpu.extend(g);
        }
        let hits = p.hits(dev, rays)?;
        let traffic = if config.traffic {
            Some(count_traffic(&wgpu_device, |observe| {
                launch(&params, observe).map(drop)
            })?)
        } else {
            None
        };
        timings.push(TraceTiming {
            kind,
            rays,
            gpu_seconds: (!gpu.is_empty()).then(|| median(gpu)),
            wall_seconds: median(wall),
            hits,
            traffic,
        });
    }
    let stack_entries = wgpu_device
        .kernel_source(p.pipeline)?
        .lines()
        .find_map(|l| l.strip_prefix("const _OPTIK_STACK: u32 = "))
        .and_then(|v| v.trim_end_matches("u;").parse().ok());
    let bandwidth = if config.bandwidth_bytes > 0 {
        Some(bandwidth::measure(
            &wgpu_device,
            config.bandwidth_bytes,
            config.repeats,
        )?)
    } else {
        None
    };
    let gpu_timed = timings.iter().all(|t| t.gpu_seconds.is_some());
    Ok(BenchReport {
        device: device_name(dev),
        timing_method: if gpu_timed {
            "GPU timestamps around the compute pass (median)"
        } else {
            "wall clock around launch + synchronize (median; no timestamp queries)"
        },
        triangles: indices.len(),
        build_seconds: p.build_seconds,
        accel_bytes: dev.accel_size(p.gas)?,
        first_launch_seconds,
        camera: p.camera,
        stack_entries,
        timings,
        bandwidth,
    })
}

/// Runs `launch` once with the instrumented kernel and returns its counts.
fn count_traffic(
    dev: &WgpuDevice,
    launch: impl Fn(crate::launch::Observe<'_>) -> Result<()>,
) -> Result<TrafficCounts> {
    let gpu = dev.gpu();
    let buffer = gpu.scoped("allocating the traffic counters", || {
        // wgpu zero-fills new buffers.
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("optik traffic counters"),
            size: counters::BUFFER_BYTES,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    })?;
    launch(crate::launch::Observe {
        timed: false,
        counters: Some(&buffer),
    })?;
    let bytes = gpu.read(&buffer, 0, counters::BUFFER_BYTES)?;
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
    Ok(TrafficCounts::from_words(&words))
}

/// The traffic of one launch of `pipeline` on a wgpu device, counted by its instrumented
/// kernel: the launch runs as [`Device::launch`] would run it, with counting added.
pub fn launch_counted(
    dev: &WgpuDevice,
    pipeline: Pipeline,
    params: &[u8],
    resources: &[Resource],
    sbt: &ShaderBindingTable,
    size: LaunchSize,
) -> Result<TrafficCounts> {
    count_traffic(dev, |observe| {
        crate::launch::launch(
            dev,
            &mut dev.objects(),
            pipeline,
            params,
            resources,
            sbt,
            size,
            observe,
        )
        .map(drop)
    })
}

/// The same rays on any device through the public API, timed with the wall clock around
/// `launch` + `synchronize` (median of `config.repeats` after `optik_core::measure::warm_up`): how the
/// Vulkan backend is compared with this one. No traffic counts or bandwidth probe.
pub fn bench_device(
    dev: &dyn Device,
    vertices: &[[f32; 3]],
    indices: &[[u32; 3]],
    config: &BenchConfig,
) -> Result<BenchReport> {
    dev.set_accuracy(config.accuracy)?;
    let size = LaunchSize::new(config.width, config.height, 1);
    let rays = size.count();
    let p = prepare(dev, vertices, indices, config)?;
    let mut timings = Vec::new();
    let mut first_launch_seconds = 0.0;
    for kind in [RayKind::Primary, RayKind::Incoherent] {
        let params = p.params(kind);
        let mut wall = Vec::new();
        let run = || -> Result<()> {
            dev.launch(
                p.pipeline,
                &params,
                &[Resource::buffer(1, p.out)],
                &p.table,
                size,
            )?;
            dev.synchronize()
        };
        for r in 0..config.repeats.max(1) + 1 {
            let t = Instant::now();
            run()?;
            if r == 0 {
                if kind == RayKind::Primary {
                    first_launch_seconds = p.pipeline_start.elapsed().as_secs_f64();
                }
                optik_core::measure::warm_up(run)?;
                continue;
            }
            wall.push(t.elapsed().as_secs_f64());
        }
        timings.push(TraceTiming {
            kind,
            rays,
            gpu_seconds: None,
            wall_seconds: median(wall),
            hits: p.hits(dev, rays)?,
            traffic: None,
        });
    }
    Ok(BenchReport {
        device: device_name(dev),
        timing_method: "wall clock around launch + synchronize (median)",
        triangles: indices.len(),
        build_seconds: p.build_seconds,
        accel_bytes: dev.accel_size(p.gas)?,
        first_launch_seconds,
        camera: p.camera,
        stack_entries: None,
        timings,
        bandwidth: None,
    })
}

/// A closed test mesh when no model is at hand: a sphere of `rings × 2·rings` quads with a
/// bumpy radius, `4·rings²` triangles.
pub fn bumpy_sphere(rings: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let segments = 2 * rings;
    let mut vertices = Vec::new();
    for r in 0..=rings {
        for s in 0..segments {
            let theta = r as f32 / rings as f32 * std::f32::consts::PI;
            let phi = s as f32 / segments as f32 * std::f32::consts::TAU;
            let radius = 1.0 + 0.05 * (7.0 * theta).sin() * (5.0 * phi).cos();
            vertices.push([
                radius * theta.sin() * phi.cos(),
                radius * theta.cos(),
                radius * theta.sin() * phi.sin(),
            ]);
        }
    }
    let mut indices = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let a = r * segments + s;
            let b = r * segments + (s + 1) % segments;
            let c = a + segments;
            let d = b + segments;
            indices.push([a, c, d]);
            indices.push([a, d, b]);
        }
    }
    (vertices, indices)
}
