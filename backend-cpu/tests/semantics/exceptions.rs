//! Exceptions: trace depth, user codes, invalid SBT indices; the exception program runs
//! and the launch index ends.

use crate::kit::*;
use optik_api::semantics::exception as code;
use optik_api::*;

/// A quad at z = 5; closest-hit re-traces from the same origin until the depth runs out.
fn recursion(kit: &Kit, max_depth: u32, flags: Setting<ExceptionFlags>) -> Log {
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
                l1.put(c, "raygen", &[c.remaining_trace_depth() as f64]);
                let mut p = [0u32];
                trace_ray(c, gas, Ray::new([0.0; 3], [0.0, 0.0, 1.0]), &mut p);
                if c.unwinding() {
                    return;
                }
                l1.put(c, "done", &[p[0] as f64]);
            }),
        ),
        (
            "closesthit__main",
            program(move |c| {
                l2.put(c, "ch", &[c.remaining_trace_depth() as f64]);
                let mut p = [c.get_payload(0) + 1];
                trace_ray(c, gas, Ray::new([0.0; 3], [0.0, 0.0, 1.0]), &mut p);
                if c.unwinding() {
                    return;
                }
                c.set_payload(0, p[0]);
            }),
        ),
        (
            "exception__main",
            program(move |c| l3.put(c, "exception", &[c.exception_code() as f64])),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let ex = kit.group(ProgramGroupDesc::Exception(ProgramRef::new(
        m,
        "exception__main",
    )));
    let options = PipelineCompileOptions {
        exception_flags: flags,
        ..Default::default()
    };
    let p = kit.pipeline(options, max_depth, &[rg, hg, ex]);
    let sbt = kit.sbt(Rec::new(rg), &[], &[Rec::new(hg)], &[], Some(Rec::new(ex)));
    kit.launch(p, &sbt, 1);
    log
}

#[test]
fn trace_depth_exceeded() {
    let kit = Kit::new();
    // Checked (Auto turns TRACE_DEPTH on when an exception program exists).
    let log = recursion(&kit, 3, Setting::Auto);
    assert_eq!(log.names(0), vec!["raygen", "ch", "ch", "ch", "exception"]);
    assert_eq!(log.get(0, "raygen"), Some(vec![3.0]));
    let remaining: Vec<f64> = log
        .of(0)
        .into_iter()
        .filter(|e| e.0 == "ch")
        .map(|e| e.1[0])
        .collect();
    assert_eq!(remaining, vec![2.0, 1.0, 0.0]);
    assert_eq!(
        log.get(0, "exception"),
        Some(vec![code::TRACE_DEPTH_EXCEEDED as f64])
    );
    // Unchecked: the trace past the depth does nothing; everything returns normally.
    let log = recursion(&kit, 3, Setting::Value(ExceptionFlags::NONE));
    assert_eq!(log.names(0), vec!["raygen", "ch", "ch", "ch", "done"]);
    assert_eq!(
        log.get(0, "done"),
        Some(vec![3.0]),
        "each level added one before the payload came back"
    );
    // max_trace_depth 0: raygen cannot trace.
    let log = recursion(&kit, 0, Setting::Value(ExceptionFlags::TRACE_DEPTH));
    assert_eq!(log.names(0), vec!["raygen", "exception"]);
}

#[test]
fn user_exceptions_end_the_launch_index() {
    let kit = Kit::new();
    let gas = kit.triangles(
        &quad(-1.0, -1.0, 1.0, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let log = Log::default();
    let (l1, l2, l3, l4) = (log.clone(), log.clone(), log.clone(), log.clone());
    let m = kit.module_with(
        vec![
            (
                "raygen__main",
                program(move |c| {
                    let x = c.launch_index()[0];
                    if x == 0 {
                        c.throw_exception(42 | (1 << 31));
                        return;
                    }
                    trace_ray(c, gas, Ray::new([0.0; 3], [0.0, 0.0, 1.0]), &mut [x]);
                    if c.unwinding() {
                        return;
                    }
                    l1.put(c, "after", &[]);
                }),
            ),
            (
                "closesthit__main",
                program(move |c| {
                    l2.put(c, "ch", &[]);
                    if c.get_payload(0) == 1 {
                        c.throw_exception(7);
                    }
                }),
            ),
            (
                "exception__main",
                program(move |c| {
                    l3.put(
                        c,
                        "exception",
                        &[c.exception_code() as f64, c.sbt_data_u32(0) as f64],
                    )
                }),
            ),
            ("miss__main", program(move |c| l4.put(c, "miss", &[]))),
        ],
        1,
        true,
    );
    let rg = kit.raygen(m, "raygen__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let ex = kit.group(ProgramGroupDesc::Exception(ProgramRef::new(
        m,
        "exception__main",
    )));
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, hg, ex]);
    assert!(
        kit.dev
            .pipeline_features(p)
            .unwrap()
            .exceptions
            .contains(ExceptionFlags::USER)
    );
    let sbt = kit.sbt(
        Rec::new(rg),
        &[],
        &[Rec::new(hg)],
        &[],
        Some(Rec::with_u32(ex, &[77])),
    );
    kit.launch(p, &sbt, 3);
    assert_eq!(
        log.of(0),
        vec![("exception".to_string(), vec![42.0, 77.0])],
        "user codes keep 30 bits"
    );
    assert_eq!(
        log.of(1),
        vec![
            ("ch".to_string(), vec![]),
            ("exception".to_string(), vec![7.0, 77.0])
        ]
    );
    assert_eq!(log.names(2), vec!["ch", "after"]);
    // Without USER checks a throw does nothing but end the throwing program.
    let options = PipelineCompileOptions {
        exception_flags: Setting::Value(ExceptionFlags::NONE),
        ..Default::default()
    };
    let p = kit.pipeline(options, 1, &[rg, hg, ex]);
    log.clear();
    kit.launch(p, &sbt, 2);
    assert_eq!(log.names(0), Vec::<String>::new());
    assert_eq!(log.names(1), vec!["ch", "after"]);
}

#[test]
fn invalid_sbt_indices() {
    let kit = Kit::new();
    let gas = kit.triangles(
        &quad(-1.0, -1.0, 1.0, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let log = Log::default();
    let (l1, l2, l3, l4, l5) = (
        log.clone(),
        log.clone(),
        log.clone(),
        log.clone(),
        log.clone(),
    );
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let x = c.launch_index()[0];
                let up = Ray::new([0.0; 3], [0.0, 0.0, 1.0]);
                match x {
                    0 => trace_ray(
                        c,
                        gas,
                        Ray {
                            sbt_offset: 1,
                            ..up
                        },
                        &mut [0],
                    ),
                    1 => trace_ray(
                        c,
                        gas,
                        Ray { miss: 1, ..up }.flags(RayFlags::CULL_FRONT_FACING_TRIANGLES.0),
                        &mut [0],
                    ),
                    2 => c.direct_call(5, &mut [0]),
                    _ => c.direct_call(0, &mut [0]),
                }
                if c.unwinding() {
                    return;
                }
                l1.put(c, "after", &[]);
            }),
        ),
        ("closesthit__main", program(move |c| l2.put(c, "ch", &[]))),
        ("miss__main", program(move |c| l3.put(c, "miss", &[]))),
        (
            "direct_callable__main",
            program(move |c| l4.put(c, "dc", &[])),
        ),
        (
            "exception__main",
            program(move |c| l5.put(c, "exception", &[c.exception_code() as f64])),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let ms = kit.miss(m, "miss__main");
    let dc = kit.group(ProgramGroupDesc::Callables {
        direct: Some(ProgramRef::new(m, "direct_callable__main")),
        continuation: None,
    });
    let ex = kit.group(ProgramGroupDesc::Exception(ProgramRef::new(
        m,
        "exception__main",
    )));
    for debug in [false, true] {
        log.clear();
        let flags = if debug {
            ExceptionFlags::DEBUG
        } else {
            ExceptionFlags::NONE
        };
        let options = PipelineCompileOptions {
            exception_flags: Setting::Value(flags),
            ..Default::default()
        };
        let p = kit.pipeline(options, 1, &[rg, hg, ms, dc, ex]);
        let sbt = kit.sbt(
            Rec::new(rg),
            &[Rec::new(ms)],
            &[Rec::new(hg)],
            &[Rec::new(dc)],
            Some(Rec::new(ex)),
        );
        kit.launch(p, &sbt, 4);
        if debug {
            assert_eq!(
                log.of(0),
                vec![("exception".to_string(), vec![code::INVALID_HIT_SBT as f64])]
            );
            assert_eq!(
                log.of(1),
                vec![("exception".to_string(), vec![code::INVALID_MISS_SBT as f64])]
            );
            assert_eq!(
                log.of(2),
                vec![(
                    "exception".to_string(),
                    vec![code::CALLABLE_INVALID_SBT as f64]
                )]
            );
        } else {
            // The hit with no record counts, but no program runs (as Vulkan's null records).
            assert_eq!(log.names(0), vec!["after"]);
            assert_eq!(log.names(1), vec!["after"]);
            assert_eq!(log.names(2), vec!["after"]);
        }
        assert_eq!(log.names(3), vec!["dc", "after"]);
    }
}
