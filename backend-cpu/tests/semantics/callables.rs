//! Direct and continuation callables: argument copy semantics, nesting, depth limits.

use crate::kit::*;
use optik_api::semantics::exception as code;
use optik_api::*;

#[test]
fn callables_copy_arguments_nest_and_overflow() {
    let kit = Kit::new();
    let gas = kit.triangles(
        &quad(-1.0, -1.0, 1.0, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let log = Log::default();
    let (l1, l2, l3) = (log.clone(), log.clone(), log.clone());
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let x = c.launch_index()[0];
                // Callable 0 adds its record's data to args[0] and recurses `args[1]` times.
                let mut args = [10u32, x * 2, 5];
                c.direct_call(0, &mut args);
                if c.unwinding() {
                    return;
                }
                l1.put(c, "args", &args.map(|a| a as f64));
                // A continuation callable that traces.
                let mut args = [0u32];
                c.continuation_call(1, &mut args);
                if c.unwinding() {
                    return;
                }
                l1.put(c, "traced", &[args[0] as f64]);
            }),
        ),
        (
            "direct_callable__add",
            program(move |c| {
                let n = c.get_payload(1);
                c.set_payload(0, c.get_payload(0) + c.sbt_data_u32(0));
                c.set_payload(2, 0);
                if n > 0 {
                    let mut args = [c.get_payload(0), n - 1];
                    c.direct_call(0, &mut args);
                    if c.unwinding() {
                        return;
                    }
                    c.set_payload(0, args[0]);
                }
            }),
        ),
        (
            "continuation_callable__trace",
            program(move |c| {
                let mut p = [0u32];
                trace_ray(c, gas, Ray::new([0.0; 3], [0.0, 0.0, 1.0]), &mut p);
                c.set_payload(0, p[0]);
            }),
        ),
        (
            "closesthit__main",
            program(move |c| c.set_payload(0, c.ray_tmax() as u32)),
        ),
        (
            "exception__main",
            program(move |c| l2.put(c, "exception", &[c.exception_code() as f64])),
        ),
        ("miss__main", program(move |c| l3.put(c, "miss", &[]))),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let dc = kit.group(ProgramGroupDesc::Callables {
        direct: Some(ProgramRef::new(m, "direct_callable__add")),
        continuation: None,
    });
    let cc = kit.group(ProgramGroupDesc::Callables {
        direct: None,
        continuation: Some(ProgramRef::new(m, "continuation_callable__trace")),
    });
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let ex = kit.group(ProgramGroupDesc::Exception(ProgramRef::new(
        m,
        "exception__main",
    )));
    let link = PipelineLinkOptions {
        max_trace_depth: 1,
        max_direct_callable_depth: 4,
        max_continuation_callable_depth: 1,
    };
    let p = kit
        .dev
        .create_pipeline(
            &PipelineCompileOptions::default(),
            &link,
            &[rg, dc, cc, hg, ex],
        )
        .unwrap();
    let f = kit.dev.pipeline_features(p).unwrap();
    assert!(f.direct_callables && f.continuation_callables);
    assert!(
        f.exceptions.contains(ExceptionFlags::STACK_OVERFLOW),
        "Auto with an exception program"
    );
    let sbt = kit.sbt(
        Rec::new(rg),
        &[],
        &[Rec::new(hg)],
        &[Rec::with_u32(dc, &[3]), Rec::new(cc)],
        Some(Rec::new(ex)),
    );
    kit.launch(p, &sbt, 3);
    // x = 0: one call; x = 1: depth 3; x = 2: depth 5 > 4 overflows.
    assert_eq!(
        log.get(0, "args"),
        Some(vec![13.0, 0.0, 0.0]),
        "copy-out of every register the callee wrote"
    );
    assert_eq!(log.get(1, "args"), Some(vec![19.0, 2.0, 0.0]));
    assert_eq!(log.get(0, "traced"), Some(vec![5.0]));
    assert_eq!(
        log.of(2),
        vec![("exception".to_string(), vec![code::STACK_OVERFLOW as f64])]
    );
    // The device refuses depths it cannot honour.
    let deep = PipelineLinkOptions {
        max_direct_callable_depth: 1000,
        ..link
    };
    let e = kit
        .dev
        .create_pipeline(&PipelineCompileOptions::default(), &deep, &[rg, dc])
        .unwrap_err();
    assert!(e.message().contains("max_direct_callable_depth"), "{e}");
}
