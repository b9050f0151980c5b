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

#[test]
fn direct_calls_from_any_hit_are_refused_with_a_reason() {
    let dev = device();
    let src = r#"
fn raygen__rg() { }
fn direct_callable__dc() { }
fn anyhit__ah() {
    var a: RtPayload;
    rt_direct_call(0u, &a);
}
"#;
    let m = dev.module(src);
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: None,
        any_hit: Some(prog(m, "anyhit__ah")),
        intersection: None,
        builtin: BuiltinIntersector::Triangle,
    });
    let dc = dev.group(ProgramGroupDesc::Callables {
        direct: Some(prog(m, "direct_callable__dc")),
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
        e.message().contains("rt_direct_call") && e.message().contains("any-hit"),
        "{e}"
    );
}
