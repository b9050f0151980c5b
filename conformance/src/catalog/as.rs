//! The `as` group: empty and null acceleration structures, refit and compaction, vertex
//! access.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, ch, float_channel, hit_group, uint_channel};
use crate::oracle::model::Models;
use crate::scene::{Gas, GeomInput, InstanceDesc, Node, Scene, Triangles};
use crate::tolerance::Tolerance;
use optik::{BuildFlags, GeometryFlags, MotionFlags, MotionOptions};

/// Every case of the `as` group.
pub fn cases() -> Vec<Case> {
    vec![empty_null_update_compact(), vertex_access()]
}

fn empty_null_update_compact() -> Case {
    let f = GeometryFlags::DISABLE_ANYHIT;
    let mut scene = Scene::default();
    let empty_gas = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(vec![], f),
    )])));
    let empty_ias = scene.add(Node::Ias(vec![]));
    let real = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(quad(0.0, 0.0, 1.0, 1.0, -1.0), f),
    )])));
    let null_child = scene.add(Node::Ias(vec![
        InstanceDesc {
            child: None,
            ..InstanceDesc::of(real)
        },
        InstanceDesc {
            id: 1,
            ..InstanceDesc::of(real).at(translate([2.0, 0.0, 0.0]))
        },
        InstanceDesc {
            id: 2,
            ..InstanceDesc::of(empty_gas)
        },
    ]));
    // Built from a quad elsewhere with ALLOW_UPDATE, then refit to the real positions.
    let mut refit = Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        quad(0.0, 0.0, 1.0, 1.0, -1.0),
        f,
    ))]);
    refit.update_from = Some(vec![GeomInput::Triangles(Triangles::soup(
        quad(5.0, 5.0, 6.0, 6.0, -3.0),
        f,
    ))]);
    let refit = scene.add(Node::Gas(refit));
    let compacted = scene.add(Node::Gas(Gas {
        compact: true,
        build_flags: BuildFlags::ALLOW_COMPACTION,
        ..Gas::new(vec![GeomInput::Triangles(Triangles::soup(
            quad(0.0, 0.0, 1.0, 1.0, -1.0),
            f,
        ))])
    }));
    let rays: Vec<Ray> = [(0.75f32, 0.25f32), (2.75, 0.25), (5.5, 5.5), (0.25, 0.75)]
        .iter()
        .map(|(x, y)| Ray::new([*x, *y, 0.0], [0.0, 0.0, -1.0]))
        .collect();
    let mut case = StdCase::new(
        Group::As,
        "empty_null_update_compact",
        "an empty GAS, an empty IAS and the null handle miss; an instance with a null child is skipped; a refit structure and a compacted one trace like a fresh build (CTS empty, null_as, update, operations)",
        &[],
        scene,
        None,
    );
    for root in [
        Some(empty_gas),
        Some(empty_ias),
        None,
        Some(null_child),
        Some(refit),
        Some(compacted),
    ] {
        case = case.launch_on(root, 4, rays.clone());
    }
    case.record(vec![
        ch::hit(),
        ch::t(Tolerance::U16),
        ch::prim(),
        ch::inst_id(),
        ch::programs(),
    ])
    .build()
}

const VERTS_WGSL: &str = r#"
fn closesthit__verts() {
    let v = rt_triangle_vertices();
    let b = ray_id() * 32u;
    for (var i = 0u; i < 3u; i++) {
        out[b + 3u * i + 0u] = bitcast<u32>(v[i].x);
        out[b + 3u * i + 1u] = bitcast<u32>(v[i].y);
        out[b + 3u * i + 2u] = bitcast<u32>(v[i].z);
    }
    out[b + 9u] = 1u;
}

fn anyhit__verts() {
    let v = rt_triangle_vertices();
    out[ray_id() * 32u + 10u] = bitcast<u32>(v[0].x + v[1].y + v[2].z);
}
"#;

fn vertex_access() -> Case {
    let f = GeometryFlags::NONE;
    let q = quad(0.0, 0.0, 1.0, 1.0, -1.0);
    let mut scene = Scene::default();
    let plain = scene.add(Node::Gas(Gas {
        build_flags: BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        ..Gas::new(vec![GeomInput::Triangles(Triangles::soup(q.clone(), f))])
    }));
    let mut pre = Triangles::soup(q.clone(), f);
    pre.pre_transform = Some(rotate_translate([0.0, 0.0, 1.0], 0.3, [0.1, 0.2, -0.5]));
    let pre = scene.add(Node::Gas(Gas {
        build_flags: BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        ..Gas::new(vec![GeomInput::Triangles(pre)])
    }));
    let mut moving = Triangles::soup(q.clone(), f);
    moving
        .keys
        .push(q.iter().map(|v| [v[0] + 0.5, v[1], v[2] - 1.0]).collect());
    let moving = scene.add(Node::Gas(Gas {
        build_flags: BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        motion: Some(MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: 0.0,
            time_end: 1.0,
        }),
        ..Gas::new(vec![GeomInput::Triangles(moving)])
    }));
    let rays: Vec<Ray> = [0.0f32, 0.5, 1.0]
        .iter()
        .flat_map(|t| {
            [(0.7f32, 0.3f32), (0.3, 0.7)]
                .map(|(x, y)| Ray::new([x, y, 0.0], [0.0, 0.0, -1.0]).at_time(*t))
        })
        .collect();
    let mut m = Models::new();
    m.add("closesthit__verts", |ctx| {
        let v = ctx.triangle_vertices();
        let b = ctx.linear_index() as usize * 32;
        for (i, vertex) in v.iter().enumerate() {
            for (c, x) in vertex.iter().enumerate() {
                ctx.write(2, b + 3 * i + c, x.to_bits());
            }
        }
        ctx.write(2, b + 9, 1);
        Ok(())
    });
    m.add("anyhit__verts", |ctx| {
        let v = ctx.triangle_vertices();
        let b = ctx.linear_index() as usize * 32 + 10;
        ctx.write(2, b, (v[0][0] + v[1][1] + v[2][2]).to_bits());
        Ok(())
    });
    let mut channels: Vec<ChannelSpec> = Vec::new();
    for i in 0..3 {
        for (c, axis) in ["x", "y", "z"].iter().enumerate() {
            channels.push(float_channel(
                &format!("v{i}{axis}"),
                3 * i + c,
                Tolerance::U16,
            ));
        }
    }
    channels.push(uint_channel("hit", 9));
    channels.push(float_channel("ah_sum", 10, Tolerance::U16));
    let mut case = StdCase::new(
        Group::As,
        "vertex_access",
        "rt_triangle_vertices in any-hit and closest-hit: the stored vertices (exactly for float3), after a pre-transform, and interpolated at the ray's time for motion (CTS position_fetch)",
        &[Rule::MatrixMotion],
        scene,
        None,
    )
    .hits(vec![hit_group(Some("closesthit__verts"), Some("anyhit__verts"), None)], vec![SbtEntry::new(0, vec![0])])
    .launch_on(Some(plain), 6, rays.clone())
    .launch_on(Some(pre), 6, rays.clone())
    .launch_on(Some(moving), 6, rays)
    .record(channels);
    case.more_wgsl = Some((VERTS_WGSL.into(), m));
    case.build()
}
