//! Motion: matrix and SRT transforms at key times, between keys and outside the range with
//! and without vanish flags; motion geometry; pipelines without motion.

use crate::kit::*;
use optik_api::semantics::{affine, motion};
use optik_api::*;

/// Logs closest-hit's t and the object-space hit point per ray.
fn trace_log(
    kit: &Kit,
    root: TraversableHandle,
    rays: Vec<Ray>,
    options: PipelineCompileOptions,
) -> Log {
    let log = Log::default();
    let (l1, l2) = (log.clone(), log.clone());
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
                let (o, d, t) = (
                    c.object_ray_origin(),
                    c.object_ray_direction(),
                    c.ray_tmax(),
                );
                l1.put(
                    c,
                    "ch",
                    &[
                        t as f64,
                        (o[0] + t * d[0]) as f64,
                        (o[1] + t * d[1]) as f64,
                        c.ray_time() as f64,
                    ],
                );
            }),
        ),
        (
            "miss__main",
            program(move |c| l2.put(c, "miss", &[c.ray_time() as f64])),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let p = kit.pipeline(options, 1, &[rg, ms, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, n);
    log
}

fn translate_x(x: f32) -> Matrix3x4 {
    [1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]
}

#[test]
fn matrix_motion_interpolates_clamps_and_vanishes() {
    let kit = Kit::new();
    // A narrow quad around x = 0 moving to x = 10 and x = 30 over times 0..2 (3 keys).
    let gas = kit.triangles(
        &quad(-0.25, -1.0, 0.25, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let keys = vec![translate_x(0.0), translate_x(10.0), translate_x(30.0)];
    let times = [-1.0f32, 0.0, 0.5, 1.0, 1.5, 2.0, 3.0];
    for vanish in [
        MotionFlags::NONE,
        MotionFlags::START_VANISH | MotionFlags::END_VANISH,
    ] {
        let mo = MotionOptions {
            num_keys: 3,
            flags: vanish,
            time_begin: 0.0,
            time_end: 2.0,
        };
        let t = kit
            .dev
            .create_transform(&TransformDesc::MatrixMotion {
                child: gas,
                motion: mo,
                keys: keys.clone(),
            })
            .unwrap();
        let root = kit.dev.traversable_handle(t).unwrap();
        // For each time, rays at the analytic position, and 2 units off it.
        let mut rays = Vec::new();
        for &time in &times {
            let at = motion::resolve_key(
                &MotionOptions {
                    flags: MotionFlags::NONE,
                    ..mo
                },
                time,
            )
            .unwrap();
            let x = motion::interpolate_matrix(&keys, at)[3];
            rays.push(Ray::new([x + 0.1, 0.0, 0.0], [0.0, 0.0, 1.0]).time(time));
            rays.push(Ray::new([x + 2.0, 0.0, 0.0], [0.0, 0.0, 1.0]).time(time));
        }
        let log = trace_log(&kit, root, rays, PipelineCompileOptions::default());
        for (i, &time) in times.iter().enumerate() {
            let vanished = vanish != MotionFlags::NONE && !(0.0..=2.0).contains(&time);
            let on = log.get(2 * i as u32, "ch");
            if vanished {
                assert!(on.is_none(), "time {time}: vanished object hit");
            } else {
                let on = on.unwrap_or_else(|| panic!("time {time}: missed the moving quad"));
                assert!(
                    (on[1] - 0.1).abs() < 1e-5,
                    "time {time}: object x {}",
                    on[1]
                );
                assert_eq!(on[3], time as f64, "rt_ray_time");
            }
            assert!(
                log.get(2 * i as u32 + 1, "ch").is_none(),
                "time {time}: hit 2 units off"
            );
        }
    }
}

fn quat_z(angle: f32) -> [f32; 4] {
    let (s, c) = (angle * 0.5).sin_cos();
    [0.0, 0.0, s, c]
}

#[test]
fn srt_motion_uses_nlerp_about_the_pivot() {
    let kit = Kit::new();
    // A small quad at object (2, 0) rotating 179° about z around pivot (1, 0, 0) (S holds
    // the pivot as its translation, T moves it back).
    let gas = kit.triangles(
        &quad(1.95, -0.05, 2.05, 0.05, 0.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let key = |angle: f32| {
        let q = quat_z(angle);
        SrtData {
            pvx: -1.0,
            qx: q[0],
            qy: q[1],
            qz: q[2],
            qw: q[3],
            tx: 1.0,
            tz: 5.0,
            ..SrtData::identity()
        }
    };
    let keys = vec![key(0.0), key(179f32.to_radians())];
    let mo = MotionOptions {
        num_keys: 2,
        flags: MotionFlags::NONE,
        time_begin: 0.0,
        time_end: 1.0,
    };
    let t = kit
        .dev
        .create_transform(&TransformDesc::SrtMotion {
            child: gas,
            motion: mo,
            keys: keys.clone(),
        })
        .unwrap();
    let root = kit.dev.traversable_handle(t).unwrap();
    let times = [0.0f32, 0.25, 0.5, 0.75, 1.0];
    let mut rays = Vec::new();
    let mut slerp_points = Vec::new();
    for &time in &times {
        let m = motion::srt_to_matrix(&motion::interpolate_srt(
            &keys,
            motion::KeyPosition { key: 0, t: time },
        ));
        let p = affine::transform_point(&m, [2.0, 0.0, 0.0]);
        rays.push(Ray::new([p[0], p[1], 0.0], [0.0, 0.0, 1.0]).time(time));
        // Where slerp (Embree's interpolation) would put it.
        let angle = 179f32.to_radians() * time;
        slerp_points.push([1.0 + angle.cos(), angle.sin()]);
        rays.push(Ray::new([1.0 + angle.cos(), angle.sin(), 0.0], [0.0, 0.0, 1.0]).time(time));
    }
    let log = trace_log(&kit, root, rays, PipelineCompileOptions::default());
    for (i, &time) in times.iter().enumerate() {
        let ch = log
            .get(2 * i as u32, "ch")
            .unwrap_or_else(|| panic!("time {time}: missed the nlerp position"));
        assert!(
            (ch[1] - 2.0).abs() < 1e-4 && ch[2].abs() < 1e-4,
            "time {time}: object hit {ch:?}"
        );
        assert!((ch[0] - 5.0).abs() < 1e-5);
        // At a quarter of the way nlerp lags slerp by ~8°: far more than the quad's size.
        let slerp_hit = log.get(2 * i as u32 + 1, "ch").is_some();
        if time == 0.25 || time == 0.75 {
            assert!(
                !slerp_hit,
                "time {time}: the slerp position hit (interpolation is not nlerp)"
            );
        }
        let _ = slerp_points[i];
    }
}

#[test]
fn motion_geometry_and_pipelines_without_motion() {
    let kit = Kit::new();
    // A triangle moving from z = 5 to z = 7 (2 keys over times 0..1).
    let k0 = [[-1.0f32, -1.0, 5.0], [-1.0, 3.0, 5.0], [3.0, -1.0, 5.0]];
    let k1 = k0.map(|v| [v[0], v[1], v[2] + 2.0]);
    let input = TriangleArray {
        vertex_buffers: vec![
            BufferView::new(kit.buffer(&k0)),
            BufferView::new(kit.buffer(&k1)),
        ],
        ..TriangleArray::new(
            BufferView::new(kit.buffer(&k0)),
            3,
            GeometryFlags::DISABLE_ANYHIT,
        )
    };
    let mo = MotionOptions {
        num_keys: 2,
        flags: MotionFlags::NONE,
        time_begin: 0.0,
        time_end: 1.0,
    };
    let gas = kit.build(
        AccelBuildOptions {
            motion: Some(mo),
            ..Default::default()
        },
        &[BuildInput::Triangles(input)],
    );
    let times = [-1.0f32, 0.0, 0.3, 1.0, 2.0];
    let rays = || {
        times
            .iter()
            .map(|&t| Ray::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).time(t))
            .collect::<Vec<_>>()
    };
    let log = trace_log(&kit, gas, rays(), PipelineCompileOptions::default());
    for (i, &time) in times.iter().enumerate() {
        let ch = log.get(i as u32, "ch").unwrap();
        assert!(
            (ch[0] - (5.0 + 2.0 * time.clamp(0.0, 1.0) as f64)).abs() < 1e-5,
            "time {time}: t {}",
            ch[0]
        );
    }
    // Compiled without motion: time is ignored (key 0) and reads 0.
    let options = PipelineCompileOptions {
        uses_motion_blur: Setting::Value(false),
        ..Default::default()
    };
    let log = trace_log(&kit, gas, rays(), options);
    for i in 0..times.len() as u32 {
        assert_eq!(log.get(i, "ch"), Some(vec![5.0, 0.0, 0.0, 0.0]));
    }
}

#[test]
fn motion_spheres_and_custom_boxes_interpolate() {
    let kit = Kit::new();
    let mo = MotionOptions {
        num_keys: 2,
        flags: MotionFlags::NONE,
        time_begin: 0.0,
        time_end: 1.0,
    };
    let options = AccelBuildOptions {
        motion: Some(mo),
        ..Default::default()
    };
    // A sphere moving from z = 10 (radius 1) to z = 14 (radius 2).
    let spheres = SphereArray {
        vertex_buffers: vec![
            BufferView::new(kit.buffer(&[0.0f32, 0.0, 10.0])),
            BufferView::new(kit.buffer(&[0.0f32, 0.0, 14.0])),
        ],
        vertex_stride: 0,
        num_vertices: 1,
        radius_buffers: vec![
            BufferView::new(kit.buffer(&[1.0f32])),
            BufferView::new(kit.buffer(&[2.0f32])),
        ],
        radius_stride: 0,
        single_radius: false,
        flags: vec![GeometryFlags::DISABLE_ANYHIT],
        sbt_index_offsets: None,
        primitive_index_offset: 0,
    };
    let gas = kit.build(options, &[BuildInput::Spheres(spheres)]);
    let log = Log::default();
    let (l1, l2) = (log.clone(), log.clone());
    let times = [0.0f32, 0.5, 1.0];
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let t = times[c.launch_index()[0] as usize];
                trace_ray(
                    c,
                    gas,
                    Ray::new([0.0; 3], [0.0, 0.0, 1.0]).time(t),
                    &mut [0],
                );
            }),
        ),
        (
            "closesthit__main",
            program(move |c| {
                l1.put(
                    c,
                    "ch",
                    &[
                        c.ray_tmax() as f64,
                        c.sphere()[2] as f64,
                        c.sphere()[3] as f64,
                    ],
                )
            }),
        ),
        ("miss__main", program(move |c| l2.put(c, "miss", &[]))),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit_builtin(
        m,
        Some("closesthit__main"),
        None,
        None,
        BuiltinIntersector::Sphere,
    );
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, 3);
    assert_eq!(log.get(0, "ch"), Some(vec![9.0, 10.0, 1.0]));
    assert_eq!(log.get(1, "ch"), Some(vec![10.5, 12.0, 1.5]));
    assert_eq!(log.get(2, "ch"), Some(vec![12.0, 14.0, 2.0]));

    // A custom box moving from x in [0, 1] to x in [10, 11]: its intersection program runs
    // only when the ray meets the box at the ray's time.
    let k0 = kit.buffer(&[0.0f32, -1.0, 4.0, 1.0, 1.0, 6.0]);
    let k1 = kit.buffer(&[10.0f32, -1.0, 4.0, 11.0, 1.0, 6.0]);
    let custom = CustomPrimitiveArray {
        aabb_buffers: vec![BufferView::new(k0), BufferView::new(k1)],
        ..CustomPrimitiveArray::new(BufferView::new(k0), 1, GeometryFlags::DISABLE_ANYHIT)
    };
    let gas = kit.build(options, &[BuildInput::CustomPrimitives(custom)]);
    let log = Log::default();
    let (l1, l2) = (log.clone(), log.clone());
    let cases = [
        (0.5f32, 0.0f32),
        (0.5, 0.5),
        (5.5, 0.5),
        (5.5, 0.0),
        (10.5, 1.0),
    ];
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let (x, t) = cases[c.launch_index()[0] as usize];
                trace_ray(
                    c,
                    gas,
                    Ray::new([x, 0.0, 0.0], [0.0, 0.0, 1.0]).time(t),
                    &mut [0],
                );
            }),
        ),
        (
            "intersection__main",
            program(move |c| {
                l1.put(c, "is", &[c.ray_time() as f64]);
                c.report_intersection(5.0, 0, &[0; 8]);
            }),
        ),
        ("closesthit__main", program(move |c| l2.put(c, "ch", &[]))),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let hg = kit.hit(
        m,
        Some("closesthit__main"),
        None,
        Some("intersection__main"),
    );
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, 5);
    let ran: Vec<bool> = (0..5).map(|x| log.count(x, "ch") == 1).collect();
    assert_eq!(ran, vec![true, false, true, false, true]);
    assert_eq!(log.get(2, "is"), Some(vec![0.5]));
}
