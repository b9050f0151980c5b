//! What is unchecked without exception flags (DESIGN.md §4: a trace or a callable past its
//! depth does nothing, a throw without `USER` raises nothing), callables past their depth
//! with `STACK_OVERFLOW`, and an exception without an exception record.

use crate::call::Calls;
use optik::*;
use optik_conformance::kit::rig::*;

const HEADER: &str = r#"
struct Params { handle: vec2<u32>, n: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
"#;

/// Launches `n` indices of `pipeline` over the null handle; returns `words` u32s of `out`.
fn launch(
    d: &dyn Device,
    pipeline: Pipeline,
    table: &ShaderBindingTable,
    n: u32,
    words: usize,
) -> Vec<u32> {
    let h = TraversableHandle::NULL.to_words();
    run(
        d,
        pipeline,
        table,
        bytemuck::cast_slice(&[h[0], h[1], n, 0]),
        n,
        1,
        words,
    )
}

#[test]
fn without_exception_flags_nothing_is_raised() {
    on_every_backend("exc: nothing raised without flags", |_, d| {
        let calls = Calls::new(d, 2, Setting::Value(ExceptionFlags::NONE));
        let out = calls.run(4);
        assert_eq!(out[8], 0, "no exception program ran");
        assert_eq!(
            out[0], 2,
            "the trace beyond the depth did nothing; raygen went on"
        );
        let out = calls.run(3);
        assert_eq!(out[8], 0, "throws are ignored without USER");
    });
}

/// Direct callable 0 calls itself until its payload counter reaches 10; continuation
/// callable 1 does the same. Each records how deep it got.
const DEEP: &str = r#"
fn raygen__rg() {
    let i = rt_launch_index().x;
    var a: RtPayload;
    if i == 0u {
        rt_direct_call(0u, &a);
    } else {
        rt_continuation_call(1u, &a);
    }
    out[i * 2u] = a[0];
}
fn direct_callable__again() {
    rt_set_payload(0u, rt_get_payload(0u) + 1u);
    if rt_get_payload(0u) < 10u {
        var a: RtPayload;
        a[0] = rt_get_payload(0u);
        rt_direct_call(0u, &a);
        rt_set_payload(0u, a[0]);
    }
}
fn continuation_callable__again() {
    rt_set_payload(0u, rt_get_payload(0u) + 1u);
    if rt_get_payload(0u) < 10u {
        var a: RtPayload;
        a[0] = rt_get_payload(0u);
        rt_continuation_call(1u, &a);
        rt_set_payload(0u, a[0]);
    }
}
fn exception__ex() {
    out[rt_launch_index().x * 2u + 1u] = bitcast<u32>(rt_exception_code());
}
"#;

#[test]
fn callables_past_their_depth_overflow_the_stack_or_are_skipped() {
    on_every_backend("exc: callables past their depth", |_, d| {
        let m = module(d, &format!("{HEADER}{DEEP}"));
        let g = groups(
            d,
            &[
                raygen(m, "raygen__rg"),
                ProgramGroupDesc::Callables {
                    direct: Some(ProgramRef::new(m, "direct_callable__again")),
                    continuation: Some(ProgramRef::new(m, "continuation_callable__again")),
                },
                ProgramGroupDesc::Callables {
                    direct: Some(ProgramRef::new(m, "direct_callable__again")),
                    continuation: Some(ProgramRef::new(m, "continuation_callable__again")),
                },
                ProgramGroupDesc::Exception(ProgramRef::new(m, "exception__ex")),
            ],
        );
        let link = PipelineLinkOptions {
            max_trace_depth: 1,
            max_direct_callable_depth: 3,
            max_continuation_callable_depth: 2,
        };
        let overflow = semantics::exception::STACK_OVERFLOW as u32;
        for flags in [ExceptionFlags::STACK_OVERFLOW, ExceptionFlags::NONE] {
            let options = PipelineCompileOptions {
                exception_flags: Setting::Value(flags),
                ..Default::default()
            };
            let p = d
                .create_pipeline(&options, &link, &g.all())
                .unwrap_or_else(|e| panic!("{e}"));
            let w = launch(d, p, &sbt(d, &g, &[]), 2, 4);
            if flags == ExceptionFlags::STACK_OVERFLOW {
                assert_eq!(
                    w[1], overflow,
                    "direct calls past max_direct_callable_depth"
                );
                assert_eq!(w[0], 0, "the launch index ended");
                assert_eq!(
                    w[3], overflow,
                    "continuation calls past max_continuation_callable_depth"
                );
            } else {
                assert_eq!(w[0], 3, "the fourth nested direct call is skipped");
                assert_eq!(w[2], 2, "the third nested continuation call is skipped");
                assert_eq!([w[1], w[3]], [0, 0], "nothing raised");
            }
        }
    });
}

#[test]
fn an_exception_without_its_record_runs_nothing_and_ends_the_launch_index() {
    on_every_backend("exc: no exception record", |_, d| {
        let src = r#"
fn raygen__rg() {
    out[0] = 1u;
    rt_throw_exception(3u);
    out[1] = 1u;
}
fn exception__ex() {
    out[2] = 1u;
}
"#;
        let m = module(d, &format!("{HEADER}{src}"));
        let g = groups(
            d,
            &[
                raygen(m, "raygen__rg"),
                ProgramGroupDesc::Exception(ProgramRef::new(m, "exception__ex")),
            ],
        );
        let options = PipelineCompileOptions {
            exception_flags: Setting::Value(ExceptionFlags::ALL),
            ..Default::default()
        };
        let p = d
            .create_pipeline(&options, &PipelineLinkOptions::default(), &g.all())
            .unwrap_or_else(|e| panic!("{e}"));
        // The table has no exception record.
        let mut table = sbt(d, &g, &[]);
        table.exception = None;
        assert_eq!(launch(d, p, &table, 1, 3), vec![1, 0, 0]);
    });
}
