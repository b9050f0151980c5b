//! What programs read about their ray: time (carried when the pipeline uses motion blur),
//! flags and visibility mask (carried for every program kind, intersection included), and
//! pipelines that skip primitive types.

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
// Ray 0 hits a box, ray 1 misses; ray i has time 0.25 + i, mask 0x3E | i and the flags of
// the raygen record (with a bit Vulkan does not know, which rt_ray_flags still reports).
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    let x = select(0.5, 5.0, i == 1u);
    rt_trace(params.handle, vec3<f32>(x, 0.5, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.25 + f32(i), 0x3Eu | i, rt_sbt_data_u32(0u), 0u, 1u, 0u, &p);
    for (var k = 0u; k < 9u; k++) {
        out[i * 9u + k] = p[k];
    }
}

fn intersection__is() {
    var a: RtAttributes;
    a[0] = bitcast<u32>(rt_ray_time());
    a[1] = rt_ray_flags();
    a[2] = rt_ray_mask();
    rt_report_intersection(4.0, 1u, a);
}

fn anyhit__ah() {
    rt_set_payload(3u, bitcast<u32>(rt_ray_time()));
    rt_set_payload(4u, rt_ray_flags());
    rt_set_payload(5u, rt_ray_mask());
}

fn closesthit__ch() {
    rt_set_payload(0u, rt_get_attribute(0u));
    rt_set_payload(1u, rt_get_attribute(1u));
    rt_set_payload(2u, rt_get_attribute(2u));
    rt_set_payload(6u, bitcast<u32>(rt_ray_time()));
    rt_set_payload(7u, rt_ray_flags());
    rt_set_payload(8u, rt_ray_mask());
}

fn miss__ms() {
    rt_set_payload(6u, bitcast<u32>(rt_ray_time()));
    rt_set_payload(7u, rt_ray_flags());
    rt_set_payload(8u, rt_ray_mask());
}
"#;

fn run(dev: &TestDevice, motion: bool) -> (Vec<[u32; 9]>, FeatureSet) {
    let boxes = dev.aabbs(&[[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]], GeometryFlags::NONE);
    let m = dev.module(&format!("{RAY_HEADER}{PROGRAMS}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: Some(prog(m, "anyhit__ah")),
        intersection: Some(prog(m, "intersection__is")),
        builtin: BuiltinIntersector::Triangle,
    });
    let options = PipelineCompileOptions {
        uses_motion_blur: Setting::Value(motion),
        ..Default::default()
    };
    let pipeline = dev
        .create_pipeline(&options, &PipelineLinkOptions::default(), &[rg, ms, hg])
        .unwrap();
    let flags = [RayFlags::CULL_BACK_FACING_TRIANGLES.0 | 0x4000];
    let mut table = Table::new(rg);
    table.raygen = (rg, &flags);
    table.miss.push((ms, &[]));
    table.hit.push((hg, &[]));
    let sbt = table.build(dev);
    let w = run_rays(
        dev,
        pipeline,
        &sbt,
        dev.traversable_handle(boxes).unwrap(),
        2,
        9,
        &[],
    );
    (
        w.chunks(9).map(|c| std::array::from_fn(|k| c[k])).collect(),
        dev.pipeline_features(pipeline).unwrap(),
    )
}

#[test]
fn programs_read_the_time_flags_and_mask_of_their_ray() {
    let dev = device();
    let (out, features) = run(&dev, true);
    assert!(features.motion);
    let flags = RayFlags::CULL_BACK_FACING_TRIANGLES.0 | 0x4000;
    let hit = out[0];
    assert_eq!(f32::from_bits(hit[0]), 0.25, "intersection reads the time");
    assert_eq!(
        (hit[1], hit[2]),
        (flags, 0x3E),
        "intersection reads flags and mask"
    );
    assert_eq!(
        (f32::from_bits(hit[3]), hit[4], hit[5]),
        (0.25, flags, 0x3E),
        "any-hit"
    );
    assert_eq!(
        (f32::from_bits(hit[6]), hit[7], hit[8]),
        (0.25, flags, 0x3E),
        "closest-hit"
    );
    let miss = out[1];
    assert_eq!(
        (f32::from_bits(miss[6]), miss[7], miss[8]),
        (1.25, flags, 0x3F),
        "miss"
    );
}

#[test]
fn without_motion_blur_rays_carry_no_time() {
    let dev = device();
    let (out, features) = run(&dev, false);
    assert!(!features.motion);
    assert_eq!(f32::from_bits(out[0][6]), 0.0);
    assert_eq!(f32::from_bits(out[1][6]), 0.0);
}

#[test]
fn pipelines_skip_primitive_types_they_do_not_intersect() {
    let dev = device();
    let src = format!(
        "{RAY_HEADER}{}",
        r#"
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 0u;
    rt_trace(params.handle, vec3<f32>(f32(i) * 2.0 + 0.25, 0.25, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[i] = p[0];
}
fn intersection__is() {
    var a: RtAttributes;
    rt_report_intersection(1.0, 0u, a);
}
fn closesthit__ch() { rt_set_payload(0u, 1u + rt_instance_index()); }
"#
    );
    let tri = dev.triangles(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        GeometryFlags::DISABLE_ANYHIT,
    );
    let boxes = dev.aabbs(
        &[[2.0, 0.0, 0.0, 3.0, 1.0, 1.0]],
        GeometryFlags::DISABLE_ANYHIT,
    );
    let mut bi = Instance::new(dev.traversable_handle(boxes).unwrap());
    bi.sbt_offset = 1;
    let ias = dev.instances(&[Instance::new(dev.traversable_handle(tri).unwrap()), bi]);
    let m = dev.module(&src);
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let tri_hg = dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__ch")));
    let box_hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: None,
        intersection: Some(prog(m, "intersection__is")),
        builtin: BuiltinIntersector::Triangle,
    });
    for (types, expect) in [
        (Setting::Auto, [1, 2]),
        (Setting::Value(PrimitiveTypeFlags::CUSTOM), [0, 2]),
    ] {
        let options = PipelineCompileOptions {
            primitive_types: types,
            ..Default::default()
        };
        let p = dev
            .create_pipeline(
                &options,
                &PipelineLinkOptions::default(),
                &[rg, tri_hg, box_hg],
            )
            .unwrap();
        let f = dev.pipeline_features(p).unwrap();
        let mut table = Table::new(rg);
        table.hit = vec![(tri_hg, &[]), (box_hg, &[])];
        let sbt = table.build(&dev);
        let w = run_rays(
            &dev,
            p,
            &sbt,
            dev.traversable_handle(ias).unwrap(),
            2,
            1,
            &[],
        );
        if dev.info().primitive_culling || types == Setting::Auto {
            assert_eq!(
                w,
                expect.to_vec(),
                "primitive types {:?}",
                f.primitive_types
            );
        }
        assert_eq!(f.traversable_graph, TraversableGraph::SingleLevelInstancing);
    }
}
