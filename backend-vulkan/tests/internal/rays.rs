//! What programs read about their ray: time (carried when the pipeline uses motion blur),
//! flags and visibility mask (carried for every program kind, intersection included), and
//! pipelines that skip primitive types.

use crate::common::*;
use optik_api::*;

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
