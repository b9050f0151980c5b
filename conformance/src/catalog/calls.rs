//! Group G (`payload`, `call`, `trace`): payload registers, live state across calls,
//! direct and continuation callables, large callable sets, recursive tracing.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, ch, hit_group, trace_words, uint_channel};
use crate::oracle::exec::Ctx;
use crate::oracle::model::{Flow, Models};
use crate::scene::{Gas, GeomInput, Scene, Triangles};
use optik::{GeometryFlags, PipelineCompileOptions, PipelineLinkOptions, Setting};

/// Every case of the `payload` group.
pub fn payload_cases() -> Vec<Case> {
    vec![copy_semantics(32), copy_semantics(1), types_semantics()]
}

/// Every case of the `call` group.
pub fn call_cases() -> Vec<Case> {
    vec![
        spill_across_calls(),
        direct_all_stages(),
        continuation_trace(),
        large_set(64),
        large_set(512),
    ]
}

/// Every case of the `trace` group.
pub fn trace_cases() -> Vec<Case> {
    vec![recursion_tree()]
}

/// A scene of one non-opaque quad over [0, 1]² at z = -1 (hit from above at (x, y) ∈ [0, 1]²).
fn one_quad() -> (Scene, usize) {
    Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        quad(0.0, 0.0, 1.0, 1.0, -1.0),
        GeometryFlags::NONE,
    ))]))
}

/// The shared header of the cases with their own raygen: parameters and buffers as in the
/// standard kit, a record of `stride` words per ray.
fn header(stride: u32) -> String {
    format!(
        r#"struct Params {{ handle: vec2<u32>, num_rays: u32, pad: u32 }}
@group(0) @binding(0) var<uniform> params: Params;
struct Ray {{
    origin: vec3<f32>, tmin: f32, dir: vec3<f32>, tmax: f32,
    time: f32, mask: u32, flags: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, aux: u32, pad: u32,
}}
@group(0) @binding(1) var<storage, read> rays: array<Ray>;
@group(0) @binding(2) var<storage, read_write> out: array<u32>;

fn ray_id() -> u32 {{
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    return i.x + d.x * (i.y + d.y * i.z);
}}

fn slot(k: u32) -> u32 {{
    return ray_id() * {stride}u + k;
}}
"#
    )
}

/// A case with its own module (the header of [`header`] plus `body`), one launch of `rays`
/// against `root`, records of `stride` words.
#[allow(clippy::too_many_arguments)]
fn own_case(
    group: Group,
    name: &str,
    summary: &str,
    guards: &[Rule],
    scene: Scene,
    root: Option<usize>,
    pipeline: PipelineDesc,
    models: Models,
    sbt: SbtLayout,
    rays: Vec<Ray>,
    stride: usize,
    channels: Vec<ChannelSpec>,
) -> Case {
    let n = rays.len() as u32;
    let width = n.min(32);
    let height = n.div_ceil(width);
    let mut rays = rays;
    while (rays.len() as u32) < width * height {
        rays.push(Ray::new([3e38; 3], [0.0, 0.0, 1.0]).interval(0.0, 0.0));
    }
    let count = rays.len();
    Case {
        name: format!("{}.{name}", group.name()),
        group,
        summary: summary.into(),
        guards: guards.to_vec(),
        scene,
        pipeline,
        models,
        sbt,
        launches: vec![Launch {
            dims: [width, height, 1],
            params: {
                let mut p = ParamWord::handle(root).to_vec();
                p.push(ParamWord::U32(count as u32));
                p.push(ParamWord::U32(0));
                p
            },
            buffers: vec![
                BufferInit {
                    binding: 1,
                    words: rays.iter().flat_map(|r| r.words()).collect(),
                },
                BufferInit {
                    binding: 2,
                    words: vec![0; count * stride],
                },
            ],
        }],
        record: RecordSpec {
            binding: 2,
            layout: RecordLayout::PerIndex { stride },
            channels,
            judgement: Judgement::PerRecord,
        },
        rounding: crate::oracle::geometry::Rounding::F32,
        backend_specific: vec![],
    }
}

/// Reads ray `id` of the rays buffer as the standard layout's words.
fn ray_words(ctx: &mut Ctx<'_, '_>, id: u32) -> Vec<u32> {
    (0..16).map(|k| ctx.read(1, id as usize * 16 + k)).collect()
}

const PAYLOAD_WGSL: &str = r#"
const INIT: array<u32, 8> = array<u32, 8>(0x7FC00001u, 0x00000001u, 0x80000000u, 0xFFFFFFFFu, 0x3F800000u, 0x007FFFFFu, 0xFF800000u, 0x12345678u);

fn raygen__payload() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    var p: RtPayload;
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        p[k] = INIT[k % 8u] ^ (k * 0x01010101u) ^ r.aux;
    }
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        out[slot(k)] = p[k];
    }
}

fn anyhit__xor() {
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        if k % 3u == 0u {
            rt_set_payload(k, rt_get_payload(k) ^ 0x0F0F0F0Fu);
        }
    }
}

fn closesthit__xor() {
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        if k % 3u == 1u {
            rt_set_payload(k, rt_get_payload(k) ^ 0x00FF00FFu);
        }
    }
}

fn miss__xor() {
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        if k % 3u == 2u {
            rt_set_payload(k, rt_get_payload(k) ^ 0xF000000Fu);
        }
    }
}
"#;

const INIT: [u32; 8] = [
    0x7FC00001, 0x00000001, 0x80000000, 0xFFFFFFFF, 0x3F800000, 0x007FFFFF, 0xFF800000, 0x12345678,
];

fn copy_semantics(n: u32) -> Case {
    let (scene, root) = one_quad();
    let wgsl = format!(
        "{}const NUM_PAYLOAD: u32 = {n}u;\n{PAYLOAD_WGSL}",
        header(32)
    );
    let mut m = Models::new();
    m.add("raygen__payload", move |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let w = ray_words(ctx, id);
        let mut p = vec![0u32; n as usize];
        for (k, v) in p.iter_mut().enumerate() {
            *v = INIT[k % 8] ^ (k as u32).wrapping_mul(0x01010101) ^ w[14];
        }
        trace_words(ctx, &w, &mut p)?;
        for (k, v) in p.iter().enumerate() {
            ctx.write(2, id as usize * 32 + k, *v);
        }
        Ok(())
    });
    let xor = |rem: u32, mask: u32| {
        move |ctx: &mut Ctx<'_, '_>| -> Flow {
            for k in 0..n {
                if k % 3 == rem {
                    let v = ctx.get_payload(k);
                    ctx.set_payload(k, v ^ mask);
                }
            }
            Ok(())
        }
    };
    m.add("anyhit__xor", xor(0, 0x0F0F_0F0F));
    m.add("closesthit__xor", xor(1, 0x00FF_00FF));
    m.add("miss__xor", xor(2, 0xF000_000F));
    let rays = vec![
        Ray {
            aux: 0,
            ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
        Ray {
            aux: 0xDEAD_0000,
            ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
        Ray {
            aux: 0,
            ..Ray::new([5.0, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
        Ray {
            aux: 0x0000_BEEF,
            ..Ray::new([5.0, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
    ];
    let pipeline = PipelineDesc {
        wgsl,
        raygen: "raygen__payload".into(),
        miss: vec![Some("miss__xor".into())],
        hit: vec![hit_group(
            Some("closesthit__xor"),
            Some("anyhit__xor"),
            None,
        )],
        callables: vec![],
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(n),
            ..Default::default()
        },
        link: PipelineLinkOptions::default(),
    };
    let sbt = SbtLayout {
        miss: vec![SbtEntry::new(0, vec![0])],
        hit: vec![SbtEntry::new(0, vec![0])],
        ..Default::default()
    };
    let channels = (0..n as usize)
        .map(|k| uint_channel(&format!("payload{k}"), k))
        .collect();
    own_case(
        Group::Payload,
        if n == 1 {
            "copy_semantics_single"
        } else {
            "copy_semantics"
        },
        &format!(
            "{n} payload register(s) copied in and out of a trace, any-hit, closest-hit and miss each XOR their own words, NaN, -0, denormal and all-ones bit patterns survive bit for bit"
        ),
        &[],
        scene,
        Some(root),
        pipeline,
        m,
        sbt,
        rays,
        32,
        channels,
    )
}

const TYPES_WGSL: &str = r#"
fn anyhit__reader() {
    rt_set_payload(7u, rt_get_payload(0u) + 1u);
}

fn closesthit__writer() {
    rt_set_payload(6u, 0xC0FFEEu);
}

fn miss__writer() {
    rt_set_payload(5u, 0xBADu);
}
"#;

fn types_semantics() -> Case {
    let (scene, root) = one_quad();
    let mut m = Models::new();
    m.add("anyhit__reader", |ctx| {
        let v = ctx.get_payload(0);
        ctx.set_payload(7, v.wrapping_add(1));
        Ok(())
    });
    m.add("closesthit__writer", |ctx| {
        ctx.set_payload(6, 0xC0FFEE);
        Ok(())
    });
    m.add("miss__writer", |ctx| {
        ctx.set_payload(5, 0xBAD);
        Ok(())
    });
    let mut case = StdCase::new(
        Group::Payload,
        "types_semantics",
        "payload words with per-stage roles (any-hit reads word 0 and writes 7, closest-hit writes 6, miss writes 5): words a stage does not write come back as the caller set them (the observable part of OptiX payload types; optik has no per-word declarations)",
        &[],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some("closesthit__writer"), Some("anyhit__reader"), None)], vec![SbtEntry::new(0, vec![0])])
    .launch(4, vec![
        Ray { aux: 41, ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0]) },
        Ray { aux: 42, ..Ray::new([5.0, 0.25, 0.0], [0.0, 0.0, -1.0]) },
        Ray { aux: 43, ..Ray::new([0.25, 0.75, 0.0], [0.0, 0.0, -1.0]) },
        Ray { aux: 44, ..Ray::new([0.25, 0.75, 0.0], [0.0, 0.0, 1.0]) },
    ])
    .record((0..8).map(ch::payload).collect());
    case.miss_groups = vec![Some("miss__writer".into())];
    case.more_wgsl = Some((TYPES_WGSL.into(), m));
    case.build()
}

const SPILL_WGSL: &str = r#"
struct Locals { a: vec3<f32>, b: array<u32, 3>, c: i32 }

fn make_locals(seed: u32) -> Locals {
    var l: Locals;
    l.a = vec3<f32>(f32(seed) * 0.5, -1.25, 1e-38);
    l.b = array<u32, 3>(seed, seed ^ 0xFFFFu, seed * 3u);
    l.c = -i32(seed) - 7;
    return l;
}

fn same(x: Locals, y: Locals) -> bool {
    return all(x.a == y.a) && x.b[0] == y.b[0] && x.b[1] == y.b[1] && x.b[2] == y.b[2] && x.c == y.c;
}

fn raygen__spill() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    let before = make_locals(id + 17u);
    var keep = before;
    var p: RtPayload;
    var flags = 0u;
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    if same(keep, before) { flags = flags | 1u; }
    var args: RtPayload;
    args[0] = id;
    rt_direct_call(0u, &args);
    if same(keep, before) && args[0] == id * 2u + 1u { flags = flags | 2u; }
    rt_continuation_call(1u, &args);
    if same(keep, before) && args[0] == (id * 2u + 1u) * 2u + 1u { flags = flags | 4u; }
    out[slot(0u)] = flags;
    out[slot(1u)] = p[3];
}

fn intersection__spill() {
    let before = make_locals(ray_id() + 5u);
    let keep = before;
    var attrs: RtAttributes;
    let accepted = rt_report_intersection(1.0, 0u, attrs);
    out[slot(2u)] = select(0u, 8u, same(keep, before) && accepted);
}

fn closesthit__spill() {
    rt_set_payload(3u, 99u);
}

fn direct_callable__double() {
    rt_set_payload(0u, rt_get_payload(0u) * 2u + 1u);
}

fn continuation_callable__double() {
    rt_set_payload(0u, rt_get_payload(0u) * 2u + 1u);
}
"#;

fn spill_across_calls() -> Case {
    let mut scene = Scene::default();
    let root = scene.add(crate::scene::Node::Gas(Gas::new(vec![GeomInput::Aabbs(
        crate::scene::Aabbs::new(
            vec![[0.0, 0.0, -2.0, 1.0, 1.0, 0.0]],
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])));
    let mut m = Models::new();
    // The model of a correct backend: locals survive every call.
    m.add("raygen__spill", |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let w = ray_words(ctx, id);
        let mut p = [0u32; 8];
        trace_words(ctx, &w, &mut p)?;
        let mut flags = 1;
        let mut args = [0u32; 8];
        args[0] = id;
        ctx.direct_call(0, &mut args)?;
        if args[0] == id * 2 + 1 {
            flags |= 2;
        }
        ctx.continuation_call(1, &mut args)?;
        if args[0] == (id * 2 + 1) * 2 + 1 {
            flags |= 4;
        }
        let s = id as usize * 4;
        ctx.write(2, s, flags);
        ctx.write(2, s + 1, p[3]);
        Ok(())
    });
    m.add("intersection__spill", |ctx| {
        let accepted = ctx.report_intersection(1.0, 0, [0; 8])?;
        let s = ctx.linear_index() as usize * 4 + 2;
        ctx.write(2, s, if accepted { 8 } else { 0 });
        Ok(())
    });
    m.add("closesthit__spill", |ctx| {
        ctx.set_payload(3, 99);
        Ok(())
    });
    let double = |ctx: &mut Ctx<'_, '_>| -> Flow {
        let v = ctx.get_payload(0);
        ctx.set_payload(0, v.wrapping_mul(2).wrapping_add(1));
        Ok(())
    };
    m.add("direct_callable__double", double);
    m.add("continuation_callable__double", double);
    let pipeline = PipelineDesc {
        wgsl: format!("{}{SPILL_WGSL}", header(4)),
        raygen: "raygen__spill".into(),
        miss: vec![None],
        hit: vec![hit_group(
            Some("closesthit__spill"),
            None,
            Some("intersection__spill"),
        )],
        callables: vec![
            CallableDesc {
                direct: Some("direct_callable__double".into()),
                continuation: None,
            },
            CallableDesc {
                direct: None,
                continuation: Some("continuation_callable__double".into()),
            },
        ],
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(8),
            ..Default::default()
        },
        link: PipelineLinkOptions {
            max_trace_depth: 1,
            ..Default::default()
        },
    };
    let sbt = plain_sbt(vec![SbtEntry::new(0, vec![]), SbtEntry::new(1, vec![])]);
    let rays = hit_and_miss_rays();
    own_case(
        Group::Call,
        "spill_across_calls",
        "a struct of vector, array and signed locals lives across rt_trace, rt_direct_call, rt_continuation_call and rt_report_intersection unchanged (CTS data_spill)",
        &[],
        scene,
        Some(root),
        pipeline,
        m,
        sbt,
        rays,
        4,
        vec![
            uint_channel("flags", 0),
            uint_channel("payload3", 1),
            uint_channel("is_flags", 2),
        ],
    )
}

const DIRECT_WGSL: &str = r#"
fn direct_callable__mix() {
    rt_set_payload(0u, rt_get_payload(0u) * 31u + rt_get_payload(1u) + rt_sbt_data_u32(0u));
    rt_set_payload(1u, rt_get_payload(1u) ^ 0x5Au);
}

fn direct_callable__nest() {
    if rt_get_payload(2u) > 0u {
        rt_set_payload(2u, rt_get_payload(2u) - 1u);
        var args: RtPayload;
        args[0] = rt_get_payload(0u);
        args[1] = rt_get_payload(1u);
        args[2] = rt_get_payload(2u);
        rt_direct_call(1u, &args);
        rt_set_payload(0u, args[0]);
    }
    rt_set_payload(0u, rt_get_payload(0u) + 1000u);
}

fn call_mix(a: u32, b: u32) -> u32 {
    var args: RtPayload;
    args[0] = a;
    args[1] = b;
    rt_direct_call(0u, &args);
    return args[0] ^ (args[1] << 16u);
}

fn raygen__calls() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    out[slot(0u)] = call_mix(id, 1u);
    var nest: RtPayload;
    nest[0] = id;
    nest[2] = 4u;
    rt_direct_call(1u, &nest);
    out[slot(1u)] = nest[0];
    var p: RtPayload;
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    out[slot(2u)] = p[0];
    out[slot(3u)] = p[1];
    out[slot(4u)] = p[2];
}

fn intersection__calls() {
    out[slot(5u)] = call_mix(ray_id(), 5u);
    var attrs: RtAttributes;
    let accepted = rt_report_intersection(1.0, 0u, attrs);
}

fn anyhit__calls() {
    rt_set_payload(2u, call_mix(rt_primitive_index(), 4u));
}

fn closesthit__calls() {
    rt_set_payload(0u, call_mix(ray_id(), 2u));
}

fn miss__calls() {
    rt_set_payload(1u, call_mix(ray_id(), 3u));
}
"#;

fn call_mix(ctx: &mut Ctx<'_, '_>, a: u32, b: u32) -> Result<u32, crate::oracle::model::Unwind> {
    let mut args = [0u32; 8];
    args[0] = a;
    args[1] = b;
    ctx.direct_call(0, &mut args)?;
    Ok(args[0] ^ (args[1] << 16))
}

fn direct_all_stages() -> Case {
    let mut scene = Scene::default();
    let root = scene.add(crate::scene::Node::Gas(Gas::new(vec![GeomInput::Aabbs(
        crate::scene::Aabbs::new(vec![[0.0, 0.0, -2.0, 1.0, 1.0, 0.0]], GeometryFlags::NONE),
    )])));
    let mut m = Models::new();
    m.add("direct_callable__mix", |ctx| {
        let (a, b, d) = (ctx.get_payload(0), ctx.get_payload(1), ctx.sbt_data_u32(0));
        ctx.set_payload(0, a.wrapping_mul(31).wrapping_add(b).wrapping_add(d));
        ctx.set_payload(1, b ^ 0x5A);
        Ok(())
    });
    m.add("direct_callable__nest", |ctx| {
        if ctx.get_payload(2) > 0 {
            let depth = ctx.get_payload(2) - 1;
            ctx.set_payload(2, depth);
            let mut args = [0u32; 8];
            args[0] = ctx.get_payload(0);
            args[1] = ctx.get_payload(1);
            args[2] = depth;
            ctx.direct_call(1, &mut args)?;
            ctx.set_payload(0, args[0]);
        }
        let v = ctx.get_payload(0);
        ctx.set_payload(0, v.wrapping_add(1000));
        Ok(())
    });
    m.add("raygen__calls", |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let s = id as usize * 8;
        let v = call_mix(ctx, id, 1)?;
        ctx.write(2, s, v);
        let mut nest = [0u32; 8];
        nest[0] = id;
        nest[2] = 4;
        ctx.direct_call(1, &mut nest)?;
        ctx.write(2, s + 1, nest[0]);
        let w = ray_words(ctx, id);
        let mut p = [0u32; 8];
        trace_words(ctx, &w, &mut p)?;
        for (k, v) in p.iter().take(3).enumerate() {
            ctx.write(2, s + 2 + k, *v);
        }
        Ok(())
    });
    m.add("intersection__calls", |ctx| {
        let id = ctx.linear_index();
        let v = call_mix(ctx, id, 5)?;
        ctx.write(2, id as usize * 8 + 5, v);
        ctx.report_intersection(1.0, 0, [0; 8])?;
        Ok(())
    });
    m.add("anyhit__calls", |ctx| {
        let prim = ctx.primitive_index();
        let v = call_mix(ctx, prim, 4)?;
        ctx.set_payload(2, v);
        Ok(())
    });
    m.add("closesthit__calls", |ctx| {
        let id = ctx.linear_index();
        let v = call_mix(ctx, id, 2)?;
        ctx.set_payload(0, v);
        Ok(())
    });
    m.add("miss__calls", |ctx| {
        let id = ctx.linear_index();
        let v = call_mix(ctx, id, 3)?;
        ctx.set_payload(1, v);
        Ok(())
    });
    let pipeline = PipelineDesc {
        wgsl: format!("{}{DIRECT_WGSL}", header(8)),
        raygen: "raygen__calls".into(),
        miss: vec![Some("miss__calls".into())],
        hit: vec![hit_group(
            Some("closesthit__calls"),
            Some("anyhit__calls"),
            Some("intersection__calls"),
        )],
        callables: vec![
            CallableDesc {
                direct: Some("direct_callable__mix".into()),
                continuation: None,
            },
            CallableDesc {
                direct: Some("direct_callable__nest".into()),
                continuation: None,
            },
        ],
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(8),
            ..Default::default()
        },
        link: PipelineLinkOptions {
            max_trace_depth: 1,
            max_direct_callable_depth: 6,
            ..Default::default()
        },
    };
    let sbt = plain_sbt(vec![SbtEntry::new(0, vec![7]), SbtEntry::new(1, vec![])]);
    let rays = hit_and_miss_rays();
    own_case(
        Group::Call,
        "direct_all_stages",
        "a direct callable called from raygen, intersection, any-hit, closest-hit, miss and itself (nested 4 deep), with arguments in and out and its own SBT data (CTS callable_shader)",
        &[],
        scene,
        Some(root),
        pipeline,
        m,
        sbt,
        rays,
        8,
        [
            "rg_call", "rg_nest", "ch_call", "ms_call", "ah_call", "is_call",
        ]
        .iter()
        .enumerate()
        .map(|(k, n)| uint_channel(n, k))
        .collect(),
    )
}

const CONT_WGSL: &str = r#"
fn continuation_callable__trace() {
    var p: RtPayload;
    let o = vec3<f32>(bitcast<f32>(rt_get_payload(0u)), 0.5, 1.0);
    rt_trace(params.handle, o, vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    rt_set_payload(1u, p[0] + 1u);
    rt_set_payload(2u, rt_remaining_trace_depth());
}

fn raygen__cont() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    var args: RtPayload;
    args[0] = bitcast<u32>(r.origin.x);
    rt_continuation_call(0u, &args);
    out[slot(0u)] = args[1];
    out[slot(1u)] = args[2];
    var p: RtPayload;
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    out[slot(2u)] = p[0];
    out[slot(3u)] = p[1];
}

fn closesthit__cont() {
    rt_set_payload(0u, 10u);
    var args: RtPayload;
    args[0] = bitcast<u32>(rt_world_ray_origin().x + 5.0);
    rt_continuation_call(0u, &args);
    rt_set_payload(1u, args[1]);
}

fn miss__cont() {
    rt_set_payload(0u, 20u);
}
"#;

fn continuation_trace() -> Case {
    let (scene, root) = one_quad();
    let mut m = Models::new();
    m.add("continuation_callable__trace", |ctx| {
        let mut p = [0u32; 8];
        let o = [f32::from_bits(ctx.get_payload(0)), 0.5, 1.0];
        let handle = [ctx.param(0), ctx.param(1)];
        ctx.trace(
            handle,
            o,
            [0.0, 0.0, -1.0],
            0.0,
            10.0,
            0.0,
            0xFF,
            0,
            0,
            1,
            0,
            &mut p,
        )?;
        ctx.set_payload(1, p[0] + 1);
        let r = ctx.remaining_trace_depth();
        ctx.set_payload(2, r);
        Ok(())
    });
    m.add("raygen__cont", |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let w = ray_words(ctx, id);
        let mut args = [0u32; 8];
        args[0] = w[0];
        ctx.continuation_call(0, &mut args)?;
        let s = id as usize * 4;
        ctx.write(2, s, args[1]);
        ctx.write(2, s + 1, args[2]);
        let mut p = [0u32; 8];
        trace_words(ctx, &w, &mut p)?;
        ctx.write(2, s + 2, p[0]);
        ctx.write(2, s + 3, p[1]);
        Ok(())
    });
    m.add("closesthit__cont", |ctx| {
        ctx.set_payload(0, 10);
        let mut args = [0u32; 8];
        args[0] = (ctx.world_ray_origin()[0] + 5.0).to_bits();
        ctx.continuation_call(0, &mut args)?;
        ctx.set_payload(1, args[1]);
        Ok(())
    });
    m.add("miss__cont", |ctx| {
        ctx.set_payload(0, 20);
        Ok(())
    });
    let pipeline = PipelineDesc {
        wgsl: format!("{}{CONT_WGSL}", header(4)),
        raygen: "raygen__cont".into(),
        miss: vec![Some("miss__cont".into())],
        hit: vec![hit_group(Some("closesthit__cont"), None, None)],
        callables: vec![CallableDesc {
            direct: None,
            continuation: Some("continuation_callable__trace".into()),
        }],
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(8),
            ..Default::default()
        },
        link: PipelineLinkOptions {
            max_trace_depth: 3,
            max_continuation_callable_depth: 2,
            ..Default::default()
        },
    };
    let sbt = plain_sbt(vec![SbtEntry::new(0, vec![])]);
    let rays = (0..8)
        .map(|k| {
            Ray::new(
                [if k % 2 == 0 { 0.25 } else { 5.25 }, 0.5, 1.0],
                [0.0, 0.0, -1.0],
            )
        })
        .collect();
    own_case(
        Group::Call,
        "continuation_trace",
        "a continuation callable that traces, called from raygen and from closest-hit: its trace result and the remaining trace depth at each level",
        &[],
        scene,
        Some(root),
        pipeline,
        m,
        sbt,
        rays,
        4,
        ["rg_cc_result", "rg_cc_depth", "ray_p0", "ch_cc_result"]
            .iter()
            .enumerate()
            .map(|(k, n)| uint_channel(n, k))
            .collect(),
    )
}

fn large_set(n: u32) -> Case {
    let mut wgsl = header(1);
    wgsl.push_str(
        r#"
fn raygen__large() {
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    var args: RtPayload;
    args[0] = i.x;
    args[1] = i.y;
    args[2] = d.x;
    rt_direct_call(ray_id(), &args);
    out[slot(0u)] = args[0];
}
"#,
    );
    for k in 0..n {
        wgsl.push_str(&format!(
            "fn direct_callable__n{k}() {{\n    rt_set_payload(0u, (rt_get_payload(2u) * (rt_get_payload(1u) / 3u) + rt_get_payload(0u)) % 199u + {k}u * 1000u);\n}}\n"
        ));
    }
    let mut m = Models::new();
    m.add("raygen__large", |ctx| {
        let (i, d) = (ctx.launch_index(), ctx.launch_dimensions());
        let mut args = [0u32; 8];
        args[0] = i[0];
        args[1] = i[1];
        args[2] = d[0];
        let id = ctx.linear_index();
        ctx.direct_call(id, &mut args)?;
        ctx.write(2, id as usize, args[0]);
        Ok(())
    });
    for k in 0..n {
        m.add(&format!("direct_callable__n{k}"), move |ctx| {
            let v = (ctx.get_payload(2) * (ctx.get_payload(1) / 3) + ctx.get_payload(0)) % 199
                + k * 1000;
            ctx.set_payload(0, v);
            Ok(())
        });
    }
    let (w, h) = (n.min(32), n / n.min(32));
    let pipeline = PipelineDesc {
        wgsl,
        raygen: "raygen__large".into(),
        miss: vec![],
        hit: vec![],
        callables: (0..n)
            .map(|k| CallableDesc {
                direct: Some(format!("direct_callable__n{k}")),
                continuation: None,
            })
            .collect(),
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(3),
            ..Default::default()
        },
        link: PipelineLinkOptions {
            max_trace_depth: 0,
            ..Default::default()
        },
    };
    let sbt = SbtLayout {
        callables: (0..n as usize).map(|k| SbtEntry::new(k, vec![])).collect(),
        ..Default::default()
    };
    Case {
        name: format!("call.large_set_{n}"),
        group: Group::Call,
        summary: format!(
            "{n} distinct direct callables; launch index k calls callable k, which returns (W·(y/3) + x) % 199 + 1000k (CTS large_shader_set)"
        ),
        guards: vec![],
        scene: Scene::default(),
        pipeline,
        models: m,
        sbt,
        launches: vec![Launch {
            dims: [w, h, 1],
            params: vec![
                ParamWord::HandleLo(None),
                ParamWord::HandleHi(None),
                ParamWord::U32(n),
                ParamWord::U32(0),
            ],
            buffers: vec![
                BufferInit {
                    binding: 1,
                    words: vec![0; 16],
                },
                BufferInit {
                    binding: 2,
                    words: vec![0; n as usize],
                },
            ],
        }],
        record: RecordSpec {
            binding: 2,
            layout: RecordLayout::PerIndex { stride: 1 },
            channels: vec![uint_channel("value", 0)],
            judgement: Judgement::PerRecord,
        },
        rounding: crate::oracle::geometry::Rounding::EXACT,
        backend_specific: vec![],
    }
}

const TREE_WGSL: &str = r#"
fn child(hit: bool) -> array<u32, 2> {
    var p: RtPayload;
    let x = select(5.0, 0.25, hit);
    rt_trace(params.handle, vec3<f32>(x, 0.5, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    return array<u32, 2>(p[0], p[1]);
}

fn node() {
    let remaining = rt_remaining_trace_depth();
    var ch = 0u;
    var ms = 0u;
    if remaining > 0u {
        let a = child(true);
        let b = child(false);
        ch = a[0] + b[0];
        ms = a[1] + b[1];
    }
    rt_set_payload(0u, rt_get_payload(0u) + ch);
    rt_set_payload(1u, rt_get_payload(1u) + ms);
    rt_set_payload(2u, min(rt_get_payload(2u), remaining));
}

fn closesthit__tree() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, 0u);
    rt_set_payload(2u, 0xFFFFu);
    node();
}

fn miss__tree() {
    rt_set_payload(0u, 0u);
    rt_set_payload(1u, 1u);
    rt_set_payload(2u, 0xFFFFu);
    node();
}

fn raygen__tree() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    var p: RtPayload;
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    out[slot(0u)] = p[0];
    out[slot(1u)] = p[1];
    out[slot(2u)] = p[2];
    out[slot(3u)] = rt_remaining_trace_depth();
}
"#;

fn recursion_tree() -> Case {
    let (scene, root) = one_quad();
    let depth = 3u32;
    fn child(ctx: &mut Ctx<'_, '_>, hit: bool) -> Result<[u32; 2], crate::oracle::model::Unwind> {
        let mut p = [0u32; 8];
        let x = if hit { 0.25 } else { 5.0 };
        let handle = [ctx.param(0), ctx.param(1)];
        ctx.trace(
            handle,
            [x, 0.5, 1.0],
            [0.0, 0.0, -1.0],
            0.0,
            10.0,
            0.0,
            0xFF,
            0,
            0,
            1,
            0,
            &mut p,
        )?;
        Ok([p[0], p[1]])
    }
    fn node(ctx: &mut Ctx<'_, '_>) -> Flow {
        let remaining = ctx.remaining_trace_depth();
        let (mut ch, mut ms) = (0, 0);
        if remaining > 0 {
            let a = child(ctx, true)?;
            let b = child(ctx, false)?;
            ch = a[0] + b[0];
            ms = a[1] + b[1];
        }
        let (p0, p1, p2) = (ctx.get_payload(0), ctx.get_payload(1), ctx.get_payload(2));
        ctx.set_payload(0, p0 + ch);
        ctx.set_payload(1, p1 + ms);
        ctx.set_payload(2, p2.min(remaining));
        Ok(())
    }
    let mut m = Models::new();
    m.add("closesthit__tree", |ctx| {
        ctx.set_payload(0, 1);
        ctx.set_payload(1, 0);
        ctx.set_payload(2, 0xFFFF);
        node(ctx)
    });
    m.add("miss__tree", |ctx| {
        ctx.set_payload(0, 0);
        ctx.set_payload(1, 1);
        ctx.set_payload(2, 0xFFFF);
        node(ctx)
    });
    m.add("raygen__tree", |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let w = ray_words(ctx, id);
        let mut p = [0u32; 8];
        trace_words(ctx, &w, &mut p)?;
        let s = id as usize * 4;
        for (k, v) in p.iter().take(3).enumerate() {
            ctx.write(2, s + k, *v);
        }
        let r = ctx.remaining_trace_depth();
        ctx.write(2, s + 3, r);
        Ok(())
    });
    let pipeline = PipelineDesc {
        wgsl: format!("{}{TREE_WGSL}", header(4)),
        raygen: "raygen__tree".into(),
        miss: vec![Some("miss__tree".into())],
        hit: vec![hit_group(Some("closesthit__tree"), None, None)],
        callables: vec![],
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(3),
            ..Default::default()
        },
        link: PipelineLinkOptions {
            max_trace_depth: depth,
            ..Default::default()
        },
    };
    let sbt = plain_sbt(Vec::new());
    own_case(
        Group::Trace,
        "recursion_tree",
        &format!(
            "closest-hit and miss each trace one hit child and one miss child until rt_remaining_trace_depth is 0 (max_trace_depth {depth}): node counts 2^d − 1 per kind, depth seen at every level (CTS recursiveTraces)"
        ),
        &[],
        scene,
        Some(root),
        pipeline,
        m,
        sbt,
        vec![
            Ray::new([0.25, 0.5, 1.0], [0.0, 0.0, -1.0]),
            Ray::new([5.0, 0.5, 1.0], [0.0, 0.0, -1.0]),
        ],
        4,
        ["ch_nodes", "ms_nodes", "min_remaining", "rg_remaining"]
            .iter()
            .enumerate()
            .map(|(k, n)| uint_channel(n, k))
            .collect(),
    )
}

/// One miss and one hit record without data, and `callables`.
fn plain_sbt(callables: Vec<SbtEntry>) -> SbtLayout {
    SbtLayout {
        miss: vec![SbtEntry::new(0, vec![])],
        hit: vec![SbtEntry::new(0, vec![])],
        callables,
        ..Default::default()
    }
}

/// Eight rays down -z, alternately through the box over the unit square (x, y in [0, 1]) and
/// beside it (x = 5.5).
fn hit_and_miss_rays() -> Vec<Ray> {
    (0..8)
        .map(|k| {
            Ray::new(
                [0.5 + if k % 2 == 0 { 0.0 } else { 5.0 }, 0.5, 1.0],
                [0.0, 0.0, -1.0],
            )
        })
        .collect()
}
