//! Instances: visibility masks, SBT offsets, ids and indices, flip and cull flags, nested
//! instance trees and static transforms flattened into Vulkan's one level, and traversables
//! destroyed under their parents.

use crate::common::*;
use optik_api::*;

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
