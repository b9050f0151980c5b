//! Ray casting through the public API: a raygen program reads rays from a buffer, traces them
//! against a triangle mesh, and the closest-hit program writes the hit record. This is what
//! `optik trace` runs and what the throughput benchmarks time — no side path around the API.

use crate::mesh::Mesh;
use optik::{
    Accel, AccelBuildOptions, Buffer, BufferView, BuildFlags, BuildInput, Device, GeometryFlags,
    LaunchSize, ModuleCompileOptions, Pipeline, PipelineCompileOptions, PipelineLinkOptions,
    ProgramGroupDesc, ProgramRef, ProgramSource, Resource, Result, SbtRecord, SbtRegion,
    ShaderBindingTable, TriangleArray,
};
use std::time::Instant;

/// Floats per ray in the input: origin xyz, tmin, direction xyz, tmax.
pub const RAY_FLOATS: usize = 8;
/// Words per hit in the output: t, prim, inst, u, v.
const HIT_WORDS: usize = 5;
/// Rays per launch: 2^20 rays bind 32 MiB of rays and 20 MiB of hits, under the smallest
/// storage binding limit WebGPU and Vulkan guarantee (128 MiB; lavapipe's), so any number
/// of rays the host holds can be traced (a launch per batch).
pub const BATCH_RAYS: usize = 1 << 20;

/// Launch width; the height covers the rest of the rays.
const LAUNCH_WIDTH: u32 = 4096;

/// The programs: the ray layout above in, the hit record out.
pub const PROGRAMS: &str = r#"
struct Params { scene: vec2<u32>, count: u32, width: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rays: array<f32>;
@group(0) @binding(2) var<storage, read_write> hits: array<u32>;

const MISS_T: u32 = 0x7f800000u;      // +inf
const NO_PRIMITIVE: u32 = 0xFFFFFFFFu;

fn raygen__cast() {
    let id = rt_launch_index();
    let i = id.y * params.width + id.x;
    if i >= params.count { return; }
    let b = i * 8u;
    let origin = vec3<f32>(rays[b], rays[b + 1u], rays[b + 2u]);
    let direction = vec3<f32>(rays[b + 4u], rays[b + 5u], rays[b + 6u]);
    // Invalid rays run no program (DESIGN.md §4): the payload keeps these miss values.
    var p: RtPayload;
    p[0] = MISS_T;
    p[1] = NO_PRIMITIVE;
    p[2] = NO_PRIMITIVE;
    p[3] = 0u;
    p[4] = 0u;
    rt_trace(params.scene, origin, direction, rays[b + 3u], rays[b + 7u], 0.0,
             0xFFu, RT_RAY_FLAG_DISABLE_ANYHIT, 0u, 1u, 0u, &p);
    let o = i * 5u;
    hits[o] = p[0];
    hits[o + 1u] = p[1];
    hits[o + 2u] = p[2];
    hits[o + 3u] = p[3];
    hits[o + 4u] = p[4];
}

fn closesthit__record() {
    let bary = rt_triangle_barycentrics();
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(1u, rt_primitive_index());
    rt_set_payload(2u, rt_instance_id());
    rt_set_payload(3u, bitcast<u32>(bary.x));
    rt_set_payload(4u, bitcast<u32>(bary.y));
}

fn miss__none() {
}
"#;

/// Per-ray results, as `optik trace` writes them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hits {
    /// Hit distance, +inf on a miss.
    pub t: Vec<f32>,
    /// Triangle index in file order, 0xFFFFFFFF on a miss.
    pub prim: Vec<u32>,
    /// Instance id (0 for the single mesh), 0xFFFFFFFF on a miss.
    pub inst: Vec<u32>,
    /// Barycentric weight of the triangle's second vertex.
    pub u: Vec<f32>,
    /// Barycentric weight of the triangle's third vertex.
    pub v: Vec<f32>,
}

/// A mesh built on a device with the ray-casting pipeline ready to launch.
pub struct RayCaster<'d> {
    device: &'d dyn Device,
    accel: Accel,
    handle: [u32; 2],
    pipeline: Pipeline,
    sbt: ShaderBindingTable,
    owned: Vec<Buffer>,
    batch_rays: usize,
    /// Seconds the acceleration structure build took (including upload of the mesh).
    pub build_seconds: f64,
}

impl<'d> RayCaster<'d> {
    /// Uploads and builds `mesh`, compiles the programs and fills the SBT.
    pub fn new(device: &'d dyn Device, mesh: &Mesh) -> Result<RayCaster<'d>> {
        Self::with_options(device, mesh, &PipelineCompileOptions::default())
    }

    /// Like [`RayCaster::new`], with explicit pipeline options (the benchmark report forces
    /// features on to measure what specialisation saves).
    pub fn with_options(
        device: &'d dyn Device,
        mesh: &Mesh,
        pipeline_options: &PipelineCompileOptions,
    ) -> Result<RayCaster<'d>> {
        let mut owned = Vec::new();
        let mut upload = |bytes: &[u8]| -> Result<Buffer> {
            let b = device.create_buffer(bytes.len().max(4) as u64)?;
            owned.push(b);
            device.write_buffer(b, 0, bytes)?;
            Ok(b)
        };
        let start = Instant::now();
        let vertices = upload(bytemuck::cast_slice(&mesh.positions))?;
        let indices = upload(bytemuck::cast_slice(&mesh.triangles))?;
        let input = TriangleArray::new(
            BufferView::new(vertices),
            mesh.positions.len() as u32,
            GeometryFlags::DISABLE_ANYHIT,
        )
        .with_indices(BufferView::new(indices), mesh.triangles.len() as u32);
        let options = AccelBuildOptions {
            flags: BuildFlags::PREFER_FAST_TRACE,
            ..Default::default()
        };
        let accel = device.accel_build(&options, &[BuildInput::Triangles(input)])?;
        device.synchronize()?;
        let build_seconds = start.elapsed().as_secs_f64();
        let handle = device.traversable_handle(accel)?.to_words();

        let (module, _log) = device.create_module(
            &ModuleCompileOptions::default(),
            pipeline_options,
            &ProgramSource::new("raycast.wgsl", PROGRAMS),
        )?;
        let groups = device.create_program_groups(&[
            ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__cast")),
            ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__none"))),
            ProgramGroupDesc::closest_hit(ProgramRef::new(module, "closesthit__record")),
        ])?;
        let pipeline =
            device.create_pipeline(pipeline_options, &PipelineLinkOptions::default(), &groups)?;
        let mut table = Vec::new();
        for g in &groups {
            table.extend_from_slice(&device.sbt_record_pack_header(*g)?);
        }
        let sbt_buffer = upload(&table)?;
        let record = |i: u64| SbtRecord {
            buffer: sbt_buffer,
            offset: 32 * i,
        };
        let sbt = ShaderBindingTable {
            raygen: record(0),
            exception: None,
            miss: Some(SbtRegion {
                buffer: sbt_buffer,
                offset: 32,
                stride: 32,
                count: 1,
            }),
            hitgroup: Some(SbtRegion {
                buffer: sbt_buffer,
                offset: 64,
                stride: 32,
                count: 1,
            }),
            callables: None,
        };
        Ok(RayCaster {
            device,
            accel,
            handle,
            pipeline,
            sbt,
            owned,
            batch_rays: BATCH_RAYS,
            build_seconds,
        })
    }

    /// The features the pipeline was compiled with.
    pub fn features(&self) -> Result<optik::FeatureSet> {
        self.device.pipeline_features(self.pipeline)
    }

    /// Rays per launch from now on (at least 1; the default is [`BATCH_RAYS`]).
    pub fn set_batch_rays(&mut self, rays: usize) {
        self.batch_rays = rays.max(1);
    }

    /// Uploads `rays` (`RAY_FLOATS` floats each) and hit buffers for them: a launch to run
    /// as often as wanted (its buffers are freed when it drops). Rays go in batches of at
    /// most [`RayCaster::set_batch_rays`], each with its own buffers and launch, so no
    /// binding exceeds a device's storage binding limit however many rays there are.
    pub fn upload(&self, rays: &[f32]) -> Result<Launch<'d>> {
        let n = rays.len() / RAY_FLOATS;
        let d = self.device;
        let mut launch = Launch {
            device: d,
            rays: n,
            batches: Vec::new(),
        };
        for (k, chunk) in rays[..n * RAY_FLOATS]
            .chunks(self.batch_rays * RAY_FLOATS)
            .enumerate()
        {
            let m = chunk.len() / RAY_FLOATS;
            // Pushed before the writes: on an error the launch drops and frees them.
            let ray_buffer = d.create_buffer((chunk.len() * 4).max(4) as u64)?;
            let hit_buffer = match d.create_buffer((m * HIT_WORDS * 4).max(4) as u64) {
                Ok(b) => b,
                Err(e) => {
                    let _ = d.destroy_buffer(ray_buffer);
                    return Err(e);
                }
            };
            let mut params = Vec::with_capacity(16);
            for w in [self.handle[0], self.handle[1], m as u32, LAUNCH_WIDTH] {
                params.extend_from_slice(&w.to_le_bytes());
            }
            launch.batches.push(Batch {
                first: k * self.batch_rays,
                rays: m,
                params,
                resources: [
                    Resource::buffer(1, ray_buffer),
                    Resource::buffer(2, hit_buffer),
                ],
                ray_buffer,
                hit_buffer,
                size: LaunchSize::new(
                    LAUNCH_WIDTH.min(m as u32),
                    (m as u32).div_ceil(LAUNCH_WIDTH),
                    1,
                ),
            });
            d.write_buffer(ray_buffer, 0, bytemuck::cast_slice(chunk))?;
        }
        Ok(launch)
    }

    /// Runs `launch` once (a launch per batch) and waits for it.
    pub fn run(&self, launch: &Launch) -> Result<()> {
        let d = self.device;
        for b in &launch.batches {
            d.launch(self.pipeline, &b.params, &b.resources, &self.sbt, b.size)
                .map_err(|e| {
                    e.context(format!("tracing rays {}..{}", b.first, b.first + b.rays))
                })?;
        }
        d.synchronize()
    }

    /// The hits `launch` wrote.
    pub fn hits(&self, launch: &Launch) -> Result<Hits> {
        let mut hits = Hits::default();
        for b in &launch.batches {
            let mut raw = vec![0u8; b.rays * HIT_WORDS * 4];
            self.device.read_buffer(b.hit_buffer, 0, &mut raw)?;
            let words: &[u32] = bytemuck::cast_slice(&raw);
            for h in words.chunks_exact(HIT_WORDS) {
                hits.t.push(f32::from_bits(h[0]));
                hits.prim.push(h[1]);
                hits.inst.push(h[2]);
                hits.u.push(f32::from_bits(h[3]));
                hits.v.push(f32::from_bits(h[4]));
            }
        }
        Ok(hits)
    }

    /// Traces `rays` (`RAY_FLOATS` floats each) `repeat` times; returns the hits and the best
    /// launch time in seconds.
    pub fn cast(&mut self, rays: &[f32], repeat: usize) -> Result<(Hits, f64)> {
        let launch = self.upload(rays)?;
        let mut best = f64::INFINITY;
        for _ in 0..repeat.max(1) {
            self.device.synchronize()?;
            let start = Instant::now();
            self.run(&launch)?;
            best = best.min(start.elapsed().as_secs_f64());
        }
        Ok((self.hits(&launch)?, best))
    }
}

/// Rays uploaded for a [`RayCaster`]: what the launches over them need. Its buffers are
/// freed when it drops.
pub struct Launch<'d> {
    device: &'d dyn Device,
    rays: usize,
    batches: Vec<Batch>,
}

/// One launch's share of the rays, with its own buffers.
struct Batch {
    first: usize,
    rays: usize,
    params: Vec<u8>,
    resources: [Resource; 2],
    ray_buffer: Buffer,
    hit_buffer: Buffer,
    size: LaunchSize,
}

impl Launch<'_> {
    /// The number of rays.
    pub fn rays(&self) -> usize {
        self.rays
    }

    /// The number of launches a run makes.
    pub fn batches(&self) -> usize {
        self.batches.len()
    }
}

impl Drop for Launch<'_> {
    fn drop(&mut self) {
        // Destroy errors only mean the device is gone, which frees everything anyway.
        for b in &self.batches {
            let _ = self.device.destroy_buffer(b.ray_buffer);
            let _ = self.device.destroy_buffer(b.hit_buffer);
        }
    }
}

impl Drop for RayCaster<'_> {
    fn drop(&mut self) {
        // Errors here mean the device is already gone, which frees everything anyway.
        let _ = self.device.destroy_pipeline(self.pipeline);
        let _ = self.device.destroy_accel(self.accel);
        for b in self.owned.drain(..) {
            let _ = self.device.destroy_buffer(b);
        }
    }
}
