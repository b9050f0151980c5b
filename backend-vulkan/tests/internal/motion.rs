//! Motion on Vulkan: pipelines created before motion structures existed are refused at launch
//! (this backend's motion proxies; the CPU backend serves them with key 0). Also, until they
//! move to optik-conformance's `tests/rules/` (rules for every backend that only these tests
//! check): nested motion chains and pipelines without motion (key 0), children destroyed and
//! refit under motion transforms, moving curves. Interpolation, clamping and vanish flags of
//! geometry keys and transforms are conformance's `motion.*` cases.

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

fn f(bits: u32) -> f32 {
    f32::from_bits(bits)
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
fn nested_motion_chains_and_pipelines_without_motion() {
    let dev = device();
    let moving = moving_triangle(&dev, MotionFlags::NONE);
    // An instance (+10 in y) over a matrix motion (+0 -> +4 in x) over an instance (+1 in x)
    // over a moving triangle (+0 -> +2 in x); a motion transform over that motion transform.
    let mut inner = Instance::new(dev.traversable_handle(moving).unwrap());
    inner.transform[3] = 1.0;
    inner.instance_id = 5;
    let inner_ias = dev.instances(&[inner]);
    let mut m1 = IDENTITY_3X4;
    m1[3] = 4.0;
    let motion = dev
        .create_transform(&TransformDesc::MatrixMotion {
            child: dev.traversable_handle(inner_ias).unwrap(),
            motion: motion_options(MotionFlags::NONE),
            keys: vec![IDENTITY_3X4, m1],
        })
        .unwrap();
    let mut lift = IDENTITY_3X4;
    lift[7] = 10.0;
    let outer_motion = dev
        .create_transform(&TransformDesc::MatrixMotion {
            child: dev.traversable_handle(motion).unwrap(),
            motion: motion_options(MotionFlags::NONE),
            keys: vec![lift, lift],
        })
        .unwrap();
    let mut outer = Instance::new(dev.traversable_handle(outer_motion).unwrap());
    outer.transform[7] = 10.0;
    let ias = dev.instances(&[outer]);
    let handle = dev.traversable_handle(ias).unwrap();
    let k = kit(&dev, PipelineCompileOptions::default());
    // At t: x offset 1 + 4t (transforms) + 2t (vertices); y offset 20.
    let rays = [
        down(1.25, 20.25, 0.0),
        down(1.25 + 3.0, 20.25, 0.5),
        down(1.25 + 6.0, 20.25, 1.0),
        down(1.25, 20.25, 0.5),
    ];
    let out = cast(&dev, &k, handle, &rays);
    assert_eq!(
        &out.iter().map(|r| r[0]).collect::<Vec<_>>(),
        &[0, 0, 0, 0xFFFF]
    );
    assert_eq!(out[1][12], 5, "the instance closest to the geometry");
    assert_eq!(
        f(out[1][6]),
        1.0 + 2.0,
        "object_to_world: the instance and the motion at t = 0.5"
    );
    assert_eq!(f(out[1][7]), 20.0);
    assert_eq!(
        f(out[1][3]),
        0.25 + 1.0,
        "object space of the moving triangle"
    );
    // A pipeline compiled without motion uses key 0 everywhere and a time of 0.
    let options = PipelineCompileOptions {
        uses_motion_blur: Setting::Value(false),
        ..Default::default()
    };
    let still = kit(&dev, options);
    assert!(!dev.pipeline_features(still.pipeline).unwrap().motion);
    let out = cast(&dev, &still, handle, &rays);
    assert_eq!(
        &out.iter().map(|r| r[0]).collect::<Vec<_>>(),
        &[0, 0xFFFF, 0xFFFF, 0]
    );
    assert_eq!(f(out[3][2]), 0.0, "rt_ray_time without motion");
    dev.assert_no_messages();
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

#[test]
fn moving_curves_follow_their_keys() {
    let dev = device();
    // A linear segment from (0, 0, 0) to (1, 0, 0), radius 0.25, moving +2 in x and growing
    // to radius 0.5.
    let key = |dx: f32| dev.f32_buffer(&[dx, 0.0, 0.0, dx + 1.0, 0.0, 0.0]);
    let radius = |r: f32| dev.f32_buffer(&[r, r]);
    let curves = CurveArray {
        curve_type: CurveType::RoundLinear,
        num_primitives: 1,
        vertex_buffers: vec![BufferView::new(key(0.0)), BufferView::new(key(2.0))],
        num_vertices: 2,
        vertex_stride: 0,
        width_buffers: vec![BufferView::new(radius(0.25)), BufferView::new(radius(0.5))],
        width_stride: 0,
        index_buffer: BufferView::new(dev.u32_buffer(&[0])),
        index_stride: 0,
        flag: GeometryFlags::DISABLE_ANYHIT,
        primitive_index_offset: 0,
        endcaps: CurveEndcaps::Default,
    };
    let options = AccelBuildOptions {
        motion: Some(motion_options(MotionFlags::NONE)),
        ..Default::default()
    };
    let gas = dev
        .accel_build(&options, &[BuildInput::Curves(curves)])
        .unwrap();
    let (m, _) = dev
        .create_module(
            &ModuleCompileOptions::default(),
            &PipelineCompileOptions::default(),
            &ProgramSource::new("motion.wgsl", PROGRAMS),
        )
        .unwrap();
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let curve = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__custom")),
        any_hit: None,
        intersection: None,
        builtin: BuiltinIntersector::Curve(CurveType::RoundLinear),
    });
    let pipeline = dev.pipeline(&[rg, ms, curve], 1);
    let mut table = Table::new(rg);
    table.miss.push((ms, &[]));
    table.hit.push((curve, &[]));
    let k = Kit {
        pipeline,
        sbt: table.build(&dev),
    };
    let rays = [
        down(0.5, 0.0, 0.0),
        down(1.5, 0.0, 0.5),
        down(0.5, 0.0, 0.5),
        down(2.5, 0.0, 1.0),
    ];
    let out = cast(&dev, &k, dev.traversable_handle(gas).unwrap(), &rays);
    assert_eq!(out[0][0], 0, "key 0");
    assert!(
        (f(out[0][1]) - 4.75).abs() < 1e-4,
        "radius 0.25 at key 0: t {}",
        f(out[0][1])
    );
    assert_eq!(out[1][0], 0, "halfway");
    assert!(
        (f(out[1][1]) - 4.625).abs() < 1e-4,
        "radius 0.375 halfway: t {}",
        f(out[1][1])
    );
    assert_eq!(out[2][0], 0xFFFF, "moved away");
    assert_eq!(out[3][0], 0, "key 1");
    assert!((f(out[3][1]) - 4.5).abs() < 1e-4);
    dev.assert_no_messages();
}
