//! Results do not depend on the number of launch threads.

use crate::native::*;
use optik_api::*;

#[test]
fn launches_are_bit_identical_for_any_thread_count() {
    let _launches = crate::shared();
    let kit = Kit::new();
    // A jittered field of non-opaque triangles; any-hit accumulates a commutative count.
    let mut v = Vec::new();
    let mut s = 1u32;
    let mut rnd = || {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (s >> 8) as f32 / (1u32 << 24) as f32
    };
    for _ in 0..2000 {
        let c = [rnd() * 10.0, rnd() * 10.0, 2.0 + rnd() * 10.0];
        v.extend([
            c,
            [c[0] + rnd(), c[1], c[2] + rnd()],
            [c[0], c[1] + rnd(), c[2]],
        ]);
    }
    let gas = kit.triangles(&v, GeometryFlags::NONE);
    let out = Log::default();
    let (l1, l2) = (out.clone(), out.clone());
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let i = c.launch_index();
                let d = c.launch_dimensions();
                let o = [
                    10.0 * i[0] as f32 / d[0] as f32,
                    10.0 * i[1] as f32 / d[1] as f32,
                    0.0,
                ];
                let mut p = [0u32, 0, 0];
                trace_ray(c, gas, Ray::new(o, [0.01, -0.02, 1.0]), &mut p);
                l1.put(
                    c,
                    "px",
                    &[
                        (i[1] * d[0] + i[0]) as f64,
                        p[0] as f64,
                        p[1] as f64,
                        p[2] as f64,
                    ],
                );
            }),
        ),
        (
            "anyhit__main",
            program(|c| c.set_payload(2, c.get_payload(2) + 1)),
        ),
        (
            "closesthit__main",
            program(|c| {
                c.set_payload(0, c.primitive_index());
                c.set_payload(1, c.ray_tmax().to_bits());
            }),
        ),
        (
            "miss__main",
            program(move |c| {
                c.set_payload(0, u32::MAX);
                let _ = &l2;
            }),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(m, Some("closesthit__main"), Some("anyhit__main"), None);
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    let mut results: Vec<Vec<Vec<f64>>> = Vec::new();
    for threads in [1usize, 2, 3] {
        kit.dev.set_threads(threads).unwrap();
        assert_eq!(kit.dev.threads(), threads);
        out.clear();
        kit.dev
            .launch(p, &[], &[], &sbt, LaunchSize::new(48, 32, 1))
            .unwrap();
        let mut px: Vec<Vec<f64>> = out.0.lock().unwrap().iter().map(|e| e.2.clone()).collect();
        px.sort_by(|a, b| a[0].total_cmp(&b[0]));
        assert_eq!(px.len(), 48 * 32);
        results.push(px);
    }
    assert!(
        results[0]
            .iter()
            .filter(|p| p[1] != u32::MAX as f64)
            .count()
            > 500,
        "the scene is hit"
    );
    assert_eq!(results[0], results[1]);
    assert_eq!(results[0], results[2]);
}

#[test]
fn launch_grids_cover_every_index_once() {
    let _launches = crate::shared();
    let kit = Kit::new();
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let s = seen.clone();
    let m = kit.module(vec![(
        "raygen__main",
        program(move |c| {
            s.lock()
                .unwrap()
                .push((c.launch_index(), c.launch_dimensions()));
        }),
    )]);
    let rg = kit.raygen(m, "raygen__main");
    let p = kit.pipeline(PipelineCompileOptions::default(), 0, &[rg]);
    let sbt = kit.sbt(Rec::new(rg), &[], &[], &[], None);
    for size in [
        LaunchSize::new(7, 1, 1),
        LaunchSize::new(3, 5, 1),
        LaunchSize::new(3, 2, 4),
    ] {
        seen.lock().unwrap().clear();
        kit.dev.launch(p, &[], &[], &sbt, size).unwrap();
        let mut got = seen.lock().unwrap().clone();
        got.sort();
        let mut want = Vec::new();
        for x in 0..size.width {
            for y in 0..size.height {
                for z in 0..size.depth {
                    want.push(([x, y, z], [size.width, size.height, size.depth]));
                }
            }
        }
        want.sort();
        assert_eq!(got, want, "{size:?}");
    }
}
