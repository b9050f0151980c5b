//! The `motion` group: matrix and SRT motion, motion geometry, motion blur turned off.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, ch, hit_group, sphere_group};
use crate::oracle::model::Models;
use crate::scene::{
    Aabbs, Gas, GeomInput, InstanceDesc, Node, Scene, Spheres, TransformKind, TransformNode,
    Triangles,
};
use crate::tolerance::Tolerance;
use optik::{GeometryFlags, MotionFlags, MotionOptions, PipelineCompileOptions, Setting, SrtData};

/// Every case of the `motion` group.
pub fn cases() -> Vec<Case> {
    vec![matrix(), srt_nlerp(), gas_vertex_aabb(), blur_disabled()]
}

fn matrix() -> Case {
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            quad(0.0, 0.0, 1.0, 1.0, -1.0),
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])));
    let variants = [
        (2u16, MotionFlags::NONE),
        (3, MotionFlags::NONE),
        (5, MotionFlags::NONE),
        (3, MotionFlags::START_VANISH | MotionFlags::END_VANISH),
    ];
    let mut instances = Vec::new();
    for (row, (keys, flags)) in variants.iter().enumerate() {
        let motion = MotionOptions {
            num_keys: *keys,
            flags: *flags,
            time_begin: 0.25,
            time_end: 0.75,
        };
        let mats = (0..*keys)
            .map(|k| translate([0.5 * k as f32, 0.0, -0.25 * k as f32]))
            .collect();
        let xf = scene.add(Node::Transform(TransformNode {
            kind: TransformKind::MatrixMotion(motion, mats),
            child: gas,
        }));
        instances.push(InstanceDesc {
            id: row as u32,
            ..InstanceDesc::of(xf).at(translate([0.0, 2.0 * row as f32, 0.0]))
        });
    }
    let root = scene.add(Node::Ias(instances));
    let times = [0.0f32, 0.25, 0.375, 0.5, 0.625, 0.75, 1.0, 0.3, 0.7];
    let mut rays = Vec::new();
    for row in 0..variants.len() {
        for t in times {
            for x in [0.125f32, 0.875, 1.375, 2.125, 2.875] {
                rays.push(
                    Ray::new([x, 2.0 * row as f32 + 0.375, 1.0], [0.0, 0.0, -1.0]).at_time(t),
                );
            }
        }
    }
    StdCase::new(
        Group::Motion,
        "matrix",
        "matrix motion with 2, 3 and 5 keys over [0.25, 0.75]: linear interpolation of the keys at key times, midpoints, before and after (clamping), and with START/END_VANISH nothing outside the range",
        &[Rule::MatrixMotion, Rule::MotionClamp],
        scene,
        Some(root),
    )
    .launch(45, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::inst_id()])
    .build()
}

/// The rotation angle about z of an nlerp between the identity and a rotation by `theta`.
fn nlerp_angle(theta: f64, t: f64) -> f64 {
    let (s, c) = ((theta / 2.0).sin(), (theta / 2.0).cos());
    2.0 * (t * s).atan2(1.0 - t + t * c)
}

fn srt_nlerp() -> Case {
    // A thin radial needle from 0.8 to 1.2 from a pivot along +x, rotated about z around the
    // pivot by SRT keys of 0 and 90° (and 179°); rays at the nlerp angle hit it, rays at the
    // slerp angle (where it differs by more than the needle's width) do not.
    let half = 0.004f32;
    let pivot = [0.25f32, -0.125, 0.0];
    let needle = [
        [0.8, -half],
        [1.2, -half],
        [1.2, half],
        [0.8, -half],
        [1.2, half],
        [0.8, half],
    ]
    .iter()
    .map(|p: &[f32; 2]| [pivot[0] + p[0], pivot[1] + p[1], 0.0])
    .collect();
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(needle, GeometryFlags::DISABLE_ANYHIT),
    )])));
    let angles = [std::f64::consts::FRAC_PI_2, 179f64.to_radians()];
    let mut instances = Vec::new();
    for (row, theta) in angles.iter().enumerate() {
        let key = |a: f64| SrtData {
            // Rotation about z around the pivot: S moves the pivot to the origin (pv = -pivot),
            // T moves it back.
            pvx: -pivot[0],
            pvy: -pivot[1],
            pvz: -pivot[2],
            qz: (a / 2.0).sin() as f32,
            qw: (a / 2.0).cos() as f32,
            tx: pivot[0],
            ty: pivot[1],
            tz: pivot[2],
            ..SrtData::identity()
        };
        let motion = MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: 0.0,
            time_end: 1.0,
        };
        let xf = scene.add(Node::Transform(TransformNode {
            kind: TransformKind::SrtMotion(motion, vec![key(0.0), key(*theta)]),
            child: gas,
        }));
        instances.push(InstanceDesc {
            id: row as u32,
            ..InstanceDesc::of(xf).at(translate([4.0 * row as f32, 0.0, -1.0]))
        });
    }
    let root = scene.add(Node::Ias(instances));
    let mut rays = Vec::new();
    for (row, theta) in angles.iter().enumerate() {
        for t in [0.0, 0.1, 0.25, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0] {
            for angle in [nlerp_angle(*theta, t), theta * t] {
                let p = [
                    pivot[0] as f64 + 0.95 * angle.cos(),
                    pivot[1] as f64 + 0.95 * angle.sin(),
                ];
                rays.push(
                    Ray::new(v32([4.0 * row as f64 + p[0], p[1], 1.0]), [0.0, 0.0, -1.0])
                        .at_time(t as f32),
                );
            }
        }
    }
    StdCase::new(
        Group::Motion,
        "srt_nlerp",
        "SRT motion rotating 90° and 179° about a pivot: the object follows normalised linear quaternion blending (nlerp, as OptiX), not slerp; rays at the slerp angle miss where the two differ",
        &[Rule::SrtMotion],
        scene,
        Some(root),
    )
    .launch(18, rays)
    .record(vec![ch::hit(), ch::prim(), ch::inst_id()])
    .build()
}

const MOTION_WGSL: &str = r#"
fn closesthit__time() {
    record_hit();
    out[slot(19u)] = bitcast<u32>(rt_ray_time());
}

fn miss__time() {
    out[slot(0u)] = 0u;
    out[slot(19u)] = bitcast<u32>(rt_ray_time());
}

fn intersection__moving() {
    let p = rt_primitive_index();
    let a = prims[2u * p];
    let b = prims[2u * p + 1u];
    let tm = clamp(rt_ray_time(), 0.0, 1.0);
    let c = a.xyz * (1.0 - tm) + b.xyz * tm;
    let o = rt_object_ray_origin();
    let d = rt_object_ray_direction();
    let f = o - c;
    let qa = dot(d, d);
    let qb = dot(f, d);
    let qc = dot(f, f) - a.w * a.w;
    let disc = qb * qb - qa * qc;
    if disc < 0.0 {
        return;
    }
    var attrs: RtAttributes;
    let accepted = rt_report_intersection((-qb - sqrt(disc)) / qa, 1u, attrs);
}
"#;

fn motion_models() -> Models {
    let mut m = Models::new();
    m.add("closesthit__time", |ctx| {
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
            (19, ctx.ray_time().to_bits()),
        ];
        for (k, v) in words {
            ctx.write(2, s + k, v);
        }
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 8);
        Ok(())
    });
    m.add("miss__time", |ctx| {
        let s = ctx.linear_index() as usize * 32;
        ctx.write(2, s, 0);
        let t = ctx.ray_time().to_bits();
        ctx.write(2, s + 19, t);
        Ok(())
    });
    m.add("intersection__moving", |ctx| {
        let p = ctx.primitive_index() as usize;
        let a: [f32; 4] = std::array::from_fn(|k| ctx.read_f32(3, 8 * p + k));
        let b: [f32; 4] = std::array::from_fn(|k| ctx.read_f32(3, 8 * p + 4 + k));
        let tm = ctx.ray_time().clamp(0.0, 1.0);
        let c: [f32; 3] = std::array::from_fn(|k| a[k] * (1.0 - tm) + b[k] * tm);
        let (o, d) = (ctx.object_ray_origin(), ctx.object_ray_direction());
        let f = [o[0] - c[0], o[1] - c[1], o[2] - c[2]];
        let dot = |x: [f32; 3], y: [f32; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
        let (qa, qb, qc) = (dot(d, d), dot(f, d), dot(f, f) - a[3] * a[3]);
        let disc = qb * qb - qa * qc;
        if disc < 0.0 {
            return Ok(());
        }
        ctx.report_intersection((-qb - disc.sqrt()) / qa, 1, [0; 8])?;
        Ok(())
    });
    m
}

fn gas_vertex_aabb() -> Case {
    let motion = |n: u16| MotionOptions {
        num_keys: n,
        flags: MotionFlags::NONE,
        time_begin: 0.0,
        time_end: 1.0,
    };
    let mut scene = Scene::default();
    // Triangles: a quad moving +2 in x over two keys.
    let q0 = quad(0.0, 0.0, 1.0, 1.0, -1.0);
    let q1: Vec<[f32; 3]> = q0.iter().map(|v| [v[0] + 2.0, v[1], v[2] - 0.5]).collect();
    let mut tris = Triangles::soup(q0, GeometryFlags::DISABLE_ANYHIT);
    tris.keys.push(q1);
    let tri_gas = scene.add(Node::Gas(Gas {
        motion: Some(motion(2)),
        ..Gas::new(vec![GeomInput::Triangles(tris)])
    }));
    // Boxes: a sphere of radius 0.4 moving from x 0.5 to 2.5 over four keys.
    let (c0, c1) = ([0.5f32, 0.5, -1.0], [2.5f32, 0.5, -1.0]);
    let keyed = |k: usize| -> [f32; 6] {
        let t = k as f32 / 3.0;
        let c = [c0[0] * (1.0 - t) + c1[0] * t, 0.5, -1.0];
        [
            c[0] - 0.4,
            c[1] - 0.4,
            c[2] - 0.4,
            c[0] + 0.4,
            c[1] + 0.4,
            c[2] + 0.4,
        ]
    };
    let mut boxes = Aabbs::new(vec![keyed(0)], GeometryFlags::DISABLE_ANYHIT);
    boxes.keys = (0..4).map(|k| vec![keyed(k)]).collect();
    let box_gas = scene.add(Node::Gas(Gas {
        motion: Some(motion(4)),
        ..Gas::new(vec![GeomInput::Aabbs(boxes)])
    }));
    // Built-in spheres: the same motion over two keys.
    let sph = Spheres {
        centres: vec![vec![c0], vec![c1]],
        radii: vec![vec![0.4], vec![0.4]],
        single_radius: false,
        flags: vec![GeometryFlags::DISABLE_ANYHIT],
        sbt_offsets: None,
        prim_index_offset: 0,
    };
    let sph_gas = scene.add(Node::Gas(Gas {
        motion: Some(motion(2)),
        ..Gas::new(vec![GeomInput::Spheres(sph)])
    }));
    let mut rays = Vec::new();
    for t in [0.0f32, 0.25, 0.5, 0.75, 1.0, 1.5] {
        for x in [0.5f32, 1.0, 1.5, 2.0, 2.5, 2.95] {
            rays.push(Ray::new([x, 0.5, 1.0], [0.0, 0.0, -1.0]).at_time(t));
        }
    }
    let with_offset = |o: u32| {
        rays.iter()
            .map(|r| Ray {
                sbt_offset: o,
                ..*r
            })
            .collect::<Vec<_>>()
    };
    let groups = vec![
        hit_group(Some("closesthit__time"), None, None),
        hit_group(Some("closesthit__time"), None, Some("intersection__moving")),
        crate::case::HitGroupDesc {
            closest_hit: Some("closesthit__time".into()),
            ..sphere_group()
        },
    ];
    let records = (0..3).map(|k| SbtEntry::new(k, vec![k as u32])).collect();
    let mut case = StdCase::new(
        Group::Motion,
        "gas_vertex_aabb",
        "motion geometry: triangle vertices (2 keys), boxes with per-key bounds and a moving intersection (4 keys), built-in spheres (2 keys): hits and t at times 0..1 and clamped beyond, rt_ray_time as traced",
        &[Rule::MatrixMotion, Rule::MotionClamp],
        scene,
        None,
    )
    .hits(groups, records)
    .launch_on(Some(tri_gas), 6, rays.clone())
    .launch_on(Some(box_gas), 6, with_offset(1))
    .launch_on(Some(sph_gas), 6, with_offset(2))
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::aux()]);
    case.miss_groups = vec![Some("miss__time".into())];
    case.prims = vec![[c0[0], c0[1], c0[2], 0.4], [c1[0], c1[1], c1[2], 0.4]];
    case.more_wgsl = Some((MOTION_WGSL.into(), motion_models()));
    case.build()
}

fn blur_disabled() -> Case {
    let mut scene = Scene::default();
    let gas = small_quad_gas(&mut scene);
    let root = scene.add(Node::Ias(vec![
        InstanceDesc::of(gas).at(translate([0.0, 0.0, -1.0])),
    ]));
    let rays = [0.0f32, 0.5, 1.0, -3.0, 7.5]
        .iter()
        .map(|t| Ray::new([0.125, 0.25, 0.0], [0.0, 0.0, -1.0]).at_time(*t))
        .collect();
    let mut case = StdCase::new(
        Group::Motion,
        "blur_disabled",
        "with uses_motion_blur off, the ray's time is ignored: rt_ray_time() is 0 in closest-hit and miss",
        &[Rule::MatrixMotion],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some("closesthit__time"), None, None)], vec![SbtEntry::new(0, vec![0])])
    .launch(5, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::aux()]);
    case.miss_groups = vec![Some("miss__time".into())];
    case.compile = PipelineCompileOptions {
        uses_motion_blur: Setting::Value(false),
        ..Default::default()
    };
    case.more_wgsl = Some((MOTION_WGSL.into(), motion_models()));
    case.build()
}
