//! Custom primitives: intersection programs in object space, reported hit kinds and
//! attributes, any-hit on reported hits, and instances translating them.

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    rt_trace(params.handle, vec3<f32>(ray_x(i), 0.5, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    for (var k = 0u; k < 4u; k++) {
        out[i * 4u + k] = p[k];
    }
}

// A sphere of radius 0.4 at the centre of each primitive's unit box, in object space.
fn intersection__ball() {
    let c = vec3<f32>(f32(rt_primitive_index()) + 0.5, 0.5, 0.5);
    let o = rt_object_ray_origin() - c;
    let d = rt_object_ray_direction();
    let b = dot(o, d);
    let disc = b * b - dot(d, d) * (dot(o, o) - 0.16);
    if disc < 0.0 {
        return;
    }
    let t = (-b - sqrt(disc)) / dot(d, d);
    let n = normalize(o + t * d);
    var a: RtAttributes;
    a[0] = bitcast<u32>(n.z);
    a[1] = 77u;
    if rt_report_intersection(t, 0x85u, a) {
        return;
    }
}

fn closesthit__ch() {
    rt_set_payload(0u, rt_primitive_index() + 1u);
    rt_set_payload(1u, rt_hit_kind());
    rt_set_payload(2u, rt_get_attribute(1u));
    rt_set_payload(3u, bitcast<u32>(rt_ray_tmax()));
}

// Ignores primitive 1's hits.
fn anyhit__skip1() {
    if rt_primitive_index() == 1u {
        rt_ignore_intersection();
    }
}

fn miss__ms() {
    rt_set_payload(0u, 0xFFu);
}
"#;

#[test]
fn intersection_programs_report_kinds_and_attributes_through_instances() {
    let dev = device();
    let boxes: Vec<[f32; 6]> = (0..3)
        .map(|k| [k as f32, 0.0, 0.0, k as f32 + 1.0, 1.0, 1.0])
        .collect();
    let gas = dev.aabbs(&boxes, GeometryFlags::NONE);
    let mut inst = Instance::new(dev.traversable_handle(gas).unwrap());
    // Move the primitives by -1 in x: world x in [-1, 2].
    inst.transform[3] = -1.0;
    let ias = dev.instances(&[inst]);

    let m = dev.module(&format!("{RAY_HEADER}{PROGRAMS}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: Some(prog(m, "anyhit__skip1")),
        intersection: Some(prog(m, "intersection__ball")),
        builtin: BuiltinIntersector::Triangle,
    });
    let pipeline = dev.pipeline(&[rg, ms, hg], 1);
    let mut table = Table::new(rg);
    table.miss.push((ms, &[]));
    table.hit.push((hg, &[]));
    let sbt = table.build(&dev);
    let n = 30;
    let w = run_rays(
        &dev,
        pipeline,
        &sbt,
        dev.traversable_handle(ias).unwrap(),
        n,
        4,
        &[],
    );
    let mut seen = [0u32; 3];
    for i in 0..n as usize {
        let x = -1.0 + 3.0 * (i as f32 + 0.5) / n as f32 + 1.0;
        let prim = x.floor() as usize;
        let dx = x - (prim as f32 + 0.5);
        let r = &w[i * 4..i * 4 + 4];
        if dx.abs() < 0.39 && prim != 1 {
            assert_eq!(r[0], prim as u32 + 1, "ray {i} at object x {x}");
            assert_eq!(r[1], 0x05, "only 7 bits of a reported hit kind count");
            assert_eq!(r[2], 77);
            let t = f32::from_bits(r[3]);
            let expect = 5.0 - 0.5 - (0.16 - dx * dx).sqrt();
            assert!(
                (t - expect).abs() < 1e-4,
                "ray {i}: t {t}, expected {expect}"
            );
            seen[prim] += 1;
        } else if dx.abs() > 0.41 || prim == 1 {
            assert_eq!(r[0], 0xFF, "ray {i} at object x {x} misses (or is ignored)");
        }
    }
    assert!(seen[0] > 0 && seen[2] > 0);
}

const IDS: &str = r#"
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 0xFFu;
    rt_trace(params.handle, vec3<f32>(f32(i) + 0.5, 0.5, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[i] = p[0];
}
fn intersection__box() {
    var a: RtAttributes;
    rt_report_intersection(1.0, 0u, a);
}
fn closesthit__ch() {
    rt_set_payload(0u, rt_primitive_index());
}
"#;

/// A pipeline of IDS's programs (one hit group, no any-hit) plus `more` WGSL, raygen `raygen`,
/// and its table.
fn ids_pipeline(dev: &TestDevice, more: &str, raygen: &str) -> (Pipeline, ShaderBindingTable) {
    let m = dev.module(&format!("{RAY_HEADER}{IDS}{more}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, raygen)));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: None,
        intersection: Some(prog(m, "intersection__box")),
        builtin: BuiltinIntersector::Triangle,
    });
    let pipeline = dev.pipeline(&[rg, hg], 1);
    let mut table = Table::new(rg);
    table.hit.push((hg, &[]));
    (pipeline, table.build(dev))
}

#[test]
fn unusable_boxes_never_hit_and_refits_that_change_them_keep_the_handle() {
    let dev = device();
    let boxes: Vec<f32> = (0..3)
        .flat_map(|k| [k as f32, 0.0, 0.0, k as f32 + 1.0, 1.0, 1.0])
        .collect();
    let mut with_nan = boxes.clone();
    with_nan[6] = f32::NAN;
    let b = dev.f32_buffer(&with_nan);
    let input = BuildInput::CustomPrimitives(CustomPrimitiveArray::new(
        BufferView::new(b),
        3,
        GeometryFlags::DISABLE_ANYHIT,
    ));
    let options = AccelBuildOptions {
        flags: BuildFlags::ALLOW_UPDATE,
        ..Default::default()
    };
    let gas = dev
        .accel_build(&options, std::slice::from_ref(&input))
        .unwrap();
    let h = dev.traversable_handle(gas).unwrap();
    let (pipeline, sbt) = ids_pipeline(&dev, "", "raygen__rg");
    let ias = dev.instances(&[Instance::new(h)]);
    let run = |accel: Accel| {
        run_rays(
            &dev,
            pipeline,
            &sbt,
            dev.traversable_handle(accel).unwrap(),
            3,
            1,
            &[],
        )
    };
    assert_eq!(
        run(gas),
        vec![0, 0xFF, 2],
        "the NaN box is left out; primitive 2 keeps its index"
    );
    // A refit that makes box 1 usable and box 2 unusable: the structure is rebuilt under its
    // handle, and the instance structure over it follows.
    let mut refit = boxes.clone();
    refit[12] = f32::INFINITY;
    dev.write_buffer(b, 0, bytemuck::cast_slice(&refit))
        .unwrap();
    dev.accel_update(
        gas,
        &AccelBuildOptions {
            operation: BuildOperation::Update,
            ..options
        },
        &[input],
    )
    .unwrap();
    assert_eq!(dev.traversable_handle(gas).unwrap(), h);
    assert_eq!(run(gas), vec![0, 1, 0xFF]);
    assert_eq!(run(ias), vec![0, 1, 0xFF]);
}

const GUARD: &str = r#"
// Ray i runs down -z at x = xs[i], y = 0.5, inside and just outside box 0's face x = 1.
@group(0) @binding(2) var<storage, read> xs: array<f32>;

fn raygen__xs() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 0xFFu;
    rt_trace(params.handle, vec3<f32>(xs[i], 0.5, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[i] = p[0];
}
"#;

/// The driver tests padded boxes (and hardware quantises them), so on its own it runs
/// intersection programs for rays that pass beside a box; optik's own slab test in front of
/// the program keeps them out, as the CPU backend does (conformance numerics.near_box_faces).
#[test]
fn intersection_programs_run_only_for_rays_that_meet_the_box() {
    let dev = device();
    // A second box far away makes the structure 16 wide: the padding is about 1e-3.
    let gas = dev.aabbs(
        &[
            [0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            [15.0, 0.0, 0.0, 16.0, 1.0, 1.0],
        ],
        GeometryFlags::DISABLE_ANYHIT,
    );
    // IDS's intersection program reports unconditionally: it hits whenever it runs.
    let (pipeline, sbt) = ids_pipeline(&dev, GUARD, "raygen__xs");
    let xs = [
        0.5f32,
        1.0,
        1.0f32.next_up(),
        1.0002,
        1.0005,
        1.0009,
        // Beside the face x = 0 (a normal number: NVIDIA flushes subnormal origins to zero).
        -0.0005,
    ];
    let xs_buffer = dev.f32_buffer(&xs);
    let got = run_rays(
        &dev,
        pipeline,
        &sbt,
        dev.traversable_handle(gas).unwrap(),
        xs.len() as u32,
        1,
        &[Resource::buffer(2, xs_buffer)],
    );
    assert_eq!(
        got,
        vec![0, 0, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF],
        "rays at x = {xs:?}: inside and on the face hit, beside it miss"
    );
    dev.assert_no_messages();
}
