//! Group C (`flags`): facing and hit kinds, ray flags, flag precedence, face culling, the
//! shadow-ray pattern, terminate-on-first-hit.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, action, ch, hit_group, prog};
use crate::oracle::model::Models;
use crate::scene::{Aabbs, Gas, GeomInput, InstanceDesc, Node, Scene, Triangles};
use crate::tolerance::Tolerance;
use optik::{GeometryFlags, InstanceFlags, PipelineLinkOptions, RayFlags};

/// Every case of the group.
pub fn cases() -> Vec<Case> {
    vec![
        facing_hitkind(),
        ray_flags_truth_table(false),
        ray_flags_truth_table(true),
        precedence_matrix(),
        face_culling_overrides(),
        shadow_ray_pattern(),
        terminate_on_first_hit(),
    ]
}

/// A counter-clockwise (seen from +z) quad over [x, x+1] × [y, y+1] at z, or clockwise.
fn facing_quad(x: f32, y: f32, z: f32, ccw: bool) -> Vec<[f32; 3]> {
    let q = quad(x, y, x + 1.0, y + 1.0, z);
    if ccw {
        q
    } else {
        q.chunks(3).flat_map(|t| [t[0], t[2], t[1]]).collect()
    }
}

fn facing_hitkind() -> Case {
    let mut scene = Scene::default();
    let mut verts = facing_quad(0.0, 0.0, 0.0, true);
    verts.extend(facing_quad(2.0, 0.0, 0.0, false));
    let gas = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(verts, GeometryFlags::DISABLE_ANYHIT),
    )])));
    let root = scene.add(Node::Ias(vec![
        InstanceDesc::of(gas),
        InstanceDesc {
            id: 1,
            flags: InstanceFlags::FLIP_TRIANGLE_FACING,
            ..InstanceDesc::of(gas).at(translate([0.0, 2.0, 0.0]))
        },
        // A mirroring instance: facing is decided in object space, so it changes nothing.
        InstanceDesc {
            id: 2,
            ..InstanceDesc::of(gas).at(scale_translate([-1.0, 1.0, 1.0], [3.0, 4.0, 0.0]))
        },
    ]));
    let mut rays = Vec::new();
    for y in [0.0f32, 2.0, 4.0] {
        for x in [0.375f32, 2.375] {
            let x = if y == 4.0 { 3.0 - x } else { x };
            rays.push(Ray::new([x, y + 0.75, 1.0], [0.0, 0.0, -1.0]));
            rays.push(Ray::new([x, y + 0.75, -1.0], [0.0, 0.0, 1.0]));
        }
    }
    StdCase::new(
        Group::Flags,
        "facing_hitkind",
        "counter-clockwise seen from the ray origin is front (hit kind 0xFE, back 0xFF); FLIP_TRIANGLE_FACING swaps; a mirroring instance does not",
        &[Rule::FrontFace],
        scene,
        Some(root),
    )
    .launch(12, rays)
    .record(vec![ch::hit(), ch::hit_kind(), ch::prim(), ch::inst_id()])
    .build()
}

const FLAGS_WGSL: &str = r#"
fn closesthit__flags() {
    record_hit();
    out[slot(19u)] = rt_ray_flags();
}

fn anyhit__flags() {
    rt_set_payload(0u, rt_get_payload(0u) | 4u);
    rt_set_payload(1u, rt_get_payload(1u) + 1u);
    rt_set_payload(3u, rt_ray_flags());
}

fn miss__flags() {
    out[slot(0u)] = 0u;
    out[slot(19u)] = rt_ray_flags();
    rt_set_payload(0u, rt_get_payload(0u) | 16u);
}
"#;

fn flags_models() -> Models {
    let mut m = Models::new();
    m.add("closesthit__flags", |ctx| {
        let s = ctx.linear_index() as usize * 32;
        let words = [
            (0, 1),
            (1, ctx.ray_tmax().to_bits()),
            (2, ctx.primitive_index()),
            (3, ctx.instance_id()),
            (4, ctx.instance_index()),
            (5, ctx.sbt_gas_index()),
            (6, ctx.hit_kind()),
            (15, ctx.sbt_data_u32(0)),
            (19, ctx.ray_flags()),
        ];
        for (k, v) in words {
            ctx.write(2, s + k, v);
        }
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 8);
        Ok(())
    });
    m.add("anyhit__flags", |ctx| {
        let p0 = ctx.get_payload(0);
        ctx.set_payload(0, p0 | 4);
        let p1 = ctx.get_payload(1);
        ctx.set_payload(1, p1 + 1);
        let f = ctx.ray_flags();
        ctx.set_payload(3, f);
        Ok(())
    });
    m.add("miss__flags", |ctx| {
        let s = ctx.linear_index() as usize * 32;
        ctx.write(2, s, 0);
        let f = ctx.ray_flags();
        ctx.write(2, s + 19, f);
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 16);
        Ok(())
    });
    m
}

fn ray_flags_truth_table(aabbs: bool) -> Case {
    // Four primitives: opaque front-facing, opaque back-facing, non-opaque front, non-opaque
    // back (facing only matters for triangles). Every flag byte 0..=255 against each.
    let opaque: Vec<[f32; 3]> = [
        facing_quad(0.0, 0.0, -1.0, true),
        facing_quad(2.0, 0.0, -1.0, false),
    ]
    .concat();
    let clear: Vec<[f32; 3]> = [
        facing_quad(4.0, 0.0, -1.0, true),
        facing_quad(6.0, 0.0, -1.0, false),
    ]
    .concat();
    let input = |v: Vec<[f32; 3]>, f: GeometryFlags| -> GeomInput {
        if aabbs {
            let boxes = v
                .chunks(6)
                .map(|q| [q[0][0], q[0][1], -1.5, q[0][0] + 1.0, q[0][1] + 1.0, -0.5])
                .collect();
            GeomInput::Aabbs(Aabbs::new(boxes, f))
        } else {
            GeomInput::Triangles(Triangles::soup(v, f))
        }
    };
    let (scene, root) = Scene::single(Gas::new(vec![
        input(opaque, GeometryFlags::DISABLE_ANYHIT),
        input(clear, GeometryFlags::NONE),
    ]));
    let mut rays = Vec::new();
    for flags in 0..256u32 {
        for x in [0.375f32, 2.375, 4.375, 6.375] {
            rays.push(Ray::new([x, 0.75, 1.0], [0.0, 0.0, -1.0]).flags(flags));
        }
    }
    let (is, ch_name) = if aabbs {
        (Some(prog::IS_FIXED), "closesthit__flags")
    } else {
        (None, "closesthit__flags")
    };
    let groups = vec![hit_group(Some(ch_name), Some("anyhit__flags"), is)];
    let records = (0..2)
        .map(|k| SbtEntry::new(0, vec![k, action::ACCEPT, 0, 0, 1, 2.0f32.to_bits()]))
        .collect();
    let mut case = StdCase::new(
        Group::Flags,
        if aabbs { "ray_flags_truth_table_aabbs" } else { "ray_flags_truth_table" },
        &format!(
            "every ray flag byte 0..255 against opaque and non-opaque, front- and back-facing {}: which programs run and the flags each sees (CTS incomingrayflags; optik defines the exclusive pairs: DISABLE wins, both culls cull all)",
            if aabbs { "custom primitives" } else { "triangles" }
        ),
        &[Rule::FlagPrecedence, Rule::FlagBitsAndWidths, Rule::FrontFace],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(64, rays)
    .record(vec![ch::hit(), ch::programs(), ch::ah_count(), ch::aux(), ch::payload(3), ch::sbt_index()]);
    case.miss_groups = vec![Some("miss__flags".into())];
    case.more_wgsl = Some((FLAGS_WGSL.into(), flags_models()));
    case.build()
}

fn precedence_matrix() -> Case {
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(Gas::new(vec![
        GeomInput::Triangles(Triangles::soup(
            quad(0.0, 0.0, 1.0, 1.0, -1.0),
            GeometryFlags::DISABLE_ANYHIT,
        )),
        GeomInput::Triangles(Triangles::soup(
            quad(2.0, 0.0, 3.0, 1.0, -1.0),
            GeometryFlags::NONE,
        )),
    ])));
    let inst_flags = [
        InstanceFlags::NONE,
        InstanceFlags::DISABLE_ANYHIT,
        InstanceFlags::ENFORCE_ANYHIT,
        InstanceFlags::DISABLE_ANYHIT | InstanceFlags::ENFORCE_ANYHIT,
    ];
    let instances = inst_flags
        .iter()
        .enumerate()
        .map(|(i, f)| InstanceDesc {
            id: i as u32,
            flags: *f,
            ..InstanceDesc::of(gas).at(translate([0.0, 2.0 * i as f32, 0.0]))
        })
        .collect();
    let root = scene.add(Node::Ias(instances));
    let ray_flags = [
        RayFlags::NONE,
        RayFlags::DISABLE_ANYHIT,
        RayFlags::ENFORCE_ANYHIT,
        RayFlags::CULL_DISABLED_ANYHIT,
        RayFlags::CULL_ENFORCED_ANYHIT,
        RayFlags::DISABLE_ANYHIT | RayFlags::CULL_ENFORCED_ANYHIT,
        RayFlags::ENFORCE_ANYHIT | RayFlags::CULL_DISABLED_ANYHIT,
    ];
    let mut rays = Vec::new();
    for i in 0..inst_flags.len() {
        for x in [0.75f32, 2.75] {
            for f in ray_flags {
                rays.push(Ray::new([x, 2.0 * i as f32 + 0.25, 1.0], [0.0, 0.0, -1.0]).flags(f.0));
            }
        }
    }
    StdCase::new(
        Group::Flags,
        "precedence_matrix",
        "geometry DISABLE_ANYHIT × instance DISABLE/ENFORCE_ANYHIT × ray DISABLE/ENFORCE/CULL_DISABLED/CULL_ENFORCED_ANYHIT: ray beats instance beats geometry; culls drop what they name",
        &[Rule::FlagPrecedence, Rule::AnyHitPerCandidate],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), Some(prog::AH), None)], vec![SbtEntry::new(0, vec![0, action::ACCEPT]), SbtEntry::new(0, vec![1, action::ACCEPT])])
    .launch(14, rays)
    .record(vec![ch::hit(), ch::programs(), ch::ah_count(), ch::inst_id(), ch::gas_index()])
    .build()
}

fn face_culling_overrides() -> Case {
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(Gas::new(vec![
        GeomInput::Triangles(Triangles::soup(
            facing_quad(0.0, 0.0, 0.0, true),
            GeometryFlags::DISABLE_ANYHIT,
        )),
        GeomInput::Triangles(Triangles::soup(
            facing_quad(2.0, 0.0, 0.0, true),
            GeometryFlags::DISABLE_ANYHIT | GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING,
        )),
    ])));
    // Two stacked non-opaque triangles for CTS preserve_flip_facing.
    let stacked = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            [
                facing_quad(4.0, 0.0, -0.5, true),
                facing_quad(4.0, 0.0, -1.0, true),
            ]
            .concat(),
            GeometryFlags::REQUIRE_SINGLE_ANYHIT_CALL,
        ),
    )])));
    let inst_flags = [
        InstanceFlags::NONE,
        InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING,
        InstanceFlags::FLIP_TRIANGLE_FACING,
        InstanceFlags::FLIP_TRIANGLE_FACING | InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING,
    ];
    let mut instances: Vec<InstanceDesc> = inst_flags
        .iter()
        .enumerate()
        .map(|(i, f)| InstanceDesc {
            id: i as u32,
            flags: *f,
            ..InstanceDesc::of(gas).at(translate([0.0, 2.0 * i as f32, 0.0]))
        })
        .collect();
    instances.push(InstanceDesc {
        id: 9,
        sbt_offset: 2,
        flags: InstanceFlags::FLIP_TRIANGLE_FACING,
        ..InstanceDesc::of(stacked).at(translate([0.0, 0.0, 0.0]))
    });
    let root = scene.add(Node::Ias(instances));
    let culls = [
        RayFlags::NONE,
        RayFlags::CULL_BACK_FACING_TRIANGLES,
        RayFlags::CULL_FRONT_FACING_TRIANGLES,
        RayFlags::CULL_BACK_FACING_TRIANGLES | RayFlags::CULL_FRONT_FACING_TRIANGLES,
    ];
    let mut rays = Vec::new();
    for i in 0..inst_flags.len() {
        for x in [0.375f32, 2.375] {
            for (z, dz) in [(1.0f32, -1.0f32), (-1.0, 1.0)] {
                for c in culls {
                    rays.push(Ray::new([x, 2.0 * i as f32 + 0.75, z], [0.0, 0.0, dz]).flags(c.0));
                }
            }
        }
    }
    // Through both stacked triangles of the flipped instance: seen from below they are back
    // faces, flipped to front, so CULL_BACK keeps both and the any-hit program runs twice;
    // seen from above the flip makes them back faces and CULL_BACK drops them.
    for c in culls {
        rays.push(Ray::new([4.375, 0.75, -2.0], [0.0, 0.0, 1.0]).flags(c.0));
        rays.push(Ray::new([4.375, 0.75, 1.0], [0.0, 0.0, -1.0]).flags(c.0));
    }
    let records = vec![
        SbtEntry::new(0, vec![0, action::ACCEPT]),
        SbtEntry::new(0, vec![1, action::ACCEPT]),
        SbtEntry::new(0, vec![2, action::IGNORE]),
    ];
    StdCase::new(
        Group::Flags,
        "face_culling_overrides",
        "CULL_BACK/CULL_FRONT rays × instance DISABLE_TRIANGLE_FACE_CULLING × geometry DISABLE_TRIANGLE_FACE_CULLING × FLIP_TRIANGLE_FACING, and the flip surviving into culling (CTS preserve_flip_facing: two any-hits)",
        &[Rule::FrontFace, Rule::FlagPrecedence],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), Some(prog::AH), None)], records)
    .launch(16, rays)
    .record(vec![ch::hit(), ch::hit_kind(), ch::inst_id(), ch::gas_index(), ch::ah_count(), ch::programs()])
    .build()
}

const SHADOW_WGSL: &str = r#"
fn miss__shadow() {
    rt_set_payload(3u, 1u);
}

fn closesthit__never() {
    rt_set_payload(3u, 77u);
}
"#;

fn shadow_ray_pattern() -> Case {
    // optix7course example 9: ray type 0 radiance, 1 shadow; SBT stride 2; miss index = ray
    // type; shadow rays DISABLE_ANYHIT | TERMINATE_ON_FIRST_HIT | DISABLE_CLOSESTHIT and a
    // shadow miss program that marks the light visible.
    let mut verts = Vec::new();
    for k in 0..6 {
        let z = -1.0 - k as f32 * 0.5;
        verts.extend(quad(k as f32 * 0.5, 0.0, k as f32 * 0.5 + 2.0, 1.0, z));
    }
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        verts,
        GeometryFlags::NONE,
    ))]));
    let shadow =
        RayFlags::DISABLE_ANYHIT | RayFlags::TERMINATE_ON_FIRST_HIT | RayFlags::DISABLE_CLOSESTHIT;
    let mut rays = Vec::new();
    for k in 0..16 {
        let x = -0.25 + 0.25 * k as f32;
        let r = Ray {
            sbt_offset: 1,
            sbt_stride: 2,
            miss_index: 1,
            ..Ray::new([x, 0.375, -5.0], [0.0, 0.0, 1.0]).flags(shadow.0)
        };
        rays.push(r);
        rays.push(Ray {
            sbt_offset: 0,
            sbt_stride: 2,
            miss_index: 0,
            flags: 0,
            ..r
        });
    }
    let groups = vec![
        hit_group(Some(prog::CH), Some(prog::AH), None),
        hit_group(Some("closesthit__never"), Some(prog::AH), None),
    ];
    let records = vec![
        SbtEntry::new(0, vec![0, action::ACCEPT]),
        SbtEntry::new(1, vec![1, action::ACCEPT]),
    ];
    let mut case = StdCase::new(
        Group::Flags,
        "shadow_ray_pattern",
        "the optix7course shadow-ray pattern: ray-type SBT offset and stride, miss index, DISABLE_ANYHIT | TERMINATE_ON_FIRST_HIT | DISABLE_CLOSESTHIT: visibility only from the shadow miss",
        &[Rule::FlagPrecedence, Rule::SbtIndex],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(32, rays)
    .record(vec![ch::hit(), ch::programs(), ch::payload(3), ch::sbt_index()]);
    case.miss_groups = vec![Some(prog::MS.into()), Some("miss__shadow".into())];
    case.miss_records = vec![SbtEntry::new(0, vec![0]), SbtEntry::new(1, vec![1])];
    let mut m = Models::new();
    m.add("miss__shadow", |ctx| {
        ctx.set_payload(3, 1);
        Ok(())
    });
    m.add("closesthit__never", |ctx| {
        ctx.set_payload(3, 77);
        Ok(())
    });
    case.more_wgsl = Some((SHADOW_WGSL.into(), m));
    case.link = PipelineLinkOptions {
        max_trace_depth: 1,
        ..Default::default()
    };
    case.build()
}

fn terminate_on_first_hit() -> Case {
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![[0.0, 0.0, -1.0, 1.0, 1.0, 0.0]],
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    let rays = vec![
        Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
        Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]).flags(RayFlags::TERMINATE_ON_FIRST_HIT.0),
    ];
    let records = vec![SbtEntry::new(
        0,
        vec![
            0,
            action::ACCEPT,
            0,
            0,
            2,
            0.6f32.to_bits(),
            0.5f32.to_bits(),
        ],
    )];
    StdCase::new(
        Group::Flags,
        "terminate_on_first_hit",
        "an intersection program reports t = 0.6 then 0.5: without TERMINATE_ON_FIRST_HIT the hit is at 0.5; with it the first report ends the program and the hit is at 0.6 (amber flags-accept-first)",
        &[Rule::FlagPrecedence, Rule::CustomClosedInterval],
        scene,
        Some(root),
    )
    .exact()
    .hits(vec![hit_group(Some(prog::CH_ATTRS), None, Some(prog::IS_FIXED))], records)
    .launch(2, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::Exact), ch::hit_kind(), ch::aux(), ch::programs()])
    .build()
}
