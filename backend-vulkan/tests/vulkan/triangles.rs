//! Triangles: hits, barycentrics, primitive index, hit kind, t, misses.

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, width: u32, height: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<u32>>;

fn raygen__rg() {
    let id = rt_launch_index();
    let x = (f32(id.x) + 0.5) / f32(params.width);
    let y = (f32(id.y) + 0.5) / f32(params.height);
    var p: RtPayload;
    rt_trace(params.handle, vec3<f32>(x, y, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, RT_RAY_FLAG_NONE, 0u, 1u, 0u, &p);
    out[id.x + id.y * params.width] = vec4<u32>(p[0], p[1], p[2], p[3]);
}

fn closesthit__ch() {
    let b = rt_triangle_barycentrics();
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, rt_primitive_index());
    rt_set_payload(2u, rt_hit_kind());
    rt_set_payload(3u, bitcast<u32>(rt_ray_tmax() + b.x * 0.0));
}

fn miss__ms() {
    rt_set_payload(0u, 2u);
}
"#;

fn run(dev: &TestDevice, gas: Accel, w: u32, h: u32) -> Vec<[u32; 4]> {
    let m = dev.module(PROGRAMS);
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let ch = dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__ch")));
    let pipeline = dev.pipeline(&[rg, ms, ch], 1);
    let mut table = Table::new(rg);
    table.miss.push((ms, &[]));
    table.hit.push((ch, &[]));
    let sbt = table.build(dev);
    let out = dev.create_buffer(w as u64 * h as u64 * 16).unwrap();
    let handle = dev.traversable_handle(gas).unwrap();
    dev.launch(
        pipeline,
        &params(handle, w, h),
        &[Resource::buffer(1, out)],
        &sbt,
        LaunchSize::new(w, h, 1),
    )
    .unwrap();
    let words = dev.read_u32(out);
    words.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
}

#[test]
fn a_triangle_hits_front_face_with_t_and_misses_outside() {
    let dev = device();
    let gas = dev.triangles(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        GeometryFlags::DISABLE_ANYHIT,
    );
    let (w, h) = (16, 16);
    let out = run(&dev, gas, w, h);
    let mut hits = 0;
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = ((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            let r = out[(x + y * w) as usize];
            if fx + fy < 0.99 {
                assert_eq!(r[0], 1, "pixel {x},{y} should hit");
                assert_eq!(r[1], 0, "primitive index");
                assert_eq!(
                    r[2], HIT_KIND_TRIANGLE_FRONT_FACE,
                    "counter-clockwise seen from the origin is front"
                );
                assert!((f32::from_bits(r[3]) - 1.0).abs() < 1e-6);
                hits += 1;
            } else if fx + fy > 1.01 {
                assert_eq!(r[0], 2, "pixel {x},{y} should miss");
            }
        }
    }
    assert!(hits > 100);
    dev.assert_no_messages();
}
