//! WGSL programs through the JIT, end to end: create_module, groups, pipeline, launch.

use optik_api::*;
use optik_cpu::CpuDevice;

const SOURCE: &str = r#"
struct Params {
    handle: vec2<u32>,
    width: u32,
    pad: u32,
}
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;

fn raygen__main() {
    let x = rt_launch_index().x;
    let origin = vec3<f32>(f32(x) + 0.25, 0.5, 0.0);
    var p: RtPayload;
    p[0] = 7u;
    rt_trace(params.handle, origin, vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[x] = vec4<f32>(bitcast<f32>(p[0]), bitcast<f32>(p[1]), bitcast<f32>(p[2]), f32(p[3]));
}

fn closesthit__main() {
    let b = rt_triangle_barycentrics();
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(1u, bitcast<u32>(b.x));
    rt_set_payload(2u, bitcast<u32>(b.y));
    rt_set_payload(3u, rt_sbt_data_u32(0u) + rt_primitive_index());
}

fn miss__main() {
    rt_set_payload(0u, bitcast<u32>(-1.0));
    rt_set_payload(3u, rt_sbt_data_u32(0u));
}
"#;

#[test]
fn wgsl_programs_trace_through_the_jit() {
    let dev = CpuDevice::with_threads(2).unwrap();
    let tri: [[f32; 3]; 3] = [[0.0, 0.0, 5.0], [0.0, 4.0, 5.0], [4.0, 0.0, 5.0]];
    let vb = dev.create_buffer(36).unwrap();
    dev.write_buffer(vb, 0, bytemuck::cast_slice(&tri)).unwrap();
    let input = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::DISABLE_ANYHIT);
    let accel = dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Triangles(input)],
        )
        .unwrap();
    let handle = dev.traversable_handle(accel).unwrap();
    let options = PipelineCompileOptions {
        num_payload_values: Setting::Value(4),
        ..Default::default()
    };
    let (module, log) = dev
        .create_module(
            &ModuleCompileOptions::default(),
            &options,
            &ProgramSource::new("trace.wgsl", SOURCE),
        )
        .unwrap();
    assert!(log.contains("trace.wgsl"), "{log}");
    let groups = dev
        .create_program_groups(&[
            ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__main")),
            ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__main"))),
            ProgramGroupDesc::closest_hit(ProgramRef::new(module, "closesthit__main")),
        ])
        .unwrap();
    let pipeline = dev
        .create_pipeline(&options, &PipelineLinkOptions::default(), &groups)
        .unwrap();
    let mut sbt_bytes = vec![0u8; 3 * 48];
    for (i, g) in groups.iter().enumerate() {
        sbt_bytes[i * 48..i * 48 + 32].copy_from_slice(&dev.sbt_record_pack_header(*g).unwrap());
        sbt_bytes[i * 48 + 32..i * 48 + 36].copy_from_slice(&(100 * i as u32).to_le_bytes());
    }
    let sbt_buffer = dev.create_buffer(sbt_bytes.len() as u64).unwrap();
    dev.write_buffer(sbt_buffer, 0, &sbt_bytes).unwrap();
    let region = |i: u64| SbtRegion {
        buffer: sbt_buffer,
        offset: i * 48,
        stride: 48,
        count: 1,
    };
    let sbt = ShaderBindingTable {
        raygen: SbtRecord {
            buffer: sbt_buffer,
            offset: 0,
        },
        exception: None,
        miss: Some(region(1)),
        hitgroup: Some(region(2)),
        callables: None,
    };
    let out = dev.create_buffer(6 * 16).unwrap();
    let words = handle.to_words();
    let params: [u32; 4] = [words[0], words[1], 6, 0];
    dev.launch(
        pipeline,
        bytemuck::cast_slice(&params),
        &[Resource::buffer(1, out)],
        &sbt,
        LaunchSize::new(6, 1, 1),
    )
    .unwrap();
    let mut bytes = vec![0u8; 6 * 16];
    dev.read_buffer(out, 0, &mut bytes).unwrap();
    let got: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
    for (x, px) in got.iter().enumerate() {
        if x < 4 {
            assert_eq!(px[0], 5.0, "t at {x}");
            assert!(
                (px[1] - 0.125).abs() < 1e-6 && (px[2] - (x as f32 + 0.25) / 4.0).abs() < 1e-6,
                "{px:?}"
            );
            assert_eq!(px[3], 200.0, "hit group record data");
        } else {
            assert_eq!((px[0], px[3]), (-1.0, 100.0), "miss at {x}");
        }
    }
    // Missing resources are reported before anything runs.
    let e = dev
        .launch(
            pipeline,
            bytemuck::cast_slice(&params),
            &[],
            &sbt,
            LaunchSize::new(6, 1, 1),
        )
        .unwrap_err();
    assert!(e.message().contains("binding 1"), "{e}");
    let e = dev
        .launch(
            pipeline,
            &[0u8; 4],
            &[Resource::buffer(1, out)],
            &sbt,
            LaunchSize::new(6, 1, 1),
        )
        .unwrap_err();
    assert!(e.message().contains("params is 4 bytes"), "{e}");
}
