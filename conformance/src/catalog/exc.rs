//! The `exc` group: exception codes and the invalid-ray policy with debug exceptions.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, action, ch, hit_group, uint_channel};
use crate::oracle::exec::Ctx;
use crate::oracle::model::{Flow, Models};
use crate::scene::{Aabbs, Gas, GeomInput, InstanceDesc, Node, Scene, Triangles};
use optik::{ExceptionFlags, GeometryFlags, PipelineCompileOptions, PipelineLinkOptions, Setting};

/// Every case of the `exc` group.
pub fn cases() -> Vec<Case> {
    vec![codes(), invalid_ray_policy()]
}

/// Programs throwing at the site the ray's `aux` word names (payload register 2, or the ray
/// buffer in intersection programs), and an exception program recording the code in words
/// 28 and 29 (0xE0 marks that it ran).
const EXC_WGSL: &str = r#"
fn exception__record() {
    out[slot(28u)] = bitcast<u32>(rt_exception_code());
    out[slot(29u)] = 0xE0u;
}

fn closesthit__throw() {
    record_hit();
    let site = rt_get_payload(2u);
    if site == 2u {
        rt_throw_exception(5u);
    }
    if site == 6u {
        var p: RtPayload;
        rt_trace(params.handle, rt_world_ray_origin(), rt_world_ray_direction(), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    }
}

fn miss__throw() {
    out[slot(0u)] = 0u;
    if rt_get_payload(2u) == 3u {
        rt_throw_exception(6u);
    }
}

fn anyhit__throw() {
    if rt_get_payload(2u) == 4u {
        rt_throw_exception(7u);
    }
}

fn intersection__throw() {
    if rays[ray_id()].aux == 5u {
        rt_throw_exception(8u);
    }
    var attrs: RtAttributes;
    let accepted = rt_report_intersection(1.5, 0u, attrs);
}

fn raygen__throw() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    if r.aux == 0u {
        rt_throw_exception(0u);
    }
    if r.aux == 1u {
        rt_throw_exception(1073741823u);
    }
    if r.aux == 7u {
        rt_throw_exception(0x80000003u);
    }
    trace_and_record(r, r.origin);
}
"#;

fn record_code(ctx: &mut Ctx<'_, '_>) -> Flow {
    let s = ctx.linear_index() as usize * 32;
    let code = ctx.exception_code() as u32;
    ctx.write(2, s + 28, code);
    ctx.write(2, s + 29, 0xE0);
    Ok(())
}

fn exc_models() -> Models {
    let mut m = Models::new();
    m.add("exception__record", record_code);
    m.add("closesthit__throw", |ctx| {
        let s = ctx.linear_index() as usize * 32;
        let words = [
            (0, 1),
            (1, ctx.ray_tmax().to_bits()),
            (2, ctx.primitive_index()),
            (3, ctx.instance_id()),
            (4, ctx.instance_index()),
            (5, ctx.sbt_gas_index()),
            (6, ctx.hit_kind()),
            (15, ctx.sbt_data_u32(0)),
        ];
        for (k, v) in words {
            ctx.write(2, s + k, v);
        }
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 8);
        let site = ctx.get_payload(2);
        if site == 2 {
            return ctx.throw_exception(5);
        }
        if site == 6 {
            let mut p = [0u32; 8];
            let handle = [ctx.param(0), ctx.param(1)];
            let (o, d) = (ctx.world_ray_origin(), ctx.world_ray_direction());
            ctx.trace(handle, o, d, 0.0, 10.0, 0.0, 0xFF, 0, 0, 1, 0, &mut p)?;
        }
        Ok(())
    });
    m.add("miss__throw", |ctx| {
        let s = ctx.linear_index() as usize * 32;
        ctx.write(2, s, 0);
        if ctx.get_payload(2) == 3 {
            return ctx.throw_exception(6);
        }
        Ok(())
    });
    m.add("anyhit__throw", |ctx| {
        if ctx.get_payload(2) == 4 {
            return ctx.throw_exception(7);
        }
        Ok(())
    });
    m.add("intersection__throw", |ctx| {
        let id = ctx.linear_index() as usize;
        if ctx.read(1, id * 16 + 14) == 5 {
            return ctx.throw_exception(8);
        }
        ctx.report_intersection(1.5, 0, [0; 8])?;
        Ok(())
    });
    m.add("raygen__throw", |ctx| {
        let id = ctx.linear_index() as usize;
        if id as u32 >= ctx.param(2) {
            return Ok(());
        }
        match ctx.read(1, id * 16 + 14) {
            0 => return ctx.throw_exception(0),
            1 => return ctx.throw_exception(1_073_741_823),
            7 => return ctx.throw_exception(0x8000_0003),
            _ => {}
        }
        // The rest is the standard raygen's trace_and_record.
        let f = |ctx: &mut Ctx<'_, '_>, k: usize| f32::from_bits(ctx.read(1, id * 16 + k));
        let w: Vec<u32> = (0..16).map(|k| ctx.read(1, id * 16 + k)).collect();
        let _ = f;
        let g = |k: usize| f32::from_bits(w[k]);
        let mut p = [0u32; 32];
        p[2] = w[14];
        let handle = [ctx.param(0), ctx.param(1)];
        ctx.trace(
            handle,
            [g(0), g(1), g(2)],
            [g(4), g(5), g(6)],
            g(3),
            g(7),
            g(8),
            w[9],
            w[10],
            w[11],
            w[12],
            w[13],
            &mut p,
        )?;
        let s = id * 32;
        let programs = ctx.read(2, s + 16) | p[0] | 1;
        ctx.write(2, s + 16, programs);
        ctx.write(2, s + 17, p[1]);
        for (k, v) in p.iter().take(8).enumerate() {
            ctx.write(2, s + 20 + k, *v);
        }
        Ok(())
    });
    m
}

fn codes() -> Case {
    let mut scene = Scene::default();
    let tris = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(quad(0.0, 0.0, 1.0, 1.0, -1.0), GeometryFlags::NONE),
    )])));
    let boxes = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![[2.0, 0.0, -2.0, 3.0, 1.0, -1.0]],
        GeometryFlags::NONE,
    ))])));
    let root = scene.add(Node::Ias(vec![
        InstanceDesc::of(tris),
        InstanceDesc {
            sbt_offset: 1,
            ..InstanceDesc::of(boxes)
        },
    ]));
    let tri = Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0]);
    let bx = Ray::new([2.5, 0.5, 0.0], [0.0, 0.0, -1.0]);
    let away = Ray::new([9.0, 0.5, 0.0], [0.0, 0.0, -1.0]);
    let rays: Vec<Ray> = [
        (tri, 0),
        (tri, 1),
        (tri, 2),
        (away, 3),
        (tri, 4),
        (bx, 5),
        (tri, 6),
        (tri, 7),
        (tri, 8),
        (bx, 8),
    ]
    .iter()
    .map(|(r, site)| Ray { aux: *site, ..*r })
    .collect();
    let groups = vec![
        hit_group(Some("closesthit__throw"), Some("anyhit__throw"), None),
        hit_group(
            Some("closesthit__throw"),
            Some("anyhit__throw"),
            Some("intersection__throw"),
        ),
    ];
    let mut case = StdCase::new(
        Group::Exc,
        "codes",
        "user exceptions 0, 2^30 − 1 and a code with high bits (masked to 30 bits) thrown from raygen, closest-hit, miss, any-hit and intersection, and TRACE_DEPTH_EXCEEDED (−2) from a trace beyond max_trace_depth: the exception program sees the code and the program that threw stops",
        &[Rule::Exceptions],
        scene,
        Some(root),
    )
    .hits(groups, vec![SbtEntry::new(0, vec![0, action::ACCEPT]), SbtEntry::new(1, vec![1, action::ACCEPT])])
    .launch(10, rays)
    .record(vec![ch::hit(), ch::programs(), uint_channel("exc_code", 28), uint_channel("exc_ran", 29)]);
    case.miss_groups = vec![Some("miss__throw".into())];
    case.raygen = "raygen__throw";
    case.more_wgsl = Some((EXC_WGSL.into(), exc_models()));
    case.compile = PipelineCompileOptions {
        exception_flags: Setting::Value(ExceptionFlags::USER | ExceptionFlags::TRACE_DEPTH),
        ..Default::default()
    };
    case.link = PipelineLinkOptions {
        max_trace_depth: 1,
        ..Default::default()
    };
    let mut case = case.build();
    case.pipeline.exception = Some("exception__record".into());
    case
}

fn invalid_ray_policy() -> Case {
    let (scene, root) = Scene::single(cube(0.0, 1.0).gas(GeometryFlags::DISABLE_ANYHIT));
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let good = Ray::new([0.5, 0.25, 5.0], [0.0, 0.0, -1.0]);
    let rays = vec![
        good,
        Ray {
            origin: [nan, 0.25, 5.0],
            ..good
        },
        Ray {
            origin: [0.5, -inf, 5.0],
            ..good
        },
        Ray {
            dir: [0.0, nan, -1.0],
            ..good
        },
        Ray {
            dir: [inf, 0.0, -1.0],
            ..good
        },
        good.interval(-1.0, 10.0),
        good.interval(nan, 10.0),
        good.interval(0.0, nan),
        good.interval(3.0, 2.0),
        good.interval(-0.0, inf),
    ];
    let mut case = StdCase::new(
        Group::Exc,
        "invalid_ray_policy",
        "with debug exceptions, rays with NaN/Inf origin or direction, negative or NaN tmin, NaN tmax or tmin > tmax raise INVALID_RAY (−9) before any program runs; valid rays trace normally",
        &[Rule::InvalidRayPolicy, Rule::Exceptions],
        scene,
        Some(root),
    )
    .launch(10, rays)
    .record(vec![ch::hit(), ch::programs(), uint_channel("exc_code", 28), uint_channel("exc_ran", 29)]);
    let mut m = Models::new();
    m.add("exception__record", record_code);
    case.more_wgsl = Some(("fn exception__record() {\n    out[slot(28u)] = bitcast<u32>(rt_exception_code());\n    out[slot(29u)] = 0xE0u;\n}\n".into(), m));
    case.compile = PipelineCompileOptions {
        exception_flags: Setting::Value(ExceptionFlags::DEBUG),
        ..Default::default()
    };
    let mut case = case.build();
    case.pipeline.exception = Some("exception__record".into());
    case
}
