//! Any-hit programs and the flags that decide whether they run (DESIGN.md §4).
mod common;
use common::*;
use optik_api::*;

/// Raygen traces one ray per launch index; any-hit counts its calls (payload 5) and marks
/// the primitives it saw (payload 4), then acts by the record's mode (data word 1):
/// 0 accept, 1 ignore all, 2 terminate, 3 ignore odd primitives.
const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, flags: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn raygen__main() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 2u;
    p[4] = 0u;
    p[5] = 0u;
    rt_trace(params.handle, vec3<f32>(0.3 + f32(i) * 0.01, 0.2, 10.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, params.flags, 0u, 1u, 0u, &p);
    for (var k = 0u; k < 6u; k = k + 1u) {
        out[6u * i + k] = p[k];
    }
}

fn anyhit__probe() {
    rt_set_payload(5u, rt_get_payload(5u) + 1u);
    rt_set_payload(4u, rt_get_payload(4u) | (1u << rt_primitive_index()));
    let mode = rt_sbt_data_u32(1u);
    if mode == 1u {
        rt_ignore_intersection();
    }
    if mode == 2u {
        rt_terminate_ray();
    }
    if mode == 3u && (rt_primitive_index() & 1u) == 1u {
        rt_ignore_intersection();
    }
    // Not reached after ignore or terminate: those end the program.
    rt_set_payload(3u, 0xDEADu);
}

fn closesthit__rec() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_primitive_index());
}

fn miss__none() {
    rt_set_payload(0u, 2u);
}
"#;

struct Outcome {
    hit: bool,
    t: f32,
    prim: u32,
    seen: u32,
    calls: u32,
    after_end: bool,
}

/// Four stacked quads at z = 0, 1, 2, 3 (primitives 2k and 2k+1 at z = k); `flags` on the
/// geometry, the any-hit `mode` in the record, `ray_flags` on the trace.
fn run_case(flags: GeometryFlags, mode: u32, ray_flags: RayFlags) -> Outcome {
    let dev = device();
    let dev = dev.as_ref();
    let vertices: Vec<[f32; 3]> = (0..4)
        .flat_map(|z| quad(0.0, 1.0, 0.0, 1.0, z as f32))
        .collect();
    let gas = triangles(dev, &vertices, flags);
    let m = module(dev, PROGRAMS);
    let g = groups(
        dev,
        &[
            raygen(m, "raygen__main"),
            miss(m, "miss__none"),
            ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(m, "closesthit__rec")),
                any_hit: Some(ProgramRef::new(m, "anyhit__probe")),
                intersection: None,
                builtin: BuiltinIntersector::Triangle,
            },
        ],
    );
    let p = pipeline(dev, &g, 1);
    let table = sbt(dev, &g, &[vec![0, mode]]);
    let handle = dev.traversable_handle(gas).unwrap();
    let out = run(dev, p, &table, &params(handle, &[ray_flags.0]), 1, 1, 6);
    Outcome {
        hit: out[0] == 1,
        t: f32::from_bits(out[1]),
        prim: out[2],
        seen: out[4],
        calls: out[5],
        after_end: out[3] == 0xDEAD,
    }
}

#[test]
fn opaque_geometry_skips_any_hit() {
    let o = run_case(GeometryFlags::DISABLE_ANYHIT, 1, RayFlags::NONE);
    assert!(o.hit && (o.t - 7.0).abs() < 1e-5, "closest quad at z = 3");
    assert_eq!(o.calls, 0);
}

#[test]
fn accepting_any_hit_keeps_the_closest() {
    let o = run_case(GeometryFlags::NONE, 0, RayFlags::NONE);
    assert!(o.hit && (o.t - 7.0).abs() < 1e-5 && o.prim / 2 == 3);
    assert!(o.calls >= 1 && o.seen & (1 << o.prim) != 0);
    assert!(o.after_end, "accepting returns normally");
}

#[test]
fn ignoring_every_candidate_misses_after_one_call_per_primitive() {
    for flags in [
        GeometryFlags::NONE,
        GeometryFlags::REQUIRE_SINGLE_ANYHIT_CALL,
    ] {
        let o = run_case(flags, 1, RayFlags::NONE);
        assert!(!o.hit, "every candidate ignored: a miss");
        assert_eq!(o.calls, 4, "one candidate per quad along the ray");
        assert_eq!(o.seen.count_ones(), 4, "each primitive once");
        assert!(!o.after_end, "rt_ignore_intersection does not return");
    }
}

#[test]
fn terminate_accepts_and_ends_traversal() {
    let o = run_case(GeometryFlags::NONE, 2, RayFlags::NONE);
    assert!(o.hit);
    assert_eq!(o.calls, 1);
    assert_eq!(o.seen, 1 << o.prim, "the terminating candidate is the hit");
    assert!(!o.after_end);
}

#[test]
fn ignored_candidates_do_not_hide_later_ones() {
    let o = run_case(GeometryFlags::NONE, 3, RayFlags::NONE);
    assert!(o.hit);
    assert_eq!(o.prim % 2, 0, "odd primitives were ignored");
}

#[test]
fn ray_flags_override_geometry() {
    let o = run_case(GeometryFlags::NONE, 1, RayFlags::DISABLE_ANYHIT);
    assert!(
        o.hit && (o.t - 7.0).abs() < 1e-5 && o.calls == 0,
        "ray DISABLE_ANYHIT makes all opaque"
    );
    let o = run_case(GeometryFlags::DISABLE_ANYHIT, 1, RayFlags::ENFORCE_ANYHIT);
    assert!(
        !o.hit && o.calls == 4,
        "ray ENFORCE_ANYHIT overrides opaque geometry"
    );
    let o = run_case(GeometryFlags::NONE, 0, RayFlags::TERMINATE_ON_FIRST_HIT);
    assert!(
        o.hit && o.calls == 1,
        "the first accepted candidate ends traversal"
    );
    let o = run_case(GeometryFlags::NONE, 0, RayFlags::CULL_ENFORCED_ANYHIT);
    assert!(!o.hit && o.calls == 0, "non-opaque candidates culled");
    let o = run_case(
        GeometryFlags::DISABLE_ANYHIT,
        0,
        RayFlags::CULL_ENFORCED_ANYHIT,
    );
    assert!(o.hit && o.calls == 0, "opaque ones stay");
}
