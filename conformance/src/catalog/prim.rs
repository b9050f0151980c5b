//! The `prim` group: built-in spheres and curves, opacity micromaps.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, action, ch, float_channel, hit_group, prog, sphere_group};
use crate::oracle::model::Models;
use crate::scene::{Curves, Gas, GeomInput, InstanceDesc, Node, Omm, Scene, Spheres, Triangles};
use crate::tolerance::Tolerance;
use optik::{
    BuiltinIntersector, CurveEndcaps, CurveType, GeometryFlags, InstanceFlags,
    OpacityMicromapFormat, RayFlags,
};

/// Every case of the `prim` group.
pub fn cases() -> Vec<Case> {
    vec![spheres(), curves(), opacity_micromap()]
}

const SPHERE_WGSL: &str = r#"
fn closesthit__sphere() {
    record_hit();
    let s = rt_sphere();
    out[slot(7u)] = bitcast<u32>(s.x);
    out[slot(8u)] = bitcast<u32>(s.y);
    out[slot(9u)] = bitcast<u32>(s.z);
    out[slot(10u)] = bitcast<u32>(s.w);
}

fn closesthit__curve() {
    record_hit();
    out[slot(7u)] = bitcast<u32>(rt_curve_parameter());
}
"#;

fn record_hit_model(ctx: &mut crate::oracle::exec::Ctx<'_, '_>) {
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
    ];
    for (k, v) in words {
        ctx.write(2, s + k, v);
    }
    let p = ctx.get_payload(0);
    ctx.set_payload(0, p | 8);
}

fn sphere_models() -> Models {
    let mut m = Models::new();
    m.add("closesthit__sphere", |ctx| {
        record_hit_model(ctx);
        let s = ctx.sphere();
        let b = ctx.linear_index() as usize * 32 + 7;
        for (k, v) in s.into_iter().enumerate() {
            ctx.write(2, b + k, v.to_bits());
        }
        Ok(())
    });
    m.add("closesthit__curve", |ctx| {
        record_hit_model(ctx);
        let u = ctx.curve_parameter().to_bits();
        let b = ctx.linear_index() as usize * 32 + 7;
        ctx.write(2, b, u);
        Ok(())
    });
    m
}

fn spheres() -> Case {
    let centres = vec![
        [0.0f32, 0.0, -5.0],
        [3.0, 0.0, -5.0],
        [6.0, 0.0, -5.0],
        [9.0, 0.0, -2000.0],
        [12.0, 0.0, -5.0],
    ];
    let radii = vec![1.0f32, 0.5, 1e-3, 1e3, 0.25];
    let multi = Spheres {
        centres: vec![centres.clone()],
        radii: vec![radii],
        single_radius: false,
        flags: vec![GeometryFlags::DISABLE_ANYHIT],
        sbt_offsets: None,
        prim_index_offset: 0,
    };
    let single = Spheres {
        radii: vec![vec![0.75]],
        single_radius: true,
        prim_index_offset: 10,
        ..multi.clone()
    };
    let mut scene = Scene::default();
    let a = scene.add(Node::Gas(Gas::new(vec![GeomInput::Spheres(multi)])));
    let b = scene.add(Node::Gas(Gas::new(vec![GeomInput::Spheres(single)])));
    let mut rays = Vec::new();
    for c in &centres {
        for (dx, dy) in [
            (0.0f32, 0.0f32),
            (0.1, 0.2),
            (-0.3, 0.1),
            (0.0, 0.6),
            (2e-4, -3e-4),
            (0.0, 0.9),
        ] {
            rays.push(Ray::new([c[0] + dx, c[1] + dy, 0.0], [0.0, 0.0, -1.0]));
        }
    }
    let mut case = StdCase::new(
        Group::Prim,
        "spheres",
        "built-in spheres with radii 1e-3 to 1e3, one radius per sphere or one for all, a primitive index offset: hits and t from outside (U16 at 1e3), centre and radius from rt_sphere",
        &[],
        scene,
        None,
    )
    .hits(vec![crate::case::HitGroupDesc { closest_hit: Some("closesthit__sphere".into()), ..sphere_group() }], vec![SbtEntry::new(0, vec![0])])
    .launch_on(Some(a), 6, rays.clone())
    .launch_on(Some(b), 6, rays)
    .record(vec![
        ch::hit(),
        ch::t(Tolerance::U16 { scale: 1e3 }),
        ch::prim(),
        float_channel("cx", 7, Tolerance::Exact),
        float_channel("cy", 8, Tolerance::Exact),
        float_channel("cz", 9, Tolerance::Exact),
        float_channel("radius", 10, Tolerance::Exact),
    ]);
    case.more_wgsl = Some((SPHERE_WGSL.into(), sphere_models()));
    case.build()
}

fn curves() -> Case {
    // Round linear curves of constant radius (capsules): two strands of three segments.
    let points = vec![
        [0.0f32, 0.0, -3.0],
        [1.0, 0.0, -3.0],
        [2.0, 0.5, -3.0],
        [3.0, 0.5, -3.5],
        [0.0, 2.0, -3.0],
        [1.0, 2.5, -3.0],
        [2.0, 2.0, -2.5],
        [3.0, 2.0, -3.0],
    ];
    let radii = vec![0.2f32; points.len()];
    let curves = Curves {
        points: vec![points],
        radii: vec![radii],
        segments: vec![0, 1, 2, 4, 5, 6],
        flag: GeometryFlags::DISABLE_ANYHIT,
        endcaps: CurveEndcaps::On,
        prim_index_offset: 0,
    };
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Curves(curves)]));
    let mut group = hit_group(Some("closesthit__curve"), None, None);
    group.builtin = Some(BuiltinIntersector::Curve(CurveType::RoundLinear));
    let rays = down_grid(32, 16, -0.5, -0.5, 3.5, 3.0, 0.0);
    let mut case = StdCase::new(
        Group::Prim,
        "curves",
        "round linear curves (capsules of constant radius, joints and end caps round): hits, t and curve parameter u within M3, silhouettes admitted either way (quadratic/cubic B-spline and Catmull-Rom bases are not modelled by the oracle)",
        &[],
        scene,
        Some(root),
    )
    .hits(vec![group], vec![SbtEntry::new(0, vec![0])])
    .launch(32, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::M3), float_channel("u", 7, Tolerance::M3)]);
    case.more_wgsl = Some((SPHERE_WGSL.into(), sphere_models()));
    case.build()
}

fn opacity_micromap() -> Case {
    // 16 quads (32 triangles), each with a micromap of one state, or a special index; an
    // any-hit program that counts and accepts. Instances: plain, FORCE_2_STATE,
    // DISABLE_OPACITY_MICROMAPS; rays with and without FORCE_OPACITY_MICROMAP_2_STATE.
    let mut verts = Vec::new();
    for k in 0..16 {
        verts.extend(quad(k as f32, 0.0, k as f32 + 1.0, 1.0, -1.0));
    }
    let states: Vec<u8> = vec![0, 1, 2, 3];
    let mut indices = Vec::new();
    for k in 0..16i32 {
        let idx = if k < 8 { k % 4 } else { -1 - (k % 4) };
        indices.extend([idx, idx]);
    }
    let mk = |format: OpacityMicromapFormat| {
        let mut t = Triangles::soup(verts.clone(), GeometryFlags::NONE);
        t.omm = Some(Omm {
            format,
            states: states.clone(),
            indices: indices.clone(),
        });
        t
    };
    let mut scene = Scene::default();
    let four = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(mk(
        OpacityMicromapFormat::FourState,
    ))])));
    let two = {
        // Two-state maps hold 0 or 1 only.
        let mut t = mk(OpacityMicromapFormat::TwoState);
        if let Some(o) = &mut t.omm {
            o.states = vec![0, 1, 0, 1];
        }
        scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(t)])))
    };
    let flags = [
        InstanceFlags::NONE,
        InstanceFlags::FORCE_OPACITY_MICROMAP_2_STATE,
        InstanceFlags::DISABLE_OPACITY_MICROMAPS,
    ];
    let mut instances = Vec::new();
    for (g, gas) in [four, two].iter().enumerate() {
        for (i, f) in flags.iter().enumerate() {
            let row = (g * flags.len() + i) as f32;
            instances.push(InstanceDesc {
                id: (g * 10 + i) as u32,
                flags: *f,
                ..InstanceDesc::of(*gas).at(translate([0.0, 2.0 * row, 0.0]))
            });
        }
    }
    let root = scene.add(Node::Ias(instances));
    let mut rays = Vec::new();
    for row in 0..6 {
        for k in 0..16 {
            for rf in [RayFlags::NONE, RayFlags::FORCE_OPACITY_MICROMAP_2_STATE] {
                rays.push(
                    Ray::new(
                        [k as f32 + 0.75, 2.0 * row as f32 + 0.25, 0.0],
                        [0.0, 0.0, -1.0],
                    )
                    .flags(rf.0),
                );
            }
        }
    }
    StdCase::new(
        Group::Prim,
        "opacity_micromap",
        "opacity micromaps at subdivision level 0 (2- and 4-state, special indices -1..-4) under instance FORCE_2_STATE / DISABLE_OPACITY_MICROMAPS and ray FORCE_2_STATE: transparent drops the hit, opaque skips any-hit, unknown runs it (higher subdivision levels need the micro-triangle order, not modelled)",
        &[Rule::FlagPrecedence],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), Some(prog::AH), None)], vec![SbtEntry::new(0, vec![0, action::ACCEPT])])
    .launch(32, rays)
    .record(vec![ch::hit(), ch::programs(), ch::ah_count(), ch::inst_id()])
    .build()
}
