//! The `call` group: live state across calls, direct and continuation callables from every
//! stage, large callable sets.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, hit_group, trace_words, uint_channel};
use crate::oracle::exec::Ctx;
use crate::oracle::model::{Flow, Models};
use crate::scene::{Gas, GeomInput, Scene};
use optik::{GeometryFlags, PipelineCompileOptions, PipelineLinkOptions, Setting};

/// Every case of the `call` group.
pub fn cases() -> Vec<Case> {
    vec![
        spill_across_calls(),
        direct_all_stages(),
        continuation_trace(),
        large_set(64),
        large_set(512),
    ]
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
