//! Motion on Vulkan: pipelines created before motion structures existed are refused at launch
//! (this backend's motion proxies; the CPU backend serves them with key 0), and a child of a
//! motion transform refit after its parent instance structure was built is traced where it
//! now is without rebuilding the parent (this backend's motion proxies; on the CPU and wgpu
//! backends the parent keeps the bounds it was built with and the moved child is missed until
//! the parent is rebuilt or updated, as OptiX asks of parents of changed children). The
//! motion rules every backend keeps are
//! conformance's `motion.*` cases and `tests/rules/motion.rs`.

use crate::common::*;
use optik_api::*;

/// Rays from a buffer (origin, time, direction, tmax), one record out per ray.
const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, n: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read> rays: array<f32>;

const WORDS: u32 = 16u;

fn raygen__rg() {
    let i = rt_launch_index().x;
    let b = i * 8u;
    var p: RtPayload;
    p[0] = 0xFFFFu;
    rt_trace(params.handle, vec3<f32>(rays[b], rays[b + 1u], rays[b + 2u]), vec3<f32>(rays[b + 4u], rays[b + 5u], rays[b + 6u]),
        0.0, rays[b + 7u], rays[b + 3u], 0xFFu, 0u, 0u, 1u, 0u, &p);
    for (var k = 0u; k < WORDS; k++) {
        out[i * WORDS + k] = p[k];
    }
}

fn record() {
    let m = rt_object_to_world();
    let w = rt_world_to_object();
    let o = rt_object_ray_origin();
    rt_set_payload(0u, rt_primitive_index());
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, bitcast<u32>(rt_ray_time()));
    rt_set_payload(3u, bitcast<u32>(o.x));
    rt_set_payload(4u, bitcast<u32>(o.y));
    rt_set_payload(5u, bitcast<u32>(o.z));
    // object_to_world: the translation column and the first column.
    rt_set_payload(6u, bitcast<u32>(m[3].x));
    rt_set_payload(7u, bitcast<u32>(m[3].y));
    rt_set_payload(8u, bitcast<u32>(m[3].z));
    rt_set_payload(9u, bitcast<u32>(m[0].x));
    rt_set_payload(10u, bitcast<u32>(m[0].y));
    // world_to_object applied to the world origin.
    let wo = w * vec4<f32>(rt_world_ray_origin(), 1.0);
    rt_set_payload(11u, bitcast<u32>(wo.x));
    rt_set_payload(12u, rt_instance_id());
    rt_set_payload(13u, rt_hit_kind());
}

fn closesthit__tri() {
    record();
    let v = rt_triangle_vertices();
    rt_set_payload(14u, bitcast<u32>(v[0].x));
    rt_set_payload(15u, bitcast<u32>(v[1].y));
}

fn closesthit__sphere() {
    record();
    let s = rt_sphere();
    rt_set_payload(14u, bitcast<u32>(s.x));
    rt_set_payload(15u, bitcast<u32>(s.w));
}

fn closesthit__custom() {
    record();
    rt_set_payload(14u, rt_get_attribute(0u));
}

// Custom primitives: a plane at object-space z = 0 over the primitive's box, hit when the ray
// crosses it; attribute 0 counts the program's runs (always 1 per report).
fn intersection__plane() {
    let o = rt_object_ray_origin();
    let d = rt_object_ray_direction();
    let t = -o.z / d.z;
    var a: RtAttributes;
    a[0] = bitcast<u32>(rt_ray_time());
    rt_report_intersection(t, 0u, a);
}

fn miss__ms() {
}
"#;

const WORDS: usize = 16;

/// A ray straight down at (x, y) from z = 5, at `time`.
fn down(x: f32, y: f32, time: f32) -> [f32; 8] {
    [x, y, 5.0, time, 0.0, 0.0, -1.0, 100.0]
}

struct Kit {
    pipeline: Pipeline,
    sbt: ShaderBindingTable,
}

/// The pipeline (hit records 0 triangles, 1 spheres, 2 custom) with `options`.
fn kit(dev: &TestDevice, options: PipelineCompileOptions) -> Kit {
    let (m, _) = dev
        .create_module(
            &ModuleCompileOptions::default(),
            &options,
            &ProgramSource::new("motion.wgsl", PROGRAMS),
        )
        .unwrap();
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let tri = dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__tri")));
    let sphere = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__sphere")),
        any_hit: None,
        intersection: None,
        builtin: BuiltinIntersector::Sphere,
    });
    let custom = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__custom")),
        any_hit: None,
        intersection: Some(prog(m, "intersection__plane")),
        builtin: BuiltinIntersector::Triangle,
    });
    let pipeline = dev
        .create_pipeline(
            &options,
            &PipelineLinkOptions::default(),
            &[rg, ms, tri, sphere, custom],
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let mut table = Table::new(rg);
    table.miss.push((ms, &[]));
    table.hit = vec![(tri, &[]), (sphere, &[]), (custom, &[])];
    Kit {
        pipeline,
        sbt: table.build(dev),
    }
}

fn cast(
    dev: &TestDevice,
    kit: &Kit,
    handle: TraversableHandle,
    rays: &[[f32; 8]],
) -> Vec<[u32; WORDS]> {
    let words: Vec<f32> = rays.iter().flatten().copied().collect();
    let buffer = dev.f32_buffer(&words);
    let out = run_rays(
        dev,
        kit.pipeline,
        &kit.sbt,
        handle,
        rays.len() as u32,
        WORDS as u32,
        &[Resource::buffer(2, buffer)],
    );
    out.chunks(WORDS)
        .map(|c| std::array::from_fn(|k| c[k]))
        .collect()
}

fn motion_options(flags: MotionFlags) -> MotionOptions {
    MotionOptions {
        num_keys: 2,
        flags,
        time_begin: 0.0,
        time_end: 1.0,
    }
}

/// A triangle (0,0) (1,0) (0,1) at z = 0 moving by +2 in x from key 0 to key 1.
fn moving_triangle(dev: &TestDevice, flags: MotionFlags) -> Accel {
    let k0 = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let k1 = [2.0f32, 0.0, 0.0, 3.0, 0.0, 0.0, 2.0, 1.0, 0.0];
    let mut t = TriangleArray::new(
        BufferView::new(dev.f32_buffer(&k0)),
        3,
        GeometryFlags::DISABLE_ANYHIT,
    );
    t.vertex_buffers.push(BufferView::new(dev.f32_buffer(&k1)));
    let options = AccelBuildOptions {
        motion: Some(motion_options(flags)),
        ..Default::default()
    };
    dev.accel_build(&options, &[BuildInput::Triangles(t)])
        .unwrap()
}

#[test]
fn children_of_motion_transforms_refit_and_destroyed() {
    let dev = device();
    let vb = dev.f32_buffer(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let t = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::DISABLE_ANYHIT);
    let options = AccelBuildOptions {
        flags: BuildFlags::ALLOW_UPDATE,
        ..Default::default()
    };
    let gas = dev
        .accel_build(&options, &[BuildInput::Triangles(t.clone())])
        .unwrap();
    let mut m1 = IDENTITY_3X4;
    m1[3] = 4.0;
    let motion = dev
        .create_transform(&TransformDesc::MatrixMotion {
            child: dev.traversable_handle(gas).unwrap(),
            motion: motion_options(MotionFlags::NONE),
            keys: vec![IDENTITY_3X4, m1],
        })
        .unwrap();
    let ias = dev.instances(&[Instance::new(dev.traversable_handle(motion).unwrap())]);
    let handle = dev.traversable_handle(ias).unwrap();
    let k = kit(&dev, PipelineCompileOptions::default());
    assert_eq!(cast(&dev, &k, handle, &[down(2.25, 0.25, 0.5)])[0][0], 0);
    // Refit the triangle 10 units up in y: the motion transform's path follows.
    dev.write_buffer(
        vb,
        0,
        bytemuck::cast_slice(&[0.0f32, 10.0, 0.0, 1.0, 10.0, 0.0, 0.0, 11.0, 0.0]),
    )
    .unwrap();
    let update = AccelBuildOptions {
        operation: BuildOperation::Update,
        ..options
    };
    dev.accel_update(gas, &update, &[BuildInput::Triangles(t)])
        .unwrap();
    let out = cast(
        &dev,
        &k,
        handle,
        &[down(2.25, 0.25, 0.5), down(2.25, 10.25, 0.5)],
    );
    assert_eq!(
        (out[0][0], out[1][0]),
        (0xFFFF, 0),
        "refit under the motion"
    );
    dev.destroy_accel(gas).unwrap();
    assert_eq!(
        cast(&dev, &k, handle, &[down(2.25, 10.25, 0.5)])[0][0],
        0xFFFF,
        "a destroyed child is missed"
    );
    dev.assert_no_messages();
}

#[test]
fn pipelines_created_before_motion_structures_are_refused_at_launch() {
    let dev = device();
    let k = kit(&dev, PipelineCompileOptions::default());
    let gas = moving_triangle(&dev, MotionFlags::NONE);
    let words: Vec<f32> = down(0.25, 0.25, 0.0).to_vec();
    let buffer = dev.f32_buffer(&words);
    let out = dev.create_buffer(64).unwrap();
    let e = dev
        .launch(
            k.pipeline,
            &params(dev.traversable_handle(gas).unwrap(), 1, 1),
            &[Resource::buffer(1, out), Resource::buffer(2, buffer)],
            &k.sbt,
            LaunchSize::new(1, 1, 1),
        )
        .unwrap_err();
    assert!(e.message().contains("motion"), "{e}");
}
