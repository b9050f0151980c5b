//! Recursion with private globals per program invocation, callables past the table, and
//! programs from two modules with their own bindings and helpers.

use optik::*;
use optik_conformance::kit::rig::*;

/// Modes: 0 recursion (closest-hit traces again until the depth runs out), 1 callables,
/// 3 a user exception in closest-hit, 4 a trace past the depth. `out[8..11]` is written by
/// the exception program.
pub const PROGRAMS: &str = r#"
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

/// A pipeline over [`PROGRAMS`] and the unit quad, with its table: `run(mode)` launches one
/// index and returns `out` (16 words).
pub struct Calls<'a> {
    d: &'a dyn Device,
    pipeline: Pipeline,
    table: ShaderBindingTable,
    handle: TraversableHandle,
}

impl<'a> Calls<'a> {
    pub fn new(
        d: &'a dyn Device,
        max_trace_depth: u32,
        exceptions: Setting<ExceptionFlags>,
    ) -> Self {
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
        Calls {
            d,
            pipeline,
            table: numbered_sbt(d, &g),
            handle: d.traversable_handle(gas).unwrap(),
        }
    }

    pub fn run(&self, mode: u32) -> Vec<u32> {
        run(
            self.d,
            self.pipeline,
            &self.table,
            &params(self.handle, &[mode]),
            1,
            1,
            16,
        )
    }
}

#[test]
fn recursion_keeps_private_globals_per_invocation_and_unknown_callables_do_nothing() {
    on_every_backend("call: private globals, callables past the table", |_, d| {
        let calls = Calls::new(d, 3, Setting::Auto);
        let out = calls.run(0);
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
        let out = calls.run(1);
        assert_eq!(out[0], 10, "direct callable 0 doubles");
        assert_eq!(out[1], 16, "direct callable 1 adds 3 and calls 0 (nested)");
        assert_eq!(
            out[2], 1003,
            "the continuation callable traced (3 levels deep)"
        );
        assert_eq!(out[3], 9, "no callable record 7: nothing runs");
        assert_eq!(out[8], 0, "no exception without DEBUG");
    });
}

#[test]
fn programs_from_two_modules_keep_their_own_bindings_and_helpers() {
    on_every_backend("call: programs from two modules", |_, d| {
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
    });
}
