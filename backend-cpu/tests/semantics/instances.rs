//! Instance graphs: three levels, static transforms, ids, summed SBT offsets, matrices,
//! destroyed and foreign children.

use crate::kit::*;
use optik_api::semantics::affine;
use optik_api::*;

fn inst(child: TraversableHandle, id: u32, sbt_offset: u32, m: Matrix3x4) -> Instance {
    let mut i = Instance::new(child);
    i.instance_id = id;
    i.sbt_offset = sbt_offset;
    i.transform = m;
    i
}

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
fn three_levels_with_a_transform() {
    let kit = Kit::new();
    // Geometry: a unit quad at z = 0 facing -z, primitive 0 and 1.
    let gas = kit.triangles(
        &quad(-0.5, -0.5, 0.5, 0.5, 0.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let rot: Matrix3x4 = [0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 3.0];
    let scale: Matrix3x4 = [2.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0];
    let shift: Matrix3x4 = [
        1.0, 0.0, 0.0, 100.0, 0.0, 1.0, 0.0, -50.0, 0.0, 0.0, 1.0, 0.0,
    ];
    let tr: Matrix3x4 = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 7.0];
    let aside: Matrix3x4 = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 50.0, 0.0, 0.0, 1.0, 0.0];
    let low = kit.instances(&[inst(gas, 1, 1, aside), inst(gas, 30, 3, rot)]);
    let transform = kit
        .dev
        .create_transform(&TransformDesc::Static {
            child: low,
            object_to_world: tr,
            world_to_object: affine::inverse(&tr).unwrap(),
        })
        .unwrap();
    let transform = kit.dev.traversable_handle(transform).unwrap();
    let mid = kit.instances(&[inst(transform, 20, 2, scale)]);
    let top = kit.instances(&[
        inst(
            gas,
            9,
            0,
            [
                1.0, 0.0, 0.0, -100.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
            ],
        ),
        inst(mid, 10, 4, shift),
    ]);
    // world = shift · scale · tr · rot · object; aim at object point (0.1, 0.2, 0) of instance 30.
    let o2w = affine::mul(&shift, &affine::mul(&scale, &affine::mul(&tr, &rot)));
    let target = affine::transform_point(&o2w, [0.1, 0.2, 0.0]);
    let origin = [target[0], target[1], target[2] - 10.0];
    let rays = vec![
        Ray::new(origin, [0.0, 0.0, 1.0]),
        Ray::new([-100.0, 0.1, -10.0], [0.0, 0.0, 2.0]),
    ];
    let log = trace_log(&kit, top, rays, false);
    let ch = log.get(0, "ch").unwrap();
    assert!(
        (ch[0] - 10.0).abs() < 1e-4,
        "t is the same in every space: {}",
        ch[0]
    );
    assert_eq!(ch[1], 30.0, "instance id of the innermost instance");
    assert_eq!(ch[2], 1.0, "instance index in its structure");
    assert_eq!(
        ch[3],
        (4 + 2 + 3) as f64,
        "SBT offsets summed over the levels"
    );
    let object_origin = [ch[5], ch[6], ch[7]];
    let object_dir = [ch[8], ch[9], ch[10]];
    let hit = [0, 1, 2].map(|k| object_origin[k] + ch[0] * object_dir[k]);
    assert!(
        (hit[0] - 0.1).abs() < 1e-4 && (hit[1] - 0.2).abs() < 1e-4 && hit[2].abs() < 1e-4,
        "{hit:?}"
    );
    for k in 0..12 {
        assert!(
            (ch[11 + k] - o2w[k] as f64).abs() < 1e-4,
            "object_to_world[{k}]"
        );
    }
    let w2o = affine::inverse(&o2w).unwrap();
    for k in 0..12 {
        assert!(
            (ch[23 + k] - w2o[k] as f64).abs() < 1e-3,
            "world_to_object[{k}]"
        );
    }
    // The direct instance at the top: id 9, index 0, t = 5 along a direction of length 2.
    let ch = log.get(1, "ch").unwrap();
    assert_eq!((ch[0], ch[1], ch[2], ch[3]), (5.0, 9.0, 0.0, 0.0));
}

#[test]
fn destroyed_and_foreign_children_miss() {
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
