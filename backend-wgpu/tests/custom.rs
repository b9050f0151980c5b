//! Custom primitives: AABBs with intersection programs and rt_report_intersection.
mod common;
use common::*;
use optik_api::*;

/// Primitive k is the slab z in [k, k + 0.5] over the unit square; the intersection program
/// reports its top (hit kind 0x85, masked to 5) and bottom (hit kind 4) and logs what each
/// report returned and the tmax it saw.
const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, flags: u32, ignore: u32, tmin: f32, tmax: f32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read_write> log: array<u32>;

fn raygen__main() {
    var p: RtPayload;
    p[0] = 2u;
    rt_trace(params.handle, vec3<f32>(0.5, 0.5, 10.0), vec3<f32>(0.0, 0.0, -1.0), params.tmin, params.tmax, 0.0, 0xFFu, params.flags, 0u, 1u, 0u, &p);
    for (var k = 0u; k < 6u; k = k + 1u) {
        out[k] = p[k];
    }
}

fn intersection__slab() {
    let k = rt_primitive_index();
    let o = rt_object_ray_origin();
    let d = rt_object_ray_direction();
    var attrs: RtAttributes;
    attrs[0] = k * 10u;
    let first = rt_report_intersection((f32(k) + 0.5 - o.z) / d.z, 0x85u, attrs);
    attrs[0] = k * 10u + 1u;
    let second = rt_report_intersection((f32(k) - o.z) / d.z, 4u, attrs);
    log[k] = u32(first) | (u32(second) << 1u) | 4u;
    log[8u + k] = bitcast<u32>(rt_ray_tmax());
}

fn anyhit__filter() {
    if rt_primitive_index() == params.ignore {
        rt_ignore_intersection();
    }
}

fn closesthit__rec() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_primitive_index());
    rt_set_payload(3u, rt_hit_kind());
    rt_set_payload(4u, rt_get_attribute(0u));
    rt_set_payload(5u, u32(rt_is_front_face_hit()));
}

fn miss__none() {
    rt_set_payload(0u, 2u);
}
"#;

struct Outcome {
    out: Vec<u32>,
    log: Vec<u32>,
}

fn run_case(with_any_hit: bool, ignore: u32, tmin: f32, tmax: f32, aabbs: &[[f32; 6]]) -> Outcome {
    let dev = device();
    let dev = dev.as_ref();
    let ab = buffer(dev, aabbs);
    let input = BuildInput::CustomPrimitives(CustomPrimitiveArray::new(
        BufferView::new(ab),
        aabbs.len() as u32,
        GeometryFlags::NONE,
    ));
    let gas = dev
        .accel_build(&AccelBuildOptions::default(), &[input])
        .unwrap();
    let m = module(dev, PROGRAMS);
    let g = groups(
        dev,
        &[
            raygen(m, "raygen__main"),
            miss(m, "miss__none"),
            ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(m, "closesthit__rec")),
                any_hit: with_any_hit.then(|| ProgramRef::new(m, "anyhit__filter")),
                intersection: Some(ProgramRef::new(m, "intersection__slab")),
                builtin: BuiltinIntersector::Triangle,
            },
        ],
    );
    let p = pipeline(dev, &g, 1);
    let table = sbt(dev, &g, &[]);
    let handle = dev.traversable_handle(gas).unwrap();
    let mut words = handle.to_words().to_vec();
    words.extend_from_slice(&[0, ignore, tmin.to_bits(), tmax.to_bits(), 0, 0]);
    let out = dev.create_buffer(6 * 4).unwrap();
    let log = dev.create_buffer(16 * 4).unwrap();
    dev.launch(
        p,
        bytemuck::cast_slice(&words),
        &[Resource::buffer(1, out), Resource::buffer(2, log)],
        &table,
        LaunchSize::new(1, 1, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    Outcome {
        out: read(dev, out),
        log: read(dev, log),
    }
}

fn slabs(n: usize) -> Vec<[f32; 6]> {
    (0..n)
        .map(|k| [0.0, 0.0, k as f32, 1.0, 1.0, k as f32 + 0.5])
        .collect()
}

#[test]
fn closest_report_wins_with_its_attributes_and_masked_hit_kind() {
    let o = run_case(false, 99, 0.0, 100.0, &slabs(4));
    assert_eq!(o.out[0], 1, "hit");
    assert_eq!(f32::from_bits(o.out[1]), 6.5, "top of slab 3");
    assert_eq!(o.out[2], 3);
    assert_eq!(o.out[3], 5, "custom hit kinds keep 7 bits");
    assert_eq!(o.out[4], 30, "the attributes of the accepted report");
    assert_eq!(o.out[5], 0, "odd custom hit kinds are back faces");
    assert_eq!(
        o.log[3],
        1 | 4,
        "slab 3: top accepted, bottom (farther) refused"
    );
    for k in 0..4 {
        assert_eq!(o.log[k] & 2, 0, "a bottom is never closer than its top");
    }
}

#[test]
fn reports_accept_the_closed_interval() {
    let o = run_case(false, 99, 0.0, 6.5, &slabs(4));
    assert_eq!(o.out[0], 1, "t = tmax is accepted for reports");
    assert_eq!(f32::from_bits(o.out[1]), 6.5);
    let o = run_case(false, 99, 7.0, 7.0, &slabs(4));
    assert_eq!(o.out[0], 1, "t = tmin = tmax is accepted");
    assert_eq!(o.out[4], 31, "slab 3's bottom at t = 7");
    let o = run_case(false, 99, 0.0, 6.4, &slabs(4));
    assert_eq!(o.out[0], 2, "nothing within [0, 6.4]");
}

#[test]
fn any_hit_filters_reports() {
    let o = run_case(true, 3, 0.0, 100.0, &slabs(4));
    assert_eq!(o.out[0], 1);
    assert_eq!(o.out[2], 2, "slab 3 ignored: slab 2 is closest");
    assert_eq!(f32::from_bits(o.out[1]), 7.5);
    assert_eq!(o.log[3] & 3, 0, "ignored reports return false");
}

#[test]
fn nan_boxes_are_inactive() {
    let mut aabbs = slabs(4);
    aabbs[3][0] = f32::NAN;
    let o = run_case(false, 99, 0.0, 100.0, &aabbs);
    assert_eq!(o.out[2], 2, "slab 3 has a NaN box and is never intersected");
    assert_eq!(o.log[3], 0, "its intersection program never ran");
}
