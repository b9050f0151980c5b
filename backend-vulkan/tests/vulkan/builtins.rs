//! Built-in primitives on AABBs with optik's shared WGSL intersectors: spheres (Ray Tracing
//! Gems ch. 7) and round curves (stated tolerance in optik_api::wgsl::CURVE).

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
// Ray i: origin and direction from the raygen record (6 floats per ray).
fn raygen__rg() {
    let i = rt_launch_index().x;
    let o = vec3<f32>(rt_sbt_data_f32(6u * i), rt_sbt_data_f32(6u * i + 1u), rt_sbt_data_f32(6u * i + 2u));
    let d = vec3<f32>(rt_sbt_data_f32(6u * i + 3u), rt_sbt_data_f32(6u * i + 4u), rt_sbt_data_f32(6u * i + 5u));
    var p: RtPayload;
    rt_trace(params.handle, o, d, 0.0, 100.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    for (var k = 0u; k < 6u; k++) {
        out[i * 6u + k] = p[k];
    }
}

fn closesthit__sphere() {
    let s = rt_sphere();
    rt_set_payload(0u, rt_primitive_index() + 1u);
    rt_set_payload(1u, rt_hit_kind());
    rt_set_payload(2u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(3u, bitcast<u32>(s.x));
    rt_set_payload(4u, bitcast<u32>(s.w));
    rt_set_payload(5u, select(0u, 1u, rt_is_front_face_hit()));
}

fn closesthit__curve() {
    rt_set_payload(0u, rt_primitive_index() + 1u);
    rt_set_payload(1u, rt_hit_kind());
    rt_set_payload(2u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(3u, bitcast<u32>(rt_curve_parameter()));
}

fn miss__ms() {
    rt_set_payload(0u, 0u);
}
"#;

fn run(
    dev: &TestDevice,
    gas: Accel,
    builtin: BuiltinIntersector,
    ch: &str,
    rays: &[[f32; 6]],
) -> Vec<[u32; 6]> {
    let m = dev.module(&format!("{RAY_HEADER}{PROGRAMS}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, ch)),
        any_hit: None,
        intersection: None,
        builtin,
    });
    let pipeline = dev.pipeline(&[rg, ms, hg], 1);
    let words: Vec<u32> = rays.iter().flatten().map(|f| f.to_bits()).collect();
    let mut table = Table::new(rg);
    table.raygen = (rg, &words);
    table.stride = 32 + 24 * rays.len() as u32;
    table.stride = table.stride.div_ceil(16) * 16;
    table.miss.push((ms, &[]));
    table.hit.push((hg, &[]));
    let sbt = table.build(dev);
    let w = run_rays(
        dev,
        pipeline,
        &sbt,
        dev.traversable_handle(gas).unwrap(),
        rays.len() as u32,
        6,
        &[],
    );
    w.chunks(6).map(|c| std::array::from_fn(|k| c[k])).collect()
}

/// The near root of a ray against a sphere, in f64.
fn sphere_t(o: [f32; 3], d: [f32; 3], c: [f64; 3], r: f64) -> Option<f64> {
    let f: Vec<f64> = (0..3).map(|k| o[k] as f64 - c[k]).collect();
    let d: Vec<f64> = d.iter().map(|v| *v as f64).collect();
    let a: f64 = d.iter().map(|v| v * v).sum();
    let b: f64 = (0..3).map(|k| f[k] * d[k]).sum();
    let cc: f64 = f.iter().map(|v| v * v).sum::<f64>() - r * r;
    let disc = b * b - a * cc;
    (disc >= 0.0).then(|| (-b - disc.sqrt()) / a)
}

#[test]
fn spheres_hit_at_the_analytic_distance_with_face_kinds() {
    let dev = device();
    let centres: Vec<f32> = vec![0.5, 0.5, 0.0, 1.5, 0.5, 0.0, 2.5, 0.5, 0.0, 10.5, 0.5, 0.0];
    let radii: Vec<f32> = vec![0.4, 0.3, 0.2, 0.001];
    let cb = dev.f32_buffer(&centres);
    let rb = dev.f32_buffer(&radii);
    let input = BuildInput::Spheres(SphereArray {
        vertex_buffers: vec![BufferView::new(cb)],
        vertex_stride: 0,
        num_vertices: 4,
        radius_buffers: vec![BufferView::new(rb)],
        radius_stride: 0,
        single_radius: false,
        flags: vec![GeometryFlags::DISABLE_ANYHIT],
        sbt_index_offsets: None,
        primitive_index_offset: 0,
    });
    let gas = dev
        .accel_build(&AccelBuildOptions::default(), &[input])
        .unwrap();
    let mut rays: Vec<[f32; 6]> = (0..30)
        .map(|i| [i as f32 * 0.1 + 0.05, 0.55, 5.0, 0.0, 0.0, -2.0])
        .collect();
    // From inside sphere 0: the exit is a back-face hit.
    rays.push([0.5, 0.5, 0.0, 0.0, 0.0, 1.0]);
    // A tiny sphere seen from 5e4 radii away: b^2 - ac cancels every bit in f32, the
    // Hearn-Baker discriminant does not.
    rays.push([10.5, 0.5, 50.0, 0.0, 0.0, -1.0]);
    let out = run(
        &dev,
        gas,
        BuiltinIntersector::Sphere,
        "closesthit__sphere",
        &rays,
    );
    let spheres = [
        ([0.5, 0.5, 0.0], 0.4),
        ([1.5, 0.5, 0.0], 0.3),
        ([2.5, 0.5, 0.0], 0.2),
        ([10.5, 0.5, 0.0], 0.001),
    ];
    let mut hits = 0;
    for (i, ray) in rays.iter().enumerate().take(30) {
        let o = [ray[0], ray[1], ray[2]];
        let d = [ray[3], ray[4], ray[5]];
        let expect = spheres
            .iter()
            .enumerate()
            .find_map(|(k, (c, r))| sphere_t(o, d, *c, *r).map(|t| (k, t, *r)));
        let r = out[i];
        match expect {
            Some((k, t, radius)) => {
                let near_edge =
                    ((ray[0] as f64 - spheres[k].0[0]).powi(2) + 0.0025).sqrt() > radius - 1e-3;
                if near_edge {
                    continue;
                }
                assert_eq!(r[0], k as u32 + 1, "ray {i}");
                assert_eq!(
                    r[1], HIT_KIND_TRIANGLE_FRONT_FACE,
                    "entering a sphere is a front-face hit"
                );
                assert_eq!(r[5], 1);
                let got = f32::from_bits(r[2]) as f64;
                assert!(
                    (got - t).abs() <= 1e-5 * t,
                    "ray {i}: t {got}, analytic {t}"
                );
                assert_eq!(f32::from_bits(r[3]), spheres[k].0[0] as f32);
                assert_eq!(f32::from_bits(r[4]) as f64, radius as f32 as f64);
                hits += 1;
            }
            None => assert_eq!(r[0], 0, "ray {i} misses"),
        }
    }
    assert!(hits > 10);
    let inside = out[30];
    assert_eq!(inside[0], 1);
    assert_eq!(
        inside[1], HIT_KIND_TRIANGLE_BACK_FACE,
        "leaving a sphere is a back-face hit"
    );
    assert_eq!(inside[5], 0);
    assert!((f32::from_bits(inside[2]) - 0.4).abs() < 1e-6);
    let far = out[31];
    assert_eq!(
        far[0], 4,
        "a 1e-3 sphere at distance 50 is hit (the stable discriminant)"
    );
    let t = f32::from_bits(far[2]) as f64;
    assert!((t - (50.0 - 0.001)).abs() < 1e-5 * 50.0, "{t}");
}

fn curve_gas(
    dev: &TestDevice,
    curve_type: CurveType,
    points: &[[f32; 3]],
    radius: f32,
    endcaps: CurveEndcaps,
) -> Accel {
    let flat: Vec<f32> = points.iter().flatten().copied().collect();
    let vb = dev.f32_buffer(&flat);
    let wb = dev.f32_buffer(&vec![radius; points.len()]);
    let per = curve_type.control_points() as usize;
    let segments: Vec<u32> = (0..=(points.len() - per) as u32).collect();
    let ib = dev.u32_buffer(&segments);
    let input = BuildInput::Curves(CurveArray {
        curve_type,
        num_primitives: segments.len() as u32,
        vertex_buffers: vec![BufferView::new(vb)],
        num_vertices: points.len() as u32,
        vertex_stride: 0,
        width_buffers: vec![BufferView::new(wb)],
        width_stride: 0,
        index_buffer: BufferView::new(ib),
        index_stride: 0,
        flag: GeometryFlags::DISABLE_ANYHIT,
        primitive_index_offset: 0,
        endcaps,
    });
    dev.accel_build(&AccelBuildOptions::default(), &[input])
        .unwrap()
}

#[test]
fn linear_curves_hit_the_tube_and_its_round_caps() {
    let dev = device();
    let gas = curve_gas(
        &dev,
        CurveType::RoundLinear,
        &[[0.0, 0.5, 0.0], [3.0, 0.5, 0.0]],
        0.2,
        CurveEndcaps::Default,
    );
    let rays = [
        [1.5, 0.5, 5.0, 0.0, 0.0, -1.0],
        [1.5, 0.6, 5.0, 0.0, 0.0, -1.0],
        [3.1, 0.5, 5.0, 0.0, 0.0, -1.0],
        [1.5, 0.8, 5.0, 0.0, 0.0, -1.0],
    ];
    let out = run(
        &dev,
        gas,
        BuiltinIntersector::Curve(CurveType::RoundLinear),
        "closesthit__curve",
        &rays,
    );
    assert_eq!(out[0][0], 1);
    assert_eq!(out[0][1], HIT_KIND_TRIANGLE_FRONT_FACE);
    assert!((f32::from_bits(out[0][2]) - 4.8).abs() < 1e-5);
    assert!(
        (f32::from_bits(out[0][3]) - 0.5).abs() < 1e-5,
        "u {}",
        f32::from_bits(out[0][3])
    );
    let t1 = 5.0 - (0.04f32 - 0.01).sqrt();
    assert!((f32::from_bits(out[1][2]) - t1).abs() < 1e-5);
    assert_eq!(out[2][0], 1, "round cap at the strand end");
    assert!((f32::from_bits(out[2][2]) - t1).abs() < 1e-5);
    assert_eq!(f32::from_bits(out[2][3]), 1.0);
    assert_eq!(out[3][0], 0, "outside the tube");
}

#[test]
fn cubic_bspline_curves_within_the_stated_tolerance_and_open_ends() {
    let dev = device();
    // Collinear, evenly spaced control points: the segment is x = 1 + u, a straight tube.
    let pts = [
        [0.0, 0.5, 0.0],
        [1.0, 0.5, 0.0],
        [2.0, 0.5, 0.0],
        [3.0, 0.5, 0.0],
    ];
    let open = curve_gas(
        &dev,
        CurveType::RoundCubicBSpline,
        &pts,
        0.2,
        CurveEndcaps::Default,
    );
    let rays = [
        [1.5, 0.5, 5.0, 0.0, 0.0, -1.0],
        [1.25, 0.55, 5.0, 0.0, 0.0, -1.0],
        [2.1, 0.5, 5.0, 0.0, 0.0, -1.0],
    ];
    let out = run(
        &dev,
        open,
        BuiltinIntersector::Curve(CurveType::RoundCubicBSpline),
        "closesthit__curve",
        &rays,
    );
    assert_eq!(out[0][0], 1);
    assert!((f32::from_bits(out[0][2]) - 4.8).abs() < 1e-3);
    assert!((f32::from_bits(out[0][3]) - 0.5).abs() < 1e-3);
    let t1 = 5.0 - (0.04f32 - 0.0025).sqrt();
    assert!((f32::from_bits(out[1][2]) - t1).abs() < 1e-3);
    assert!((f32::from_bits(out[1][3]) - 0.25).abs() < 1e-3);
    assert_eq!(out[2][0], 0, "open ends: no cap past the segment's end");
    let capped = curve_gas(
        &dev,
        CurveType::RoundCubicBSpline,
        &pts,
        0.2,
        CurveEndcaps::On,
    );
    let out = run(
        &dev,
        capped,
        BuiltinIntersector::Curve(CurveType::RoundCubicBSpline),
        "closesthit__curve",
        &rays,
    );
    assert_eq!(out[2][0], 1, "end caps on: the round cap is hit");
}
