//! Recursion through per-depth copies, private globals per program invocation, direct and
//! continuation callables, and exceptions.
mod common;
use common::*;
use optik_api::*;
use std::sync::{Mutex, OnceLock};

const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, mode: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

var<private> owner: u32 = 7u;
var<private> ch_calls: u32;

fn trace_down(p: ptr<function, RtPayload>) {
    rt_trace(params.handle, vec3<f32>(0.5, 0.5, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, p);
}

fn raygen__main() {
    // Overwritten at the end unless an exception ends this launch index first.
    out[0] = 0xEEEEu;
    if owner != 7u {
        out[6] = 0xBADu;
    }
    owner = 42u;
    var p: RtPayload;
    for (var k = 0u; k < 8u; k = k + 1u) {
        p[k] = 0u;
    }
    if params.mode == 0u || params.mode == 3u || params.mode == 4u {
        trace_down(&p);
    } else if params.mode == 1u {
        var args: RtPayload;
        args[0] = 5u;
        rt_direct_call(0u, &args);
        p[0] = args[0];
        args[0] = 5u;
        rt_direct_call(1u, &args);
        p[1] = args[0];
        args[0] = 0u;
        rt_continuation_call(2u, &args);
        p[2] = args[0];
        args[0] = 9u;
        rt_direct_call(7u, &args);
        p[3] = args[0];
    } else if params.mode == 2u {
        rt_trace(params.handle, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, -1.0), -1.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    }
    out[0] = p[0];
    out[1] = p[1];
    out[2] = p[2];
    out[3] = p[3];
    out[4] = owner;
    out[5] = p[7];
}

fn closesthit__recurse() {
    ch_calls = ch_calls + 1u;
    owner = 99u;
    let depth = rt_get_payload(0u) + 1u;
    rt_set_payload(0u, depth);
    rt_set_payload(depth, rt_remaining_trace_depth());
    if params.mode == 3u {
        rt_throw_exception(77u);
    }
    if rt_remaining_trace_depth() > 0u || params.mode == 4u {
        var q: RtPayload;
        for (var k = 0u; k < 8u; k = k + 1u) {
            q[k] = 0u;
        }
        q[0] = depth;
        trace_down(&q);
        rt_set_payload(0u, q[0]);
        for (var k = 1u; k < 7u; k = k + 1u) {
            if q[k] != 0u {
                rt_set_payload(k, q[k]);
            }
        }
        if q[7] != 0u {
            rt_set_payload(7u, q[7]);
        }
    }
    // This invocation's private globals survive the nested trace.
    if ch_calls != 1u || owner != 99u {
        rt_set_payload(7u, 0xBADu);
    }
}

fn miss__none() {
    rt_set_payload(0u, 0xFFFFu);
}

fn direct_callable__double() {
    rt_set_payload(0u, rt_get_payload(0u) * 2u);
}

fn direct_callable__add_then_double() {
    var a: RtPayload;
    a[0] = rt_get_payload(0u) + 3u;
    rt_direct_call(0u, &a);
    rt_set_payload(0u, a[0]);
}

fn continuation_callable__trace() {
    var q: RtPayload;
    q[0] = 0u;
    trace_down(&q);
    rt_set_payload(0u, q[0] + 1000u);
}

fn exception__record() {
    out[8] = bitcast<u32>(rt_exception_code());
    out[9] = rt_sbt_data_u32(0u);
    out[10] = rt_launch_index().x + 1u;
}
"#;

struct Rig {
    dev: Box<dyn Device>,
    pipeline: Pipeline,
    table: ShaderBindingTable,
    handle: TraversableHandle,
}

/// One pipeline per (depth, exception flags), compiled once for all tests of this file:
/// lavapipe compiles a kernel at its first dispatch, which takes seconds for deep ones.
fn rig(max_trace_depth: u32, exceptions: Setting<ExceptionFlags>) -> &'static Rig {
    type Rigs = Mutex<Vec<((u32, Setting<ExceptionFlags>), &'static Rig)>>;
    static RIGS: OnceLock<Rigs> = OnceLock::new();
    let mut rigs = RIGS.get_or_init(|| Mutex::new(Vec::new())).lock().unwrap();
    if let Some((_, r)) = rigs
        .iter()
        .find(|(k, _)| *k == (max_trace_depth, exceptions))
    {
        return r;
    }
    let dev = device();
    let d = dev.as_ref();
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(d, PROGRAMS);
    let g = groups(
        d,
        &[
            raygen(m, "raygen__main"),
            miss(m, "miss__none"),
            closest_hit(m, "closesthit__recurse"),
            ProgramGroupDesc::Callables {
                direct: Some(ProgramRef::new(m, "direct_callable__double")),
                continuation: None,
            },
            ProgramGroupDesc::Callables {
                direct: Some(ProgramRef::new(m, "direct_callable__add_then_double")),
                continuation: None,
            },
            ProgramGroupDesc::Callables {
                direct: None,
                continuation: Some(ProgramRef::new(m, "continuation_callable__trace")),
            },
            ProgramGroupDesc::Exception(ProgramRef::new(m, "exception__record")),
        ],
    );
    let pipeline = d
        .create_pipeline(
            &PipelineCompileOptions {
                exception_flags: exceptions,
                ..Default::default()
            },
            &PipelineLinkOptions {
                max_trace_depth,
                ..Default::default()
            },
            &g.all(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let table = numbered_sbt(d, &g);
    let handle = d.traversable_handle(gas).unwrap();
    let r: &'static Rig = Box::leak(Box::new(Rig {
        dev,
        pipeline,
        table,
        handle,
    }));
    rigs.push(((max_trace_depth, exceptions), r));
    r
}

fn run_mode(mode: u32, max_trace_depth: u32, exceptions: Setting<ExceptionFlags>) -> Vec<u32> {
    let r = rig(max_trace_depth, exceptions);
    let d = r.dev.as_ref();
    run(
        d,
        r.pipeline,
        &r.table,
        &params(r.handle, &[mode]),
        1,
        1,
        16,
    )
}

#[test]
fn recursion_to_the_maximum_depth_with_private_globals_per_invocation() {
    let out = run_mode(0, 3, Setting::Auto);
    assert_eq!(out[0], 3, "raygen → closest-hit ×3");
    assert_eq!(
        &out[1..4],
        &[2, 1, 0],
        "remaining trace depth at depths 1, 2, 3"
    );
    assert_eq!(
        out[4], 42,
        "raygen's private global kept through the traces"
    );
    assert_eq!(out[5], 0, "each closest-hit kept its own private globals");
    assert_eq!(out[6], 0, "raygen started with the initial value");
    assert_eq!(out[8], 0, "no exception");
}

#[test]
fn direct_and_continuation_callables() {
    let out = run_mode(1, 3, Setting::Auto);
    assert_eq!(out[0], 10, "direct callable 0 doubles");
    assert_eq!(out[1], 16, "direct callable 1 adds 3 and calls 0 (nested)");
    assert_eq!(
        out[2], 1003,
        "the continuation callable traced (3 levels deep)"
    );
    assert_eq!(out[3], 9, "no callable record 7: nothing runs");
}

#[test]
fn trace_depth_exceeded_runs_the_exception_program_and_ends_the_launch_index() {
    let out = run_mode(4, 2, Setting::Auto);
    assert_eq!(
        out[8] as i32,
        optik_api::semantics::exception::TRACE_DEPTH_EXCEEDED
    );
    assert_eq!(out[9], 300, "the exception record's data");
    assert_eq!(out[10], 1, "rt_launch_index in the exception program");
    assert_eq!(
        out[0], 0xEEEE,
        "raygen did not continue after the exception"
    );
}

#[test]
fn user_exceptions() {
    let out = run_mode(3, 2, Setting::Auto);
    assert_eq!(out[8], 77);
    assert_eq!(out[0], 0xEEEE);
}

#[test]
fn invalid_rays_raise_with_debug_exceptions() {
    let out = run_mode(
        2,
        2,
        Setting::Value(ExceptionFlags::DEBUG | ExceptionFlags::USER),
    );
    assert_eq!(out[8] as i32, optik_api::semantics::exception::INVALID_RAY);
    let out = run_mode(2, 2, Setting::Auto);
    assert_eq!(
        out[8], 0,
        "without DEBUG the invalid ray just misses, silently"
    );
    assert_eq!(out[0], 0, "no program ran, the payload is unchanged");
}

#[test]
fn without_exception_flags_nothing_is_raised() {
    let out = run_mode(4, 2, Setting::Value(ExceptionFlags::NONE));
    assert_eq!(out[8], 0);
    assert_eq!(
        out[0], 2,
        "the trace beyond the depth did nothing; raygen went on"
    );
    let out = run_mode(3, 2, Setting::Value(ExceptionFlags::NONE));
    assert_eq!(out[8], 0, "throws are ignored without USER");
}
