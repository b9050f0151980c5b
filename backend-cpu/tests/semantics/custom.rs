//! Custom primitives: intersection programs, the closed interval, report results, any-hit
//! from reports, attributes and hit kinds.

use crate::kit::*;
use optik_api::*;
use optik_cpu::program::abi::DeviceCalls;

/// One unit AABB around the origin of the ray's path at z in [4, 6].
fn aabb_gas(kit: &Kit, flags: GeometryFlags) -> TraversableHandle {
    let b = kit.buffer(&[-1.0f32, -1.0, 4.0, 1.0, 1.0, 6.0]);
    kit.build(
        AccelBuildOptions::default(),
        &[BuildInput::CustomPrimitives(CustomPrimitiveArray::new(
            BufferView::new(b),
            1,
            flags,
        ))],
    )
}

/// A program body that logs.
type Body = Box<dyn Fn(&mut dyn DeviceCalls, &Log) + Send + Sync>;

struct Programs {
    is: Body,
    ah: Option<Body>,
}

fn run(kit: &Kit, gas: TraversableHandle, rays: Vec<Ray>, p: Programs) -> Log {
    let log = Log::default();
    let (l1, l2, l3, l4) = (log.clone(), log.clone(), log.clone(), log.clone());
    let n = rays.len() as u32;
    let is = p.is;
    let mut programs = vec![
        (
            "raygen__main",
            program(move |c| {
                let r = rays[c.launch_index()[0] as usize];
                trace_ray(c, gas, r, &mut [0]);
            }),
        ),
        ("intersection__main", program(move |c| is(c, &l1))),
        (
            "closesthit__main",
            program(move |c| {
                let mut v = vec![
                    c.ray_tmax() as f64,
                    c.hit_kind() as f64,
                    c.is_front_face_hit() as u32 as f64,
                ];
                v.extend((0..8).map(|i| c.get_attribute(i) as f64));
                l2.put(c, "ch", &v);
            }),
        ),
        ("miss__main", program(move |c| l3.put(c, "miss", &[]))),
    ];
    let has_ah = p.ah.is_some();
    if let Some(ah) = p.ah {
        programs.push(("anyhit__main", program(move |c| ah(c, &l4))));
    }
    let m = kit.module(programs);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(
        m,
        Some("closesthit__main"),
        has_ah.then_some("anyhit__main"),
        Some("intersection__main"),
    );
    let pl = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    kit.launch(pl, &sbt, n);
    log
}

#[test]
fn reports_use_the_closed_interval() {
    let kit = Kit::new();
    let gas = aabb_gas(&kit, GeometryFlags::DISABLE_ANYHIT);
    let up = Ray::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    // The program reports t = tmin, then tmax (when finite), then tmax + 1 ulp.
    let rays = vec![
        Ray {
            tmin: 5.0,
            tmax: 5.0,
            ..up
        },
        Ray {
            tmin: 4.5,
            tmax: 5.5,
            ..up
        },
        Ray {
            tmin: 0.0,
            tmax: 10.0,
            ..up
        },
    ];
    let is: Body = Box::new(|c, log| {
        let (lo, hi) = (c.ray_tmin(), c.ray_tmax());
        let a = c.report_intersection(hi, 3, &[1, 2, 3, 4, 5, 6, 7, 8]);
        let b = c.report_intersection(f32::from_bits(hi.to_bits() + 1), 4, &[0; 8]);
        let d = c.report_intersection(lo, 0x85, &[9; 8]);
        log.put(
            c,
            "is",
            &[
                a as u32 as f64,
                b as u32 as f64,
                d as u32 as f64,
                c.ray_tmax() as f64,
            ],
        );
    });
    let log = run(&kit, gas, rays, Programs { is, ah: None });
    for x in 0..3 {
        let is = log.get(x, "is").unwrap();
        assert_eq!(
            &is[..3],
            &[1.0, 0.0, 1.0],
            "ray {x}: [tmin, tmax] accepted, beyond rejected"
        );
        let ch = log.get(x, "ch").unwrap();
        // The last accepted report (at tmin) is the closest; its hit kind keeps 7 bits.
        assert_eq!(ch[1], 0x05 as f64);
        assert_eq!(ch[2], 0.0, "odd custom hit kinds are back faces");
        assert_eq!(&ch[3..], &[9.0; 8]);
        assert_eq!(is[3], ch[0], "the intersection program sees the new tmax");
    }
}

#[test]
fn any_hit_decides_reports_and_terminate_ends_the_intersection_program() {
    let kit = Kit::new();
    let gas = aabb_gas(&kit, GeometryFlags::NONE);
    let up = Ray::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    // Reports at 5.7 (any-hit ignores t in (5.6, 5.8)), then 5.2, then (terminating) 4.5.
    let is: Body = Box::new(|c, log| {
        for t in [5.7f32, 5.2, 4.5, 4.2] {
            let accepted = c.report_intersection(t, 0, &[t.to_bits(), 0, 0, 0, 0, 0, 0, 0]);
            log.put(c, "report", &[t as f64, accepted as u32 as f64]);
            if c.unwinding() {
                return;
            }
        }
        log.put(c, "is_end", &[]);
    });
    let ah: Body = Box::new(|c, log| {
        let t = c.ray_tmax();
        log.put(c, "ah", &[t as f64, fb(c.get_attribute(0))]);
        if t > 5.6 && t < 5.8 {
            c.ignore_intersection();
        } else if t == 4.5 {
            c.terminate_ray();
        }
    });
    let log = run(&kit, gas, vec![up], Programs { is, ah: Some(ah) });
    let reports: Vec<Vec<f64>> = log
        .of(0)
        .into_iter()
        .filter(|e| e.0 == "report")
        .map(|e| e.1)
        .collect();
    assert_eq!(
        reports,
        vec![
            vec![5.7f32 as f64, 0.0],
            vec![5.2f32 as f64, 1.0],
            vec![4.5, 1.0]
        ]
    );
    assert_eq!(
        log.count(0, "is_end"),
        0,
        "terminate ended the intersection program"
    );
    let ahs: Vec<Vec<f64>> = log
        .of(0)
        .into_iter()
        .filter(|e| e.0 == "ah")
        .map(|e| e.1)
        .collect();
    assert_eq!(ahs.len(), 3);
    for a in &ahs {
        assert_eq!(a[0], a[1], "any-hit sees the candidate's t and attributes");
    }
    assert_eq!(log.get(0, "ch").unwrap()[0], 4.5);
}

#[test]
fn no_report_or_no_intersection_program_misses() {
    let kit = Kit::new();
    let gas = aabb_gas(&kit, GeometryFlags::DISABLE_ANYHIT);
    let up = Ray::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    let is: Body = Box::new(|c, log| log.put(c, "is", &[]));
    let log = run(
        &kit,
        gas,
        vec![up, Ray::new([3.0, 0.0, 0.0], [0.0, 0.0, 1.0])],
        Programs { is, ah: None },
    );
    assert_eq!(log.names(0), vec!["is", "miss"]);
    assert_eq!(
        log.names(1),
        vec!["miss"],
        "the box is not met: no intersection program"
    );
    // A hit group without an intersection program: custom primitives cannot be hit.
    let log = Log::default();
    let l = log.clone();
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| trace_ray(c, gas, up, &mut [0])),
        ),
        ("miss__main", program(move |c| l.put(c, "miss", &[]))),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.group(ProgramGroupDesc::HitGroup {
        closest_hit: None,
        any_hit: None,
        intersection: None,
        builtin: BuiltinIntersector::Triangle,
    });
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, 1);
    assert_eq!(log.names(0), vec!["miss"]);
}
