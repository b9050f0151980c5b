//! The `numerics` group: rays where `f32` rounding decides (DESIGN.md §5, docs/numerics.md):
//! shared edges and vertices near the origin, far from it and tiny; grazing rays; secondary
//! rays with and without `rt_offset_ray`; degenerate neighbours; signed zeros, infinities,
//! NaN and denormals in rays; interval boundaries; tiny and huge spheres; extreme, mirrored
//! and sheared instances; motion at, between and outside its keys.

use super::tri::COUNTED;
use super::util::*;
use crate::case::{Case, Group, HitGroupDesc, Rule, SbtEntry};
use crate::kit::{Ray, StdCase, action, ch, hit_group, prog, sphere_group};
use crate::scene::{
    Aabbs, Gas, GeomInput, InstanceDesc, Node, Scene, Spheres, TransformKind, TransformNode,
    Triangles,
};
use crate::tolerance::Tolerance;
use optik::{GeometryFlags, MotionFlags, MotionOptions};

/// Every case of the group.
pub fn cases() -> Vec<Case> {
    vec![
        shared_edges(
            "shared_edge_origin",
            "edge midpoints of a closed icosphere at the origin",
            1.0,
            [0.0; 3],
            Target::Edges,
        ),
        shared_edges(
            "shared_vertex_origin",
            "vertices of a closed icosphere at the origin",
            1.0,
            [0.0; 3],
            Target::Vertices,
        ),
        shared_edges(
            "shared_edge_far",
            "edge midpoints of a closed icosphere of radius 10 at (1e5, -1e5, 3e4)",
            10.0,
            FAR,
            Target::Edges,
        ),
        shared_edges(
            "shared_vertex_far",
            "vertices of a closed icosphere of radius 10 at (1e5, -1e5, 3e4)",
            10.0,
            FAR,
            Target::Vertices,
        ),
        shared_edges(
            "shared_edge_tiny",
            "edge midpoints of a closed icosphere of radius 1e-4",
            1e-4,
            [0.3, 0.2, 0.1],
            Target::Edges,
        ),
        shared_edges(
            "shared_vertex_tiny",
            "vertices of a closed icosphere of radius 1e-4",
            1e-4,
            [0.3, 0.2, 0.1],
            Target::Vertices,
        ),
        fan_high_valence(),
        grazing_plane(),
        grazing_ridge(),
        secondary("secondary_no_offset", false, 1.0, [0.0; 3]),
        secondary("secondary_offset_ray", true, 1.0, [0.0; 3]),
        secondary("secondary_offset_far", true, 10.0, FAR),
        degenerate_neighbours(),
        signed_zero_directions(),
        inf_nan_ray_components(),
        denormal_rays(),
        tmin_tmax_ulps(),
        tmax_zero_and_infinite(),
        tiny_sphere_far(),
        huge_sphere_near(),
        extreme_scale_instances(),
        mirrored_instance(),
        sheared_instance(),
        far_instance(),
        motion_key_times(),
        motion_between_keys(),
        motion_outside_range(),
        axis_aligned_integer_mesh(),
        needle_triangles(),
        near_box_faces(),
    ]
}

const FAR: [f64; 3] = [1.0e5, -1.0e5, 3.0e4];

/// Two hit records over one hit group (closest-hit and any-hit): record 0 accepts, record 1
/// ignores (so the any-hit count is the number of surfaces crossed).
fn record_and_count() -> (Vec<HitGroupDesc>, Vec<SbtEntry>) {
    (
        vec![hit_group(Some(prog::CH), Some(prog::AH), None)],
        vec![
            SbtEntry::new(0, vec![0, action::ACCEPT]),
            SbtEntry::new(0, vec![1, action::IGNORE]),
        ],
    )
}

/// Each ray twice: through record 0 (recorded) and record 1 (counted).
fn twice(rays: Vec<Ray>) -> Vec<Ray> {
    rays.into_iter()
        .flat_map(|r| [r, Ray { sbt_offset: 1, ..r }])
        .collect()
}

#[derive(Clone, Copy)]
enum Target {
    Edges,
    Vertices,
}

fn shared_edges(name: &str, what: &str, scale: f64, offset: [f64; 3], target: Target) -> Case {
    let mesh = icosphere(2).placed(scale, offset);
    let c = mesh.centroid();
    let targets: Vec<[f64; 3]> = match target {
        Target::Edges => mesh
            .edges()
            .iter()
            .map(|(a, b)| mesh.midpoint(*a, *b))
            .collect(),
        Target::Vertices => mesh.vertices.iter().map(|v| v.map(|x| x as f64)).collect(),
    };
    let rays = twice(targets.iter().map(|t| ray_to(c, *t)).collect());
    let (scene, root) = Scene::single(mesh.gas(COUNTED));
    let (groups, records) = record_and_count();
    StdCase::new(
        Group::Numerics,
        name,
        &format!("rays from inside through the {what}: exactly one crossing (any-hit count 1) and a hit, whichever triangle"),
        &[Rule::Watertight, Rule::SingleAnyHit],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(64, rays)
    .record(vec![ch::hit(), ch::prim(), ch::ah_count(), ch::sbt_index()])
    .build()
}

fn fan_high_valence() -> Case {
    let mut scene = Scene::default();
    let mut case_rays = Vec::new();
    for (n, off) in [(1024u32, [0.0f64; 3]), (1024, FAR)] {
        let m = fan(n, 100.0, 0.0).placed(1.0, off);
        let root = scene.add(Node::Gas(m.gas(COUNTED)));
        let from = [off[0], off[1], off[2] - 1.0];
        let mut rays = vec![ray_to(from, off)];
        // Points ever closer to the centre vertex, in several directions.
        for k in 0..8 {
            let a = 0.37 + k as f64 * 0.785;
            for e in [1e-2, 1e-4, 1e-6, 1e-7, 1e-9] {
                rays.push(ray_to(
                    from,
                    [off[0] + e * a.cos(), off[1] + e * a.sin(), off[2]],
                ));
            }
        }
        case_rays.push((root, twice(rays)));
    }
    let (groups, records) = record_and_count();
    let mut case = StdCase::new(
        Group::Numerics,
        "fan_high_valence",
        "a closed fan of 1024 slivers at the origin and at 1e5: rays through and ever nearer the centre vertex cross it exactly once",
        &[Rule::Watertight],
        scene,
        None,
    )
    .hits(groups, records);
    for (root, rays) in case_rays {
        case = case.launch_on(Some(root), 41, rays);
    }
    case.record(vec![ch::hit(), ch::prim(), ch::ah_count(), ch::sbt_index()])
        .build()
}

fn grazing_plane() -> Case {
    let plane = terrain(16, |_, _| 0.0).placed(8.0, [-4.0, -4.0, 0.0]);
    let (scene, root) = Scene::single(plane.gas(COUNTED));
    let mut rays = Vec::new();
    let mut rng = Rng::new(5);
    for k in 0..8 {
        let eps = 10f64.powi(-k - 1);
        for _ in 0..8 {
            let (x, y) = (rng.range(-3.0, -2.0), rng.range(-3.0, 3.0));
            let h = eps * rng.range(1.0, 4.0);
            // Travel ~1..4 units in x, down by h: the hit lies inside the plane.
            rays.push(Ray::new(v32([x, y, h]), v32([1.0, 0.1, -eps])));
        }
    }
    // Rays exactly in the plane (z = 0, no z component): parallel, never hit.
    for k in 0..8 {
        rays.push(Ray::new(
            [-3.5, -3.0 + 0.7 * k as f32, 0.0],
            [1.0, 0.05, 0.0],
        ));
    }
    let (groups, records) = record_and_count();
    StdCase::new(
        Group::Numerics,
        "grazing_plane",
        "rays reaching a tessellated plane at angles down to 1e-8 cross it once; rays lying in the plane never hit",
        &[Rule::Watertight],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(36, twice(rays))
    .record(vec![ch::hit(), ch::prim(), ch::ah_count(), ch::sbt_index()])
    .build()
}

fn grazing_ridge() -> Case {
    // Two quads meeting at a ridge along y = 0 with a dihedral angle of 179.9°.
    let s = 1e-3f32;
    let verts = vec![
        [-1.0, -1.0, -s],
        [1.0, -1.0, -s],
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [1.0, 1.0, -s],
        [-1.0, 1.0, -s],
    ];
    let tris = vec![[0, 1, 2], [0, 2, 3], [3, 2, 4], [3, 4, 5]];
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::mesh(
        verts, tris, COUNTED,
    ))]));
    let mut rays = Vec::new();
    for k in 0..16 {
        let x = -0.9 + 0.11 * k as f64;
        // From below, nearly parallel to either face, aimed exactly at the ridge.
        for dir_y in [1.0, -1.0] {
            let from = [x, -2.0 * dir_y, -0.01];
            rays.push(ray_to(from, [x, 0.0, 0.0]));
        }
    }
    let (groups, records) = record_and_count();
    StdCase::new(
        Group::Numerics,
        "grazing_ridge",
        "grazing rays aimed exactly at the shared edge of a nearly flat ridge cross it once",
        &[Rule::Watertight],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(32, twice(rays))
    .record(vec![ch::hit(), ch::prim(), ch::ah_count(), ch::sbt_index()])
    .build()
}

fn secondary(name: &str, offset: bool, scale: f64, at: [f64; 3]) -> Case {
    let inner = icosphere(2).placed(scale, at);
    let outer = icosphere(1).placed(2.5 * scale, at);
    let mut scene = Scene::default();
    let root = scene.add(Node::Gas(Gas::new(vec![
        inner.input(GeometryFlags::DISABLE_ANYHIT),
        outer.input(GeometryFlags::DISABLE_ANYHIT),
    ])));
    let mut rng = Rng::new(61);
    let mut rays = Vec::new();
    let mut normals = Vec::new();
    for _ in 0..512 {
        let t = inner.triangles[rng.next_u32() as usize % inner.triangles.len()];
        let v = t.map(|i| inner.vertices[i as usize]);
        let (u, w) = (rng.range(0.1, 0.45) as f32, rng.range(0.1, 0.45) as f32);
        // The hit point as an f32 intersector would reconstruct it from barycentrics.
        let p: [f32; 3] =
            std::array::from_fn(|i| v[0][i] + u * (v[1][i] - v[0][i]) + w * (v[2][i] - v[0][i]));
        let e1: [f32; 3] = std::array::from_fn(|i| v[1][i] - v[0][i]);
        let e2: [f32; 3] = std::array::from_fn(|i| v[2][i] - v[0][i]);
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let n = n.map(|c| c / len);
        let tangent = rng.direction();
        let d: [f32; 3] = std::array::from_fn(|i| n[i] + 0.9 * tangent[i] as f32);
        let dot = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
        let d = if dot <= 0.05 { n } else { d };
        rays.push(Ray::new(p, d));
        normals.push([n[0], n[1], n[2], 0.0]);
    }
    let what = if offset {
        "spawned with rt_offset_ray: they never re-hit the surface they leave and hit the enclosing mesh"
    } else {
        "spawned from the reconstructed hit point with tmin 0 (no offset): a self-hit within rounding is admissible, anything else is not"
    };
    let mut case = StdCase::new(
        Group::Numerics,
        name,
        &format!("secondary rays leaving a closed mesh (scale {scale:e}), {what}"),
        if offset {
            &[Rule::OffsetRay]
        } else {
            &[Rule::TriangleOpenInterval]
        },
        scene,
        Some(root),
    )
    .hits(
        vec![hit_group(Some(prog::CH), None, None)],
        vec![
            SbtEntry::new(0, vec![0, action::ACCEPT]),
            SbtEntry::new(0, vec![1, action::ACCEPT]),
        ],
    )
    .launch(32, rays)
    .record(vec![
        ch::hit(),
        ch::prim(),
        ch::gas_index(),
        ch::sbt_index(),
    ]);
    if offset {
        case.raygen = prog::RAYGEN_OFFSET;
        case.extra = normals;
    }
    case.build()
}

fn degenerate_neighbours() -> Case {
    // A closed cube whose faces carry zero-area slivers along their diagonals and edges, and
    // a NaN triangle: rays from inside through those shared edges still cross exactly once.
    let m = cube(-1.0, 1.0);
    let mut verts: Vec<[f32; 3]> = m
        .triangles
        .iter()
        .flat_map(|t| t.map(|i| m.vertices[i as usize]))
        .collect();
    let mut extra = Vec::new();
    for t in &m.triangles {
        let v = t.map(|i| m.vertices[i as usize]);
        let mid: [f32; 3] = std::array::from_fn(|i| 0.5 * (v[0][i] + v[2][i]));
        extra.extend([v[0], mid, v[2]]);
        extra.extend([v[1], v[1], v[2]]);
    }
    extra.extend([[f32::NAN, 0.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0]]);
    verts.extend(extra);
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        verts, COUNTED,
    ))]));
    let mut targets = Vec::new();
    for (a, b) in m.edges() {
        targets.push(m.midpoint(a, b));
        let (pa, pb) = (m.vertices[a as usize], m.vertices[b as usize]);
        targets.push(std::array::from_fn(|i| {
            0.75 * pa[i] as f64 + 0.25 * pb[i] as f64
        }));
    }
    let rays = twice(
        targets
            .iter()
            .map(|t| ray_to([0.01, 0.02, 0.03], *t))
            .collect(),
    );
    let (groups, records) = record_and_count();
    StdCase::new(
        Group::Numerics,
        "degenerate_neighbours",
        "zero-area slivers along the shared edges of a closed cube and a NaN triangle: rays through those edges cross exactly once",
        &[Rule::DegenerateTriangles, Rule::Watertight],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(36, rays)
    .record(vec![ch::hit(), ch::ah_count(), ch::sbt_index()])
    .build()
}

fn signed_zero_directions() -> Case {
    let mut scene = Scene::default();
    let tri = scene.add(Node::Gas(cube(0.0, 1.0).gas(GeometryFlags::DISABLE_ANYHIT)));
    let boxes = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![
            [0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            [0.0, 2.0, 0.0, 1.0, 3.0, 1.0],
        ],
        GeometryFlags::DISABLE_ANYHIT,
    ))])));
    let z = 0.0f32;
    let nz = -0.0f32;
    let mut rays = Vec::new();
    // Along x, through the cube and one box, on and off their y and z slab planes.
    for (oy, oz) in [
        (0.5f32, 0.5f32),
        (0.25, 0.75),
        (1.0, 0.5),
        (0.0, 0.5),
        (0.5, 1.0),
        (2.0, 0.5),
        (3.0, 1.0),
    ] {
        for dy in [z, nz] {
            for dz in [z, nz] {
                rays.push(Ray::new([-1.0, oy, oz], [1.0, dy, dz]));
                rays.push(Ray::new([4.0, oy, oz], [-1.0, dy, dz]));
            }
        }
    }
    // Along ±y, reaching only one box each (tmax 1.5).
    for (ox, oz) in [(0.5f32, 0.5f32), (1.0, 0.25), (0.0, 1.0)] {
        for dx in [z, nz] {
            rays.push(Ray::new([ox, -1.0, oz], [dx, 1.0, nz]).interval(0.0, 1.5));
            rays.push(Ray::new([ox, 4.0, oz], [nz, -1.0, dx]).interval(0.0, 1.5));
        }
    }
    let groups = vec![
        hit_group(Some(prog::CH), None, None),
        hit_group(Some(prog::CH_ATTRS), None, Some(prog::IS_FIXED)),
    ];
    let t_report = 0.5f32.to_bits();
    let records = vec![
        SbtEntry::new(0, vec![0, action::ACCEPT]),
        SbtEntry::new(1, vec![1, action::ACCEPT, 0, 0, 1, t_report]),
    ];
    let n = rays.len();
    let box_rays: Vec<Ray> = rays
        .iter()
        .map(|r| Ray {
            sbt_offset: 1,
            ..*r
        })
        .collect();
    StdCase::new(
        Group::Numerics,
        "signed_zero_directions",
        "+0 and -0 direction components, origins inside, beside and on the slab planes of a cube mesh and of boxes: the sign of zero never changes the answer (obvhs F0, F4)",
        &[Rule::TriangleOpenInterval, Rule::CustomClosedInterval],
        scene,
        None,
    )
    .hits(groups, records)
    .launch_on(Some(tri), n as u32, rays)
    .launch_on(Some(boxes), n as u32, box_rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::prim(), ch::sbt_index()])
    .build()
}

fn inf_nan_ray_components() -> Case {
    let (scene, root) = Scene::single(cube(0.0, 1.0).gas(GeometryFlags::DISABLE_ANYHIT));
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let good = Ray::new([0.5, 0.25, 5.0], [0.0, 0.0, -1.0]);
    let rays = vec![
        good,
        Ray {
            origin: [nan, 0.25, 5.0],
            ..good
        },
        Ray {
            origin: [0.5, inf, 5.0],
            ..good
        },
        Ray {
            origin: [0.5, 0.25, -inf],
            ..good
        },
        Ray {
            dir: [nan, 0.0, -1.0],
            ..good
        },
        Ray {
            dir: [0.0, -inf, -1.0],
            ..good
        },
        Ray {
            dir: [0.0, 0.0, nan],
            ..good
        },
        good.interval(nan, 10.0),
        good.interval(0.0, nan),
        good.interval(-1e-30, 10.0),
        good.interval(-0.0, 10.0),
        good.interval(2.0, 1.0),
        good.interval(0.0, inf),
        good.interval(inf, inf),
        Ray {
            dir: [0.0, 0.0, 0.0],
            ..good
        },
        Ray {
            origin: [1e38, 0.25, 5.0],
            ..good
        },
        Ray {
            dir: [0.0, 0.0, -1e20],
            ..good
        },
        Ray {
            origin: [0.5, 0.25, f32::MAX],
            ..good
        },
        good,
    ];
    StdCase::new(
        Group::Numerics,
        "inf_nan_ray_components",
        "rays with NaN or infinite origin, direction or tmax, negative or NaN tmin, tmin > tmax: no program runs; -0 tmin, infinite tmax, zero and huge directions are valid",
        &[Rule::InvalidRayPolicy],
        scene,
        Some(root),
    )
    .launch(19, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::prim(), ch::programs()])
    .build()
}

fn denormal_rays() -> Case {
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        quad(-1.0, -0.5, 1.0, 1.0, -1.0),
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    let den = 1e-40f32;
    let tiny = f32::from_bits(1);
    let base = Ray::new([0.25, 0.375, 0.0], [0.0, 0.0, -1.0]);
    let rays = vec![
        Ray {
            dir: [den, den, -1.0],
            ..base
        },
        Ray {
            dir: [-den, tiny, -1.0],
            ..base
        },
        Ray {
            dir: [tiny, -tiny, -tiny],
            ..base
        },
        Ray {
            dir: [0.0, 0.0, -den],
            ..base
        },
        Ray {
            origin: [den, -den, 0.0],
            ..base
        },
        Ray {
            origin: [tiny, tiny, tiny],
            ..base
        },
        base.interval(den, 10.0),
        base.interval(tiny, 10.0),
        base.interval(0.0, den),
        Ray {
            dir: [den, 0.0, 0.0],
            ..base
        },
        Ray {
            dir: [f32::MIN_POSITIVE, 0.0, -f32::MIN_POSITIVE],
            ..base
        },
        base,
    ];
    StdCase::new(
        Group::Numerics,
        "denormal_rays",
        "denormal components in origins, directions and tmin/tmax: rays that reach the quad hit it with the right t (t up to 1e45 is not representable and misses)",
        &[Rule::TriangleOpenInterval],
        scene,
        Some(root),
    )
    .launch(12, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::prim()])
    .build()
}

fn tmin_tmax_ulps() -> Case {
    // Depths with short mantissas, so that every intersector computes t exactly.
    let depths = [2f32.powi(-20), 0.375, 12345.5, 1e5, 2f32.powi(20), 7.0];
    let mut verts = Vec::new();
    for (k, c) in depths.iter().enumerate() {
        let x = 4.0 * k as f32;
        verts.extend([[x, 0.0, -c], [x + 2.0, 0.0, -c], [x, 2.0, -c]]);
    }
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        verts,
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    let step = |x: f32, k: i32| f32::from_bits((x.to_bits() as i32 + k) as u32);
    let mut rays = Vec::new();
    for (k, c) in depths.iter().enumerate() {
        let r = Ray::new([4.0 * k as f32 + 0.5, 0.5, 0.0], [0.0, 0.0, -1.0]);
        for u in [-3, -2, -1, 0, 1, 2, 3] {
            rays.push(r.interval(step(*c, u), f32::INFINITY));
            rays.push(r.interval(0.0, step(*c, u)));
        }
    }
    StdCase::new(
        Group::Numerics,
        "tmin_tmax_ulps",
        "tmin and tmax within ±3 ulps of exact t from 2^-20 to 2^20: hits exactly when tmin < t < tmax (exact scene)",
        &[Rule::TriangleOpenInterval],
        scene,
        Some(root),
    )
    .exact()
    .launch(14, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::Exact)])
    .build()
}

fn tmax_zero_and_infinite() -> Case {
    let mut scene = Scene::default();
    let tri = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            quad(-1.0, -1.0, 1.0, 1.0, 0.0),
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])));
    let boxes = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![[-1.0, -1.0, -1.0, 1.0, 1.0, 1.0]],
        GeometryFlags::DISABLE_ANYHIT,
    ))])));
    let inf = f32::INFINITY;
    let on = Ray::new([0.25, 0.125, 0.0], [0.0, 0.0, -1.0]);
    let above = Ray::new([0.25, 0.125, 2.0], [0.0, 0.0, -1.0]);
    let rays = vec![
        on.interval(0.0, 0.0),
        on.interval(0.0, inf),
        above.interval(0.0, 0.0),
        above.interval(0.0, inf),
        above.interval(inf, inf),
        above.interval(2.0, 2.0),
        above.interval(f32::MAX, inf),
        above.interval(0.0, f32::MAX),
    ];
    let groups = vec![
        hit_group(Some(prog::CH), None, None),
        hit_group(Some(prog::CH_ATTRS), None, Some(prog::IS_FIXED)),
    ];
    let records = vec![
        SbtEntry::new(0, vec![0, action::ACCEPT]),
        // The intersection program reports t = 0 and t = 2.
        SbtEntry::new(
            1,
            vec![
                1,
                action::ACCEPT,
                0,
                0,
                2,
                0.0f32.to_bits(),
                2.0f32.to_bits(),
            ],
        ),
    ];
    let box_rays: Vec<Ray> = rays
        .iter()
        .map(|r| Ray {
            sbt_offset: 1,
            ..*r
        })
        .collect();
    StdCase::new(
        Group::Numerics,
        "tmax_zero_and_infinite",
        "tmax = 0, tmin = tmax, infinite and maximal bounds: triangles need tmin < t < tmax, reports need tmin ≤ t ≤ tmax (exact scene)",
        &[Rule::TriangleOpenInterval, Rule::CustomClosedInterval],
        scene,
        None,
    )
    .exact()
    .hits(groups, records)
    .launch_on(Some(tri), 8, rays)
    .launch_on(Some(boxes), 8, box_rays)
    .record(vec![ch::hit(), ch::t(Tolerance::Exact), ch::sbt_index(), ch::aux()])
    .build()
}

fn spheres_case(
    name: &str,
    what: &str,
    centres: Vec<[f32; 3]>,
    radii: Vec<f32>,
    rays: Vec<Ray>,
    t: Tolerance,
) -> Case {
    let input = GeomInput::Spheres(Spheres {
        centres: vec![centres],
        radii: vec![radii],
        single_radius: false,
        flags: vec![GeometryFlags::DISABLE_ANYHIT],
        sbt_offsets: None,
        prim_index_offset: 0,
    });
    let (scene, root) = Scene::single(Gas::new(vec![input]));
    let n = rays.len() as u32;
    StdCase::new(Group::Numerics, name, what, &[], scene, Some(root))
        .hits(
            vec![sphere_group()],
            vec![SbtEntry::new(0, vec![0, action::ACCEPT])],
        )
        .launch(n.min(32), rays)
        .record(vec![ch::hit(), ch::t(t), ch::prim()])
        .build()
}

fn tiny_sphere_far() -> Case {
    let (r, dist) = (1.0f64, 1e4f64);
    let mut centres = Vec::new();
    let mut rays = Vec::new();
    for k in 0..4 {
        let a = 0.3 + 1.1 * k as f64;
        let c = [dist * a.cos(), dist * a.sin(), 0.5 * dist];
        centres.push(v32(c));
        let c = v32(c).map(|x| x as f64);
        let cl = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        // A unit vector perpendicular to the line of sight.
        let perp = [
            -c[1] / (c[0] * c[0] + c[1] * c[1]).sqrt(),
            c[0] / (c[0] * c[0] + c[1] * c[1]).sqrt(),
            0.0,
        ];
        for off in [0.0, 0.5, 0.9, 1.1, 2.0] {
            let target = [c[0] + off * r * perp[0], c[1] + off * r * perp[1], c[2]];
            rays.push(Ray::new([0.0; 3], v32(target.map(|x| x / cl))));
        }
    }
    spheres_case(
        "tiny_sphere_far",
        "spheres of radius 1 at distance 1e4 (where b² − ac cancels all 24 bits), rays at 0, 0.5, 0.9, 1.1 and 2 radii from the centre: the stable quadratic keeps hits and t (U16 at 1e4)",
        centres,
        vec![r as f32; 4],
        rays,
        Tolerance::U16 { scale: 1e4 },
    )
}

fn huge_sphere_near() -> Case {
    let r = 1e5f32;
    let centre = [0.0f32, 0.0, -1e5];
    let mut rays = Vec::new();
    for k in 0..16 {
        let x = (k as f32 - 8.0) * 37.0;
        rays.push(Ray::new([x, 0.0, 1.0], [0.0, 0.0, -1.0]));
        rays.push(Ray::new([x, 3.0, 2.0], [0.3, -0.2, -1.0]));
    }
    // Grazing: just above the surface, tangent-ish.
    for k in 0..8 {
        rays.push(Ray::new([0.0, 0.0, 0.5 + k as f32], [1.0, 0.0, -0.02]));
    }
    spheres_case(
        "huge_sphere_near",
        "a sphere of radius 1e5 seen from one unit above its surface: hits at t ≈ 1 with t within U16 of 1e5 (the surface position itself is only known to f32 at that radius)",
        vec![centre],
        vec![r],
        rays,
        Tolerance::U16 { scale: 1e5 },
    )
}

fn instanced(
    name: &str,
    what: &str,
    guards: &[Rule],
    transforms: Vec<optik::Matrix3x4>,
    rays: Vec<Ray>,
    t: Tolerance,
) -> Case {
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(icosphere(2).gas(GeometryFlags::DISABLE_ANYHIT)));
    let instances = transforms
        .into_iter()
        .enumerate()
        .map(|(i, m)| InstanceDesc {
            id: i as u32,
            ..InstanceDesc::of(gas).at(m)
        })
        .collect();
    let root = scene.add(Node::Ias(instances));
    let n = rays.len() as u32;
    StdCase::new(Group::Numerics, name, what, guards, scene, Some(root))
        .launch(n.min(32), rays)
        .record(vec![
            ch::hit(),
            ch::t(t),
            ch::prim(),
            ch::inst_id(),
            ch::hit_kind(),
        ])
        .build()
}

/// Rays from `from` to random points near the surface of the unit sphere under `m`.
fn rays_at(m: &optik::Matrix3x4, from: [f64; 3], n: usize, seed: u64) -> Vec<Ray> {
    let mm = crate::oracle::math::m_from_f32(m);
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| {
            let p = rng.direction();
            let p = crate::oracle::math::m_point(&mm, [0.9 * p[0], 0.9 * p[1], 0.9 * p[2]]);
            ray_to(from, p)
        })
        .collect()
}

fn extreme_scale_instances() -> Case {
    let ms = vec![
        scale_translate([1e-4, 1e-4, 1e-4], [0.0, 0.0, 0.0]),
        scale_translate([1e4, 1e4, 1e4], [0.0, 3e4, 0.0]),
        scale_translate([1e-3, 1e3, 1.0], [0.0, -3e4, 0.0]),
    ];
    let mut rays = rays_at(&ms[0], [0.0, 0.0, 1e-3], 32, 1);
    rays.extend(rays_at(&ms[1], [0.0, 3e4, 2e4], 32, 2));
    rays.extend(rays_at(&ms[2], [0.0, -3e4, 5.0], 32, 3));
    instanced(
        "extreme_scale_instances",
        "instances scaled by 1e-4, 1e4 and (1e-3, 1e3, 1): hits, t (U16 at 1e4) and facing as in object space",
        &[Rule::FrontFace],
        ms,
        rays,
        Tolerance::U16 { scale: 1e4 },
    )
}

fn mirrored_instance() -> Case {
    let ms = vec![
        scale_translate([-1.0, 1.0, 1.0], [0.0, 0.0, 0.0]),
        scale_translate([1.0, -1.0, -1.0], [5.0, 0.0, 0.0]),
        scale_translate([-2.0, -2.0, -2.0], [0.0, 6.0, 0.0]),
    ];
    let mut rays = rays_at(&ms[0], [0.1, 0.2, 4.0], 24, 4);
    rays.extend(rays_at(&ms[1], [5.0, 0.1, -4.0], 24, 5));
    rays.extend(rays_at(&ms[2], [0.3, 6.0, 6.0], 24, 6));
    instanced(
        "mirrored_instance",
        "mirroring instances (det < 0): rays from outside still see front faces, because facing is decided in object space",
        &[Rule::FrontFace],
        ms,
        rays,
        Tolerance::U16,
    )
}

fn sheared_instance() -> Case {
    let ms = vec![
        [1.0, 10.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        [
            1.0, 0.0, 0.0, 40.0, 0.5, 1.0, -30.0, 0.0, 0.0, 0.0, 0.1, 0.0,
        ],
    ];
    let mut rays = rays_at(&ms[0], [3.0, 2.0, 8.0], 32, 7);
    rays.extend(rays_at(&ms[1], [40.0, -5.0, 3.0], 32, 8));
    instanced(
        "sheared_instance",
        "heavily sheared instances: t is the same in object and world space (U16 at 100), facing from object space",
        &[Rule::FrontFace],
        ms,
        rays,
        Tolerance::U16 { scale: 100.0 },
    )
}

fn far_instance() -> Case {
    let ms = vec![scale_translate([3.0, 3.0, 3.0], [1.0e5, -1.0e5, 3.0e4])];
    let rays = rays_at(&ms[0], [1.0e5 + 5.0, -1.0e5 + 7.0, 3.0e4 + 11.0], 96, 9);
    instanced(
        "far_instance",
        "an instance translated to (1e5, -1e5, 3e4), rays from 15 units away: hits and t within U16 at 1e5",
        &[Rule::Watertight],
        ms,
        rays,
        Tolerance::U16 { scale: 1e5 },
    )
}

/// A quad at z = -1 over [0, 1]² moved by 3 matrix keys; rays at x positions and times.
fn motion_case(
    name: &str,
    what: &str,
    guards: &[Rule],
    flags: MotionFlags,
    rays: Vec<Ray>,
    exact: bool,
) -> Case {
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            quad(0.0, 0.0, 1.0, 1.0, -1.0),
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])));
    let keys = vec![
        translate([0.0, 0.0, 0.0]),
        translate([1.0, 0.0, -1.0]),
        translate([2.0, 0.0, -2.0]),
    ];
    let motion = MotionOptions {
        num_keys: 3,
        flags,
        time_begin: 0.0,
        time_end: 1.0,
    };
    let xf = scene.add(Node::Transform(TransformNode {
        kind: TransformKind::MatrixMotion(motion, keys),
        child: gas,
    }));
    let root = scene.add(Node::Ias(vec![InstanceDesc::of(xf)]));
    let n = rays.len() as u32;
    let c = StdCase::new(Group::Numerics, name, what, guards, scene, Some(root))
        .launch(n.min(32), rays)
        .record(vec![
            ch::hit(),
            ch::t(if exact {
                Tolerance::Exact
            } else {
                Tolerance::U16
            }),
        ]);
    if exact { c.exact().build() } else { c.build() }
}

fn motion_rays(times: &[f32], xs: &[f32]) -> Vec<Ray> {
    times
        .iter()
        .flat_map(|t| {
            xs.iter()
                .map(move |x| Ray::new([*x, 0.375, 0.0], [0.0, 0.0, -1.0]).at_time(*t))
        })
        .collect()
}

fn motion_key_times() -> Case {
    motion_case(
        "motion_key_times",
        "matrix motion at exactly its key times 0, 0.5 and 1: the key's transform exactly (exact scene)",
        &[Rule::MatrixMotion],
        MotionFlags::NONE,
        motion_rays(&[0.0, 0.5, 1.0], &[0.25, 0.75, 1.25, 1.75, 2.25, 2.75]),
        true,
    )
}

fn motion_between_keys() -> Case {
    motion_case(
        "motion_between_keys",
        "matrix motion between keys (0.1, 0.25, 0.6, 0.9): the linearly interpolated transform",
        &[Rule::MatrixMotion],
        MotionFlags::NONE,
        motion_rays(
            &[0.1, 0.25, 0.6, 0.9],
            &[0.1, 0.3, 0.55, 0.9, 1.3, 1.7, 2.05, 2.6],
        ),
        false,
    )
}

fn motion_outside_range() -> Case {
    let times = [-1.0, -1e-7, 1.0 + 1e-7, 2.0, f32::NAN];
    let xs = [0.25, 0.75, 2.25, 2.75];
    let mut c = motion_case(
        "motion_outside_range",
        "times before, after and NaN: the nearest key (clamping; NaN uses the first), and with START/END_VANISH nothing outside the range",
        &[Rule::MotionClamp],
        MotionFlags::NONE,
        motion_rays(&times, &xs),
        true,
    );
    // A second transform with the vanish flags, traced in a second launch.
    let gas = 0;
    let keys = vec![
        translate([0.0, 0.0, 0.0]),
        translate([1.0, 0.0, -1.0]),
        translate([2.0, 0.0, -2.0]),
    ];
    let motion = MotionOptions {
        num_keys: 3,
        flags: MotionFlags::START_VANISH | MotionFlags::END_VANISH,
        time_begin: 0.0,
        time_end: 1.0,
    };
    let xf = c.scene.add(Node::Transform(TransformNode {
        kind: TransformKind::MatrixMotion(motion, keys),
        child: gas,
    }));
    let root = c.scene.add(Node::Ias(vec![InstanceDesc::of(xf)]));
    let mut second = c.launches[0].clone();
    second.params[0] = crate::case::ParamWord::HandleLo(Some(root));
    second.params[1] = crate::case::ParamWord::HandleHi(Some(root));
    c.launches.push(second);
    c
}

fn axis_aligned_integer_mesh() -> Case {
    let grid = terrain(8, |_, _| 0.0).placed(8.0, [0.0, 0.0, 0.0]);
    let (scene, root) = Scene::single(grid.gas(COUNTED));
    let mut rays = Vec::new();
    for j in 1..8 {
        for i in 1..8 {
            let (x, y) = (i as f64, j as f64);
            rays.push(Ray::new(v32([x, y, 3.0]), [0.0, 0.0, -1.0]));
            rays.push(Ray::new(v32([x + 0.5, y, 3.0]), [0.0, 0.0, -1.0]));
            rays.push(Ray::new(v32([x + 0.5, y + 0.5, 3.0]), [0.0, 0.0, -1.0]));
            rays.push(ray_to([x - 1.0, y - 2.0, 2.0], [x, y, 0.0]));
        }
    }
    let (groups, records) = record_and_count();
    StdCase::new(
        Group::Numerics,
        "axis_aligned_integer_mesh",
        "an integer grid mesh with rays exactly through its vertices, edges and diagonals, where f32 edge functions are exactly zero (the f64 fallback case): exactly one crossing",
        &[Rule::Watertight],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(56, twice(rays))
    .record(vec![ch::hit(), ch::prim(), ch::ah_count(), ch::sbt_index()])
    .build()
}

fn needle_triangles() -> Case {
    // The unit square split into 2000 needles fanning from two opposite corners.
    let n = 1000u32;
    let mut vertices = vec![[0.0f32, 0.0, -1.0], [1.0, 1.0, -1.0]];
    for i in 0..=n {
        let s = i as f32 / n as f32;
        vertices.push([s, 1.0 - s, -1.0]);
    }
    let mut triangles = Vec::new();
    for i in 0..n {
        triangles.push([0, 2 + i + 1, 2 + i]);
        triangles.push([1, 2 + i, 2 + i + 1]);
    }
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::mesh(
        vertices, triangles, COUNTED,
    ))]));
    let mut rng = Rng::new(3);
    let rays: Vec<Ray> = (0..256)
        .map(|_| {
            Ray::new(
                v32([rng.range(0.01, 0.99), rng.range(0.01, 0.99), 0.0]),
                [0.0, 0.0, -1.0],
            )
        })
        .collect();
    let (groups, records) = record_and_count();
    StdCase::new(
        Group::Numerics,
        "needle_triangles",
        "a square made of 2000 needle triangles (aspect about 1e3): every ray crosses exactly once",
        &[Rule::Watertight],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(64, twice(rays))
    .record(vec![ch::hit(), ch::ah_count(), ch::sbt_index()])
    .build()
}

fn near_box_faces() -> Case {
    // A row of boxes sharing faces; rays along the shared faces and just inside them with
    // zero, -0, tiny and denormal cross components: a box whose closed bounds the ray meets
    // must run its intersection program (boxes may be enlarged, never shrunk).
    let boxes: Vec<[f32; 6]> = (0..4)
        .flat_map(|i| {
            let x = i as f32;
            [
                [x, 0.0, 0.0, x + 1.0, 1.0, 1.0],
                [x, 1.0, 0.0, x + 1.0, 2.0, 1.0],
            ]
        })
        .collect();
    let mut aabbs = Aabbs::new(boxes, GeometryFlags::REQUIRE_SINGLE_ANYHIT_CALL);
    aabbs.flags = vec![GeometryFlags::REQUIRE_SINGLE_ANYHIT_CALL];
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Aabbs(aabbs)]));
    let mut rays = Vec::new();
    for y in [1.0f32, 0.999, 1.001, 0.5, 2.0, 0.0] {
        for dy in [0.0f32, -0.0, 1e-9, -1e-12, 1e-40] {
            rays.push(Ray::new([-1.0, y, 0.5], [1.0, dy, 0.0]));
        }
    }
    let groups = vec![hit_group(None, Some(prog::AH), Some(prog::IS_FIXED))];
    // The intersection program reports t = 0.25; the any-hit program ignores it, so every
    // box crossed runs both programs once.
    let records = vec![SbtEntry::new(
        0,
        vec![0, action::IGNORE, 0, 0, 1, 0.25f32.to_bits()],
    )];
    StdCase::new(
        Group::Numerics,
        "near_box_faces",
        "rays along and just beside the shared faces of adjacent boxes, with +0, -0, tiny and denormal components: every box whose closed bounds the ray meets runs its intersection program",
        &[Rule::CustomClosedInterval],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(30, rays)
    .record(vec![ch::is_count(), ch::ah_count(), ch::programs()])
    .build()
}
