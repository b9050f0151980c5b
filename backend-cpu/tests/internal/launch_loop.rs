//! A ray generation program compiled with its launch loop (`RepeatedCall::run_indices`,
//! docs/cpu-backend.md §5): every launch index runs once, in rows the loop steps along x,
//! programs the trace runs read the index the loop has reached, an exception ends its index
//! only, and the launch's stop flag is still read before every index.

use optik_api::*;
use optik_cpu::{CpuBackend, CpuDevice};

/// Launch size: rows longer than a launch task's 64 indices, and a depth, so that tasks
/// start and end inside rows and rows inside tasks.
const SIZE: [u32; 3] = [150, 3, 2];
/// Launch indices along x whose ray generation program throws (`x % THROWS == 1`).
const THROWS: u32 = 7;

const PROGRAMS: &str = r#"
@group(0) @binding(0) var<uniform> handle: vec2<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn raygen__main() {
    let id = rt_launch_index();
    let dims = rt_launch_dimensions();
    let i = (id.z * dims.y + id.y) * dims.x + id.x;
    // A ray that misses: the miss program reads the launch index from its own state.
    var p: RtPayload;
    p[0] = 0u;
    rt_trace(handle, vec3<f32>(100.0, 100.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0,
             0xFFu, 0u, 0u, 1u, 0u, &p);
    out[2u * i] = id.x | (id.y << 10u) | (id.z << 20u);
    if id.x % 7u == 1u {
        rt_throw_exception(5u);
    }
    out[2u * i + 1u] = p[0];
}

fn miss__index() {
    let id = rt_launch_index();
    rt_set_payload(0u, 1u + (id.x | (id.y << 10u) | (id.z << 20u)));
}

fn closesthit__none() {
}

fn exception__count() {
    let id = rt_launch_index();
    let dims = rt_launch_dimensions();
    let i = (id.z * dims.y + id.y) * dims.x + id.x;
    out[2u * i + 1u] = 0xE0000000u | bitcast<u32>(rt_exception_code());
}
"#;

/// What `PROGRAMS` writes for each launch index, pair by pair.
fn expected() -> Vec<u32> {
    let [w, h, d] = SIZE;
    let mut want = Vec::new();
    for z in 0..d {
        for y in 0..h {
            for x in 0..w {
                let packed = x | y << 10 | z << 20;
                let second = if x % THROWS == 1 {
                    0xE000_0005
                } else {
                    packed + 1
                };
                want.extend([packed, second]);
            }
        }
    }
    want
}

#[test]
fn a_launch_loop_runs_every_index_once_and_an_exception_ends_its_index_only() {
    let _launches = crate::shared();
    for threads in [1, 3] {
        let dev = CpuBackend::with_threads(threads)
            .map(CpuDevice::new)
            .unwrap();
        let options = PipelineCompileOptions {
            num_payload_values: Setting::Value(1),
            exception_flags: Setting::Value(ExceptionFlags::USER),
            ..Default::default()
        };
        let (module, log) = dev
            .create_module(
                &ModuleCompileOptions::default(),
                &options,
                &ProgramSource::new("launch_loop.wgsl", PROGRAMS),
            )
            .unwrap();
        if cfg!(target_os = "linux") {
            assert!(log.contains("compiled with their launch loop"), "{log}");
        }
        let program = |name: &str| ProgramRef::new(module, name);
        let groups = dev
            .create_program_groups(&[
                ProgramGroupDesc::Raygen(program("raygen__main")),
                ProgramGroupDesc::Miss(Some(program("miss__index"))),
                ProgramGroupDesc::closest_hit(program("closesthit__none")),
                ProgramGroupDesc::Exception(program("exception__count")),
            ])
            .unwrap();
        let pipeline = dev
            .create_pipeline(&options, &PipelineLinkOptions::default(), &groups)
            .unwrap();
        let sbt = crate::jit::sbt_of(&dev, &groups);
        let handle =
            crate::jit::triangles(&dev, &[[0.0, 0.0, 5.0], [0.0, 1.0, 5.0], [1.0, 0.0, 5.0]]);
        let want = expected();
        let out = dev.create_buffer(want.len() as u64 * 4).unwrap();
        dev.launch(
            pipeline,
            bytemuck::cast_slice(&handle.to_words()),
            &[Resource::buffer(1, out)],
            &sbt,
            LaunchSize::new(SIZE[0], SIZE[1], SIZE[2]),
        )
        .unwrap();
        let mut bytes = vec![0u8; want.len() * 4];
        dev.read_buffer(out, 0, &mut bytes).unwrap();
        let got: Vec<u32> = bytemuck::cast_slice(&bytes).to_vec();
        for (i, (g, w)) in got.chunks(2).zip(want.chunks(2)).enumerate() {
            assert_eq!(g, w, "launch index {i} on {threads} threads");
        }
    }
}
