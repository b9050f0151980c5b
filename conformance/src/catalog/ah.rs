//! The `ah` group: any-hit control (ignore, terminate, single calls, order independence).

use super::tri::COUNTED;
use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, action, ch, hit_group, prog};
use crate::oracle::exec::Ctx;
use crate::oracle::model::{Flow, Models};
use crate::scene::{Aabbs, Gas, GeomInput, InstanceDesc, Node, Scene, Triangles};
use crate::tolerance::Tolerance;
use optik::GeometryFlags;

/// Every case of the `ah` group.
pub fn cases() -> Vec<Case> {
    vec![
        control("ignore"),
        control("terminate"),
        terminate_from_is(),
        terminate_ends_traversal(),
        single_call(),
        order_independence(),
    ]
}

/// Any-hit programs that set payload word 3 to 1, end with ignore or terminate (directly,
/// through a helper, or under a dynamic condition), then would set it to 2; miss sets word 4,
/// closest-hit word 5.
const CONTROL_WGSL: &str = r#"
fn stop_ignore() {
    rt_ignore_intersection();
}

fn stop_terminate() {
    rt_terminate_ray();
}

fn anyhit__ignore_direct() {
    rt_set_payload(3u, 1u);
    rt_ignore_intersection();
    rt_set_payload(3u, 2u);
}

fn anyhit__ignore_helper() {
    rt_set_payload(3u, 1u);
    stop_ignore();
    rt_set_payload(3u, 2u);
}

fn anyhit__ignore_dynamic() {
    rt_set_payload(3u, 1u);
    if rt_ray_tmax() > rt_ray_tmin() {
        rt_ignore_intersection();
    }
    rt_set_payload(3u, 2u);
}

fn anyhit__terminate_direct() {
    rt_set_payload(3u, 1u);
    rt_terminate_ray();
    rt_set_payload(3u, 2u);
}

fn anyhit__terminate_helper() {
    rt_set_payload(3u, 1u);
    stop_terminate();
    rt_set_payload(3u, 2u);
}

fn anyhit__terminate_dynamic() {
    rt_set_payload(3u, 1u);
    if rt_ray_tmax() > rt_ray_tmin() {
        rt_terminate_ray();
    }
    rt_set_payload(3u, 2u);
}

fn miss__word4() {
    rt_set_payload(4u, 1u);
    rt_set_payload(0u, rt_get_payload(0u) | 16u);
}

fn closesthit__word5() {
    rt_set_payload(5u, 1u);
    rt_set_payload(0u, rt_get_payload(0u) | 8u);
    out[slot(1u)] = bitcast<u32>(rt_ray_tmax());
    out[slot(2u)] = rt_primitive_index();
}
"#;

fn control_models() -> Models {
    fn stop(ctx: &mut Ctx<'_, '_>, terminate: bool) -> Flow {
        ctx.set_payload(3, 1);
        if terminate {
            ctx.terminate_ray()
        } else {
            ctx.ignore_intersection()
        }
    }
    let mut m = Models::new();
    for name in ["ignore_direct", "ignore_helper", "ignore_dynamic"] {
        m.add(&format!("anyhit__{name}"), |ctx| stop(ctx, false));
    }
    for name in ["terminate_direct", "terminate_helper", "terminate_dynamic"] {
        m.add(&format!("anyhit__{name}"), |ctx| stop(ctx, true));
    }
    m.add("miss__word4", |ctx| {
        ctx.set_payload(4, 1);
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 16);
        Ok(())
    });
    m.add("closesthit__word5", |ctx| {
        ctx.set_payload(5, 1);
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 8);
        let s = ctx.linear_index() as usize * 32;
        let t = ctx.ray_tmax().to_bits();
        ctx.write(2, s + 1, t);
        let prim = ctx.primitive_index();
        ctx.write(2, s + 2, prim);
        Ok(())
    });
    m
}

fn control(kind: &str) -> Case {
    // Three non-opaque quads stacked along the ray; the any-hit program of each variant.
    let verts = [
        quad(0.0, 0.0, 1.0, 1.0, -1.0),
        quad(0.0, 0.0, 1.0, 1.0, -2.0),
        quad(0.0, 0.0, 1.0, 1.0, -3.0),
    ]
    .concat();
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        verts,
        GeometryFlags::NONE,
    ))]));
    let variants = ["direct", "helper", "dynamic"];
    let groups: Vec<HitGroupDesc> = variants
        .iter()
        .map(|v| {
            hit_group(
                Some("closesthit__word5"),
                Some(&format!("anyhit__{kind}_{v}")),
                None,
            )
        })
        .collect();
    let records = (0..3)
        .map(|k| SbtEntry::new(k, vec![k as u32, action::ACCEPT]))
        .collect();
    let mut rays = Vec::new();
    for k in 0..3 {
        rays.push(Ray {
            sbt_offset: k,
            ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0])
        });
        // Only the nearest quad in range, so order cannot matter for terminate either.
        rays.push(Ray {
            sbt_offset: k,
            ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0]).interval(0.0, 1.5)
        });
    }
    let ignore = kind == "ignore";
    let mut case = StdCase::new(
        Group::Ah,
        kind,
        if ignore {
            "rt_ignore_intersection directly, through a helper and under a condition: the payload write before stands, the one after never happens, the candidate is discarded (miss runs, closest-hit does not) (CTS traversal_control, OpIgnoreIntersection)"
        } else {
            "rt_terminate_ray directly, through a helper and under a condition: the write after never happens, the candidate is accepted, closest-hit runs and miss does not (CTS traversal_control, OpTerminateRay)"
        },
        &[Rule::IgnoreTerminate, Rule::AnyHitPerCandidate],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(6, rays)
    .record(vec![ch::payload(3), ch::payload(4), ch::payload(5), ch::programs(), ch::t(Tolerance::U16)]);
    case.miss_groups = vec![Some("miss__word4".into())];
    case.more_wgsl = Some((CONTROL_WGSL.into(), control_models()));
    if !ignore {
        // With terminate, the nearest-first and farthest-first orders accept different quads
        // for the three-quad ray; record only what is order independent there.
        case.channels = vec![
            ch::payload(3),
            ch::payload(4),
            ch::payload(5),
            ch::programs(),
        ];
    }
    case.build()
}

fn terminate_ends_traversal() -> Case {
    // Every any-hit call terminates, so whichever candidate traversal meets first is the only
    // one: one any-hit call, closest-hit runs, miss does not, in every traversal order.
    // Eight stacked non-opaque quads, and two instances of boxes whose intersection programs
    // report far beyond the boxes (t = 100 in one, 90 in the other): a backend that went on
    // after the terminate would run the other box's program, which reports inside the
    // shrunken interval (90 < 100) or not, depending on order; rays cross the two boxes in
    // both orders, so one of them sees a second any-hit call.
    let mut verts = Vec::new();
    for layer in 0..8 {
        verts.extend(quad(0.0, 0.0, 1.0, 1.0, -1.0 - layer as f32));
    }
    let mut scene = Scene::default();
    let tris = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(verts, GeometryFlags::NONE),
    )])));
    let boxes_at = |scene: &mut Scene, near_x: f32, far_x: f32| {
        scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
            vec![
                [near_x, 0.0, -1.25, near_x + 1.0, 1.0, -0.75],
                [far_x, 0.0, -2.25, far_x + 1.0, 1.0, -1.75],
            ],
            GeometryFlags::NONE,
        ))])))
    };
    // Instance A is nearer at x in [2, 3], instance B at x in [4, 5].
    let a = boxes_at(&mut scene, 2.0, 4.0);
    let b = boxes_at(&mut scene, 4.0, 2.0);
    let root = scene.add(Node::Ias(vec![
        InstanceDesc::of(tris),
        InstanceDesc {
            sbt_offset: 1,
            ..InstanceDesc::of(a)
        },
        InstanceDesc {
            sbt_offset: 2,
            ..InstanceDesc::of(b)
        },
    ]));
    let report_at =
        |k: u32, t: f32| SbtEntry::new(1, vec![k, action::TERMINATE, 0, 0, 1, t.to_bits()]);
    let records = vec![
        SbtEntry::new(0, vec![0, action::TERMINATE]),
        report_at(1, 100.0),
        report_at(2, 90.0),
    ];
    let mut rng = Rng::new(31);
    let rays: Vec<Ray> = (0..24)
        .map(|k| {
            let x = 2.0 * (k / 8) as f64;
            let o = [x + rng.range(0.1, 0.9), rng.range(0.1, 0.9), 0.0];
            Ray::new(v32(o), [0.0, 0.0, -1.0])
        })
        .collect();
    StdCase::new(
        Group::Ah,
        "terminate_ends_traversal",
        "rt_terminate_ray in every any-hit program, over eight stacked triangles and two stacked boxes whose intersection programs report beyond them: traversal ends at the first candidate, whichever it is (one intersection and one any-hit call, closest-hit runs, miss does not)",
        &[Rule::IgnoreTerminate, Rule::AnyHitPerCandidate],
        scene,
        Some(root),
    )
    .hits(
        vec![
            hit_group(Some(prog::CH), Some(prog::AH), None),
            hit_group(Some(prog::CH_ATTRS), Some(prog::AH), Some(prog::IS_FIXED)),
        ],
        records,
    )
    .launch(24, rays)
    .record(vec![ch::hit(), ch::ah_count(), ch::is_count(), ch::programs()])
    .build()
}

fn terminate_from_is() -> Case {
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![[0.0, 0.0, -2.0, 1.0, 1.0, -1.0]],
        GeometryFlags::NONE,
    ))]));
    let records = vec![
        SbtEntry::new(
            0,
            vec![
                0,
                action::TERMINATE,
                0,
                0,
                2,
                1.5f32.to_bits(),
                1.25f32.to_bits(),
            ],
        ),
        SbtEntry::new(
            0,
            vec![
                1,
                action::ACCEPT,
                0,
                0,
                2,
                1.5f32.to_bits(),
                1.25f32.to_bits(),
            ],
        ),
    ];
    let rays = vec![
        Ray::new([0.5, 0.5, 0.0], [0.0, 0.0, -1.0]),
        Ray {
            sbt_offset: 1,
            ..Ray::new([0.5, 0.5, 0.0], [0.0, 0.0, -1.0])
        },
    ];
    StdCase::new(
        Group::Ah,
        "terminate_from_is",
        "an any-hit program invoked by rt_report_intersection terminates the ray: the report does not return (the intersection program's write after it never happens), the first report's hit is final and closest-hit runs (CTS TerminationTest)",
        &[Rule::IgnoreTerminate],
        scene,
        Some(root),
    )
    .exact()
    .hits(vec![hit_group(Some(prog::CH_ATTRS), Some(prog::AH), Some(prog::IS_FIXED))], records)
    .launch(2, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::Exact), ch::aux(), ch::ah_count(), ch::programs()])
    .build()
}

fn single_call() -> Case {
    // 4 × 4 columns of 4 stacked quads (triangles), and the same grid of boxes; diagonal-ish
    // rays; REQUIRE_SINGLE_ANYHIT_CALL; the any-hit program counts and ignores.
    let mut verts = Vec::new();
    let mut boxes = Vec::new();
    for layer in 0..4 {
        for j in 0..4 {
            for i in 0..4 {
                let (x, y, z) = (i as f32, j as f32, -1.0 - layer as f32);
                verts.extend(quad(x + 0.1, y + 0.1, x + 0.9, y + 0.9, z));
                boxes.push([x + 0.1, y + 0.1, z - 0.3, x + 0.9, y + 0.9, z + 0.3]);
            }
        }
    }
    let mut scene = Scene::default();
    let tris = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(verts, COUNTED),
    )])));
    let boxg = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        boxes, COUNTED,
    ))])));
    let mut rng = Rng::new(8);
    let rays: Vec<Ray> = (0..32)
        .map(|_| {
            let o = [rng.range(0.2, 3.8), rng.range(0.2, 3.8), 0.0];
            let d = [rng.range(-0.08, 0.08), rng.range(-0.08, 0.08), -1.0];
            Ray::new(v32(o), v32(d))
        })
        .collect();
    let box_rays = rays
        .iter()
        .map(|r| Ray {
            sbt_offset: 1,
            ..*r
        })
        .collect();
    let groups = vec![
        hit_group(Some(prog::CH), Some(prog::AH), None),
        hit_group(Some(prog::CH_ATTRS), Some(prog::AH), Some(prog::IS_FIXED)),
    ];
    let records = vec![
        SbtEntry::new(0, vec![0, action::IGNORE]),
        SbtEntry::new(1, vec![1, action::IGNORE, 0, 0, 1, 2.5f32.to_bits()]),
    ];
    StdCase::new(
        Group::Ah,
        "single_call",
        "REQUIRE_SINGLE_ANYHIT_CALL over a 4×4×4 grid of triangles and of boxes: every primitive a ray crosses gets exactly one any-hit call (CTS NO_DUPLICATE_ANY_HIT)",
        &[Rule::SingleAnyHit, Rule::AnyHitPerCandidate],
        scene,
        None,
    )
    .hits(groups, records)
    .launch_on(Some(tris), 32, rays)
    .launch_on(Some(boxg), 32, box_rays)
    .record(vec![ch::ah_count(), ch::programs()])
    .build()
}

const SUM_WGSL: &str = r#"
fn anyhit__sum() {
    rt_set_payload(1u, rt_get_payload(1u) + 1u);
    rt_set_payload(3u, rt_get_payload(3u) + rt_primitive_index() / 2u + 1u);
    if rt_primitive_index() / 2u != 7u {
        rt_ignore_intersection();
    }
}
"#;

fn order_independence() -> Case {
    // Eight parallel non-opaque layers; the any-hit program sums (layer + 1) and counts, and
    // accepts only the farthest layer, so every order of visits reaches all eight.
    let verts: Vec<[f32; 3]> = (0..8)
        .flat_map(|k| quad(0.0, 0.0, 1.0, 1.0, -1.0 - 0.125 * k as f32))
        .collect();
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        verts, COUNTED,
    ))]));
    let rays: Vec<Ray> = (0..16)
        .map(|k| {
            Ray::new(
                [0.1 + 0.05 * k as f32, 0.7 - 0.03 * k as f32, 0.0],
                [0.01, -0.02, -1.0],
            )
        })
        .collect();
    let mut m = Models::new();
    m.add("anyhit__sum", |ctx| {
        let c = ctx.get_payload(1);
        ctx.set_payload(1, c + 1);
        let layer = ctx.primitive_index() / 2;
        let s = ctx.get_payload(3);
        ctx.set_payload(3, s + layer + 1);
        if layer != 7 {
            return ctx.ignore_intersection();
        }
        Ok(())
    });
    let mut case = StdCase::new(
        Group::Ah,
        "order_independence",
        "eight layers whose any-hit program sums a per-layer value and accepts only the farthest: sum 36, count 8 and the far hit whatever the traversal order",
        &[Rule::AnyHitPerCandidate, Rule::SingleAnyHit],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), Some("anyhit__sum"), None)], vec![SbtEntry::new(0, vec![0, action::ACCEPT])])
    .launch(16, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::ah_count(), ch::payload(3)]);
    case.more_wgsl = Some((SUM_WGSL.into(), m));
    case.build()
}
