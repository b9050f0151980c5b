//! Inactive boxes: a custom primitive whose box has a NaN bound is never intersected (its
//! intersection program never runs); the other boxes of its input still are.

use optik::*;
use optik_conformance::kit::rig::*;

const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, pad: vec2<u32> }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read_write> log: array<u32>;

fn raygen__main() {
    var p: RtPayload;
    p[0] = 2u;
    rt_trace(params.handle, vec3<f32>(0.5, 0.5, 10.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[0] = p[0];
    out[1] = p[1];
}

// Primitive k is the slab z in [k, k + 0.5]: reports its top.
fn intersection__slab() {
    let k = rt_primitive_index();
    var attrs: RtAttributes;
    rt_report_intersection((f32(k) + 0.5 - rt_object_ray_origin().z) / rt_object_ray_direction().z, 0u, attrs);
    log[k] = 1u;
}

fn closesthit__rec() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, rt_primitive_index());
}

fn miss__none() {
    rt_set_payload(0u, 2u);
}
"#;

#[test]
fn nan_boxes_are_inactive() {
    on_every_backend("aabb: NaN boxes", |_, d| {
        let mut aabbs: Vec<[f32; 6]> = (0..4)
            .map(|k| [0.0, 0.0, k as f32, 1.0, 1.0, k as f32 + 0.5])
            .collect();
        aabbs[3][0] = f32::NAN;
        let ab = buffer(d, &aabbs);
        let gas = d
            .accel_build(
                &AccelBuildOptions::default(),
                &[BuildInput::CustomPrimitives(CustomPrimitiveArray::new(
                    BufferView::new(ab),
                    4,
                    GeometryFlags::DISABLE_ANYHIT,
                ))],
            )
            .unwrap();
        let m = module(d, PROGRAMS);
        let g = groups(
            d,
            &[
                raygen(m, "raygen__main"),
                miss(m, "miss__none"),
                ProgramGroupDesc::HitGroup {
                    closest_hit: Some(ProgramRef::new(m, "closesthit__rec")),
                    any_hit: None,
                    intersection: Some(ProgramRef::new(m, "intersection__slab")),
                    builtin: BuiltinIntersector::Triangle,
                },
            ],
        );
        let p = pipeline(d, &g, 1);
        let table = sbt(d, &g, &[]);
        let out = d.create_buffer(8).unwrap();
        let log = buffer(d, &[0u32; 4]);
        d.launch(
            p,
            &params(d.traversable_handle(gas).unwrap(), &[]),
            &[Resource::buffer(1, out), Resource::buffer(2, log)],
            &table,
            LaunchSize::new(1, 1, 1),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let out: Vec<u32> = read(d, out);
        let log: Vec<u32> = read(d, log);
        assert_eq!(out, vec![1, 2], "slab 2 is the closest active box");
        assert_eq!(
            log[3], 0,
            "slab 3 has a NaN box: its intersection program never ran"
        );
        assert_eq!(log[2], 1, "the nearest active box was intersected");
    });
}
