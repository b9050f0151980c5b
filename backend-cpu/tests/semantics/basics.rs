//! Closest hit, miss, the values programs read, payload copy semantics, invalid rays.

use crate::kit::*;
use optik_api::*;

/// One triangle at z = 5 in front of rays going +z; rays with x index 0..4 hit, 4.. miss.
fn triangle_scene(kit: &Kit, log: &Log) -> (Pipeline, ShaderBindingTable) {
    let gas = kit.triangles(
        &[[0.0, 0.0, 5.0], [0.0, 4.0, 5.0], [4.0, 0.0, 5.0]],
        GeometryFlags::DISABLE_ANYHIT,
    );
    let (l1, l2, l3) = (log.clone(), log.clone(), log.clone());
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let x = c.launch_index()[0];
                let mut payload = [7u32, 0, 0];
                trace_ray(
                    c,
                    gas,
                    Ray::new([x as f32 + 0.25, 0.5, 0.0], [0.0, 0.0, 1.0]),
                    &mut payload,
                );
                l1.put(c, "payload", &payload.map(|v| v as f64));
            }),
        ),
        (
            "closesthit__main",
            program(move |c| {
                let b = c.triangle_barycentrics();
                let v = c.triangle_vertices();
                l2.put(
                    c,
                    "ch",
                    &[
                        c.ray_tmax() as f64,
                        c.primitive_index() as f64,
                        c.hit_kind() as f64,
                        b[0] as f64,
                        b[1] as f64,
                        fb(c.get_attribute(0)),
                        v[1][1] as f64,
                        c.sbt_data_u32(0) as f64,
                        c.is_front_face_hit() as u32 as f64,
                    ],
                );
                let p0 = c.get_payload(0);
                c.set_payload(1, p0 + 1);
            }),
        ),
        (
            "miss__main",
            program(move |c| {
                l3.put(
                    c,
                    "miss",
                    &[
                        c.ray_tmax() as f64,
                        c.sbt_data_u32(0) as f64,
                        c.world_ray_origin()[0] as f64,
                    ],
                );
                c.set_payload(2, 99);
            }),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let sbt = kit.sbt(
        Rec::new(rg),
        &[Rec::with_u32(ms, &[33])],
        &[Rec::with_u32(hg, &[44])],
        &[],
        None,
    );
    (p, sbt)
}

#[test]
fn closest_hit_and_miss_see_the_hit_and_the_ray() {
    let kit = Kit::new();
    let log = Log::default();
    let (p, sbt) = triangle_scene(&kit, &log);
    kit.launch(p, &sbt, 6);
    for x in 0..6u32 {
        let payload = log.get(x, "payload").unwrap();
        if x < 4 {
            let ch = log.get(x, "ch").unwrap();
            assert_eq!(ch[0], 5.0, "t");
            assert_eq!(ch[1], 0.0, "primitive index");
            assert_eq!(ch[2], HIT_KIND_TRIANGLE_FRONT_FACE as f64);
            // (x + .25, .5) = v0 + u (v1 - v0) + v (v2 - v0) with v1 = (0, 4), v2 = (4, 0).
            assert!(
                (ch[3] - 0.125).abs() < 1e-6 && (ch[4] - (x as f64 + 0.25) / 4.0).abs() < 1e-6,
                "{ch:?}"
            );
            assert_eq!(ch[5], ch[3], "attribute 0 holds the first barycentric");
            assert_eq!(ch[6], 4.0, "vertices");
            assert_eq!(ch[7], 44.0, "SBT data");
            assert_eq!(ch[8], 1.0, "front face");
            assert_eq!(payload, vec![7.0, 8.0, 0.0]);
            assert_eq!(log.count(x, "miss"), 0);
        } else {
            assert_eq!(
                log.get(x, "miss").unwrap(),
                vec![f32::INFINITY as f64, 33.0, x as f64 + 0.25]
            );
            assert_eq!(payload, vec![7.0, 0.0, 99.0]);
            assert_eq!(log.count(x, "ch"), 0);
        }
    }
}

#[test]
fn invalid_rays_run_no_program_and_keep_the_payload() {
    let kit = Kit::new();
    let log = Log::default();
    let gas = kit.triangles(
        &quad(-10.0, -10.0, 10.0, 10.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let bad: Vec<Ray> = vec![
        Ray::new([f32::NAN, 0.0, 0.0], [0.0, 0.0, 1.0]),
        Ray::new([0.0, f32::INFINITY, 0.0], [0.0, 0.0, 1.0]),
        Ray::new([0.0, 0.0, 0.0], [0.0, f32::NAN, 1.0]),
        Ray::new([0.0, 0.0, 0.0], [f32::NEG_INFINITY, 0.0, 1.0]),
        Ray {
            tmin: -1.0,
            ..Ray::new([0.0; 3], [0.0, 0.0, 1.0])
        },
        Ray {
            tmin: f32::NAN,
            ..Ray::new([0.0; 3], [0.0, 0.0, 1.0])
        },
        Ray {
            tmax: f32::NAN,
            ..Ray::new([0.0; 3], [0.0, 0.0, 1.0])
        },
        Ray {
            tmin: 3.0,
            tmax: 2.0,
            ..Ray::new([0.0; 3], [0.0, 0.0, 1.0])
        },
        // Valid edge cases: -0.0 tmin, tmin == tmax, zero direction.
        Ray {
            tmin: -0.0,
            ..Ray::new([0.0; 3], [0.0, 0.0, 1.0])
        },
        Ray {
            tmin: 2.0,
            tmax: 2.0,
            ..Ray::new([0.0; 3], [0.0, 0.0, 1.0])
        },
        Ray::new([0.0; 3], [0.0; 3]),
    ];
    let n = bad.len() as u32;
    let (l1, l2, l3, l4) = (log.clone(), log.clone(), log.clone(), log.clone());
    let rays = bad.clone();
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let mut payload = [5u32];
                let r = rays[c.launch_index()[0] as usize];
                trace_ray(c, gas, r, &mut payload);
                // The contract of every program: return when the runtime unwinds.
                if c.unwinding() {
                    return;
                }
                l1.put(c, "payload", &[payload[0] as f64]);
            }),
        ),
        ("closesthit__main", program(move |c| l2.put(c, "ch", &[]))),
        ("miss__main", program(move |c| l3.put(c, "miss", &[]))),
        (
            "exception__main",
            program(move |c| l4.put(c, "exception", &[c.exception_code() as f64])),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let ex = kit.group(ProgramGroupDesc::Exception(ProgramRef::new(
        m,
        "exception__main",
    )));
    for debug in [false, true] {
        log.clear();
        let options = PipelineCompileOptions {
            exception_flags: Setting::Value(if debug {
                ExceptionFlags::DEBUG
            } else {
                ExceptionFlags::NONE
            }),
            ..Default::default()
        };
        let p = kit.pipeline(options, 1, &[rg, ms, hg, ex]);
        let sbt = kit.sbt(
            Rec::new(rg),
            &[Rec::new(ms)],
            &[Rec::new(hg)],
            &[],
            Some(Rec::new(ex)),
        );
        kit.launch(p, &sbt, n);
        for x in 0..8 {
            assert_eq!(
                log.count(x, "ch") + log.count(x, "miss"),
                0,
                "ray {x} ran a program"
            );
            if debug {
                assert_eq!(
                    log.get(x, "exception"),
                    Some(vec![semantics::exception::INVALID_RAY as f64]),
                    "ray {x}"
                );
                // The exception ended the launch index: raygen wrote nothing after trace.
                assert_eq!(log.count(x, "payload"), 0, "ray {x}");
            } else {
                assert_eq!(log.get(x, "payload"), Some(vec![5.0]), "ray {x}");
                assert_eq!(log.count(x, "exception"), 0);
            }
        }
        assert_eq!(log.names(8), vec!["ch", "payload"], "tmin = -0.0 is valid");
        assert_eq!(
            log.names(9),
            vec!["miss", "payload"],
            "tmin == tmax is valid; triangles need t inside"
        );
        assert_eq!(
            log.names(10),
            vec!["miss", "payload"],
            "a zero direction is valid and misses triangles"
        );
    }
}

#[test]
fn signed_zero_directions_hit_the_same() {
    let kit = Kit::new();
    let log = Log::default();
    // A wall at x = 10 made of many triangles over [0, 1]² and one cell beyond (rays on the
    // square's border cross shared edges, not the wall's own border); rays along +x with ±0
    // in y and z.
    let mut v = Vec::new();
    for i in -1..17 {
        for j in -1..17 {
            let (y, z) = (i as f32 / 16.0, j as f32 / 16.0);
            let q = quad(y, z, y + 1.0 / 16.0, z + 1.0 / 16.0, 10.0);
            v.extend(q.into_iter().map(|p| [p[2], p[0], p[1]]));
        }
    }
    let gas = kit.triangles(&v, GeometryFlags::DISABLE_ANYHIT);
    let (l1, l2) = (log.clone(), log.clone());
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let x = c.launch_index()[0];
                let o = [0.0, (x % 20) as f32 / 19.0, (x / 20) as f32 / 19.0];
                for d in [[1.0, 0.0, 0.0], [1.0, -0.0, -0.0], [1.0, -0.0, 0.0]] {
                    let mut payload = [u32::MAX, 0];
                    trace_ray(c, gas, Ray::new(o, d), &mut payload);
                    l1.put(c, "hit", &[payload[0] as f64, fb(payload[1])]);
                }
            }),
        ),
        (
            "closesthit__main",
            program(move |c| {
                c.set_payload(0, c.primitive_index());
                c.set_payload(1, c.ray_tmax().to_bits());
                let _ = &l2;
            }),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, 400);
    for x in 0..400 {
        let hits: Vec<Vec<f64>> = log.of(x).into_iter().map(|e| e.1).collect();
        assert_eq!(hits.len(), 3);
        assert_ne!(hits[0][0], u32::MAX as f64, "ray {x} missed the wall");
        assert_eq!(hits[0], hits[1], "ray {x}");
        assert_eq!(hits[0], hits[2], "ray {x}");
    }
}
