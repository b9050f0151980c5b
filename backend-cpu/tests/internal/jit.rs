//! WGSL programs through the JIT, end to end: create_module, groups, pipeline, launch.

use optik_api::*;
use optik_cpu::{CpuBackend, CpuDevice};

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
    let _launches = crate::shared();
    let dev = CpuBackend::with_threads(2).map(CpuDevice::new).unwrap();
    let handle = one_triangle(&dev);
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

/// The programs of one test launch: names in `source` (`None`: absent).
struct Programs<'a> {
    source: &'a str,
    closest_hit: Option<&'a str>,
    any_hit: Option<&'a str>,
    intersection: Option<&'a str>,
    exception: Option<&'a str>,
    options: PipelineCompileOptions,
}

/// Launches `raygen__main` of `p.source` once against `handle` (params: the handle) with
/// a zeroed `out` buffer of `words` words at binding 1; returns `out`.
fn launch_once(
    dev: &CpuDevice,
    handle: TraversableHandle,
    p: &Programs<'_>,
    words: usize,
) -> Vec<u32> {
    let (module, _) = dev
        .create_module(
            &ModuleCompileOptions::default(),
            &p.options,
            &ProgramSource::new("test.wgsl", p.source),
        )
        .unwrap();
    let r = |name: &str| ProgramRef::new(module, name);
    let mut descs = vec![
        ProgramGroupDesc::Raygen(r("raygen__main")),
        ProgramGroupDesc::Miss(None),
        ProgramGroupDesc::HitGroup {
            closest_hit: p.closest_hit.map(r),
            any_hit: p.any_hit.map(r),
            intersection: p.intersection.map(r),
            builtin: BuiltinIntersector::Triangle,
        },
    ];
    if let Some(e) = p.exception {
        descs.push(ProgramGroupDesc::Exception(r(e)));
    }
    let groups = dev.create_program_groups(&descs).unwrap();
    let pipeline = dev
        .create_pipeline(&p.options, &PipelineLinkOptions::default(), &groups)
        .unwrap();
    let sbt = sbt_of(dev, &groups);
    let out = dev.create_buffer(words as u64 * 4).unwrap();
    let params = handle.to_words();
    dev.launch(
        pipeline,
        bytemuck::cast_slice(&params),
        &[Resource::buffer(1, out)],
        &sbt,
        LaunchSize::new(1, 1, 1),
    )
    .unwrap();
    let mut bytes = vec![0u8; words * 4];
    dev.read_buffer(out, 0, &mut bytes).unwrap();
    bytemuck::cast_slice(&bytes).to_vec()
}

/// A table of one header-only record per group of `groups`: raygen, miss, hit group and,
/// when there is a fourth, exception.
pub fn sbt_of(dev: &CpuDevice, groups: &[ProgramGroup]) -> ShaderBindingTable {
    let mut table = Vec::new();
    for g in groups {
        table.extend_from_slice(&dev.sbt_record_pack_header(*g).unwrap());
    }
    let sbt_buffer = dev.create_buffer(table.len() as u64).unwrap();
    dev.write_buffer(sbt_buffer, 0, &table).unwrap();
    let record = |i: u64| SbtRecord {
        buffer: sbt_buffer,
        offset: 32 * i,
    };
    let region = |i: u64| SbtRegion {
        buffer: sbt_buffer,
        offset: 32 * i,
        stride: 32,
        count: 1,
    };
    ShaderBindingTable {
        raygen: record(0),
        exception: (groups.len() > 3).then(|| record(3)),
        miss: Some(region(1)),
        hitgroup: Some(region(2)),
        callables: None,
    }
}

const THROW_IN_CLOSEST_HIT: &str = r#"
@group(0) @binding(0) var<uniform> handle: vec2<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn trace_up() {
    var p: RtPayload;
    rt_trace(handle, vec3<f32>(0.25, 0.25, 0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0,
             0xFFu, 0u, 0u, 1u, 0u, &p);
    out[1] = 1u;
}

fn raygen__main() {
    out[0] = 1u;
    trace_up();
    out[2] = 1u;
}

fn closesthit__throw() {
    out[3] = 1u;
    rt_throw_exception(7u);
    out[4] = 1u;
}

fn exception__record() {
    out[5] = bitcast<u32>(rt_exception_code());
}
"#;

fn one_triangle(dev: &CpuDevice) -> TraversableHandle {
    triangles(dev, &[[0.0, 0.0, 5.0], [0.0, 4.0, 5.0], [4.0, 0.0, 5.0]])
}

/// A structure of the opaque triangles `vertices` (three a triangle).
pub fn triangles(dev: &CpuDevice, vertices: &[[f32; 3]]) -> TraversableHandle {
    let vb = dev.create_buffer(12 * vertices.len() as u64).unwrap();
    dev.write_buffer(vb, 0, bytemuck::cast_slice(vertices))
        .unwrap();
    let input = TriangleArray::new(
        BufferView::new(vb),
        vertices.len() as u32,
        GeometryFlags::DISABLE_ANYHIT,
    );
    let accel = dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Triangles(input)],
        )
        .unwrap();
    dev.traversable_handle(accel).unwrap()
}

#[test]
fn an_exception_in_a_closest_hit_ends_the_raygen_too() {
    let _launches = crate::shared();
    let dev = CpuBackend::with_threads(1).map(CpuDevice::new).unwrap();
    let handle = one_triangle(&dev);
    let mut programs = Programs {
        source: THROW_IN_CLOSEST_HIT,
        closest_hit: Some("closesthit__throw"),
        any_hit: None,
        intersection: None,
        exception: Some("exception__record"),
        options: PipelineCompileOptions::default(),
    };
    // Auto exception flags include USER (the module throws): the exception program runs,
    // and neither the helper nor the raygen goes on after rt_trace.
    let out = launch_once(&dev, handle, &programs, 6);
    assert_eq!(out, [1, 0, 0, 1, 0, 7]);
    // Without USER the throw ends only the closest-hit; the raygen goes on.
    programs.options.exception_flags = Setting::Value(ExceptionFlags::NONE);
    let out = launch_once(&dev, handle, &programs, 6);
    assert_eq!(out, [1, 1, 1, 1, 0, 0]);
}

const INTERSECT_TWICE: &str = r#"
@group(0) @binding(0) var<uniform> handle: vec2<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn raygen__main() {
    var p: RtPayload;
    rt_trace(handle, vec3<f32>(0.5, 0.5, -2.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0,
             0xFFu, 0u, 0u, 1u, 0u, &p);
    out[0] = p[0];
}

fn report(t: f32) -> bool {
    return rt_report_intersection(t, 0u, RtAttributes(0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u));
}

fn intersection__twice() {
    out[1] += 1u;
    let first = report(3.0);
    out[2] = select(10u, 11u, first);
    let second = report(2.5);
    out[3] = select(20u, 21u, second);
}

fn anyhit__stop() {
    out[4] += 1u;
    rt_terminate_ray();
}

fn anyhit__accept() {
    out[4] += 1u;
}

fn closesthit__seen() {
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
}
"#;

#[test]
fn an_intersection_program_stops_after_its_any_hit_terminates_the_ray() {
    let _launches = crate::shared();
    let dev = CpuBackend::with_threads(1).map(CpuDevice::new).unwrap();
    let aabb: [f32; 6] = [0.0, 0.0, 0.0, 1.0, 1.0, 4.0];
    let ab = dev.create_buffer(24).unwrap();
    dev.write_buffer(ab, 0, bytemuck::cast_slice(&aabb))
        .unwrap();
    let input = CustomPrimitiveArray::new(BufferView::new(ab), 1, GeometryFlags::NONE);
    let accel = dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::CustomPrimitives(input)],
        )
        .unwrap();
    let handle = dev.traversable_handle(accel).unwrap();
    let mut programs = Programs {
        source: INTERSECT_TWICE,
        closest_hit: Some("closesthit__seen"),
        any_hit: Some("anyhit__stop"),
        intersection: Some("intersection__twice"),
        exception: None,
        options: PipelineCompileOptions::default(),
    };
    // The first report is committed and ends the ray: the intersection program returns
    // inside `report` (nothing after it runs), the closest-hit sees t = 3.
    let out = launch_once(&dev, handle, &programs, 5);
    assert_eq!(out, [3.0f32.to_bits(), 1, 0, 0, 1]);
    // An any-hit that accepts lets the program go on to the nearer report.
    programs.any_hit = Some("anyhit__accept");
    let out = launch_once(&dev, handle, &programs, 5);
    assert_eq!(out, [2.5f32.to_bits(), 1, 11, 21, 2]);
}
