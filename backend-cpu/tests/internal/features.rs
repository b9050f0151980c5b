//! Pipelines compile what their scene and programs use, report it, and skip the rest.

use crate::native::*;
use optik_api::*;
use optik_cpu::CpuDeviceExt;

#[test]
fn features_follow_the_scene_and_the_programs() {
    let _launches = crate::shared();
    let kit = Kit::new();
    let gas = kit.triangles(
        &quad(-1.0, -1.0, 1.0, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let log = Log::default();
    let (l1, l2, l3) = (log.clone(), log.clone(), log.clone());
    let root = std::sync::Arc::new(std::sync::Mutex::new(gas));
    let r = root.clone();
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let h = *r.lock().unwrap();
                trace_ray(
                    c,
                    h,
                    Ray::new([0.0; 3], [0.0, 0.0, 1.0]).time(0.5),
                    &mut [0],
                );
            }),
        ),
        (
            "closesthit__main",
            program(move |c| l1.put(c, "ch", &[c.ray_time() as f64])),
        ),
        ("miss__main", program(move |c| l2.put(c, "miss", &[]))),
        ("anyhit__main", program(|_| {})),
        (
            "exception__main",
            program(move |c| l3.put(c, "exception", &[c.exception_code() as f64])),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let hg_ah = kit.hit(m, Some("closesthit__main"), Some("anyhit__main"), None);
    let ex = kit.group(ProgramGroupDesc::Exception(ProgramRef::new(
        m,
        "exception__main",
    )));
    // One triangle structure, closest-hit only.
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let f = kit.dev.pipeline_features(p).unwrap();
    assert_eq!(f.names(), vec!["triangles", "single-gas"]);
    assert!(!f.motion && !f.any_hit && !f.instancing() && f.exceptions.is_empty());
    assert_eq!(f.num_payload_values, 8);
    let p_ah = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg_ah]);
    assert!(kit.dev.pipeline_features(p_ah).unwrap().any_hit);
    // Instances alive at creation turn instancing on.
    let ias = kit.instances(&[Instance::new(gas)]);
    let p_inst = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    assert!(kit.dev.pipeline_features(p_inst).unwrap().instancing());
    // A pipeline compiled for a single structure does not traverse instances: the ray
    // misses, or raises INVALID_TRAVERSABLE with debug exceptions.
    *root.lock().unwrap() = ias;
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, 1);
    assert_eq!(log.names(0), vec!["miss"]);
    log.clear();
    kit.launch(p_inst, &sbt, 1);
    assert_eq!(
        log.get(0, "ch"),
        Some(vec![0.0]),
        "no motion compiled: rt_ray_time reads 0"
    );
    let debug = PipelineCompileOptions {
        traversable_graph: Setting::Value(TraversableGraph::SingleGas),
        exception_flags: Setting::Value(ExceptionFlags::DEBUG),
        ..Default::default()
    };
    let p_debug = kit.pipeline(debug, 1, &[rg, ms, hg, ex]);
    log.clear();
    let sbt_debug = kit.sbt(
        Rec::new(rg),
        &[Rec::new(ms)],
        &[Rec::new(hg)],
        &[],
        Some(Rec::new(ex)),
    );
    kit.launch(p_debug, &sbt_debug, 1);
    assert_eq!(log.names(0), vec!["exception"]);
    // Motion alive at creation turns motion on; the time then reaches programs.
    let mo = MotionOptions {
        num_keys: 2,
        flags: MotionFlags::NONE,
        time_begin: 0.0,
        time_end: 1.0,
    };
    let keys = vec![IDENTITY_3X4, IDENTITY_3X4];
    let t = kit
        .dev
        .create_transform(&TransformDesc::MatrixMotion {
            child: gas,
            motion: mo,
            keys,
        })
        .unwrap();
    let p_motion = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let f = kit.dev.pipeline_features(p_motion).unwrap();
    assert!(f.motion && f.motion_kinds.matrix && !f.motion_kinds.srt);
    *root.lock().unwrap() = kit.dev.traversable_handle(t).unwrap();
    log.clear();
    kit.launch(p_motion, &sbt, 1);
    assert_eq!(log.get(0, "ch"), Some(vec![0.5]));
}

#[test]
fn accuracy_applies_to_pipelines_created_afterwards() {
    let _launches = crate::shared();
    let kit = Kit::new();
    let m = kit.module(vec![("raygen__main", program(|_| {}))]);
    let rg = kit.raygen(m, "raygen__main");
    assert_eq!(kit.dev.accuracy(), Accuracy::ROBUST);
    let robust = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg]);
    kit.dev.set_accuracy(Accuracy::FAST).unwrap();
    let fast = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg]);
    assert_eq!(kit.dev.pipeline_accuracy(robust).unwrap(), Accuracy::ROBUST);
    assert_eq!(kit.dev.pipeline_accuracy(fast).unwrap(), Accuracy::FAST);
    // The driver's triangle test is the Vulkan backend's.
    let driver = Accuracy {
        triangle: TriangleTest::Driver,
        ..Accuracy::ROBUST
    };
    let e = kit.dev.set_accuracy(driver).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Unsupported);
    assert!(e.message().contains("TriangleTest::Driver"), "{e}");
    assert_eq!(kit.dev.accuracy(), Accuracy::FAST);
}
