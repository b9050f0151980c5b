//! Custom primitives: intersection programs in object space, reported hit kinds and
//! attributes, any-hit on reported hits, and instances translating them.

use crate::common::*;
use optik_api::*;

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
