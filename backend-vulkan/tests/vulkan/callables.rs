//! Direct and continuation callables, recursion, and the remaining trace depth.

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
fn raygen__rg() {
    let i = rt_launch_index().x;
    var a: RtPayload;
    a[0] = 5u;
    rt_direct_call(1u, &a);            // direct callable 1: a[0] = a[0] * 2 + data (3), via callable 0 (+100)
    out[i * 8u] = a[0];
    var c: RtPayload;
    c[1] = 0u;
    rt_continuation_call(2u, &c);      // continuation callable: traces, returns the primitive
    out[i * 8u + 1u] = c[0];
    out[i * 8u + 2u] = c[1];
    var p: RtPayload;
    rt_trace(params.handle, vec3<f32>(0.25, 0.25, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[i * 8u + 3u] = p[0];           // remaining depth in the primary closest-hit
    out[i * 8u + 4u] = p[1];           // remaining depth in the secondary closest-hit
    out[i * 8u + 5u] = p[2];           // how many closest-hits ran
    out[i * 8u + 6u] = rt_remaining_trace_depth();
    var none: RtPayload;
    none[0] = 0xBEEFu;
    rt_direct_call(9u, &none);         // past the table: nothing runs
    out[i * 8u + 7u] = none[0];
}

fn direct_callable__add() {
    rt_set_payload(0u, rt_get_payload(0u) + rt_sbt_data_u32(0u));
}

fn direct_callable__twice() {
    var inner: RtPayload;
    inner[0] = rt_get_payload(0u) * 2u;
    rt_direct_call(0u, &inner);
    rt_set_payload(0u, inner[0] + rt_sbt_data_u32(0u));
}

fn continuation_callable__shoot() {
    var p: RtPayload;
    rt_trace(params.handle, vec3<f32>(1.25, 0.25, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    rt_set_payload(0u, p[3]);
    rt_set_payload(1u, rt_remaining_trace_depth());
}

// Traces once more from the first hit; records the remaining depth per level.
fn closesthit__ch() {
    let depth = rt_remaining_trace_depth();
    rt_set_payload(2u, rt_get_payload(2u) + 1u);
    rt_set_payload(3u, rt_primitive_index() + 1u);
    if depth == 1u {
        rt_set_payload(0u, depth);
        var p: RtPayload;
        p[2] = 0u;
        rt_trace(params.handle, rt_world_ray_origin() + vec3<f32>(1.0, 0.0, 0.0), rt_world_ray_direction(), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
        rt_set_payload(1u, p[1]);
        rt_set_payload(2u, rt_get_payload(2u) + p[2]);
    } else {
        rt_set_payload(1u, depth);
        // Past max_trace_depth: the trace is skipped (no exception flags), nothing runs.
        var q: RtPayload;
        q[2] = 0u;
        rt_trace(params.handle, rt_world_ray_origin(), rt_world_ray_direction(), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &q);
        rt_set_payload(2u, rt_get_payload(2u) + q[2]);
    }
}

fn miss__ms() {
    rt_set_payload(3u, 999u);
}
"#;

#[test]
fn direct_continuation_callables_and_recursion() {
    let dev = device();
    let tris: Vec<[f32; 3]> = (0..2)
        .flat_map(|k| {
            [
                [k as f32, 0.0, 0.0],
                [k as f32 + 1.0, 0.0, 0.0],
                [k as f32, 1.0, 0.0],
            ]
        })
        .collect();
    let gas = dev.triangles(&tris, GeometryFlags::DISABLE_ANYHIT);
    let m = dev.module(&format!("{RAY_HEADER}{PROGRAMS}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let ch = dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__ch")));
    let add = dev.group(ProgramGroupDesc::Callables {
        direct: Some(prog(m, "direct_callable__add")),
        continuation: None,
    });
    let twice = dev.group(ProgramGroupDesc::Callables {
        direct: Some(prog(m, "direct_callable__twice")),
        continuation: None,
    });
    let shoot = dev.group(ProgramGroupDesc::Callables {
        direct: None,
        continuation: Some(prog(m, "continuation_callable__shoot")),
    });
    let pipeline = dev.pipeline(&[rg, ms, ch, add, twice, shoot], 2);
    let features = dev.pipeline_features(pipeline).unwrap();
    assert!(features.direct_callables && features.continuation_callables);
    let mut table = Table::new(rg);
    table.miss.push((ms, &[]));
    table.hit.push((ch, &[]));
    table.callables = vec![(add, &[100]), (twice, &[3]), (shoot, &[])];
    let sbt = table.build(&dev);
    let w = run_rays(
        &dev,
        pipeline,
        &sbt,
        dev.traversable_handle(gas).unwrap(),
        1,
        8,
        &[],
    );
    assert_eq!(
        w[0],
        5 * 2 + 100 + 3,
        "direct callables nest and read their own records"
    );
    assert_eq!(
        w[1], 2,
        "the continuation callable traced and hit primitive 1"
    );
    assert_eq!(
        w[2], 2,
        "a continuation callable called from raygen sees the raygen's depth"
    );
    assert_eq!(w[3], 1, "remaining depth in the primary closest-hit");
    assert_eq!(w[4], 0, "remaining depth in the secondary closest-hit");
    assert_eq!(
        w[5], 2,
        "two closest-hits ran: the third trace was past max_trace_depth"
    );
    assert_eq!(w[6], 2, "remaining depth in raygen is max_trace_depth");
    assert_eq!(w[7], 0xBEEF, "a callable index past the table runs nothing");
}

/// Programs for direct calls from intersection and any-hit programs: a custom primitive whose
/// intersection program reports at the t a direct callable computes, an any-hit program that
/// asks a direct callable whether to ignore the candidate, and callables that nest.
const INLINED: &str = r#"
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 0xFFFFu;
    p[1] = 0u;
    p[2] = i;
    // Ray i down at x = i + 0.5 over boxes 0..3 of one custom GAS.
    rt_trace(params.handle, vec3<f32>(f32(i) + 0.5, 0.5, 10.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[i * 4u] = p[0];
    out[i * 4u + 1u] = p[1];
    out[i * 4u + 2u] = p[3];
}

// Callable 0: t = 10 - (args[0] + its record's data).
fn direct_callable__depth() {
    rt_set_payload(0u, rt_get_payload(0u) + rt_sbt_data_u32(0u));
}

// Callable 1: calls callable 0 twice (nested), then doubles.
fn direct_callable__twice() {
    var a: RtPayload;
    a[0] = rt_get_payload(0u);
    rt_direct_call(0u, &a);
    rt_direct_call(0u, &a);
    rt_set_payload(0u, a[0] * 2u);
}

// Callable 2: recurses through callable 2 until the depth runs out.
fn direct_callable__forever() {
    var a: RtPayload;
    rt_direct_call(2u, &a);
}

// Callable 3: throws.
fn direct_callable__throws() {
    rt_throw_exception(77u);
}

fn intersection__is() {
    let prim = rt_primitive_index();
    var a: RtPayload;
    a[0] = prim;
    // Box 0 and 2 use callable 0 (t = 10 - (prim + 1)); box 1 callable 1 (t = 10 - 2(1 + 2)).
    if prim == 1u {
        rt_direct_call(1u, &a);
    } else {
        rt_direct_call(0u, &a);
    }
    if prim == 3u {
        // Past the table: nothing runs, the arguments stay.
        rt_direct_call(9u, &a);
        a[0] = a[0] + 100u;
    }
    var attributes: RtAttributes;
    attributes[0] = a[0];
    rt_report_intersection(10.0 - f32(a[0] % 10u), 0u, attributes);
}

fn anyhit__ah() {
    var a: RtPayload;
    a[0] = rt_get_attribute(0u);
    rt_direct_call(0u, &a);
    rt_set_payload(1u, a[0]);
    // Ray 2 recurses past the depth (the pipeline checks nothing: the call is skipped), ray 3
    // throws (USER is checked).
    if rt_get_payload(2u) == 2u {
        rt_direct_call(2u, &a);
    }
    if rt_get_payload(2u) == 3u {
        rt_direct_call(3u, &a);
    }
}

fn closesthit__ch() {
    rt_set_payload(0u, rt_primitive_index());
    rt_set_payload(3u, bitcast<u32>(rt_ray_tmax()));
}

fn exception__ex() {
    out[rt_launch_index().x * 4u + 3u] = bitcast<u32>(rt_exception_code());
}
"#;

#[test]
fn direct_calls_from_intersection_and_any_hit_programs() {
    let dev = device();
    let boxes: Vec<[f32; 6]> = (0..4)
        .map(|k| [k as f32, 0.0, -1.0, k as f32 + 1.0, 1.0, 1.0])
        .collect();
    let gas = dev.aabbs(&boxes, GeometryFlags::NONE);
    let m = dev.module(&format!("{RAY_HEADER}{INLINED}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: Some(prog(m, "anyhit__ah")),
        intersection: Some(prog(m, "intersection__is")),
        builtin: BuiltinIntersector::Triangle,
    });
    let callable = |name: &str| {
        dev.group(ProgramGroupDesc::Callables {
            direct: Some(prog(m, name)),
            continuation: None,
        })
    };
    let (depth, twice, forever, throws) = (
        callable("direct_callable__depth"),
        callable("direct_callable__twice"),
        callable("direct_callable__forever"),
        callable("direct_callable__throws"),
    );
    let ex = dev.group(ProgramGroupDesc::Exception(prog(m, "exception__ex")));
    let options = PipelineCompileOptions {
        exception_flags: Setting::Value(ExceptionFlags::USER),
        ..Default::default()
    };
    let link = PipelineLinkOptions {
        max_direct_callable_depth: 3,
        ..Default::default()
    };
    let pipeline = dev
        .create_pipeline(
            &options,
            &link,
            &[rg, hg, depth, twice, forever, throws, ex],
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let mut table = Table::new(rg);
    table.hit.push((hg, &[]));
    table.callables = vec![(depth, &[1]), (twice, &[]), (forever, &[]), (throws, &[])];
    table.exception = Some((ex, &[]));
    let sbt = table.build(&dev);
    let w = run_rays(
        &dev,
        pipeline,
        &sbt,
        dev.traversable_handle(gas).unwrap(),
        4,
        4,
        &[],
    );
    let ray = |i: usize| &w[4 * i..4 * i + 4];
    // Box 0: the intersection's callable gives 0 + 1 = 1, t = 9; the any-hit's callable
    // adds 1 to attribute 0 (1): 2.
    assert_eq!(ray(0)[..3], [0, 2, 9.0f32.to_bits()], "ray 0: {:?}", ray(0));
    // Box 1: callable 1 nests callable 0 twice: (1 + 1 + 1) * 2 = 6, t = 4.
    assert_eq!(ray(1)[..3], [1, 7, 4.0f32.to_bits()], "ray 1: {:?}", ray(1));
    // Box 2: t = 10 - 3 = 7; recursion past max_direct_callable_depth is skipped.
    assert_eq!(ray(2)[..3], [2, 4, 7.0f32.to_bits()], "ray 2: {:?}", ray(2));
    assert_eq!(ray(2)[3], 0, "no exception without STACK_OVERFLOW");
    // Box 3: the index past the table runs nothing; callable 3 throws from the any-hit: the
    // exception program runs and the launch index ends.
    assert_eq!(ray(3)[3], 77, "ray 3: {:?}", ray(3));
    assert_eq!(ray(3)[0], 0, "nothing after the throw writes");
    dev.assert_no_messages();
}

#[test]
fn direct_calls_from_any_hit_reach_callables_of_its_module_only() {
    let dev = device();
    let a = dev.module(
        "fn raygen__rg() { }\nfn anyhit__ah() {\n    var a: RtPayload;\n    rt_direct_call(0u, &a);\n}\n",
    );
    let b = dev.module("fn direct_callable__dc() { }\n");
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(a, "raygen__rg")));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: None,
        any_hit: Some(prog(a, "anyhit__ah")),
        intersection: None,
        builtin: BuiltinIntersector::Triangle,
    });
    let dc = dev.group(ProgramGroupDesc::Callables {
        direct: Some(prog(b, "direct_callable__dc")),
        continuation: None,
    });
    let e = dev
        .create_pipeline(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions::default(),
            &[rg, hg, dc],
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Unsupported);
    assert!(
        e.message().contains("rt_direct_call") && e.message().contains("same module"),
        "{e}"
    );
}
