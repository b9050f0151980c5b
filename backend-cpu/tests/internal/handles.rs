//! Handles checked at trace time: a foreign or destroyed structure traced directly misses
//! (debug exceptions raise INVALID_TRAVERSABLE) and a new structure in the same slot does not
//! revive an old handle. The GPU backends differ (docs/vulkan-backend.md: such a handle in
//! launch parameters is undefined behaviour there, as in OptiX); that an instance whose child
//! was destroyed is missed holds everywhere (conformance's `tests/rules/inst.rs`).

use crate::native::*;
use optik_api::*;

/// Traces the rays and logs what closest-hit sees; `debug` turns on debug exceptions.
fn trace_log(kit: &Kit, root: TraversableHandle, rays: Vec<Ray>, debug: bool) -> Log {
    let log = Log::default();
    let (l1, l2, l3) = (log.clone(), log.clone(), log.clone());
    let n = rays.len() as u32;
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let r = rays[c.launch_index()[0] as usize];
                trace_ray(c, root, r, &mut [0]);
            }),
        ),
        (
            "closesthit__main",
            program(move |c| {
                let mut v = vec![
                    c.ray_tmax() as f64,
                    c.instance_id() as f64,
                    c.instance_index() as f64,
                    c.sbt_data_u32(0) as f64,
                    c.primitive_index() as f64,
                ];
                v.extend(c.object_ray_origin().map(|x| x as f64));
                v.extend(c.object_ray_direction().map(|x| x as f64));
                v.extend(c.object_to_world().map(|x| x as f64));
                v.extend(c.world_to_object().map(|x| x as f64));
                l1.put(c, "ch", &v);
            }),
        ),
        ("miss__main", program(move |c| l2.put(c, "miss", &[]))),
        (
            "exception__main",
            program(move |c| l3.put(c, "exception", &[c.exception_code() as f64])),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let ex = kit.group(ProgramGroupDesc::Exception(ProgramRef::new(
        m,
        "exception__main",
    )));
    let options = PipelineCompileOptions {
        exception_flags: Setting::Value(if debug {
            ExceptionFlags::DEBUG
        } else {
            ExceptionFlags::NONE
        }),
        ..Default::default()
    };
    let p = kit.pipeline(options, 1, &[rg, ms, hg, ex]);
    let hits: Vec<Rec> = (0..16u32).map(|i| Rec::with_u32(hg, &[i])).collect();
    let sbt = kit.sbt(
        Rec::new(rg),
        &[Rec::new(ms)],
        &hits,
        &[],
        Some(Rec::new(ex)),
    );
    kit.launch(p, &sbt, n);
    log
}

#[test]
fn destroyed_and_foreign_children_miss() {
    let _launches = crate::shared();
    let kit = Kit::new();
    let other = Kit::new();
    let tri = quad(-1.0, -1.0, 1.0, 1.0, 5.0);
    let gas_accel = kit
        .dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Triangles(TriangleArray::new(
                BufferView::new(kit.buffer(&tri)),
                6,
                GeometryFlags::DISABLE_ANYHIT,
            ))],
        )
        .unwrap();
    let gas = kit.dev.traversable_handle(gas_accel).unwrap();
    let root = kit.instances(&[Instance::new(gas)]);
    let foreign = other.triangles(&tri, GeometryFlags::DISABLE_ANYHIT);
    let rays = || vec![Ray::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])];
    assert!(trace_log(&kit, root, rays(), false).get(0, "ch").is_some());
    // A foreign handle in an instance is an error at build time.
    let ib = kit.buffer(&[Instance::new(foreign)]);
    let e = kit
        .dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Instances(InstanceArray {
                instances: BufferView::new(ib),
                num_instances: 1,
            })],
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidHandle);
    assert!(e.message().contains("instance 0"), "{e}");
    // Traced directly it misses (debug exceptions report it).
    assert_eq!(
        trace_log(&kit, foreign, rays(), false).names(0),
        vec!["miss"]
    );
    assert_eq!(
        trace_log(&kit, foreign, rays(), true).get(0, "exception"),
        Some(vec![semantics::exception::INVALID_TRAVERSABLE as f64])
    );
    // Destroying the child: the instance misses; nothing dangles.
    kit.dev.destroy_accel(gas_accel).unwrap();
    assert_eq!(trace_log(&kit, root, rays(), false).names(0), vec!["miss"]);
    assert_eq!(trace_log(&kit, gas, rays(), false).names(0), vec!["miss"]);
    assert_eq!(
        trace_log(&kit, root, rays(), true).get(0, "exception"),
        Some(vec![semantics::exception::INVALID_TRAVERSABLE as f64])
    );
    // A new structure in the same slot does not revive the old handle.
    let again = kit.triangles(&tri, GeometryFlags::DISABLE_ANYHIT);
    assert_ne!(again, gas);
    assert_eq!(trace_log(&kit, root, rays(), false).names(0), vec!["miss"]);
    assert!(trace_log(&kit, again, rays(), false).get(0, "ch").is_some());
}
