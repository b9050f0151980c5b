//! The `aabb` group: custom primitives with intersection programs (reported t outside the
//! box, rays starting inside, attributes, `rt_report_intersection`'s result).

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, action, ch, hit_group, prog};
use crate::oracle::model::Models;
use crate::scene::{Aabbs, Gas, GeomInput, InstanceDesc, Node, Scene, Triangles};
use crate::tolerance::Tolerance;
use optik::GeometryFlags;

/// Every case of the `aabb` group.
pub fn cases() -> Vec<Case> {
    vec![
        hits_outside_bounds(),
        ray_inside(),
        false_positive_safe(),
        attributes_max(),
        report_return_value(),
        no_report(),
    ]
}

fn hits_outside_bounds() -> Case {
    // A wall of small boxes whose intersection program reports the analytic sphere behind
    // them (hits outside the boxes), and a triangle in between (CTS procedural_geometry).
    let mut boxes = Vec::new();
    for j in 0..6 {
        for i in 0..6 {
            let (x, y) = (-3.0 + i as f32, -3.0 + j as f32);
            boxes.push([x + 0.1, y + 0.1, -1.05, x + 0.9, y + 0.9, -1.0]);
        }
    }
    let n = boxes.len();
    let mut scene = Scene::default();
    let wall = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        boxes,
        GeometryFlags::DISABLE_ANYHIT,
    ))])));
    let tri = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            quad(-0.75, -0.75, 0.75, 0.75, -2.0),
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])));
    let root = scene.add(Node::Ias(vec![
        InstanceDesc::of(wall),
        InstanceDesc {
            id: 1,
            sbt_offset: 1,
            ..InstanceDesc::of(tri)
        },
    ]));
    let mut case = StdCase::new(
        Group::Aabb,
        "hits_outside_bounds",
        "intersection programs may report hits outside their boxes: a wall of boxes shows the sphere behind it where a box was entered, the triangle in between occludes it (CTS procedural_geometry)",
        &[Rule::CustomClosedInterval],
        scene,
        Some(root),
    )
    .hits(
        vec![hit_group(Some(prog::CH_ATTRS), None, Some(prog::IS_SPHERE)), hit_group(Some(prog::CH), None, None)],
        vec![SbtEntry::new(0, vec![0]), SbtEntry::new(1, vec![1])],
    )
    .launch(26, down_grid(26, 26, -3.0, -3.0, 3.0, 3.0, 0.0))
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::prim(), ch::inst_index(), ch::hit_kind()]);
    case.prims = vec![[0.0, 0.0, -5.0, 2.5]; n];
    case.build()
}

const TMIN_WGSL: &str = r#"
fn intersection__tmin() {
    out[slot(18u)] = out[slot(18u)] + 1u;
    var attrs: RtAttributes;
    let accepted = rt_report_intersection(rt_ray_tmin(), 5u, attrs);
}
"#;

fn ray_inside() -> Case {
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![[-1.0, -1.0, -1.0, 1.0, 1.0, 1.0]],
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    let o = [0.25f32, -0.5, 0.125];
    let mut rays = Vec::new();
    for d in [[0.0f32, 0.0, -1.0], [1.0, 0.5, 0.25], [0.0, 2.0, 0.0]] {
        for (tmin, tmax) in [
            (0.0f32, 0.0f32),
            (0.0, 0.5),
            (0.0, 1.0),
            (0.0, 100.0),
            (0.25, 0.25),
            (0.5, 4.0),
        ] {
            rays.push(Ray::new(o, d).interval(tmin, tmax));
        }
    }
    let mut m = Models::new();
    m.add("intersection__tmin", |ctx| {
        let s = ctx.linear_index() as usize * 32 + 18;
        let c = ctx.read(2, s);
        ctx.write(2, s, c + 1);
        let t = ctx.ray_tmin();
        ctx.report_intersection(t, 5, [0; 8])?;
        Ok(())
    });
    let mut case = StdCase::new(
        Group::Aabb,
        "ray_inside",
        "rays starting inside a box with tmax 0, inside, at the face and beyond: the intersection program runs and its report at t = tmin is accepted in all (inclusive interval) (CTS inside_aabbs)",
        &[Rule::CustomClosedInterval],
        scene,
        Some(root),
    )
    .exact()
    .hits(vec![hit_group(Some(prog::CH_ATTRS), None, Some("intersection__tmin"))], vec![SbtEntry::new(0, vec![0])])
    .launch(6, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::Exact), ch::hit_kind(), ch::is_count()]);
    case.more_wgsl = Some((TMIN_WGSL.into(), m));
    case.build()
}

fn false_positive_safe() -> Case {
    // Spheres in boxes; rays through the boxes' corners that miss the spheres, and thin boxes.
    let spheres: Vec<[f32; 4]> = (0..8).map(|i| [i as f32 * 3.0, 0.0, -5.0, 1.0]).collect();
    let boxes: Vec<[f32; 6]> = spheres
        .iter()
        .map(|s| {
            [
                s[0] - 1.0,
                s[1] - 1.0,
                s[2] - 1.0,
                s[0] + 1.0,
                s[1] + 1.0,
                s[2] + 1.0,
            ]
        })
        .collect();
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        boxes,
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    let mut rays = Vec::new();
    for s in &spheres {
        for (dx, dy) in [
            (0.9f32, 0.9f32),
            (-0.95, 0.8),
            (0.5, 0.5),
            (0.0, 0.99),
            (0.0, 1.01),
            (0.71, 0.69),
        ] {
            rays.push(Ray::new([s[0] + dx, s[1] + dy, 0.0], [0.0, 0.0, -1.0]));
        }
    }
    let mut case = StdCase::new(
        Group::Aabb,
        "false_positive_safe",
        "rays through the corners of the boxes around spheres: the analytic intersection program rejects them, so only true sphere hits count whatever boxes the traversal tests",
        &[Rule::CustomClosedInterval],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH_ATTRS), None, Some(prog::IS_SPHERE))], vec![SbtEntry::new(0, vec![0])])
    .launch(12, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::prim()]);
    case.prims = spheres;
    case.build()
}

const ATTRS_WGSL: &str = r#"
fn intersection__attrs() {
    var attrs: RtAttributes;
    for (var i = 0u; i < 8u; i++) {
        attrs[i] = 1u + ray_id() + i;
    }
    let accepted = rt_report_intersection(0.5, ray_id() % 256u, attrs);
}

fn anyhit__attrs() {
    rt_set_payload(3u, rt_get_attribute(0u) ^ rt_get_attribute(3u) ^ rt_get_attribute(7u));
    rt_set_payload(4u, rt_get_attribute(7u));
    rt_set_payload(5u, rt_hit_kind());
}
"#;

fn attributes_max() -> Case {
    let boxes: Vec<[f32; 6]> = (0..128)
        .map(|i| [i as f32, 0.0, -1.0, i as f32 + 0.5, 1.0, 0.0])
        .collect();
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        boxes,
        GeometryFlags::NONE,
    ))]));
    // Even rays hit a box, odd rays pass between boxes and miss.
    let rays: Vec<Ray> = (0..256)
        .map(|k| Ray::new([0.25 + 0.5 * k as f32, 0.5, 1.0], [0.0, 0.0, -1.0]))
        .collect();
    let mut m = Models::new();
    m.add("intersection__attrs", |ctx| {
        let id = ctx.linear_index();
        let attrs: [u32; 8] = std::array::from_fn(|i| 1 + id + i as u32);
        ctx.report_intersection(0.5, id % 256, attrs)?;
        Ok(())
    });
    m.add("anyhit__attrs", |ctx| {
        let x = ctx.get_attribute(0) ^ ctx.get_attribute(3) ^ ctx.get_attribute(7);
        ctx.set_payload(3, x);
        let a7 = ctx.get_attribute(7);
        ctx.set_payload(4, a7);
        let hk = ctx.hit_kind();
        ctx.set_payload(5, hk);
        Ok(())
    });
    let mut channels = vec![ch::hit(), ch::hit_kind()];
    channels.extend((0..8).map(ch::attr_u));
    channels.extend([ch::payload(3), ch::payload(4), ch::payload(5)]);
    let mut case = StdCase::new(
        Group::Aabb,
        "attributes_max",
        "eight attribute registers (1 + ray + i) reach any-hit and closest-hit unchanged; hit kinds 0..255 keep their low 7 bits; alternate rays miss (CTS maxrayhitattributesize)",
        &[Rule::CustomClosedInterval],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH_ATTRS), Some("anyhit__attrs"), Some("intersection__attrs"))], vec![SbtEntry::new(0, vec![0])])
    .launch(64, rays)
    .record(channels);
    case.more_wgsl = Some((ATTRS_WGSL.into(), m));
    case.build()
}

fn report_return_value() -> Case {
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![[0.0, 0.0, -1.0, 1.0, 1.0, 0.0]],
        GeometryFlags::NONE,
    ))]));
    let records = vec![SbtEntry::new(
        0,
        vec![
            0,
            action::IGNORE_IN_RANGE,
            0.6f32.to_bits(),
            0.8f32.to_bits(),
            2,
            0.7f32.to_bits(),
            0.2f32.to_bits(),
        ],
    )];
    StdCase::new(
        Group::Aabb,
        "report_return_value",
        "reports at 0.7 (ignored by any-hit) then 0.2 (accepted): rt_report_intersection returns false then true, any-hit runs twice, the hit is at 0.2 (CTS report_intersection_result)",
        &[Rule::IgnoreTerminate, Rule::CustomClosedInterval],
        scene,
        Some(root),
    )
    .exact()
    .hits(vec![hit_group(Some(prog::CH_ATTRS), Some(prog::AH), Some(prog::IS_FIXED))], records)
    .launch(4, vec![Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]); 4])
    .record(vec![ch::hit(), ch::t(Tolerance::Exact), ch::aux(), ch::ah_count(), ch::programs()])
    .build()
}

fn no_report() -> Case {
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![[0.0, 0.0, -1.0, 1.0, 1.0, 0.0]],
        GeometryFlags::NONE,
    ))]));
    StdCase::new(
        Group::Aabb,
        "no_report",
        "an intersection program that reports nothing: it runs once, then miss; any-hit and closest-hit never run",
        &[Rule::CustomClosedInterval],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH_ATTRS), Some(prog::AH), Some(prog::IS_FIXED))], vec![SbtEntry::new(0, vec![0, action::ACCEPT, 0, 0, 0])])
    .launch(2, vec![Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]), Ray::new([1.5, 0.5, 1.0], [0.0, 0.0, -1.0])])
    .record(vec![ch::hit(), ch::programs(), ch::is_count(), ch::ah_count(), ch::sbt_index()])
    .build()
}
