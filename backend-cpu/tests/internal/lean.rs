//! The lean trace (`device_api::lean`, docs/cpu-backend.md §5): compiled programs' traces from
//! a triangle root, in pipelines without any-hit programs, instancing or debug exceptions,
//! skip the invocation's trace state. They must give what the full trace gives: the same
//! pipeline compiled for instancing (which takes the full path from the same root, and shows
//! programs the same values) is the reference, ray for ray and word for word.

use optik_api::*;
use optik_cpu::{CpuBackend, CpuDevice};

/// Payload words each ray writes back.
const WORDS: usize = 16;
/// Rays per launch.
const RAYS: u32 = 4096;

/// Rays from a hash of the launch index: origins around and inside the triangles' slab,
/// directions of every sign, some rays invalid, every flag the lean path reads, hit group
/// and miss indices past the records.
const RAYGEN: &str = r#"
@group(0) @binding(0) var<uniform> handle: vec2<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}

fn unit(x: u32) -> f32 {
    return f32(hash(x) >> 8u) / 16777216.0;
}

fn raygen__rays() {
    let i = rt_launch_index().x;
    let k = i * 16u;
    var origin = vec3<f32>(unit(k) * 8.0 - 1.0, unit(k + 1u) * 6.0 - 1.0, unit(k + 2u) * 9.0 - 2.0);
    let direction = vec3<f32>(unit(k + 3u) - 0.5, unit(k + 4u) - 0.5, unit(k + 5u) * 2.0 - 0.5);
    let pick = hash(k + 6u);
    var flags = 0u;
    switch pick & 7u {
        case 1u: { flags = RT_RAY_FLAG_TERMINATE_ON_FIRST_HIT; }
        case 2u: { flags = RT_RAY_FLAG_DISABLE_CLOSESTHIT; }
        case 3u: { flags = RT_RAY_FLAG_CULL_BACK_FACING_TRIANGLES; }
        case 4u: { flags = RT_RAY_FLAG_CULL_FRONT_FACING_TRIANGLES; }
        default: {}
    }
    var tmin = 0.0;
    var tmax = 1e30;
    switch (pick >> 3u) & 15u {
        case 0u: { origin.x = bitcast<f32>(0x7fc00000u); }
        case 1u: { tmin = 2.0; tmax = 1.0; }
        case 2u: { tmax = 2.5; }
        default: {}
    }
    // Past the one hit group record: a hit without programs; past the one miss record: a
    // miss that runs nothing.
    let sbt_offset = select(0u, 5u, ((pick >> 7u) & 15u) == 0u);
    let miss_index = select(0u, 3u, ((pick >> 11u) & 15u) == 0u);
    var p: RtPayload;
    for (var w = 0u; w < 16u; w++) {
        p[w] = 0xA0000000u + w;
    }
    rt_trace(handle, origin, direction, tmin, tmax, 0.0, 0xFFu, flags, sbt_offset, 1u,
             miss_index, &p);
    for (var w = 0u; w < 16u; w++) {
        out[i * 16u + w] = p[w];
    }
}

fn miss__values() {
    rt_set_payload(0u, 0xDEADu);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_ray_flags());
    rt_set_payload(3u, rt_remaining_trace_depth());
    rt_set_payload(4u, rt_get_payload(4u) + 1u);
}

fn closesthit__values() {
    let b = rt_triangle_barycentrics();
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmin()));
    rt_set_payload(2u, bitcast<u32>(b.x));
    rt_set_payload(3u, bitcast<u32>(b.y));
    rt_set_payload(4u, rt_primitive_index());
    rt_set_payload(5u, rt_sbt_gas_index());
    rt_set_payload(6u, rt_instance_id());
    rt_set_payload(7u, rt_instance_index() + bitcast<u32>(rt_world_to_object()[3].y + rt_object_to_world()[1].y));
    rt_set_payload(8u, rt_hit_kind());
    rt_set_payload(9u, rt_ray_flags());
    rt_set_payload(10u, bitcast<u32>(rt_world_ray_origin().x + rt_object_ray_direction().z));
    rt_set_payload(11u, rt_remaining_trace_depth());
    rt_set_payload(12u, rt_get_payload(12u) + 1u);
    AGAIN
}
"#;

/// What keeps the closest hit from being inlined: the hit's vertices (asked of the runtime)
/// and a second trace (a lean trace inside a program), folded into the payload.
const AGAIN: &str = r#"
    let v = rt_triangle_vertices();
    rt_set_payload(13u, bitcast<u32>(v[2].x));
    var q: RtPayload;
    q[0] = 7u;
    rt_trace(handle, rt_world_ray_origin(), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0, 0xFFu,
             0u, 0u, 1u, 0u, &q);
    rt_set_payload(14u, q[0]);
"#;

/// Triangles at z = 5 (one facing each way) and a larger one behind them at z = 6.
fn scene(dev: &CpuDevice) -> TraversableHandle {
    crate::jit::triangles(
        dev,
        &[
            [0.0, 0.0, 5.0],
            [0.0, 4.0, 5.0],
            [3.0, 0.0, 5.0],
            [3.0, 0.0, 5.0],
            [6.0, 0.0, 5.0],
            [3.0, 4.0, 5.0],
            [-1.0, -1.0, 6.0],
            [7.0, -1.0, 6.0],
            [-1.0, 5.0, 6.0],
        ],
    )
}

/// What a module's compile log says when it inlined its closest hit.
const INLINED: &str = "closest-hit program inlined";

/// Launches the rays with the closest hit inlined (`again` empty) or not ([`AGAIN`] in it),
/// compiled for `graph`; returns each ray's payload.
fn launch(
    dev: &CpuDevice,
    handle: TraversableHandle,
    again: &str,
    graph: TraversableGraph,
) -> Vec<u32> {
    let options = PipelineCompileOptions {
        num_payload_values: Setting::Value(WORDS as u32),
        traversable_graph: Setting::Value(graph),
        ..Default::default()
    };
    let source = RAYGEN.replace("AGAIN", again);
    let (module, log) = dev
        .create_module(
            &ModuleCompileOptions::default(),
            &options,
            &ProgramSource::new("lean.wgsl", &source),
        )
        .unwrap();
    assert_eq!(log.contains(INLINED), again.is_empty(), "{log}");
    let groups = dev
        .create_program_groups(&[
            ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__rays")),
            ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__values"))),
            ProgramGroupDesc::closest_hit(ProgramRef::new(module, "closesthit__values")),
        ])
        .unwrap();
    let link = PipelineLinkOptions {
        max_trace_depth: 2,
        ..Default::default()
    };
    let pipeline = dev.create_pipeline(&options, &link, &groups).unwrap();
    let sbt = crate::jit::sbt_of(dev, &groups);
    let words = RAYS as usize * WORDS;
    let out = dev.create_buffer(words as u64 * 4).unwrap();
    dev.launch(
        pipeline,
        bytemuck::cast_slice(&handle.to_words()),
        &[Resource::buffer(1, out)],
        &sbt,
        LaunchSize::new(RAYS, 1, 1),
    )
    .unwrap();
    let mut bytes = vec![0u8; words * 4];
    dev.read_buffer(out, 0, &mut bytes).unwrap();
    bytemuck::cast_slice(&bytes).to_vec()
}

#[test]
fn lean_traces_give_what_full_traces_give() {
    let _launches = crate::shared();
    let dev = CpuBackend::with_threads(2).map(CpuDevice::new).unwrap();
    let handle = scene(&dev);
    for (what, again) in [("inlined closest hit", ""), ("called closest hit", AGAIN)] {
        let lean = launch(&dev, handle, again, TraversableGraph::SingleGas);
        let full = launch(&dev, handle, again, TraversableGraph::SingleLevelInstancing);
        for (i, (l, f)) in lean.chunks(WORDS).zip(full.chunks(WORDS)).enumerate() {
            assert_eq!(l, f, "{what}: ray {i}");
        }
        // The rays reach every ending the lean path has.
        let rays: Vec<&[u32]> = lean.chunks(WORDS).collect();
        let untouched = |r: &[u32]| (0..WORDS).all(|w| r[w] == 0xA000_0000 + w as u32);
        let missed = rays.iter().filter(|r| r[0] == 0xDEAD).count();
        let hit = rays
            .iter()
            .filter(|r| r[12] == 0xA000_000D && r[4] < 3)
            .count();
        let nothing_ran = rays.iter().filter(|r| untouched(r)).count();
        assert!(missed > 100, "{what}: {missed} rays ran the miss program");
        assert!(hit > 100, "{what}: {hit} rays ran the closest hit");
        assert!(nothing_ran > 100, "{what}: {nothing_ran} rays ran nothing");
        if !again.is_empty() {
            let traced_again = rays.iter().filter(|r| r[14] != 0xA000_000E).count();
            assert_eq!(traced_again, hit, "{what}: every closest hit traced again");
        }
    }
}
