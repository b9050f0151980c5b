//! Opacity micromaps: special indices, micro-triangle states, 2-state forcing.
mod common;
use common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, flags: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read> rays: array<vec4<f32>>;

fn raygen__rays() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 2u;
    p[1] = 0u;
    rt_trace(params.handle, rays[i].xyz, vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, params.flags, 0u, 1u, 0u, &p);
    out[2u * i] = p[0];
    out[2u * i + 1u] = p[1];
}

fn anyhit__count() {
    rt_set_payload(1u, rt_get_payload(1u) + 1u);
}

fn closesthit__hit() {
    rt_set_payload(0u, 1u);
}

fn miss__none() {
    rt_set_payload(0u, 2u);
}
"#;

/// The unit triangle at x offsets 0, 2, 4, 6 with micromap indices `indices`; the first
/// uses a level-1 four-state map of `states` (micro-triangles 0..4).
fn trace(
    states: [u8; 4],
    indices: [i32; 4],
    ray_flags: RayFlags,
    points: &[[f32; 2]],
) -> Vec<(bool, u32)> {
    let dev = device();
    let d = dev.as_ref();
    let vertices: Vec<[f32; 3]> = (0..4)
        .flat_map(|k| {
            let x = 2.0 * k as f32;
            [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0]]
        })
        .collect();
    let vb = buffer(d, &vertices);
    let data = vec![states[0] | (states[1] << 2) | (states[2] << 4) | (states[3] << 6)];
    let array = d
        .create_opacity_micromap_array(&OpacityMicromapArrayDesc {
            micromaps: vec![OpacityMicromapDesc {
                byte_offset: 0,
                subdivision_level: 1,
                format: OpacityMicromapFormat::FourState,
            }],
            data,
        })
        .unwrap();
    let ib = buffer(d, &indices);
    let mut input = TriangleArray::new(BufferView::new(vb), 12, GeometryFlags::NONE);
    input.opacity_micromap = Some(TriangleOpacityMicromap {
        array,
        index_buffer: Some(BufferView::new(ib)),
        index_size_in_bytes: 4,
        index_stride: 0,
        base_index: 0,
    });
    let gas = d
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Triangles(input)],
        )
        .unwrap();
    let m = module(d, PROGRAMS);
    let g = groups(
        d,
        &[
            raygen(m, "raygen__rays"),
            miss(m, "miss__none"),
            ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(m, "closesthit__hit")),
                any_hit: Some(ProgramRef::new(m, "anyhit__count")),
                intersection: None,
                builtin: BuiltinIntersector::Triangle,
            },
        ],
    );
    let p = pipeline(d, &g, 1);
    assert!(d.pipeline_features(p).unwrap().opacity_micromaps);
    let table = sbt(d, &g, &[]);
    let rb = buffer(
        d,
        &points
            .iter()
            .map(|q| [q[0], q[1], 1.0, 0.0])
            .collect::<Vec<[f32; 4]>>(),
    );
    let out = d.create_buffer((points.len() * 8) as u64).unwrap();
    d.launch(
        p,
        &params(d.traversable_handle(gas).unwrap(), &[ray_flags.0]),
        &[Resource::buffer(1, out), Resource::buffer(2, rb)],
        &table,
        LaunchSize::new(points.len() as u32, 1, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    read::<u32>(d, out)
        .chunks_exact(2)
        .map(|c| (c[0] == 1, c[1]))
        .collect()
}

const TRANSPARENT: u8 = 0;
const OPAQUE: u8 = 1;
const UNKNOWN_TRANSPARENT: u8 = 2;
const UNKNOWN_OPAQUE: u8 = 3;

/// Centroids of the four level-1 micro-triangles: the middle (inverted) one, then the
/// corners at vertex 0, 1 and 2.
const MIDDLE: [f32; 2] = [1.0 / 3.0, 1.0 / 3.0];
const CORNERS: [[f32; 2]; 3] = [
    [1.0 / 6.0, 1.0 / 6.0],
    [2.0 / 3.0, 1.0 / 6.0],
    [1.0 / 6.0, 2.0 / 3.0],
];

#[test]
fn special_indices() {
    let c = |k: f32| [2.0 * k + 0.25, 0.25];
    let out = trace(
        [OPAQUE; 4],
        [-1, -2, -3, -4],
        RayFlags::NONE,
        &[c(0.0), c(1.0), c(2.0), c(3.0)],
    );
    assert_eq!(out[0], (false, 0), "fully transparent: never hit");
    assert_eq!(out[1], (true, 0), "fully opaque: hit without any-hit");
    assert_eq!(out[2], (true, 1), "unknown: any-hit decides");
    assert_eq!(out[3], (true, 1));
    let out = trace(
        [OPAQUE; 4],
        [-1, -2, -3, -4],
        RayFlags::FORCE_OPACITY_MICROMAP_2_STATE,
        &[c(2.0), c(3.0)],
    );
    assert_eq!(
        out[0],
        (false, 0),
        "forced 2-state: unknown-transparent is transparent"
    );
    assert_eq!(
        out[1],
        (true, 0),
        "forced 2-state: unknown-opaque is opaque"
    );
}

#[test]
fn micro_triangle_states_follow_the_bird_curve() {
    // OptiX's and Vulkan's numbering puts the middle (inverted) micro-triangle at index 1.
    let mut points = vec![MIDDLE];
    points.extend_from_slice(&CORNERS);
    let out = trace(
        [TRANSPARENT, OPAQUE, TRANSPARENT, TRANSPARENT],
        [0, -1, -1, -1],
        RayFlags::NONE,
        &points,
    );
    assert_eq!(out, vec![(true, 0), (false, 0), (false, 0), (false, 0)]);
    let out = trace(
        [OPAQUE, TRANSPARENT, UNKNOWN_OPAQUE, UNKNOWN_TRANSPARENT],
        [0, -1, -1, -1],
        RayFlags::NONE,
        &points,
    );
    assert!(!out[0].0, "the middle is transparent now");
    let corners: Vec<(bool, u32)> = out[1..].to_vec();
    assert!(
        corners.iter().all(|c| c.0),
        "opaque or unknown corners are hit"
    );
    assert_eq!(
        corners.iter().map(|c| c.1).sum::<u32>(),
        2,
        "the two unknown corners ran any-hit"
    );
}
