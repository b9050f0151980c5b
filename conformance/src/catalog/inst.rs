//! The `inst` group: instance masks and ids, multi-level instancing, non-uniform transforms.

use super::builtin::xform_case;
use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, ch};
use crate::scene::{InstanceDesc, Node, Scene, TransformKind, TransformNode};
use crate::tolerance::Tolerance;
use optik::{GeometryFlags, Matrix3x4};

/// Every case of the `inst` group.
pub fn cases() -> Vec<Case> {
    vec![masks_and_ids(), multilevel(), nonuniform_scale()]
}

fn masks_and_ids() -> Case {
    let mut scene = Scene::default();
    let gas = small_quad_gas(&mut scene);
    let mut id = 0u32;
    let mut instances = Vec::new();
    for k in 1..=255u32 {
        id = (id.wrapping_mul(7).wrapping_add(153325)) & 0xFF_FFFF;
        let (x, y) = ((k % 16) as f32 * 2.0, (k / 16) as f32 * 2.0);
        instances.push(InstanceDesc {
            id,
            mask: k,
            ..InstanceDesc::of(gas).at(translate([x, y, -1.0]))
        });
    }
    let root = scene.add(Node::Ias(instances));
    let mut rays = Vec::new();
    for k in 1..=255u32 {
        let (x, y) = ((k % 16) as f32 * 2.0, (k / 16) as f32 * 2.0);
        let r = Ray::new([x + 0.125, y - 0.25, 0.0], [0.0, 0.0, -1.0]);
        // The ray's mask with garbage above bit 8: visible.
        rays.push(Ray {
            mask: k | 0x00FF_FF00,
            ..r
        });
        // The complement within 8 bits: invisible.
        rays.push(Ray {
            mask: !k & 0xFF | 0x100,
            ..r
        });
    }
    StdCase::new(
        Group::Inst,
        "masks_and_ids",
        "255 instances with masks 1..255 and 24-bit ids (prev·7 + 153325): a ray sees an instance exactly when the low 8 bits of the masks share a bit; ids and indices as given (CTS cullmask, cullmask_extrabits)",
        &[Rule::FlagBitsAndWidths],
        scene,
        Some(root),
    )
    .launch(30, rays)
    .record(vec![ch::hit(), ch::inst_id(), ch::inst_index()])
    .build()
}

fn multilevel() -> Case {
    // top IAS → mid IAS → static transform → GAS; SBT offsets add up along the path.
    let mut scene = Scene::default();
    let gas = small_quad_gas(&mut scene);
    let rot = rotate_translate([0.0, 0.0, 1.0], 0.5, [0.25, 0.0, 0.0]);
    let xf = scene.add(Node::Transform(TransformNode {
        kind: TransformKind::Static(rot),
        child: gas,
    }));
    let mid = scene.add(Node::Ias(vec![
        InstanceDesc {
            id: 20,
            sbt_offset: 1,
            ..InstanceDesc::of(xf).at(translate([0.0, 0.0, -1.0]))
        },
        InstanceDesc {
            id: 21,
            sbt_offset: 5,
            ..InstanceDesc::of(xf).at(scale_translate([1.0, 2.0, 1.0], [3.0, 0.0, -2.0]))
        },
    ]));
    let root = scene.add(Node::Ias(vec![
        InstanceDesc {
            id: 10,
            sbt_offset: 0,
            ..InstanceDesc::of(mid)
        },
        InstanceDesc {
            id: 11,
            sbt_offset: 2,
            ..InstanceDesc::of(mid).at(rotate_translate([1.0, 0.0, 0.0], 0.2, [0.0, 6.0, 0.0]))
        },
    ]));
    let records = (0..8).map(|k| SbtEntry::new(0, vec![k])).collect();
    let mut rays = Vec::new();
    for (x, y) in [(0.25f32, 0.0f32), (3.25, 0.0), (0.25, 6.0), (3.25, 6.0)] {
        for (dx, dy) in [(0.05f32, 0.1f32), (-0.1, 0.05), (0.0, -0.15), (0.12, -0.02)] {
            rays.push(Ray::new([x + dx, y + dy, 3.0], [0.0, 0.01, -1.0]));
        }
    }
    xform_case(
        Group::Inst,
        "multilevel",
        "IAS → IAS → static transform → GAS: instance id and index of the nearest instance, SBT offsets summed over the path, the composed object↔world matrices and object ray",
        &[Rule::SbtIndex],
        scene,
        root,
        records,
        rays,
        Tolerance::U16 { scale: 10.0 },
    )
}

fn nonuniform_scale() -> Case {
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(icosphere(2).gas(GeometryFlags::DISABLE_ANYHIT)));
    let ms: Vec<Matrix3x4> = vec![
        scale_translate([3.0, 0.5, 1.0], [0.0, 0.0, -5.0]),
        [1.0, 0.8, 0.0, 8.0, 0.0, 1.0, 0.3, 0.0, 0.2, 0.0, 1.0, -5.0],
        scale_translate([-1.0, 1.0, 1.0], [16.0, 0.0, -5.0]),
        scale_translate([2.0, -1.0, -0.5], [24.0, 0.0, -5.0]),
    ];
    let instances = ms
        .iter()
        .enumerate()
        .map(|(i, m)| InstanceDesc {
            id: i as u32,
            ..InstanceDesc::of(gas).at(*m)
        })
        .collect();
    let root = scene.add(Node::Ias(instances));
    let mut rng = Rng::new(31);
    let mut rays = Vec::new();
    for k in 0..4 {
        for _ in 0..8 {
            let o = [
                8.0 * k as f64 + rng.range(-0.5, 0.5),
                rng.range(-0.3, 0.3),
                2.0,
            ];
            rays.push(Ray::new(
                v32(o),
                v32([rng.range(-0.05, 0.05), rng.range(-0.05, 0.05), -1.0]),
            ));
        }
    }
    xform_case(
        Group::Inst,
        "nonuniform_scale",
        "scaled, sheared and mirrored (det < 0) instances: t the same in object and world space, the object ray, and front faces seen from outside whatever the determinant",
        &[Rule::FrontFace],
        scene,
        root,
        vec![SbtEntry::new(0, vec![0])],
        rays,
        Tolerance::U16 { scale: 10.0 },
    )
}
