//! Triangles end to end: hits, misses, facing, barycentrics, the open t interval.
mod common;
use common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
fn raygen__grid() {
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    var p: RtPayload;
    p[0] = 0xFFFFFFFFu;
    let x = (f32(i.x) + 0.5) / f32(d.x);
    let y = (f32(i.y) + 0.5) / f32(d.y);
    rt_trace(params.handle, vec3<f32>(x, y, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    let k = (i.y * d.x + i.x) * 4u;
    out[k] = p[0];
    out[k + 1u] = p[1];
    out[k + 2u] = p[2];
    out[k + 3u] = p[3];
}

fn closesthit__record() {
    rt_set_payload(0u, rt_primitive_index());
    rt_set_payload(1u, rt_hit_kind());
    rt_set_payload(2u, bitcast<u32>(rt_ray_tmax()));
    let b = rt_triangle_barycentrics();
    rt_set_payload(3u, u32(b.x * 1000.0 + 0.5) * 10000u + u32(b.y * 1000.0 + 0.5));
}

fn miss__none() {
    rt_set_payload(0u, 777u);
}
"#;

#[test]
fn a_quad_is_hit_inside_and_missed_outside() {
    let dev = device();
    let dev = dev.as_ref();
    // The quad covers x in [0.25, 0.75], y in [0, 1] at z = 0.
    let gas = triangles(dev, &quad(0.25, 0.75, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(dev, &format!("{HEADER}{PROGRAMS}"));
    let g = groups(dev, &[raygen(m, "raygen__grid"), miss(m, "miss__none"), closest_hit(m, "closesthit__record")]);
    let p = pipeline(dev, &g, 1);
    let table = sbt(dev, &g, &[]);
    let handle = dev.traversable_handle(gas).unwrap();
    let out = run(dev, p, &table, &params(handle, &[]), 8, 2, 8 * 2 * 4);
    for y in 0..2 {
        for x in 0..8 {
            let k = (y * 8 + x) * 4;
            let px = (x as f32 + 0.5) / 8.0;
            if (0.25..0.75).contains(&px) {
                assert!(out[k] < 2, "pixel {x},{y} should hit, got {:?}", &out[k..k + 4]);
                assert_eq!(out[k + 1], 0xFE, "seen from +z the quad is front-facing");
                assert_eq!(f32::from_bits(out[k + 2]), 1.0, "t = 1");
            } else {
                assert_eq!(out[k], 777, "pixel {x},{y} should miss");
            }
        }
    }
}
