//! Programs from several modules, vertex and index formats, vertex data access, textures,
//! 3D launch indices, instance flag precedence, scenes that grow after linking.
mod common;
use common::*;
use optik_api::*;

#[test]
fn programs_from_two_modules_with_their_own_bindings() {
    let dev = device();
    let d = dev.as_ref();
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    // Module A: raygen and miss; its `out` is binding 1. Module B: closest-hit, with a
    // differently shaped parameter struct and its own buffer at binding 3.
    let a = module(
        d,
        r#"
struct Params { handle: vec2<u32>, x: f32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
fn helper() -> u32 { return 5u; }
fn raygen__a() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = helper();
    rt_trace(params.handle, vec3<f32>(params.x + f32(i) * 3.0, 0.5, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[i] = p[0];
}
fn miss__a() { rt_set_payload(0u, rt_get_payload(0u) + helper()); }
"#,
    );
    let b = module(
        d,
        r#"
struct Other { a: vec4<u32> }
@group(0) @binding(0) var<uniform> params: Other;
@group(0) @binding(3) var<storage, read> table: array<u32>;
fn helper() -> u32 { return 1000u; }
fn closesthit__b() { rt_set_payload(0u, table[0] + helper() + params.a.w); }
"#,
    );
    let g = groups(
        d,
        &[
            raygen(a, "raygen__a"),
            miss(a, "miss__a"),
            closest_hit(b, "closesthit__b"),
        ],
    );
    let p = pipeline(d, &g, 1);
    let table = sbt(d, &g, &[]);
    let data = buffer(d, &[7u32]);
    let out = d.create_buffer(8).unwrap();
    let h = d.traversable_handle(gas).unwrap();
    let mut words = h.to_words().to_vec();
    words.extend_from_slice(&[0.5f32.to_bits(), 40]);
    d.launch(
        p,
        bytemuck::cast_slice(&words),
        &[Resource::buffer(1, out), Resource::buffer(3, data)],
        &table,
        LaunchSize::new(2, 1, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let r: Vec<u32> = read(d, out);
    assert_eq!(
        r,
        vec![7 + 1000 + 40, 10],
        "each module's helpers, bindings and parameters"
    );
}

#[test]
fn index_and_vertex_formats_and_vertex_access() {
    let dev = device();
    let d = dev.as_ref();
    // Half-float vertices with u16 indices and a pre-transform that lifts z by 2.
    let positions: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let halves: Vec<u16> = positions.iter().flat_map(|p| p.map(half_bits)).collect();
    let vb = buffer(d, &halves);
    let ib = buffer(d, &[0u16, 1, 2, 0, 2, 3]);
    let pre = buffer(
        d,
        &[
            1.0f32, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0,
        ],
    );
    let mut t = TriangleArray::new(BufferView::new(vb), 4, GeometryFlags::NONE);
    t.vertex_format = VertexFormat::Half3;
    t.indices = Some(TriangleIndices {
        buffer: BufferView::new(ib),
        format: IndexFormat::U16x3,
        stride: 0,
        num_triangles: 2,
    });
    t.pre_transform = Some(BufferView::new(pre));
    let gas = d
        .accel_build(&AccelBuildOptions::default(), &[BuildInput::Triangles(t)])
        .unwrap();
    let m = module(
        d,
        &format!(
            "{HEADER}\nfn raygen__r() {{ var p: RtPayload; rt_trace(params.handle, vec3<f32>(0.75, 0.25, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p); for (var k = 0u; k < 10u; k = k + 1u) {{ out[k] = p[k]; }} }}\nfn closesthit__v() {{ let v = rt_triangle_vertices(); for (var k = 0u; k < 3u; k = k + 1u) {{ rt_set_payload(3u * k, bitcast<u32>(v[k].x)); rt_set_payload(3u * k + 1u, bitcast<u32>(v[k].y)); rt_set_payload(3u * k + 2u, bitcast<u32>(v[k].z)); }} rt_set_payload(9u, bitcast<u32>(rt_ray_tmax())); }}\nfn miss__m() {{ }}\n"
        ),
    );
    let g = groups(
        d,
        &[
            raygen(m, "raygen__r"),
            miss(m, "miss__m"),
            closest_hit(m, "closesthit__v"),
        ],
    );
    let p = pipeline(d, &g, 1);
    let table = sbt(d, &g, &[]);
    let out: Vec<f32> = run(
        d,
        p,
        &table,
        &params(d.traversable_handle(gas).unwrap(), &[]),
        1,
        1,
        10,
    )
    .into_iter()
    .map(f32::from_bits)
    .collect();
    assert_eq!(
        &out[..9],
        &[0.0, 0.0, 2.0, 1.0, 0.0, 2.0, 1.0, 1.0, 2.0],
        "triangle 0's vertices after the pre-transform"
    );
    assert_eq!(out[9], 3.0);
}

fn half_bits(v: f32) -> u16 {
    // Exact for the small integers used here.
    match v {
        0.0 => 0x0000,
        1.0 => 0x3C00,
        _ => panic!("unsupported"),
    }
}

#[test]
fn textures_and_three_dimensional_launches() {
    let dev = device();
    let d = dev.as_ref();
    triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let tex = d
        .create_texture(&TextureDesc {
            width: 2,
            height: 1,
            format: TextureFormat::R32Float,
        })
        .unwrap();
    d.write_texture(tex, bytemuck::cast_slice(&[0.25f32, 0.75]))
        .unwrap();
    let m = module(
        d,
        r#"
struct Params { handle: vec2<u32>, pad: vec2<u32> }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var tex: texture_2d<f32>;
@group(0) @binding(3) var smp: sampler;
fn raygen__r() {
    let i = rt_launch_index();
    let n = rt_launch_dimensions();
    let k = (i.z * n.y + i.y) * n.x + i.x;
    let s = textureSampleLevel(tex, smp, vec2<f32>((f32(i.x) + 0.5) / 2.0, 0.5), 0.0).x;
    out[k] = u32(s * 100.0) + 1000u * (i.x + 10u * i.y + 100u * i.z);
}
fn miss__m() { }
"#,
    );
    let g = groups(d, &[raygen(m, "raygen__r"), miss(m, "miss__m")]);
    let p = pipeline(d, &g, 1);
    let table = sbt(d, &g, &[]);
    let out = d.create_buffer(2 * 3 * 2 * 4).unwrap();
    d.launch(
        p,
        &[0u8; 16],
        &[
            Resource::buffer(1, out),
            Resource::Texture {
                binding: 2,
                texture: tex,
            },
            Resource::Sampler {
                binding: 3,
                sampler: SamplerDesc::default(),
            },
        ],
        &table,
        LaunchSize::new(2, 3, 2),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let r: Vec<u32> = read(d, out);
    for z in 0..2 {
        for y in 0..3 {
            for x in 0..2 {
                let k = (z * 3 + y) * 2 + x;
                assert_eq!(
                    r[k as usize],
                    [25, 75][x as usize] + 1000 * (x + 10 * y + 100 * z)
                );
            }
        }
    }
}

/// An instance of the two-sided unit quad at z = 0 with `flags`, traced by RAY_LIST from
/// above with `ray_flags`; the hit group has an any-hit that ignores everything.
fn instance_flags_case(flags: InstanceFlags, geometry: GeometryFlags, ray_flags: RayFlags) -> Rec {
    let dev = device();
    let d = dev.as_ref();
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), geometry);
    let inst = Instance {
        flags: flags.0,
        ..Instance::new(d.traversable_handle(gas).unwrap())
    };
    let ib = buffer(d, &[inst]);
    let ias = d
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Instances(InstanceArray {
                instances: BufferView::new(ib),
                num_instances: 1,
            })],
        )
        .unwrap();
    let m = module(
        d,
        &format!("{RAY_LIST}\nfn anyhit__ignore() {{ rt_ignore_intersection(); }}\n"),
    );
    let g = groups(
        d,
        &[
            raygen(m, "raygen__rays"),
            miss(m, "miss__rec"),
            ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(m, "closesthit__rec")),
                any_hit: Some(ProgramRef::new(m, "anyhit__ignore")),
                intersection: None,
                builtin: BuiltinIntersector::Triangle,
            },
        ],
    );
    let p = pipeline(d, &g, 1);
    let table = numbered_sbt(d, &g);
    let args = TraceArgs {
        flags: ray_flags.0,
        ..Default::default()
    };
    trace_rays(
        d,
        p,
        &table,
        d.traversable_handle(ias).unwrap(),
        &[Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0])],
        args,
    )[0]
}

#[test]
fn instance_flags_and_their_precedence() {
    let none = GeometryFlags::NONE;
    let opaque = GeometryFlags::DISABLE_ANYHIT;
    assert!(
        instance_flags_case(InstanceFlags::NONE, none, RayFlags::NONE).missed(),
        "any-hit ignores"
    );
    assert!(
        instance_flags_case(InstanceFlags::DISABLE_ANYHIT, none, RayFlags::NONE).hit(),
        "instance forces opaque"
    );
    assert!(
        instance_flags_case(InstanceFlags::ENFORCE_ANYHIT, opaque, RayFlags::NONE).missed(),
        "instance overrides geometry"
    );
    assert!(
        instance_flags_case(
            InstanceFlags::ENFORCE_ANYHIT,
            none,
            RayFlags::DISABLE_ANYHIT
        )
        .hit(),
        "the ray overrides the instance"
    );
    let cull_front = RayFlags::CULL_FRONT_FACING_TRIANGLES | RayFlags::DISABLE_ANYHIT;
    assert!(instance_flags_case(InstanceFlags::NONE, none, cull_front).missed());
    assert!(
        instance_flags_case(
            InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING,
            none,
            cull_front
        )
        .hit()
    );
    let flipped = instance_flags_case(InstanceFlags::FLIP_TRIANGLE_FACING, none, cull_front);
    assert!(
        flipped.hit() && flipped.hit_kind() == 0xFF,
        "flipped: the front is now the back"
    );
}

#[test]
fn scenes_that_grow_after_linking_get_bigger_kernels() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let d: &dyn Device = &dev;
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    // Linked for any graph while only a GAS exists: the stack is sized for it.
    let p = d
        .create_pipeline(
            &PipelineCompileOptions {
                traversable_graph: Setting::Value(TraversableGraph::Any),
                ..Default::default()
            },
            &PipelineLinkOptions::default(),
            &g.all(),
        )
        .unwrap();
    let before = dev.kernel_source(p).unwrap();
    // Now three levels of instances.
    let mut top = d.traversable_handle(gas).unwrap();
    for level in 0..3 {
        let inst = Instance {
            transform: [
                1.0,
                0.0,
                0.0,
                level as f32,
                0.0,
                1.0,
                0.0,
                0.0,
                0.0,
                0.0,
                1.0,
                0.0,
            ],
            ..Instance::new(top)
        };
        let ib = buffer(d, &[inst]);
        let ias = d
            .accel_build(
                &AccelBuildOptions::default(),
                &[BuildInput::Instances(InstanceArray {
                    instances: BufferView::new(ib),
                    num_instances: 1,
                })],
            )
            .unwrap();
        top = d.traversable_handle(ias).unwrap();
    }
    let after = dev.kernel_source(p).unwrap();
    let levels = |s: &str| {
        s.lines()
            .find(|l| l.starts_with("const _OPTIK_LEVELS"))
            .map(str::to_string)
    };
    assert_ne!(
        levels(&before),
        levels(&after),
        "the level array grew with the scene"
    );
    let table = numbered_sbt(d, &g);
    // Shifted by 0 + 1 + 2 = 3 in x.
    let recs = trace_rays(
        d,
        p,
        &table,
        top,
        &[
            Ray::new([3.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
            Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
        ],
        TraceArgs::default(),
    );
    assert!(recs[0].hit() && recs[1].missed());
}
