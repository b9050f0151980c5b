//! Any-hit programs: ignore, terminate, and the flags that switch them off; the staging path.

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[1] = 0u;
    rt_trace(params.handle, vec3<f32>(0.25, 0.25, 10.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, rt_sbt_data_u32(i), 0u, 1u, 0u, &p);
    out[i * 3u] = p[0];
    out[i * 3u + 1u] = p[1];
    out[i * 3u + 2u] = p[2];
}

fn closesthit__ch() {
    rt_set_payload(0u, rt_primitive_index() + 1u);
    rt_set_payload(2u, bitcast<u32>(rt_ray_tmax()));
}

fn miss__ms() {
    rt_set_payload(0u, 100u);
}

// Counts its calls in payload 1; ignores primitive 0 (the nearest), terminates on primitive 2.
fn anyhit__ah() {
    rt_set_payload(1u, rt_get_payload(1u) + 1u);
    let prim = rt_primitive_index();
    if prim == 0u {
        rt_ignore_intersection();
    }
    if prim == 2u {
        rt_terminate_ray();
    }
}
"#;

/// Four stacked triangles over (0.25, 0.25) at z = 3, 2, 1, 0 (primitives 0..3).
fn stack() -> Vec<[f32; 3]> {
    [3.0f32, 2.0, 1.0, 0.0]
        .iter()
        .flat_map(|z| [[0.0, 0.0, *z], [1.0, 0.0, *z], [0.0, 1.0, *z]])
        .collect()
}

/// Traces one ray per entry of `flags` (with those flags) from z = 10 with `tmin`.
fn run(dev: &TestDevice, flags: &[u32], tmin: f32) -> Vec<[u32; 3]> {
    let programs = PROGRAMS.replace(
        "vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0",
        &format!("vec3<f32>(0.0, 0.0, -1.0), {tmin:?}, 100.0"),
    );
    let m = dev.module(&format!("{RAY_HEADER}{programs}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: Some(prog(m, "anyhit__ah")),
        intersection: None,
        builtin: BuiltinIntersector::Triangle,
    });
    let pipeline = dev.pipeline(&[rg, ms, hg], 1);
    let gas = dev.triangles(&stack(), GeometryFlags::NONE);
    // The raygen record's data holds each ray's flags.
    let mut table = Table::new(rg);
    table.raygen = (rg, flags);
    table.miss.push((ms, &[]));
    table.hit.push((hg, &[]));
    table.stride = 96;
    let sbt = table.build(dev);
    let words = run_rays(
        dev,
        pipeline,
        &sbt,
        dev.traversable_handle(gas).unwrap(),
        flags.len() as u32,
        3,
        &[],
    );
    words.chunks(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Runs the any-hit cases on `dev` and checks optik's answers.
pub fn check(dev: &TestDevice) {
    let f = |r: RayFlags| r.0;
    let rays = [
        f(RayFlags::NONE),
        f(RayFlags::DISABLE_ANYHIT),
        f(RayFlags::TERMINATE_ON_FIRST_HIT | RayFlags::DISABLE_ANYHIT),
        f(RayFlags::CULL_ENFORCED_ANYHIT),
        f(RayFlags::DISABLE_ANYHIT | RayFlags::CULL_DISABLED_ANYHIT),
        f(RayFlags::ENFORCE_ANYHIT | RayFlags::CULL_ENFORCED_ANYHIT),
        f(RayFlags::CULL_DISABLED_ANYHIT | RayFlags::CULL_ENFORCED_ANYHIT),
    ];
    let out = run(dev, &rays, 0.0);
    // No flags: any-hit ignores primitive 0 (t = 7), accepts 1 (t = 8), terminates on 2
    // (t = 9). Candidates come in the driver's order (lavapipe and NVIDIA differ): when 1 comes
    // before 2, 1 is accepted and 2 lies past the new tmax, so 1 at t = 8 is the hit; when 2
    // comes first, terminate accepts it at t = 9 and ends the search.
    let hit = (out[0][0], f32::from_bits(out[0][2]));
    assert!(
        hit == (2, 8.0) || hit == (3, 9.0),
        "the closest hit is primitive 1 at t = 8, or primitive 2 at t = 9 when it terminated first: {:?}",
        out[0]
    );
    assert!(
        out[0][1] >= 2,
        "any-hit ran for the ignored and the accepted candidate: {:?}",
        out[0]
    );
    // DISABLE_ANYHIT: every candidate opaque, the nearest (primitive 0 at t=7) wins.
    assert_eq!(out[1], [1, 0, 7.0f32.to_bits()]);
    assert_eq!(out[2][1], 0);
    // CULL_ENFORCED_ANYHIT culls non-opaque geometry: everything, a miss.
    assert_eq!(out[3][0], 100);
    // Combinations Vulkan cannot take directly keep optik's semantics: all culled.
    assert_eq!(out[4][0], 100);
    assert_eq!(out[5][0], 100);
    assert_eq!(out[6][0], 100);
}

#[test]
fn staging_memory_gives_the_same_results() {
    let dev = device_with(true);
    assert!(dev.uses_staging());
    check(&dev);
}
