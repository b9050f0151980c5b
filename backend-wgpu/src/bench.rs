//! A benchmark entry point for the GPU machine: primary and incoherent rays against a
//! triangle mesh, timed with GPU timestamps around the launch's compute pass.
//!
//! Rays are made in the raygen program from the launch index (a pinhole camera framing
//! the mesh, or random origins inside its box with random directions), so the timing is
//! traversal and intersection, not ray loading. Every ray's closest t is written out and
//! the hits are counted on the host as a check. `cargo run --release -p optik-wgpu
//! --example bench_trace -- [mesh.obj]` prints a report (see docs/wgpu-backend.md).

use crate::device::WgpuDevice;
use optik_api::{
    AccelBuildOptions, Accuracy, BufferView, BuildFlags, BuildInput, Device, Error, GeometryFlags,
    LaunchSize, ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions,
    ProgramGroupDesc, ProgramRef, ProgramSource, Resource, Result, SbtRecord, SbtRegion,
    ShaderBindingTable, TriangleArray,
};
use std::time::Instant;

/// Which rays a benchmark traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// One camera ray per pixel, framing the mesh's box.
    Primary,
    /// Origins uniform in the mesh's box, directions uniform on the sphere.
    Incoherent,
}

/// Timing of one kind of rays.
#[derive(Clone, Debug)]
pub struct TraceTiming {
    pub kind: RayKind,
    /// Rays per launch.
    pub rays: u64,
    /// Median GPU time of a launch (timestamps around the compute pass), when the adapter
    /// offers timestamp queries.
    pub gpu_seconds: Option<f64>,
    /// Median wall time of a launch including submission and waiting.
    pub wall_seconds: f64,
    /// Rays that hit the mesh.
    pub hits: u64,
}

impl TraceTiming {
    /// Million rays per second, from GPU time where there is one.
    pub fn mrays_per_second(&self) -> f64 {
        self.rays as f64 / self.gpu_seconds.unwrap_or(self.wall_seconds) / 1e6
    }
}

/// A benchmark run.
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub device: String,
    pub triangles: usize,
    /// Host build and upload of the acceleration structure.
    pub build_seconds: f64,
    /// Bytes of the acceleration structure on the GPU.
    pub accel_bytes: u64,
    /// Pipeline creation plus the first launch (which compiles the kernel on some drivers).
    pub first_launch_seconds: f64,
    /// Entries of the kernel's traversal stack (sized from the structure's depth).
    pub stack_entries: u32,
    pub timings: Vec<TraceTiming>,
}

impl std::fmt::Display for BenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "device           {}", self.device)?;
        writeln!(f, "triangles        {}", self.triangles)?;
        writeln!(
            f,
            "build            {:.3} s ({:.1} MiB on the GPU)",
            self.build_seconds,
            self.accel_bytes as f64 / (1 << 20) as f64
        )?;
        writeln!(f, "first launch     {:.3} s", self.first_launch_seconds)?;
        writeln!(f, "traversal stack  {} entries", self.stack_entries)?;
        for t in &self.timings {
            writeln!(
                f,
                "{:<16} {} rays, {:.1}% hit, {} gpu, {:.3} ms wall, {:.1} Mrays/s",
                format!("{:?}", t.kind).to_lowercase(),
                t.rays,
                100.0 * t.hits as f64 / t.rays as f64,
                t.gpu_seconds
                    .map(|s| format!("{:.3} ms", s * 1e3))
                    .unwrap_or_else(|| "n/a".into()),
                t.wall_seconds * 1e3,
                t.mrays_per_second()
            )?;
        }
        Ok(())
    }
}

const PROGRAMS: &str = r#"
struct Params { scene: vec2<u32>, kind: u32, seed: u32, lo: vec4<f32>, hi: vec4<f32> }
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
    let centre = 0.5 * (lo + hi);
    var origin: vec3<f32>;
    var direction: vec3<f32>;
    if params.kind == 0u {
        // A pinhole camera looking along (-1, -0.5, -1) at the box, framing it.
        let w = normalize(vec3<f32>(-1.0, -0.5, -1.0));
        let u = normalize(cross(w, vec3<f32>(0.0, 1.0, 0.0)));
        let v = cross(u, w);
        let radius = 0.5 * length(hi - lo);
        origin = centre - w * (radius / 0.5 * 1.1);
        let aspect = f32(dim.x) / f32(dim.y);
        let sx = ((f32(id.x) + 0.5) / f32(dim.x) * 2.0 - 1.0) * 0.5 * aspect;
        let sy = (1.0 - (f32(id.y) + 0.5) / f32(dim.y) * 2.0) * 0.5;
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

/// Builds `vertices` / `indices` into a GAS on a fresh device and times `repeats` launches
/// of `width × height` primary and incoherent rays with `accuracy`.
pub fn bench_trace(
    vertices: &[[f32; 3]],
    indices: &[[u32; 3]],
    width: u32,
    height: u32,
    repeats: u32,
    accuracy: Accuracy,
) -> Result<BenchReport> {
    if vertices.is_empty() || indices.is_empty() {
        return Err(Error::invalid("bench_trace needs a mesh with triangles"));
    }
    let wgpu_device = WgpuDevice::new()?;
    let dev: &dyn Device = &wgpu_device;
    dev.set_accuracy(accuracy)?;
    let upload = |bytes: &[u8]| -> Result<optik_api::Buffer> {
        let b = dev.create_buffer(bytes.len() as u64)?;
        dev.write_buffer(b, 0, bytes)?;
        Ok(b)
    };
    let vb = upload(bytemuck::cast_slice(vertices))?;
    let ib = upload(bytemuck::cast_slice(indices))?;
    let start = Instant::now();
    let input = BuildInput::Triangles(
        TriangleArray::new(
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
    let first = Instant::now();
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
    let rays = width as u64 * height as u64;
    let out = dev.create_buffer(rays * 4)?;
    let handle = dev.traversable_handle(gas)?;
    let mut timings = Vec::new();
    let mut first_launch_seconds = 0.0;
    for (k, kind) in [RayKind::Primary, RayKind::Incoherent]
        .into_iter()
        .enumerate()
    {
        let mut words: Vec<u32> = handle.to_words().to_vec();
        words.extend_from_slice(&[k as u32, 12345]);
        words.extend(lo.iter().map(|v| v.to_bits()));
        words.push(0);
        words.extend(hi.iter().map(|v| v.to_bits()));
        words.push(0);
        let mut gpu = Vec::new();
        let mut wall = Vec::new();
        for r in 0..repeats.max(1) + 1 {
            let t = Instant::now();
            let g = crate::launch::launch(
                &wgpu_device,
                pipeline,
                bytemuck::cast_slice(&words),
                &[Resource::buffer(1, out)],
                &table,
                LaunchSize::new(width, height, 1),
                Some(()),
            )?;
            dev.synchronize()?;
            let elapsed = t.elapsed().as_secs_f64();
            if k == 0 && r == 0 {
                // The first launch compiles the kernel on drivers that compile lazily.
                first_launch_seconds = first.elapsed().as_secs_f64();
                continue;
            }
            wall.push(elapsed);
            gpu.extend(g);
        }
        let mut t_bytes = vec![0u8; (rays * 4) as usize];
        dev.read_buffer(out, 0, &mut t_bytes)?;
        let hits = t_bytes
            .chunks_exact(4)
            .filter(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) != 0x7f80_0000)
            .count() as u64;
        timings.push(TraceTiming {
            kind,
            rays,
            gpu_seconds: (!gpu.is_empty()).then(|| median(gpu)),
            wall_seconds: median(wall),
            hits,
        });
    }
    let stack_entries = wgpu_device
        .kernel_source(pipeline)?
        .lines()
        .find_map(|l| l.strip_prefix("const OPTK_STACK: u32 = "))
        .and_then(|v| v.trim_end_matches("u;").parse().ok())
        .unwrap_or(0);
    Ok(BenchReport {
        stack_entries,
        device: dev.properties().device_name.clone(),
        triangles: indices.len(),
        build_seconds,
        accel_bytes: dev.accel_size(gas)?,
        first_launch_seconds,
        timings,
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
