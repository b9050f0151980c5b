//! Exceptions: user throws from every kind of program, trace depth exceeded, invalid rays
//! with and without debug exceptions. The exception program runs as a callable; afterwards
//! the launch index ends (its later writes do not happen).

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
// Ray i: its raygen record word i says where to throw (0 nowhere, 1 raygen, 2 closest-hit,
// 3 any-hit, 4 intersection, 5 miss, 6 direct callable, 7 trace too deep, 8 invalid ray).
fn raygen__rg() {
    let i = rt_launch_index().x;
    let what = rt_sbt_data_u32(i);
    out[i * 4u] = 1u;
    if what == 1u {
        rt_throw_exception(11u);
    }
    var p: RtPayload;
    p[0] = what;
    var x = 0.5;
    if what == 5u {
        x = 5.0;
    }
    var tmin = 0.0;
    if what == 8u {
        tmin = -1.0;
    }
    if what == 4u {
        x = 3.5;
    }
    trace(x, tmin, &p);
    out[i * 4u + 1u] = p[1] + 1u;
    if what == 6u {
        rt_direct_call(0u, &p);
    }
    out[i * 4u + 2u] = 7u;
}

fn trace(x: f32, tmin: f32, p: ptr<function, RtPayload>) {
    rt_trace(params.handle, vec3<f32>(x, 0.25, 1.0), vec3<f32>(0.0, 0.0, -1.0), tmin, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, p);
}

fn closesthit__ch() {
    let what = rt_get_payload(0u);
    if what == 2u {
        rt_throw_exception(22u);
    }
    if what == 7u {
        var q: RtPayload;
        q[0] = 7u;
        trace(0.5, 0.0, &q);
    }
    rt_set_payload(1u, 100u);
}

fn anyhit__ah() {
    if rt_get_payload(0u) == 3u {
        rt_throw_exception(33u);
    }
}

fn intersection__is() {
    if rt_primitive_index() == 0u && rt_ray_tmin() == 0.0 {
        rt_throw_exception(44u);
    }
}

fn miss__ms() {
    if rt_get_payload(0u) == 5u {
        rt_throw_exception(55u);
    }
    rt_set_payload(1u, 200u);
}

fn direct_callable__dc() {
    rt_throw_exception(66u);
}

fn exception__ex() {
    let i = rt_launch_index().x;
    out[i * 4u + 3u] = bitcast<u32>(rt_exception_code()) ^ rt_sbt_data_u32(0u);
}
"#;

fn run(dev: &TestDevice, exceptions: Setting<ExceptionFlags>, what: &[u32]) -> Vec<[u32; 4]> {
    let tris: Vec<[f32; 3]> = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let tri = dev.triangles(&tris, GeometryFlags::NONE);
    let boxes = dev.aabbs(&[[3.0, 0.0, -1.0, 4.0, 1.0, 0.0]], GeometryFlags::NONE);
    let mut ti = Instance::new(dev.traversable_handle(tri).unwrap());
    ti.sbt_offset = 0;
    let mut bi = Instance::new(dev.traversable_handle(boxes).unwrap());
    bi.sbt_offset = 1;
    let ias = dev.instances(&[ti, bi]);
    let m = dev.module(&format!("{RAY_HEADER}{PROGRAMS}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let tri_hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: Some(prog(m, "anyhit__ah")),
        intersection: None,
        builtin: BuiltinIntersector::Triangle,
    });
    let box_hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: None,
        intersection: Some(prog(m, "intersection__is")),
        builtin: BuiltinIntersector::Triangle,
    });
    let dc = dev.group(ProgramGroupDesc::Callables {
        direct: Some(prog(m, "direct_callable__dc")),
        continuation: None,
    });
    let ex = dev.group(ProgramGroupDesc::Exception(prog(m, "exception__ex")));
    let options = PipelineCompileOptions {
        exception_flags: exceptions,
        ..Default::default()
    };
    let link = PipelineLinkOptions {
        max_trace_depth: 1,
        ..Default::default()
    };
    let pipeline = dev
        .create_pipeline(&options, &link, &[rg, ms, tri_hg, box_hg, dc, ex])
        .unwrap_or_else(|e| panic!("{e}"));
    let mut table = Table::new(rg);
    table.raygen = (rg, what);
    table.miss.push((ms, &[]));
    table.hit = vec![(tri_hg, &[]), (box_hg, &[])];
    table.callables.push((dc, &[]));
    table.exception = Some((ex, &[0xF000_0000]));
    table.stride = 96;
    let sbt = table.build(dev);
    let w = run_rays(
        dev,
        pipeline,
        &sbt,
        dev.traversable_handle(ias).unwrap(),
        what.len() as u32,
        4,
        &[],
    );
    w.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
}

/// The exception program's record: its data word marks what it wrote.
fn code(c: i32) -> u32 {
    (c as u32) ^ 0xF000_0000
}

#[test]
fn exceptions_run_the_exception_program_and_end_the_launch_index() {
    let dev = device();
    let what: Vec<u32> = (0..9).collect();
    let out = run(&dev, Setting::Value(ExceptionFlags::ALL), &what);
    assert_eq!(
        out[0],
        [1, 101, 7, 0],
        "no exception: the ray hits, raygen finishes"
    );
    assert_eq!(out[1], [1, 0, 0, code(11)], "throw in raygen");
    assert_eq!(
        out[2],
        [1, 0, 0, code(22)],
        "throw in closest-hit: raygen's later writes are skipped"
    );
    assert_eq!(
        out[3],
        [1, 0, 0, code(33)],
        "throw in any-hit (run from the tracing stage)"
    );
    assert_eq!(out[4], [1, 0, 0, code(44)], "throw in intersection");
    assert_eq!(out[5], [1, 0, 0, code(55)], "throw in miss");
    assert_eq!(out[6], [1, 101, 0, code(66)], "throw in a direct callable");
    assert_eq!(
        out[7],
        [1, 0, 0, code(semantics::exception::TRACE_DEPTH_EXCEEDED)],
        "trace past max_trace_depth"
    );
    assert_eq!(
        out[8],
        [1, 0, 0, code(semantics::exception::INVALID_RAY)],
        "negative tmin with debug exceptions"
    );
}

#[test]
fn without_exception_flags_throws_are_ignored_and_invalid_rays_miss_silently() {
    let dev = device();
    let what = [2u32, 8, 7];
    let out = run(&dev, Setting::Value(ExceptionFlags::NONE), &what);
    assert_eq!(
        out[0],
        [1, 101, 7, 0],
        "a throw without USER checking does nothing"
    );
    assert_eq!(
        out[1],
        [1, 1, 7, 0],
        "an invalid ray runs no program and leaves the payload"
    );
    assert_eq!(
        out[2],
        [1, 101, 7, 0],
        "a trace past max_trace_depth is skipped"
    );
}

const DEEP: &str = r#"
// Direct callable 0 calls itself until its payload counter reaches 10; continuation
// callable 1 does the same. Each records how deep it got.
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
fn callables_past_their_depth_overflow_the_stack() {
    let dev = device();
    let m = dev.module(&format!("{RAY_HEADER}{DEEP}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let calls = dev.group(ProgramGroupDesc::Callables {
        direct: Some(prog(m, "direct_callable__again")),
        continuation: Some(prog(m, "continuation_callable__again")),
    });
    let ex = dev.group(ProgramGroupDesc::Exception(prog(m, "exception__ex")));
    let link = PipelineLinkOptions {
        max_trace_depth: 1,
        max_direct_callable_depth: 3,
        max_continuation_callable_depth: 2,
    };
    for (flags, with_exception) in [
        (ExceptionFlags::STACK_OVERFLOW, true),
        (ExceptionFlags::NONE, false),
    ] {
        let options = PipelineCompileOptions {
            exception_flags: Setting::Value(flags),
            ..Default::default()
        };
        let groups: Vec<ProgramGroup> = if with_exception {
            vec![rg, calls, ex]
        } else {
            vec![rg, calls]
        };
        let p = dev
            .create_pipeline(&options, &link, &groups)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut table = Table::new(rg);
        table.callables = vec![(calls, &[]), (calls, &[])];
        if with_exception {
            table.exception = Some((ex, &[]));
        }
        let sbt = table.build(&dev);
        let w = run_rays(&dev, p, &sbt, TraversableHandle::NULL, 2, 2, &[]);
        let overflow = semantics::exception::STACK_OVERFLOW as u32;
        if with_exception {
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
        }
    }
}

#[test]
fn an_exception_program_without_its_record_runs_nothing_and_ends_the_launch_index() {
    let dev = device();
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
    let m = dev.module(&format!("{RAY_HEADER}{src}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ex = dev.group(ProgramGroupDesc::Exception(prog(m, "exception__ex")));
    let options = PipelineCompileOptions {
        exception_flags: Setting::Value(ExceptionFlags::ALL),
        ..Default::default()
    };
    let p = dev
        .create_pipeline(&options, &PipelineLinkOptions::default(), &[rg, ex])
        .unwrap();
    // No exception record: the null callable stands in (and raises under DEBUG, which must
    // not run it again).
    let sbt = Table::new(rg).build(&dev);
    let w = run_rays(&dev, p, &sbt, TraversableHandle::NULL, 1, 3, &[]);
    assert_eq!(w, vec![1, 0, 0]);
}
