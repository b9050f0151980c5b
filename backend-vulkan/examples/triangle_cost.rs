//! What optik's own triangle test costs on this device against the driver's triangles, in one
//! run: the same mesh and rays under `TriangleTest::Watertight` (the default),
//! `MollerTrumbore` and `Driver` (native Vulkan triangles).
//!
//! `cargo run -p optik-vulkan --example triangle_cost [subdivisions] [width] [rounds]`
//! prints, per test, the build time, the best launch, the rays per second and the ratio to
//! the driver's. The mesh is an icosphere (20 · 4^subdivisions triangles, default 6 =
//! 81 920) seen by a pinhole camera of width × width rays (default 512), about 37% of which
//! hit. Each test has its own device (the triangle path is a device setting); launches of
//! the three alternate for `rounds` rounds (default 20), so that load from other processes
//! falls on all of them alike, and the best of each counts.

use optik_api::*;
use optik_vulkan::{VulkanBackend, VulkanDevice, VulkanOptions};
use std::time::Instant;

const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, width: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn raygen__rg() {
    let id = rt_launch_index();
    let w = f32(params.width);
    let x = (f32(id.x) + 0.5) / w * 3.0 - 1.5;
    let y = (f32(id.y) + 0.5) / w * 3.0 - 1.5;
    var p: RtPayload;
    p[0] = 0xFFFFFFFFu;
    rt_trace(params.handle, vec3<f32>(0.0, 0.0, 4.0), normalize(vec3<f32>(x, y, -4.0)), 0.0, 1e30, 0.0, 0xFFu, RT_RAY_FLAG_DISABLE_ANYHIT, 0u, 1u, 0u, &p);
    out[id.x + id.y * params.width] = p[0];
}

fn closesthit__ch() {
    rt_set_payload(0u, rt_primitive_index());
}

fn miss__ms() {
}
"#;

/// The shared icosphere (`optik_api::shapes`), flattened for buffer upload.
fn icosphere(subdivisions: u32) -> (Vec<f32>, Vec<u32>) {
    let (vertices, triangles) = optik_api::shapes::icosphere(subdivisions);
    (
        vertices.into_iter().flatten().collect(),
        triangles.into_iter().flatten().collect(),
    )
}

/// A device set up to trace the camera under one accuracy.
struct Setup {
    dev: VulkanDevice,
    pipeline: Pipeline,
    sbt: ShaderBindingTable,
    out: Buffer,
    params: Vec<u8>,
    width: u32,
    /// Seconds the acceleration structure build took.
    build: f64,
}

impl Setup {
    /// Opens a device, builds the mesh and the pipeline under `accuracy`.
    fn new(accuracy: Accuracy, mesh: &(Vec<f32>, Vec<u32>), width: u32) -> Result<Setup> {
        let options = VulkanOptions {
            validation: false,
            pipeline_cache: false,
            ..VulkanOptions::from_env()
        };
        let dev = VulkanBackend::open(&options).map(VulkanDevice::new)?;
        dev.set_accuracy(accuracy)?;
        let upload = |bytes: &[u8]| -> Result<Buffer> {
            let b = dev.create_buffer(bytes.len().max(4) as u64)?;
            dev.write_buffer(b, 0, bytes)?;
            Ok(b)
        };
        let vb = upload(bytemuck::cast_slice(&mesh.0))?;
        let ib = upload(bytemuck::cast_slice(&mesh.1))?;
        let start = Instant::now();
        let input = TriangleArray::new(
            BufferView::new(vb),
            (mesh.0.len() / 3) as u32,
            GeometryFlags::DISABLE_ANYHIT,
        )
        .with_indices(BufferView::new(ib), (mesh.1.len() / 3) as u32);
        let options = AccelBuildOptions {
            flags: BuildFlags::PREFER_FAST_TRACE,
            ..Default::default()
        };
        let gas = dev.accel_build(&options, &[BuildInput::Triangles(input)])?;
        dev.synchronize()?;
        let build = start.elapsed().as_secs_f64();
        let (m, _) = dev.create_module(
            &ModuleCompileOptions::default(),
            &PipelineCompileOptions::default(),
            &ProgramSource::new("triangle_cost.wgsl", PROGRAMS),
        )?;
        let groups = dev.create_program_groups(&[
            ProgramGroupDesc::Raygen(ProgramRef::new(m, "raygen__rg")),
            ProgramGroupDesc::Miss(Some(ProgramRef::new(m, "miss__ms"))),
            ProgramGroupDesc::closest_hit(ProgramRef::new(m, "closesthit__ch")),
        ])?;
        let pipeline = dev.create_pipeline(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions::default(),
            &groups,
        )?;
        let mut table = Vec::new();
        for g in &groups {
            table.extend_from_slice(&dev.sbt_record_pack_header(*g)?);
        }
        let sbt = ShaderBindingTable::raygen_miss_hit(upload(&table)?);
        let out = dev.create_buffer(width as u64 * width as u64 * 4)?;
        let handle = dev.traversable_handle(gas)?.to_words();
        let params: Vec<u8> = [handle[0], handle[1], width, 0]
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect();
        let setup = Setup {
            dev,
            pipeline,
            sbt,
            out,
            params,
            width,
            build,
        };
        // The first launch compiles the pipeline in the driver; it is not counted.
        setup.launch()?;
        Ok(setup)
    }

    /// One launch, waited for; its seconds.
    fn launch(&self) -> Result<f64> {
        self.dev.synchronize()?;
        let start = Instant::now();
        self.dev.launch(
            self.pipeline,
            &self.params,
            &[Resource::buffer(1, self.out)],
            &self.sbt,
            LaunchSize::new(self.width, self.width, 1),
        )?;
        self.dev.synchronize()?;
        Ok(start.elapsed().as_secs_f64())
    }

    /// Rays that hit something.
    fn hits(&self) -> Result<usize> {
        let mut bytes = vec![0u8; self.width as usize * self.width as usize * 4];
        self.dev.read_buffer(self.out, 0, &mut bytes)?;
        Ok(bytes
            .chunks_exact(4)
            .filter(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]) != u32::MAX)
            .count())
    }
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let subdivisions: u32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(6);
    let width: u32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(512);
    let rounds: u32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(20);
    let mesh = icosphere(subdivisions);
    let tests = [
        TriangleTest::Driver,
        TriangleTest::Watertight,
        TriangleTest::MollerTrumbore,
    ];
    let setups: Vec<Setup> = tests
        .iter()
        .map(|&triangle| {
            let accuracy = Accuracy {
                triangle,
                box_test: BoxTest::Conservative,
            };
            Setup::new(accuracy, &mesh, width)
        })
        .collect::<Result<_>>()?;
    println!(
        "{}: {} triangles, {}x{} rays, best of {rounds} alternating rounds",
        setups[0].dev.properties().device_name,
        mesh.1.len() / 3,
        width,
        width
    );
    let mut best = [f64::INFINITY; 3];
    for _ in 0..rounds {
        for (b, s) in best.iter_mut().zip(&setups) {
            *b = b.min(s.launch()?);
        }
    }
    let rays = width as f64 * width as f64;
    println!("test            build ms  trace ms  Mrays/s  trace / driver  hits");
    for ((triangle, s), trace) in tests.iter().zip(&setups).zip(best) {
        println!(
            "{:<15} {:>8.1}  {:>8.2}  {:>7.2}  {:>14.2}  {}",
            format!("{triangle:?}"),
            s.build * 1e3,
            trace * 1e3,
            rays / trace / 1e6,
            trace / best[0],
            s.hits()?
        );
    }
    Ok(())
}
