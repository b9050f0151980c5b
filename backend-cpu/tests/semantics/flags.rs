//! Opacity precedence, face culling, masks, terminate-on-first-hit.

use crate::kit::*;
use optik_api::semantics::opacity::{self, CandidateFate};
use optik_api::*;

/// A logging pipeline: raygen traces the ray `rays[x]` against `root`; AH logs "ah", CH
/// logs "ch" with the hit kind and instance id, MS logs "miss".
fn run(kit: &Kit, root: TraversableHandle, rays: Vec<Ray>, any_hit: bool) -> Log {
    let log = Log::default();
    let (l1, l2, l3) = (log.clone(), log.clone(), log.clone());
    let n = rays.len() as u32;
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let r = rays[c.launch_index()[0] as usize];
                trace_ray(c, root, r, &mut [0]);
            }),
        ),
        (
            "anyhit__main",
            program(move |c| {
                l1.put(
                    c,
                    "ah",
                    &[c.primitive_index() as f64, c.instance_id() as f64],
                )
            }),
        ),
        (
            "closesthit__main",
            program(move |c| {
                l2.put(
                    c,
                    "ch",
                    &[
                        c.hit_kind() as f64,
                        c.instance_id() as f64,
                        c.ray_tmax() as f64,
                    ],
                )
            }),
        ),
        ("miss__main", program(move |c| l3.put(c, "miss", &[]))),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(
        m,
        Some("closesthit__main"),
        any_hit.then_some("anyhit__main"),
        None,
    );
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, n);
    log
}

fn instance(
    child: TraversableHandle,
    id: u32,
    mask: u32,
    flags: InstanceFlags,
    tx: f32,
) -> Instance {
    let mut i = Instance::new(child);
    i.instance_id = id;
    i.visibility_mask = mask;
    i.flags = flags.0;
    i.transform[3] = tx;
    i
}

#[test]
fn opacity_follows_optix_precedence() {
    let kit = Kit::new();
    let geometry = [GeometryFlags::NONE, GeometryFlags::DISABLE_ANYHIT];
    let instance_flags = [
        InstanceFlags::NONE,
        InstanceFlags::DISABLE_ANYHIT,
        InstanceFlags::ENFORCE_ANYHIT,
    ];
    let ray_flags = [
        RayFlags::NONE,
        RayFlags::DISABLE_ANYHIT,
        RayFlags::ENFORCE_ANYHIT,
        RayFlags::CULL_DISABLED_ANYHIT,
        RayFlags::CULL_ENFORCED_ANYHIT,
    ];
    let gases = geometry.map(|g| kit.triangles(&quad(-1.0, -1.0, 1.0, 1.0, 5.0), g));
    // Instance k = g * 3 + i sits at x = 10 k with mask bit k.
    let mut insts = Vec::new();
    for (gi, gas) in gases.iter().enumerate() {
        for (ii, f) in instance_flags.iter().enumerate() {
            let k = (gi * 3 + ii) as u32;
            insts.push(instance(*gas, k, 1 << k, *f, 10.0 * k as f32));
        }
    }
    let root = kit.instances(&insts);
    let mut rays = Vec::new();
    let mut expected = Vec::new();
    for (gi, g) in geometry.iter().enumerate() {
        for (ii, i) in instance_flags.iter().enumerate() {
            for r in ray_flags {
                let k = gi * 3 + ii;
                rays.push(
                    Ray::new([10.0 * k as f32, 0.5, 0.0], [0.0, 0.0, 1.0])
                        .mask(1 << k)
                        .flags(r.0),
                );
                expected.push((*g, *i, r, opacity::resolve(*g, *i, r, None)));
            }
        }
    }
    let log = run(&kit, root, rays, true);
    for (x, (g, i, r, fate)) in expected.iter().enumerate() {
        let x = x as u32;
        let names = log.names(x);
        let want: Vec<&str> = match fate {
            CandidateFate::Culled => vec!["miss"],
            CandidateFate::Opaque => vec!["ch"],
            CandidateFate::NonOpaque => vec!["ah", "ch"],
        };
        assert_eq!(names, want, "geometry {g:?}, instance {i:?}, ray {r:?}");
    }
    // Every fate occurs in the table, so each branch above was checked.
    for f in [
        CandidateFate::Culled,
        CandidateFate::Opaque,
        CandidateFate::NonOpaque,
    ] {
        assert!(expected.iter().any(|e| e.3 == f));
    }
}

#[test]
fn face_culling_flip_and_overrides() {
    let kit = Kit::new();
    // Front face seen by rays going +z.
    let front = kit.triangles(
        &quad(-1.0, -1.0, 1.0, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let no_cull = kit.triangles(
        &quad(-1.0, -1.0, 1.0, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT | GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING,
    );
    // Instances: 0 plain, 1 flipped, 2 culling disabled by the instance, 3 geometry flag,
    // 4 mirrored by its transform (facing is decided in object space: unchanged).
    let mut mirrored = instance(front, 4, 1 << 4, InstanceFlags::NONE, 40.0);
    mirrored.transform[0] = -1.0;
    let root = kit.instances(&[
        instance(front, 0, 1, InstanceFlags::NONE, 0.0),
        instance(front, 1, 2, InstanceFlags::FLIP_TRIANGLE_FACING, 10.0),
        instance(
            front,
            2,
            4,
            InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING,
            20.0,
        ),
        instance(no_cull, 3, 8, InstanceFlags::NONE, 30.0),
        mirrored,
    ]);
    let cull = [
        RayFlags::NONE,
        RayFlags::CULL_BACK_FACING_TRIANGLES,
        RayFlags::CULL_FRONT_FACING_TRIANGLES,
    ];
    let mut rays = Vec::new();
    for k in 0..5u32 {
        for (dir, z) in [(1.0f32, 0.0f32), (-1.0, 10.0)] {
            for f in cull {
                rays.push(
                    Ray::new([10.0 * k as f32, 0.5, z], [0.0, 0.0, dir])
                        .mask(1 << k)
                        .flags(f.0),
                );
            }
        }
    }
    let log = run(&kit, root, rays, false);
    let mut x = 0;
    for k in 0..5u32 {
        for going_up in [true, false] {
            let front = going_up != (k == 1);
            for f in cull {
                let culled = k != 2
                    && k != 3
                    && opacity::triangle_face_culled(
                        front,
                        GeometryFlags::NONE,
                        InstanceFlags::NONE,
                        f,
                    );
                match log.get(x, "ch") {
                    Some(ch) => {
                        assert!(
                            !culled,
                            "instance {k}, up {going_up}, {f:?}: should be culled"
                        );
                        assert_eq!(
                            ch[0],
                            facing::triangle_hit_kind(front) as f64,
                            "instance {k}, up {going_up}"
                        );
                    }
                    None => assert!(culled, "instance {k}, up {going_up}, {f:?}: missed"),
                }
                x += 1;
            }
        }
    }
}

use optik_api::semantics::facing;

#[test]
fn visibility_masks_use_the_low_eight_bits() {
    let kit = Kit::new();
    let gas = kit.triangles(
        &quad(-1.0, -1.0, 1.0, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    // Nine instances stacked along the ray, nearest first, masks 1, 2, 4, … and 0x100.
    let insts: Vec<Instance> = (0..9u32)
        .map(|k| {
            let mut i = instance(
                gas,
                k,
                if k < 8 { 1 << k } else { 0x100 },
                InstanceFlags::NONE,
                0.0,
            );
            i.transform[11] = k as f32;
            i
        })
        .collect();
    let root = kit.instances(&insts);
    let masks = [0x01u32, 0x02, 0x80, 0x06, 0xF0, 0x100, 0xFF00, 0x1FF, 0];
    let rays = masks
        .iter()
        .map(|&m| Ray::new([0.0, 0.5, 0.0], [0.0, 0.0, 1.0]).mask(m))
        .collect();
    let log = run(&kit, root, rays, false);
    for (x, &m) in masks.iter().enumerate() {
        let want = (0..8u32).find(|k| (m & 0xFF) & (1 << k) != 0);
        let got = log.get(x as u32, "ch").map(|ch| ch[1] as u32);
        assert_eq!(got, want, "ray mask {m:#x}");
    }
}

#[test]
fn terminate_on_first_hit_and_disable_closest_hit() {
    let kit = Kit::new();
    let mut v = Vec::new();
    for k in 0..16 {
        v.extend(quad(-1.0, -1.0, 1.0, 1.0, 1.0 + k as f32));
    }
    let gas = kit.triangles(&v, GeometryFlags::NONE);
    let up = Ray::new([0.0, 0.5, 0.0], [0.0, 0.0, 1.0]);
    let rays = vec![
        up,
        up.flags(RayFlags::TERMINATE_ON_FIRST_HIT.0),
        up.flags(RayFlags::DISABLE_CLOSESTHIT.0),
        up.flags((RayFlags::TERMINATE_ON_FIRST_HIT | RayFlags::DISABLE_CLOSESTHIT).0),
    ];
    let log = run(&kit, gas, rays, true);
    // Without flags: the closest layer, reached after at least one any-hit.
    assert!(log.count(0, "ah") >= 1);
    assert_eq!(log.get(0, "ch").unwrap()[2], 1.0, "closest layer");
    // The first accepted hit ends traversal: one any-hit, closest-hit with that hit.
    assert_eq!(log.count(1, "ah"), 1);
    let ch = log.get(1, "ch").unwrap();
    assert!(
        (1.0..=16.0).contains(&ch[2]) && ch[2].fract() == 0.0,
        "{ch:?}"
    );
    assert_eq!(log.count(1, "miss"), 0);
    assert_eq!(
        log.names(2)
            .iter()
            .filter(|n| *n == "ch" || *n == "miss")
            .count(),
        0,
        "no closest-hit, no miss"
    );
    assert_eq!(log.names(3), vec!["ah"]);
}
