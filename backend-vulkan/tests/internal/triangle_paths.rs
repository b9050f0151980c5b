//! The triangle paths: optik's triangle stage (the default, watertight; Möller–Trumbore) and
//! the driver's triangles (`TriangleTest::Driver`) give the same answers wherever the driver
//! follows optik's semantics: facing decided in object space and flipped per instance, face
//! culling with its geometry and instance overrides, the open interval, barycentrics,
//! degenerate and NaN triangles, vertices, opacity and any-hit. Only optik's watertight test
//! keeps rays from inside a closed mesh from leaking through its vertices and edges, and only
//! optik's stage culls both faces when a ray asks for both.

use crate::common::*;
use optik_api::*;

/// Rays from a buffer, one hit record out per ray.
const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, n: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
// origin xyz, tmin, direction xyz, tmax, flags (bits)
@group(0) @binding(2) var<storage, read> rays: array<f32>;

const WORDS: u32 = 8u;

fn raygen__rg() {
    let i = rt_launch_index().x;
    let b = i * 9u;
    var p: RtPayload;
    p[0] = 0xFFFFu;
    rt_trace(params.handle, vec3<f32>(rays[b], rays[b + 1u], rays[b + 2u]), vec3<f32>(rays[b + 4u], rays[b + 5u], rays[b + 6u]),
        rays[b + 3u], rays[b + 7u], 0.0, 0xFFu, bitcast<u32>(rays[b + 8u]), 0u, 1u, 0u, &p);
    for (var k = 0u; k < WORDS; k++) {
        out[i * WORDS + k] = p[k];
    }
}

fn closesthit__ch() {
    let bary = rt_triangle_barycentrics();
    let v = rt_triangle_vertices();
    rt_set_payload(0u, rt_primitive_index());
    rt_set_payload(1u, rt_hit_kind());
    rt_set_payload(2u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(3u, bitcast<u32>(bary.x));
    rt_set_payload(4u, bitcast<u32>(bary.y));
    rt_set_payload(5u, rt_instance_id());
    rt_set_payload(6u, select(0u, 1u, rt_is_front_face_hit()));
    rt_set_payload(7u, bitcast<u32>(v[1].x + v[1].y + v[2].x + v[2].y + f32(rt_get_attribute(2u) + rt_get_attribute(7u))));
}

fn miss__ms() {
}
"#;

const WORDS: usize = 8;

/// One ray: origin, tmin, direction, tmax, ray flags.
#[derive(Clone, Copy)]
struct Ray {
    origin: [f32; 3],
    tmin: f32,
    direction: [f32; 3],
    tmax: f32,
    flags: RayFlags,
}

impl Ray {
    fn down(x: f32, y: f32, flags: RayFlags) -> Ray {
        Ray {
            origin: [x, y, 5.0],
            tmin: 0.0,
            direction: [0.0, 0.0, -1.0],
            tmax: 100.0,
            flags,
        }
    }

    fn words(&self) -> [f32; 9] {
        let o = self.origin;
        let d = self.direction;
        [
            o[0],
            o[1],
            o[2],
            self.tmin,
            d[0],
            d[1],
            d[2],
            self.tmax,
            f32::from_bits(self.flags.0),
        ]
    }
}

/// The accuracy settings of the three triangle paths.
fn paths() -> [Accuracy; 3] {
    [
        Accuracy::ROBUST,
        Accuracy {
            triangle: TriangleTest::MollerTrumbore,
            box_test: BoxTest::Conservative,
        },
        Accuracy {
            triangle: TriangleTest::Driver,
            box_test: BoxTest::Conservative,
        },
    ]
}

/// Casts `rays` against `handle`; the hit record of each (`[0xFFFF, ..]` on a miss).
fn cast(dev: &TestDevice, handle: TraversableHandle, rays: &[Ray]) -> Vec<[u32; WORDS]> {
    let m = dev.module(PROGRAMS);
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let ch = dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__ch")));
    let pipeline = dev.pipeline(&[rg, ms, ch], 1);
    let mut table = Table::new(rg);
    table.miss.push((ms, &[]));
    table.hit.push((ch, &[]));
    let sbt = table.build(dev);
    let words: Vec<f32> = rays.iter().flat_map(|r| r.words()).collect();
    let ray_buffer = dev.f32_buffer(&words);
    let out = run_rays(
        dev,
        pipeline,
        &sbt,
        handle,
        rays.len() as u32,
        WORDS as u32,
        &[Resource::buffer(2, ray_buffer)],
    );
    dev.destroy_pipeline(pipeline).unwrap();
    out.chunks(WORDS)
        .map(|c| std::array::from_fn(|k| c[k]))
        .collect()
}

/// A GAS of one input of `triangles` with `flags` and vertex access.
fn gas(dev: &TestDevice, triangles: &[[f32; 3]], flags: GeometryFlags) -> Accel {
    let flat: Vec<f32> = triangles.iter().flatten().copied().collect();
    let input = TriangleArray::new(
        BufferView::new(dev.f32_buffer(&flat)),
        triangles.len() as u32,
        flags,
    );
    let options = AccelBuildOptions {
        flags: BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        ..Default::default()
    };
    dev.accel_build(&options, &[BuildInput::Triangles(input)])
        .unwrap()
}

const CCW: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
const CW: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]];

#[test]
fn every_triangle_path_agrees_on_facing_culling_intervals_and_attributes() {
    use semantics::opacity::triangle_face_culled;
    // Instance i sits at x = 2i: (triangle, geometry flags, instance flags).
    let cases: [([[f32; 3]; 3], GeometryFlags, InstanceFlags); 5] = [
        (CCW, GeometryFlags::NONE, InstanceFlags::NONE),
        (
            CCW,
            GeometryFlags::NONE,
            InstanceFlags::FLIP_TRIANGLE_FACING,
        ),
        (CW, GeometryFlags::NONE, InstanceFlags::NONE),
        (
            CW,
            GeometryFlags::NONE,
            InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING,
        ),
        (
            CW,
            GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING,
            InstanceFlags::NONE,
        ),
    ];
    let cull = [
        RayFlags::NONE,
        RayFlags::CULL_BACK_FACING_TRIANGLES,
        RayFlags::CULL_FRONT_FACING_TRIANGLES,
        RayFlags::CULL_BACK_FACING_TRIANGLES | RayFlags::CULL_FRONT_FACING_TRIANGLES,
    ];
    for accuracy in paths() {
        let dev = device();
        dev.set_accuracy(accuracy).unwrap();
        let mut instances = Vec::new();
        for (i, (tri, g, f)) in cases.iter().enumerate() {
            let child = dev.traversable_handle(gas(&dev, tri, *g)).unwrap();
            let mut inst = Instance::new(child);
            inst.transform[3] = 2.0 * i as f32;
            inst.instance_id = i as u32;
            inst.flags = f.0;
            instances.push(inst);
        }
        let ias = dev.instances(&instances);
        let mut rays = Vec::new();
        for flags in cull {
            for i in 0..cases.len() {
                rays.push(Ray::down(2.0 * i as f32 + 0.25, 0.5, flags));
            }
        }
        let out = cast(&dev, dev.traversable_handle(ias).unwrap(), &rays);
        for (ray, r) in rays.iter().zip(&out) {
            let i = ((ray.origin[0] - 0.25) / 2.0) as usize;
            let (tri, g, f) = cases[i];
            // Seen from +z: counter-clockwise is front; the instance flag swaps.
            let front = (tri == CCW) != f.contains(InstanceFlags::FLIP_TRIANGLE_FACING);
            let both = ray.flags.contains(RayFlags::CULL_FRONT_FACING_TRIANGLES)
                && ray.flags.contains(RayFlags::CULL_BACK_FACING_TRIANGLES);
            let flags = if both && accuracy.triangle == TriangleTest::Driver {
                // Vulkan cannot take both face-culling flags: native triangles keep back-face
                // culling only (docs/vulkan-backend.md §11).
                RayFlags::CULL_BACK_FACING_TRIANGLES
            } else {
                ray.flags
            };
            let what = format!("{accuracy:?}: instance {i}, flags {:?}", ray.flags);
            if triangle_face_culled(front, g, f, flags) {
                assert_eq!(r[0], 0xFFFF, "{what}: culled");
                continue;
            }
            assert_eq!(r[0], 0, "{what}: a hit");
            assert_eq!(r[1], semantics::facing::triangle_hit_kind(front), "{what}");
            assert_eq!(r[6], u32::from(front), "{what}: rt_is_front_face_hit");
            assert_eq!(f32::from_bits(r[2]), 5.0, "{what}: t");
            assert_eq!(r[5], i as u32, "{what}: instance id");
            // (0.25, 0.5) in the triangle's own vertex order.
            let (u, v) = if tri == CCW { (0.25, 0.5) } else { (0.5, 0.25) };
            assert!(
                (f32::from_bits(r[3]) - u).abs() < 1e-6 && (f32::from_bits(r[4]) - v).abs() < 1e-6,
                "{what}: barycentrics {} {}",
                f32::from_bits(r[3]),
                f32::from_bits(r[4])
            );
            // Vertices 1 and 2 (object space) and attributes 2 and 7, which triangles leave 0.
            assert_eq!(f32::from_bits(r[7]), 2.0, "{what}: vertices and attributes");
        }
    }
}

#[test]
fn every_triangle_path_hits_in_the_open_interval_and_never_hits_degenerate_or_nan_triangles() {
    for accuracy in paths() {
        let dev = device();
        dev.set_accuracy(accuracy).unwrap();
        // 0: a triangle at z = 0; 1: degenerate (collinear) at x = 2; 2: NaN vertex at x = 4;
        // 3: its neighbour sharing two vertices at x = 4..5.
        let n = f32::NAN;
        let tris = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0],
            [3.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [n, 1.0, 0.0],
            [4.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [4.0, 1.0, 0.0],
        ];
        let g = gas(&dev, &tris, GeometryFlags::DISABLE_ANYHIT);
        let at = |x: f32, tmin: f32, tmax: f32| Ray {
            tmin,
            tmax,
            ..Ray::down(x, 0.25, RayFlags::NONE)
        };
        let rays = [
            at(0.25, 0.0, 5.0),
            at(0.25, 5.0, 6.0),
            at(0.25, 0.0, 5.0f32.next_up()),
            at(2.5, 0.0, 100.0),
            at(4.25, 0.0, 100.0),
        ];
        let out = cast(&dev, dev.traversable_handle(g).unwrap(), &rays);
        let what = format!("{accuracy:?}");
        assert_eq!(out[0][0], 0xFFFF, "{what}: t = tmax is outside");
        assert_eq!(out[1][0], 0xFFFF, "{what}: t = tmin is outside");
        assert_eq!(out[2][0], 0, "{what}: just inside tmax");
        assert_eq!(
            out[3][0], 0xFFFF,
            "{what}: a degenerate triangle never hits"
        );
        assert_eq!(
            out[4][0], 3,
            "{what}: the NaN triangle's neighbour still hits"
        );
    }
}

#[test]
fn every_triangle_path_runs_any_hit_and_opacity_as_optik_defines() {
    for accuracy in paths() {
        let dev = device();
        dev.set_accuracy(accuracy).unwrap();
        crate::anyhit::check(&dev);
    }
}

/// Rays from `inside` aimed exactly at every vertex and every edge midpoint of a mesh.
fn aimed_at_vertices_and_edges(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    inside: [f32; 3],
) -> Vec<Ray> {
    let mut targets = positions.to_vec();
    for t in triangles {
        for e in 0..3 {
            let (a, b) = (positions[t[e] as usize], positions[t[(e + 1) % 3] as usize]);
            targets.push(std::array::from_fn(|k| 0.5 * (a[k] + b[k])));
        }
    }
    targets
        .iter()
        .map(|p| Ray {
            origin: inside,
            tmin: 0.0,
            direction: std::array::from_fn(|k| p[k] - inside[k]),
            tmax: f32::INFINITY,
            flags: RayFlags::DISABLE_ANYHIT,
        })
        .collect()
}

#[test]
fn optik_watertight_triangles_never_let_rays_out_of_a_closed_mesh() {
    let (positions, triangles) = optik_api::shapes::icosphere(3);
    let inside = [0.0123, -0.0311, 0.0217];
    let rays = aimed_at_vertices_and_edges(&positions, &triangles, inside);
    for accuracy in paths() {
        let dev = device();
        // optik's own stage, also when the suite runs with the driver's triangles mixed in
        // (OPTIK_VULKAN_DRIVER_TRIANGLES=1, whatever the driver's check says).
        dev.set_driver_triangles(false).unwrap();
        dev.set_accuracy(accuracy).unwrap();
        let vb = dev.f32_buffer(&positions.iter().flatten().copied().collect::<Vec<_>>());
        let ib = dev.u32_buffer(&triangles.iter().flatten().copied().collect::<Vec<_>>());
        let input = TriangleArray::new(
            BufferView::new(vb),
            positions.len() as u32,
            GeometryFlags::DISABLE_ANYHIT,
        )
        .with_indices(BufferView::new(ib), triangles.len() as u32);
        let g = dev
            .accel_build(
                &AccelBuildOptions::default(),
                &[BuildInput::Triangles(input)],
            )
            .unwrap();
        let out = cast(&dev, dev.traversable_handle(g).unwrap(), &rays);
        let escaped = out.iter().filter(|r| r[0] == 0xFFFF).count();
        eprintln!(
            "{:?}: {escaped} of {} rays aimed at vertices and edges escaped",
            accuracy.triangle,
            rays.len()
        );
        if accuracy.triangle == TriangleTest::Watertight {
            assert_eq!(escaped, 0, "optik's watertight test leaks");
        }
    }
}

/// The default on a driver that passed optik's check (docs/vulkan-backend.md §2.4): static
/// triangles are the driver's, and optik's stage serves what the driver's cannot (motion
/// keys, face-culling records, motion transforms, instances that disable face culling under
/// rays culling both faces), in one scene and one pipeline, with the answers of optik's stage
/// alone everywhere the rays stay away from edges and vertices (where the driver may differ:
/// lavapipe's leaks). Refit and destroyed structures keep the box twins in step.
#[test]
fn the_default_mixes_the_drivers_triangles_with_optiks_and_answers_as_optiks_alone() {
    let cull = [
        RayFlags::NONE,
        RayFlags::CULL_BACK_FACING_TRIANGLES,
        RayFlags::CULL_FRONT_FACING_TRIANGLES,
        RayFlags::CULL_BACK_FACING_TRIANGLES | RayFlags::CULL_FRONT_FACING_TRIANGLES,
    ];
    let scene = |dev: &TestDevice, vb: Buffer| -> (Accel, Vec<Accel>) {
        let static_options = AccelBuildOptions {
            flags: BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS | BuildFlags::ALLOW_UPDATE,
            ..Default::default()
        };
        let input = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::NONE);
        let plain = dev
            .accel_build(&static_options, &[BuildInput::Triangles(input)])
            .unwrap();
        let unculled = gas(dev, &CW, GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING);
        let mut keyed = TriangleArray::new(
            BufferView::new(dev.f32_buffer(&CCW.concat())),
            3,
            GeometryFlags::DISABLE_ANYHIT,
        );
        keyed
            .vertex_buffers
            .push(BufferView::new(dev.f32_buffer(&CCW.concat())));
        let motion = MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: 0.0,
            time_end: 1.0,
        };
        let moving = dev
            .accel_build(
                &AccelBuildOptions {
                    motion: Some(motion),
                    ..Default::default()
                },
                &[BuildInput::Triangles(keyed)],
            )
            .unwrap();
        let transform = dev
            .create_transform(&TransformDesc::MatrixMotion {
                child: dev.traversable_handle(plain).unwrap(),
                motion,
                keys: vec![IDENTITY_3X4, IDENTITY_3X4],
            })
            .unwrap();
        // Instance i at x = 2i: (child, instance flags).
        let children = [
            (plain, InstanceFlags::NONE),
            (plain, InstanceFlags::FLIP_TRIANGLE_FACING),
            (plain, InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING),
            (unculled, InstanceFlags::NONE),
            (moving, InstanceFlags::NONE),
            (transform, InstanceFlags::FLIP_TRIANGLE_FACING),
        ];
        let instances: Vec<Instance> = children
            .iter()
            .enumerate()
            .map(|(i, (child, flags))| {
                let mut inst = Instance::new(dev.traversable_handle(*child).unwrap());
                inst.transform[3] = 2.0 * i as f32;
                inst.instance_id = i as u32;
                inst.flags = flags.0;
                inst
            })
            .collect();
        (
            dev.instances(&instances),
            vec![plain, unculled, moving, transform],
        )
    };
    let mut rays = Vec::new();
    for flags in cull {
        for i in 0..6 {
            let x = 2.0 * i as f32;
            rays.push(Ray::down(x + 0.25, 0.5, flags));
            rays.push(Ray {
                origin: [x + 0.5, 0.25, -5.0],
                direction: [0.0, 0.0, 1.0],
                ..Ray::down(0.0, 0.0, flags)
            });
        }
    }
    let answers = |driver_triangles: bool| {
        let dev = device();
        dev.set_driver_triangles(driver_triangles).unwrap();
        assert_eq!(dev.driver_triangles(), driver_triangles);
        let vb = dev.f32_buffer(&CCW.concat());
        let (ias, parts) = scene(&dev, vb);
        let handle = dev.traversable_handle(ias).unwrap();
        let held: Vec<bool> = parts
            .iter()
            .map(|p| dev.holds_driver_triangles(dev.traversable_handle(*p).unwrap()))
            .collect();
        // Only the static structure without face-culling records is the driver's (where
        // the device can skip triangles for rays culling both faces).
        let mixed = driver_triangles && dev.info().primitive_culling;
        assert_eq!(held, [mixed, false, false, false]);
        let m = dev.module(PROGRAMS);
        let groups = [
            dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg"))),
            dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__ch"))),
        ];
        let p = dev.pipeline(&groups, 1);
        assert_eq!(dev.pipeline_features(p).unwrap().driver_triangles, mixed);
        dev.destroy_pipeline(p).unwrap();
        let before = cast(&dev, handle, &rays);
        // A refit moves the static triangle 0.5 up in y; the paths above (the box twin of
        // the instance that disables culling included) follow.
        let moved: Vec<f32> = CCW.iter().flat_map(|v| [v[0], v[1] + 0.5, v[2]]).collect();
        dev.write_buffer(vb, 0, bytemuck::cast_slice(&moved))
            .unwrap();
        let update = AccelBuildOptions {
            flags: BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS | BuildFlags::ALLOW_UPDATE,
            operation: BuildOperation::Update,
            ..Default::default()
        };
        let input = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::NONE);
        dev.accel_update(parts[0], &update, &[BuildInput::Triangles(input)])
            .unwrap();
        let after = cast(&dev, handle, &rays);
        dev.destroy_accel(parts[0]).unwrap();
        let gone = cast(&dev, handle, &rays);
        dev.assert_no_messages();
        (before, after, gone)
    };
    let optik = answers(false);
    let mixed = answers(true);
    // Möller–Trumbore, the fast option, takes the driver's triangles too where they serve.
    let dev = device();
    dev.set_driver_triangles(true).unwrap();
    dev.set_accuracy(Accuracy {
        triangle: TriangleTest::MollerTrumbore,
        box_test: BoxTest::Conservative,
    })
    .unwrap();
    let g = gas(&dev, &CCW, GeometryFlags::NONE);
    assert_eq!(
        dev.holds_driver_triangles(dev.traversable_handle(g).unwrap()),
        dev.info().primitive_culling
    );
    for (what, a, b) in [
        ("built", &optik.0, &mixed.0),
        ("refit", &optik.1, &mixed.1),
        ("destroyed", &optik.2, &mixed.2),
    ] {
        for (k, (x, y)) in a.iter().zip(b).enumerate() {
            assert_eq!(x, y, "{what}: ray {k} ({:?})", rays[k].flags);
        }
    }
    // The scene is not empty: both faces culled by the instance that disables culling still
    // hits (its box twin), and the refit moved the hits.
    assert!(optik.0.iter().filter(|r| r[0] == 0).count() > 20);
    assert_ne!(optik.0, optik.1);
}
