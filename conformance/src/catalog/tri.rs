//! Group B (`tri`): triangle intersection — t, barycentrics, scaled directions,
//! watertightness, interval bounds, degenerate input, vertex formats, complex meshes.

use super::util::*;
use crate::case::{Case, Group, Rule, SbtEntry};
use crate::kit::{Ray, StdCase, action, ch, geometry_channels, hit_group, prog};
use crate::scene::{Gas, GeomInput, InstanceDesc, Node, SbtOffsets, Scene, Triangles};
use crate::tolerance::Tolerance;
use optik::{GeometryFlags, IndexFormat, VertexFormat};

/// Every case of the group.
pub fn cases() -> Vec<Case> {
    vec![
        t_plane(),
        barycentrics(),
        direction_scaling(),
        watertight_subdivided(),
        closed_fan(),
        watertight_far(),
        t_interval_bounds(),
        degenerate_and_nan(),
        formats_indices(),
        complex_mesh_hitrate(),
    ]
}

/// A hit group whose any-hit ignores every candidate and counts it (record 0), used to count
/// how many surfaces a ray crosses; geometry must be non-opaque with single any-hit calls.
pub fn counting_hits() -> (Vec<crate::case::HitGroupDesc>, Vec<SbtEntry>) {
    (
        vec![hit_group(Some(prog::CH), Some(prog::AH), None)],
        vec![SbtEntry::new(0, vec![0, action::IGNORE])],
    )
}

/// Flags of counted geometry: non-opaque, any-hit once per primitive.
pub const COUNTED: GeometryFlags = GeometryFlags::REQUIRE_SINGLE_ANYHIT_CALL;

fn t_plane() -> Case {
    // 16 × 16 cells, each a quad at z = -(0.03125 + 0.25 · k / 256), 4 × 4 rays per cell.
    let mut verts = Vec::new();
    for j in 0..16 {
        for i in 0..16 {
            let z = -(0.03125 + 0.25 * (i + 16 * j) as f32 / 256.0);
            verts.extend(quad(i as f32, j as f32, (i + 1) as f32, (j + 1) as f32, z));
        }
    }
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        verts,
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    StdCase::new(
        Group::Tri,
        "t_plane",
        "t of axis rays against triangles at known depths (CTS builtin hitT layout), F6",
        &[Rule::TriangleOpenInterval],
        scene,
        Some(root),
    )
    // 64 × 48 rays: cell fractions 1/8.. in x and 1/6.. in y never meet the quads' diagonals.
    .launch(64, down_grid(64, 48, 0.0, 0.0, 16.0, 16.0, 0.0))
    .record(vec![
        ch::hit(),
        ch::t(Tolerance::F6),
        ch::prim(),
        ch::hit_kind(),
    ])
    .build()
}

fn barycentrics() -> Case {
    let tri = vec![[0.0, -1.0, 5.0], [-1.0, 1.0, 5.0], [1.0, 1.0, 5.0]];
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        tri.clone(),
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    let mut rng = Rng::new(77);
    let mut rays = Vec::new();
    for k in 0..20 {
        // Barycentrics (b1, b2) of vertices 1 and 2; the first three lie near the vertices.
        let (b1, b2) = match k {
            0 => (0.0005, 0.0005),
            1 => (0.999, 0.0005),
            2 => (0.0005, 0.999),
            _ => {
                let (a, b) = (rng.range(0.02, 0.96), rng.range(0.02, 0.96));
                if a + b > 0.98 {
                    (0.98 - b, 0.98 - a)
                } else {
                    (a, b)
                }
            }
        };
        let b0 = 1.0 - b1 - b2;
        let p: [f64; 3] = std::array::from_fn(|i| {
            b0 * tri[0][i] as f64 + b1 * tri[1][i] as f64 + b2 * tri[2][i] as f64
        });
        rays.push(Ray::new([0.0; 3], v32(p)).interval(0.999, 1.001));
    }
    StdCase::new(
        Group::Tri,
        "barycentrics",
        "barycentrics of 20 rays aimed at known points, t within [0.999, 1.001] (CTS barycentric_coordinates), M3",
        &[Rule::FrontFace],
        scene,
        Some(root),
    )
    .launch(20, rays)
    .record(geometry_channels(Tolerance::M3, Some(Tolerance::M3)))
    .build()
}

fn direction_scaling() -> Case {
    // A quad at z = 5 in object space, 4 units from the ray origin (0, 0, 1); five rotated
    // instances far apart; directions scaled by 1 and five factors in [0.5, 10].
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            quad(-1.0, -1.0, 1.0, 1.0, 5.0),
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])));
    let mut rng = Rng::new(1410);
    let mut instances = Vec::new();
    let mut rays = Vec::new();
    let scales: Vec<f64> = std::iter::once(1.0)
        .chain((0..5).map(|_| rng.range(0.5, 10.0)))
        .collect();
    for r in 0..5 {
        let axis = rng.direction();
        let angle = rng.range(0.0, std::f64::consts::TAU);
        let offset = [20.0 * r as f32, 0.0, 0.0];
        let m = rotate_translate(axis, angle, offset);
        instances.push(InstanceDesc {
            id: r,
            ..InstanceDesc::of(gas).at(m)
        });
        let mm = crate::oracle::math::m_from_f32(&m);
        for s in &scales {
            let o = crate::oracle::math::m_point(&mm, [0.3, 0.1, 1.0]);
            let d = crate::oracle::math::m_vector(&mm, [0.0, 0.0, *s]);
            let expected = 4.0 / s;
            rays.push(
                Ray::new(v32(o), v32(d))
                    .interval((expected - 2e-3) as f32, (expected + 2e-3) as f32),
            );
        }
    }
    let root = scene.add(Node::Ias(instances));
    StdCase::new(
        Group::Tri,
        "direction_scaling",
        "t is in units of the unnormalised direction, equal in object and world space (CTS direction_length), M3",
        &[Rule::TriangleOpenInterval],
        scene,
        Some(root),
    )
    .launch(6, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::M3), ch::inst_id()])
    .build()
}

fn watertight_subdivided() -> Case {
    let mut scene = Scene::default();
    let (groups, records) = counting_hits();
    let mut case = StdCase::new(
        Group::Tri,
        "watertight_subdivided",
        "every ray through a crumpled, randomly subdivided square crosses it exactly once: any-hit count 1, never 0 or 2 (CTS watertightness, stricter)",
        &[Rule::Watertight, Rule::AnyHitPerCandidate, Rule::SingleAnyHit],
        Scene::default(),
        None,
    )
    .hits(groups, records);
    let meshes: Vec<_> = [(64, 11u64), (512, 12), (2048, 13)]
        .iter()
        .map(|(n, seed)| subdivided_square(*n, *seed))
        .collect();
    let roots: Vec<_> = meshes
        .iter()
        .map(|m| scene.add(Node::Gas(m.gas(COUNTED))))
        .collect();
    case.scene = scene;
    for root in roots {
        case = case.launch_on(Some(root), 64, down_grid(64, 64, 0.0, 0.0, 1.0, 1.0, 0.0));
    }
    case.record(vec![ch::ah_count(), ch::programs()]).build()
}

fn closed_fan() -> Case {
    let mut scene = Scene::default();
    let (groups, records) = counting_hits();
    let mut launches = Vec::new();
    let rays_for = |m: &Mesh| -> Vec<Ray> {
        let mut v = vec![ray_to([0.0, 0.0, -1.0], [0.0, 0.0, 0.0])];
        for i in 1..m.vertices.len() as u32 {
            v.push(ray_to([0.0, 0.0, -1.0], m.midpoint(0, i)));
        }
        v
    };
    for n in [4u32, 16, 64, 256] {
        let m = fan(n, 1.0, 0.0);
        let root = scene.add(Node::Gas(m.gas(COUNTED)));
        launches.push((root, rays_for(&m)));
    }
    // closedFan2: every triangle in its own GAS and instance.
    for n in [16u32, 64] {
        let m = fan(n, 1.0, 0.0);
        let mut instances = Vec::new();
        for t in &m.triangles {
            let tri: Vec<[f32; 3]> = t.iter().map(|i| m.vertices[*i as usize]).collect();
            let g = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
                Triangles::soup(tri, COUNTED),
            )])));
            instances.push(InstanceDesc::of(g));
        }
        let root = scene.add(Node::Ias(instances));
        launches.push((root, rays_for(&m)));
    }
    let mut case = StdCase::new(
        Group::Tri,
        "closed_fan",
        "rays through the centre vertex and every shared edge of closed fans (4..256 triangles; one GAS, and one instance per triangle): exactly one any-hit (CTS closedFan/closedFan2)",
        &[Rule::Watertight, Rule::SingleAnyHit],
        scene,
        None,
    )
    .hits(groups, records);
    for (root, rays) in launches {
        let w = rays.len().min(64) as u32;
        case = case.launch_on(Some(root), w, rays);
    }
    case.record(vec![ch::ah_count(), ch::programs()]).build()
}

fn watertight_far() -> Case {
    let offset = [148376.0, 1234.0, -223423.0];
    let sphere = icosphere(3).placed(100.0, offset);
    let plane =
        terrain(32, |_, _| 0.0).placed(400.0, [offset[0] - 200.0, offset[1] - 200.0, offset[2]]);
    let mut scene = Scene::default();
    let s = scene.add(Node::Gas(sphere.gas(GeometryFlags::DISABLE_ANYHIT)));
    let p = scene.add(Node::Gas(plane.gas(GeometryFlags::DISABLE_ANYHIT)));
    let mut rng = Rng::new(2024);
    let inside: Vec<Ray> = (0..4096)
        .map(|_| {
            let d = rng.direction();
            let r = 50.0 * rng.unit().cbrt();
            let u = rng.direction();
            let o = [
                offset[0] + r * u[0],
                offset[1] + r * u[1],
                offset[2] + r * u[2],
            ];
            Ray::new(v32(o), v32(d))
        })
        .collect();
    let above: Vec<Ray> = (0..4096)
        .map(|_| {
            let o = [
                offset[0] + rng.range(-190.0, 190.0),
                offset[1] + rng.range(-190.0, 190.0),
                offset[2] + 50.0,
            ];
            let d = [rng.range(-0.3, 0.3), rng.range(-0.3, 0.3), -1.0];
            Ray::new(v32(o), v32(d))
        })
        .collect();
    StdCase::new(
        Group::Tri,
        "watertight_far",
        "a closed sphere mesh and a plane at (148376, 1234, -223423): every ray from inside the sphere and every ray down onto the plane hits (Embree verify watertight_*_far; miss rate 0)",
        &[Rule::Watertight],
        scene,
        None,
    )
    .launch_on(Some(s), 64, inside)
    .launch_on(Some(p), 64, above)
    .record(vec![ch::hit(), ch::prim()])
    .build()
}

fn t_interval_bounds() -> Case {
    // Triangles at z = -c at distinct x; rays from x + 0.5 straight down. All exact in f32.
    let depths = [1.0f32, 0.75, 3.0, 1024.0, 1.0 / 1024.0];
    let mut verts = Vec::new();
    for (k, c) in depths.iter().enumerate() {
        let x = 4.0 * k as f32;
        verts.extend([[x, 0.0, -c], [x + 2.0, 0.0, -c], [x, 2.0, -c]]);
    }
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        verts,
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    let up = |x: f32| f32::from_bits(x.to_bits() + 1);
    let down = |x: f32| f32::from_bits(x.to_bits() - 1);
    let mut rays = Vec::new();
    for (k, c) in depths.iter().enumerate() {
        let o = [4.0 * k as f32 + 0.5, 0.5, 0.0];
        for len in [1.0f32, 2.0] {
            let t = c / len;
            let r = Ray::new(o, [0.0, 0.0, -len]);
            for (tmin, tmax) in [
                (0.0, f32::INFINITY),
                (t, f32::INFINITY),
                (down(t), f32::INFINITY),
                (up(t), f32::INFINITY),
                (0.0, t),
                (0.0, up(t)),
                (0.0, down(t)),
                (t, t),
                (down(t), up(t)),
            ] {
                rays.push(r.interval(tmin, tmax));
            }
        }
    }
    StdCase::new(
        Group::Tri,
        "t_interval_bounds",
        "triangles at exactly tmin or tmax, and one ulp either side: hit only in the open interval (tmin, tmax) (exact scene)",
        &[Rule::TriangleOpenInterval],
        scene,
        Some(root),
    )
    .exact()
    .launch(18, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::Exact), ch::prim()])
    .build()
}

fn degenerate_and_nan() -> Case {
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    // Valid quads at z = -1 in cells x ∈ [2k, 2k+1]; invalid triangles over and between them.
    let mut verts = Vec::new();
    let mut valid_cells = Vec::new();
    for k in 0..6 {
        let x = 2.0 * k as f32;
        verts.extend(quad(x, 0.0, x + 1.0, 1.0, -1.0));
        valid_cells.push(x);
    }
    let invalid: Vec<[[f32; 3]; 3]> = vec![
        // Collinear, repeated vertex, all three equal: over cell 0 and 1, nearer than the quads.
        [[0.0, 0.0, -0.5], [0.5, 0.5, -0.5], [1.0, 1.0, -0.5]],
        [[2.0, 0.0, -0.5], [2.0, 0.0, -0.5], [3.0, 1.0, -0.5]],
        [[2.5, 0.5, -0.5], [2.5, 0.5, -0.5], [2.5, 0.5, -0.5]],
        // NaN and infinite coordinates (CTS inactive triangles: NaN x in various vertices).
        [[nan, 0.0, -0.5], [5.0, 0.0, -0.5], [5.0, 1.0, -0.5]],
        [[4.0, 0.0, -0.5], [nan, nan, nan], [5.0, 1.0, -0.5]],
        [[6.0, 0.0, -0.5], [7.0, 0.0, -0.5], [6.0, inf, -0.5]],
        [[-inf, 0.0, -0.5], [inf, 0.0, -0.5], [0.0, 1.0, -0.5]],
        // Degenerate sliver along a valid quad's edge (shares the edge x = 9).
        [[9.0, 0.0, -1.0], [9.0, 0.5, -1.0], [9.0, 1.0, -1.0]],
        // A NaN triangle sharing two vertices with the valid quad of cell 5.
        [[10.0, 0.0, -1.0], [11.0, 1.0, -1.0], [10.5, nan, -1.0]],
    ];
    for t in &invalid {
        verts.extend(t.iter().copied());
    }
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        verts,
        GeometryFlags::DISABLE_ANYHIT,
    ))]));
    let rays = down_grid(96, 6, 0.0, 0.0, 12.0, 1.0, 0.0);
    StdCase::new(
        Group::Tri,
        "degenerate_and_nan",
        "zero-area (collinear, repeated vertex) and NaN/Inf-vertex triangles over and beside valid ones: they never hit and the valid ones are hit as if alone",
        &[Rule::DegenerateTriangles],
        scene,
        Some(root),
    )
    .launch(96, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::prim()])
    .build()
}

fn formats_indices() -> Case {
    // Eight inputs, each a quad in its own cell of a 4 × 2 grid inside [-1, 1]², every
    // vertex format, strides and index formats; one input with a pre-transform.
    let cell =
        |k: usize| -> (f32, f32) { (-1.0 + 0.5 * (k % 4) as f32, -1.0 + 1.0 * (k / 4) as f32) };
    let quad_in = |k: usize, z: f32| -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let (x, y) = cell(k);
        let (x0, y0, x1, y1) = (x + 0.0625, y + 0.125, x + 0.4375, y + 0.875);
        (
            vec![[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    };
    let unindexed = |v: &[[f32; 3]], t: &[[u32; 3]]| -> Vec<[f32; 3]> {
        t.iter()
            .flat_map(|tri| tri.map(|i| v[i as usize]))
            .collect()
    };
    let f = GeometryFlags::DISABLE_ANYHIT;
    let mut inputs = Vec::new();
    // (vertex format, vertex stride, index format and stride, z)
    type Spec = (VertexFormat, u32, Option<(IndexFormat, u32)>, f32);
    let specs: [Spec; 8] = [
        (VertexFormat::Float3, 0, None, -0.25),
        (
            VertexFormat::Float3,
            16,
            Some((IndexFormat::U32x3, 16)),
            -0.3,
        ),
        (VertexFormat::Float2, 0, Some((IndexFormat::U16x3, 0)), 0.0),
        (VertexFormat::Half3, 8, Some((IndexFormat::U16x3, 8)), -0.5),
        (VertexFormat::Half2, 0, None, 0.0),
        (
            VertexFormat::Snorm16x3,
            10,
            Some((IndexFormat::U32x3, 0)),
            -0.7,
        ),
        (VertexFormat::Snorm16x2, 6, None, 0.0),
        (VertexFormat::Float3, 0, Some((IndexFormat::U32x3, 0)), -0.2),
    ];
    for (k, (format, stride, index, z)) in specs.iter().enumerate() {
        let (v, t) = quad_in(k, *z);
        let mut tris = match index {
            Some((fmt, istride)) => Triangles {
                indices: Some((t.clone(), *fmt, *istride)),
                ..Triangles::soup(v.clone(), f)
            },
            None => Triangles::soup(unindexed(&v, &t), f),
        };
        tris.format = *format;
        tris.vertex_stride = *stride;
        if k == 7 {
            // Pre-transform: the quad is stored around the origin at half size and moved.
            let (x, y) = cell(k);
            let centre = [x + 0.25, y + 0.5];
            tris.keys[0] = tris.keys[0]
                .iter()
                .map(|p| [2.0 * (p[0] - centre[0]), 2.0 * (p[1] - centre[1]), p[2]])
                .collect();
            tris.pre_transform = Some(scale_translate(
                [0.5, 0.5, 1.0],
                [centre[0], centre[1], 0.0],
            ));
        }
        inputs.push(GeomInput::Triangles(tris));
    }
    let (scene, root) = Scene::single(Gas::new(inputs));
    let rays = down_grid(64, 24, -1.0, -1.0, 1.0, 1.0, 1.0);
    let hit_records = (0..8)
        .map(|i| SbtEntry::new(0, vec![i, action::ACCEPT]))
        .collect();
    StdCase::new(
        Group::Tri,
        "formats_indices",
        "vertex formats float3/float2/half3/half2/snorm16x3/snorm16x2, vertex strides, no/u16/u32 indices with strides, a pre-transform: t and primitive as decoded (CTS acceleration_structures.format)",
        &[Rule::TriangleOpenInterval],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), None, None)], hit_records)
    .launch(64, rays)
    .record(vec![ch::hit(), ch::t(Tolerance::U16), ch::prim(), ch::gas_index(), ch::sbt_index()])
    .build()
}

fn complex_mesh_hitrate() -> Case {
    let mut rng = Rng::new(99);
    let ico = icosphere(2).placed(0.45, [0.5, 0.5, -1.0]);
    let ter = terrain(24, |x, y| -1.0 + 0.2 * (7.0 * x).sin() * (5.0 * y).cos());
    let knot = torus_knot(2.0, 3.0, 96, 8, 0.12).placed(0.3, [0.5, 0.5, -1.0]);
    let mut soup = Mesh::default();
    for _ in 0..300 {
        let c = [
            rng.range(0.0, 1.0),
            rng.range(0.0, 1.0),
            rng.range(-1.5, -0.5),
        ];
        let base = soup.vertices.len() as u32;
        for _ in 0..3 {
            let d = rng.direction();
            soup.vertices.push(v32([
                c[0] + 0.08 * d[0],
                c[1] + 0.08 * d[1],
                c[2] + 0.08 * d[2],
            ]));
        }
        soup.triangles.push([base, base + 1, base + 2]);
    }
    let mut scene = Scene::default();
    let roots: Vec<_> = [ico, ter, knot, soup]
        .iter()
        .map(|m| scene.add(Node::Gas(m.gas(GeometryFlags::DISABLE_ANYHIT))))
        .collect();
    let mut case = StdCase::new(
        Group::Tri,
        "complex_mesh_hitrate",
        "icosphere, terrain, torus knot and triangle soup: per-ray hit and primitive against the oracle, ambiguous edge rays admitted (CTS complex_geometry, per ray instead of ±0.5 %)",
        &[Rule::Watertight],
        scene,
        None,
    );
    for root in roots {
        case = case.launch_on(Some(root), 64, down_grid(64, 64, 0.0, 0.0, 1.0, 1.0, 0.0));
    }
    case.record(vec![
        ch::hit(),
        ch::t(Tolerance::U16),
        ch::prim(),
        ch::hit_kind(),
    ])
    .build()
}

/// A mesh input with per-primitive SBT offsets (used by other groups).
pub fn with_offsets(
    mut t: Triangles,
    offsets: Vec<u32>,
    size_in_bytes: u32,
    stride: u32,
    flags: Vec<GeometryFlags>,
) -> Triangles {
    t.flags = flags;
    t.sbt_offsets = Some(SbtOffsets {
        offsets,
        size_in_bytes,
        stride,
    });
    t
}
