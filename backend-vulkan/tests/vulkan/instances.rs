//! Instances: visibility masks, SBT offsets, ids and indices, flip and cull flags, nested
//! instance trees and static transforms flattened into Vulkan's one level, and traversables
//! destroyed under their parents.

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
// Ray i goes down at x = i + 0.25 with the mask and flags of its raygen record words.
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 0u;
    let mask = rt_sbt_data_u32(2u * i);
    let flags = rt_sbt_data_u32(2u * i + 1u);
    rt_trace(params.handle, vec3<f32>(f32(i) + 0.25, 0.25, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, mask, flags, 0u, 1u, 0u, &p);
    for (var k = 0u; k < 5u; k++) {
        out[i * 5u + k] = p[k];
    }
}

fn closesthit__ch() {
    rt_set_payload(0u, rt_sbt_data_u32(0u));
    rt_set_payload(1u, rt_instance_id());
    rt_set_payload(2u, rt_instance_index());
    rt_set_payload(3u, rt_hit_kind());
    rt_set_payload(4u, bitcast<u32>(rt_object_ray_origin().x));
}

fn miss__ms() {
    rt_set_payload(0u, 0xFFFFu);
}
"#;

fn setup(dev: &TestDevice) -> Basic {
    basic(dev, PROGRAMS)
}

fn trace(
    dev: &TestDevice,
    s: &Basic,
    handle: TraversableHandle,
    rays: &[(u32, u32)],
) -> Vec<[u32; 5]> {
    let words: Vec<u32> = rays.iter().flat_map(|(m, f)| [*m, *f]).collect();
    let data: Vec<[u32; 1]> = (0..8).map(|k| [10 + k]).collect();
    let mut table = Table::new(s.rg);
    table.raygen = (s.rg, &words);
    table.stride = 128;
    table.miss.push((s.ms, &[]));
    table.hit = data.iter().map(|d| (s.ch, &d[..])).collect();
    let sbt = table.build(dev);
    let w = run_rays(dev, s.pipeline, &sbt, handle, rays.len() as u32, 5, &[]);
    w.chunks(5)
        .map(|c| [c[0], c[1], c[2], c[3], c[4]])
        .collect()
}

/// A unit right triangle at the origin, counter-clockwise seen from +z.
fn unit_triangle(dev: &TestDevice) -> Accel {
    dev.triangles(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        GeometryFlags::DISABLE_ANYHIT,
    )
}

fn placed(
    child: TraversableHandle,
    x: f32,
    id: u32,
    sbt_offset: u32,
    mask: u32,
    flags: InstanceFlags,
) -> Instance {
    let mut i = Instance::new(child);
    i.transform[3] = x;
    i.instance_id = id;
    i.sbt_offset = sbt_offset;
    i.visibility_mask = mask;
    i.flags = flags.0;
    i
}

#[test]
fn masks_offsets_ids_indices_and_flags() {
    let dev = device();
    let s = setup(&dev);
    let tri = dev.traversable_handle(unit_triangle(&dev)).unwrap();
    let ias = dev.instances(&[
        placed(tri, 0.0, 7, 0, 0xFF, InstanceFlags::NONE),
        placed(tri, 1.0, 0x1234_5678, 2, 0x01, InstanceFlags::NONE),
        placed(tri, 2.0, 8, 2, 0x01, InstanceFlags::NONE),
        placed(tri, 3.0, 9, 3, 0xFF, InstanceFlags::FLIP_TRIANGLE_FACING),
        placed(tri, 4.0, 10, 1, 0x100, InstanceFlags::NONE),
        placed(tri, 5.0, 11, 1, 0xFF, InstanceFlags::FLIP_TRIANGLE_FACING),
        placed(
            tri,
            6.0,
            12,
            1,
            0xFF,
            InstanceFlags::FLIP_TRIANGLE_FACING | InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING,
        ),
    ]);
    let h = dev.traversable_handle(ias).unwrap();
    let cull_back = RayFlags::CULL_BACK_FACING_TRIANGLES.0;
    let out = trace(
        &dev,
        &s,
        h,
        &[
            (0xFF, 0),
            (0x01, 0),
            (0x02, 0),
            (0xFF, 0),
            (0xFF, 0),
            (0xFF, cull_back),
            (0xFF, cull_back),
        ],
    );
    assert_eq!(&out[0][..4], &[10, 7, 0, HIT_KIND_TRIANGLE_FRONT_FACE]);
    assert_eq!(f32::from_bits(out[0][4]), 0.25, "object-space origin");
    assert_eq!(
        &out[1][..3],
        &[12, 0x0034_5678, 1],
        "instance ids keep 24 bits; SBT offset 2"
    );
    assert_eq!(
        out[2][0], 0xFFFF,
        "mask 0x02 misses an instance with mask 0x01"
    );
    assert_eq!(
        &out[3][..4],
        &[13, 9, 3, HIT_KIND_TRIANGLE_BACK_FACE],
        "flipped facing"
    );
    assert_eq!(
        out[4][0], 0xFFFF,
        "only 8 bits of an instance mask count: 0x100 is 0"
    );
    assert_eq!(
        out[5][0], 0xFFFF,
        "a flipped triangle is back-facing and culled"
    );
    assert_eq!(
        &out[6][..4],
        &[11, 12, 6, HIT_KIND_TRIANGLE_BACK_FACE],
        "the instance disables culling"
    );
}

#[test]
fn nested_instances_and_transforms_flatten() {
    let dev = device();
    let s = setup(&dev);
    let tri = dev.traversable_handle(unit_triangle(&dev)).unwrap();
    // Inner IAS: the triangle at x = +1 (id 5, SBT offset 1).
    let inner = dev.instances(&[placed(tri, 1.0, 5, 1, 0xFF, InstanceFlags::NONE)]);
    let inner_h = dev.traversable_handle(inner).unwrap();
    // A static transform moving the triangle by +2.
    let mut m = IDENTITY_3X4;
    m[3] = 2.0;
    let mut inv = IDENTITY_3X4;
    inv[3] = -2.0;
    let xf = dev
        .create_transform(&TransformDesc::Static {
            child: tri,
            object_to_world: m,
            world_to_object: inv,
        })
        .unwrap();
    let xf_h = dev.traversable_handle(xf).unwrap();
    // Outer IAS: the inner IAS at x = 0 (id 8, SBT offset 2) and at x = 2 (masked 0x0F
    // over the inner's 0xFF), and the transform at x = 2 (so x = 4).
    let outer = dev.instances(&[
        placed(inner_h, 0.0, 8, 2, 0xFF, InstanceFlags::NONE),
        placed(
            inner_h,
            2.0,
            9,
            4,
            0x0F,
            InstanceFlags::FLIP_TRIANGLE_FACING,
        ),
        placed(xf_h, 2.0, 12, 0, 0xFF, InstanceFlags::NONE),
    ]);
    let h = dev.traversable_handle(outer).unwrap();
    let out = trace(
        &dev,
        &s,
        h,
        &[
            (0xFF, 0),
            (0xFF, 0),
            (0xF0, 0),
            (0x01, 0),
            (0xFF, 0),
            (0xFF, 0),
        ],
    );
    assert_eq!(out[0][0], 0xFFFF);
    // Path outer[0] -> inner[0]: x = 1, offsets 2 + 1, the innermost instance's id and index.
    assert_eq!(&out[1][..4], &[13, 5, 0, HIT_KIND_TRIANGLE_FRONT_FACE]);
    assert_eq!(f32::from_bits(out[1][4]), 0.25);
    // Path outer[1] -> inner[0]: x = 3, mask 0x0F; a ray with mask 0xF0 misses it ...
    assert_eq!(out[2][0], 0xFFFF);
    // ... and one with 0x01 hits it, through offsets 4 + 1, flipped once.
    assert_eq!(&out[3][..4], &[15, 5, 0, HIT_KIND_TRIANGLE_BACK_FACE]);
    // Path outer[2] -> transform: x = 4; no instance below the outer one: its id and index.
    assert_eq!(&out[4][..3], &[10, 12, 2]);
    assert_eq!(
        f32::from_bits(out[4][4]),
        0.25,
        "the transform's and instance's translations compose"
    );

    // Tracing the GAS and the transform directly: no instance, id and index 0.
    let direct = trace(&dev, &s, xf_h, &[(0xFF, 0), (0xFF, 0), (0xFF, 0)]);
    assert_eq!(&direct[2][..3], &[10, 0, 0]);
    let gas_direct = trace(&dev, &s, tri, &[(0xFF, 0)]);
    assert_eq!(&gas_direct[0][..3], &[10, 0, 0]);
    // The null handle misses.
    let null = trace(&dev, &s, TraversableHandle::NULL, &[(0xFF, 0)]);
    assert_eq!(null[0][0], 0xFFFF);
}

#[test]
fn masks_that_do_not_nest_are_refused() {
    let dev = device();
    let tri = dev.traversable_handle(unit_triangle(&dev)).unwrap();
    let inner = dev.instances(&[placed(tri, 0.0, 0, 0, 0x01, InstanceFlags::NONE)]);
    let b = dev.buffer_with(bytemuck::cast_slice(&[placed(
        dev.traversable_handle(inner).unwrap(),
        0.0,
        0,
        0,
        0x02,
        InstanceFlags::NONE,
    )]));
    let e = dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Instances(InstanceArray {
                instances: BufferView::new(b),
                num_instances: 1,
            })],
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Unsupported);
    assert!(e.message().contains("mask"), "{e}");
}

#[test]
fn destroyed_children_are_missed_and_handles_stay() {
    let dev = device();
    let s = setup(&dev);
    let a = unit_triangle(&dev);
    let b = unit_triangle(&dev);
    let ias = dev.instances(&[
        placed(
            dev.traversable_handle(a).unwrap(),
            0.0,
            1,
            0,
            0xFF,
            InstanceFlags::NONE,
        ),
        placed(
            dev.traversable_handle(b).unwrap(),
            1.0,
            2,
            0,
            0xFF,
            InstanceFlags::NONE,
        ),
    ]);
    let h = dev.traversable_handle(ias).unwrap();
    let before = trace(&dev, &s, h, &[(0xFF, 0), (0xFF, 0)]);
    assert_eq!((before[0][1], before[1][1]), (1, 2));
    dev.destroy_accel(a).unwrap();
    assert_eq!(
        dev.traversable_handle(ias).unwrap(),
        h,
        "the parent keeps its handle"
    );
    let after = trace(&dev, &s, h, &[(0xFF, 0), (0xFF, 0)]);
    assert_eq!(after[0][0], 0xFFFF, "the destroyed child is missed");
    assert_eq!(after[1][1], 2, "the other child still hits");
    let e = dev.traversable_handle(a).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidHandle);
}
