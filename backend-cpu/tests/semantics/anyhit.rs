//! Any-hit: exactly once per primitive, ignore, terminate.

use crate::kit::*;
use optik_api::*;

/// 32 layers of one triangle each across the ray, non-opaque, single any-hit call.
fn layers(kit: &Kit) -> TraversableHandle {
    let mut v = Vec::new();
    for k in 0..32 {
        let z = 1.0 + k as f32 * 0.5;
        v.extend([[-1.0, -1.0, z], [-1.0, 3.0, z], [3.0, -1.0, z]]);
    }
    kit.triangles(&v, GeometryFlags::REQUIRE_SINGLE_ANYHIT_CALL)
}

fn pipeline(
    kit: &Kit,
    root: TraversableHandle,
    ah: impl Fn(&mut dyn optik_cpu::program::abi::DeviceCalls) + Send + Sync + 'static,
    log: &Log,
) {
    let (l1, l2) = (log.clone(), log.clone());
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let x = c.launch_index()[0];
                trace_ray(
                    c,
                    root,
                    Ray::new([0.0, 0.0, 0.0], [0.01 * x as f32, 0.02, 1.0]),
                    &mut [0],
                );
            }),
        ),
        ("anyhit__main", program(ah)),
        (
            "closesthit__main",
            program(move |c| {
                l1.put(
                    c,
                    "ch",
                    &[
                        c.primitive_index() as f64,
                        c.instance_id() as f64,
                        c.ray_tmax() as f64,
                    ],
                )
            }),
        ),
        ("miss__main", program(move |c| l2.put(c, "miss", &[]))),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(m, Some("closesthit__main"), Some("anyhit__main"), None);
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, 8);
}

#[test]
fn any_hit_runs_exactly_once_per_primitive_and_instance() {
    let kit = Kit::new();
    let gas = layers(&kit);
    for root in [gas, {
        let mut b = Instance::new(gas);
        b.instance_id = 1;
        kit.instances(&[Instance::new(gas), b])
    }] {
        let log = Log::default();
        let l = log.clone();
        // Ignoring every candidate lets the ray meet all of them.
        pipeline(
            &kit,
            root,
            move |c| {
                l.put(
                    c,
                    "ah",
                    &[c.primitive_index() as f64, c.instance_id() as f64],
                );
                c.ignore_intersection();
            },
            &log,
        );
        let copies = if root == gas { 1 } else { 2 };
        for x in 0..8 {
            let mut calls: Vec<(u64, u64)> = log
                .of(x)
                .into_iter()
                .filter(|e| e.0 == "ah")
                .map(|e| (e.1[0] as u64, e.1[1] as u64))
                .collect();
            calls.sort();
            let n = calls.len();
            calls.dedup();
            assert_eq!(
                n,
                calls.len(),
                "ray {x}: an any-hit ran twice for one primitive"
            );
            assert_eq!(n, 32 * copies, "ray {x}: every layer once per instance");
            assert_eq!(log.names(x).last().map(|s| s.as_str()), Some("miss"));
        }
    }
}

#[test]
fn ignore_discards_and_terminate_accepts() {
    let kit = Kit::new();
    let gas = layers(&kit);
    // Ignore even layers: the closest hit is layer 1.
    let log = Log::default();
    let l = log.clone();
    pipeline(
        &kit,
        gas,
        move |c| {
            l.put(c, "ah", &[c.primitive_index() as f64]);
            if c.primitive_index() % 2 == 0 {
                c.ignore_intersection();
            }
        },
        &log,
    );
    for x in 0..8 {
        assert_eq!(log.get(x, "ch").unwrap()[0], 1.0);
        // Layers 0 and 1 at least; farther ones only until layer 1 is accepted.
        assert!(log.count(x, "ah") >= 2);
    }
    // Ignore everything: miss.
    let log = Log::default();
    pipeline(&kit, gas, |c| c.ignore_intersection(), &log);
    for x in 0..8 {
        assert_eq!(log.names(x), vec!["miss"]);
    }
    // Ignore everything but layer 20, which terminates: traversal ends there and the
    // closest-hit program sees layer 20, though nearer layers exist.
    let log = Log::default();
    let l = log.clone();
    pipeline(
        &kit,
        gas,
        move |c| {
            l.put(c, "ah", &[c.primitive_index() as f64, c.ray_tmax() as f64]);
            if c.primitive_index() == 20 {
                c.terminate_ray();
            } else {
                c.ignore_intersection();
            }
        },
        &log,
    );
    for x in 0..8 {
        let ahs: Vec<Vec<f64>> = log
            .of(x)
            .into_iter()
            .filter(|e| e.0 == "ah")
            .map(|e| e.1)
            .collect();
        let last = ahs.last().unwrap();
        assert_eq!(
            last[0], 20.0,
            "traversal stopped at the terminating any-hit"
        );
        let ch = log.get(x, "ch").unwrap();
        assert_eq!(
            (ch[0], ch[2]),
            (20.0, last[1]),
            "closest-hit sees the terminating hit"
        );
        assert_eq!(log.count(x, "miss"), 0);
    }
}
