//! Triangles end to end: hits, misses, facing, barycentrics, the open t interval.
mod common;
use common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
fn raygen__grid() {
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    var p: RtPayload;
    p[0] = 0xFFFFFFFFu;
    let x = (f32(i.x) + 0.5) / f32(d.x);
    let y = (f32(i.y) + 0.5) / f32(d.y);
    rt_trace(params.handle, vec3<f32>(x, y, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    let k = (i.y * d.x + i.x) * 4u;
    out[k] = p[0];
    out[k + 1u] = p[1];
    out[k + 2u] = p[2];
    out[k + 3u] = p[3];
}

fn closesthit__record() {
    rt_set_payload(0u, rt_primitive_index());
    rt_set_payload(1u, rt_hit_kind());
    rt_set_payload(2u, bitcast<u32>(rt_ray_tmax()));
    let b = rt_triangle_barycentrics();
    rt_set_payload(3u, u32(b.x * 1000.0 + 0.5) * 10000u + u32(b.y * 1000.0 + 0.5));
}

fn miss__none() {
    rt_set_payload(0u, 777u);
}
"#;

#[test]
fn a_quad_is_hit_inside_and_missed_outside() {
    let dev = device();
    let dev = dev.as_ref();
    // The quad covers x in [0.25, 0.75], y in [0, 1] at z = 0.
    let gas = triangles(dev, &quad(0.25, 0.75, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(dev, &format!("{HEADER}{PROGRAMS}"));
    let g = groups(
        dev,
        &[
            raygen(m, "raygen__grid"),
            miss(m, "miss__none"),
            closest_hit(m, "closesthit__record"),
        ],
    );
    let p = pipeline(dev, &g, 1);
    let table = sbt(dev, &g, &[]);
    let handle = dev.traversable_handle(gas).unwrap();
    let out = run(dev, p, &table, &params(handle, &[]), 8, 2, 8 * 2 * 4);
    for y in 0..2 {
        for x in 0..8 {
            let k = (y * 8 + x) * 4;
            let px = (x as f32 + 0.5) / 8.0;
            if (0.25..0.75).contains(&px) {
                assert!(
                    out[k] < 2,
                    "pixel {x},{y} should hit, got {:?}",
                    &out[k..k + 4]
                );
                assert_eq!(out[k + 1], 0xFE, "seen from +z the quad is front-facing");
                assert_eq!(f32::from_bits(out[k + 2]), 1.0, "t = 1");
            } else {
                assert_eq!(out[k], 777, "pixel {x},{y} should miss");
            }
        }
    }
}

struct Rig {
    dev: Box<dyn Device>,
    pipeline: Pipeline,
    table: ShaderBindingTable,
    handle: TraversableHandle,
}

/// A RAY_LIST pipeline over one GAS of `vertices`, with the device's accuracy set first.
fn rig(vertices: &[[f32; 3]], accuracy: Accuracy) -> Rig {
    let dev = device();
    dev.set_accuracy(accuracy).unwrap();
    let gas = triangles(dev.as_ref(), vertices, GeometryFlags::NONE);
    let m = module(dev.as_ref(), RAY_LIST);
    let g = ray_list_groups(dev.as_ref(), m, 1, &[]);
    let pipeline = pipeline(dev.as_ref(), &g, 1);
    let table = numbered_sbt(dev.as_ref(), &g);
    let handle = dev.traversable_handle(gas).unwrap();
    Rig {
        dev,
        pipeline,
        table,
        handle,
    }
}

impl Rig {
    fn trace(&self, rays: &[Ray], args: TraceArgs) -> Vec<Rec> {
        trace_rays(
            self.dev.as_ref(),
            self.pipeline,
            &self.table,
            self.handle,
            rays,
            args,
        )
    }
}

const UNIT: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

#[test]
fn barycentrics_facing_and_t() {
    let r = rig(&UNIT, Accuracy::ROBUST);
    let down = |x, y| Ray::new([x, y, 2.0], [0.0, 0.0, -1.0]);
    let up = |x, y| Ray::new([x, y, -3.0], [0.0, 0.0, 1.0]);
    let recs = r.trace(
        &[down(0.25, 0.5), up(0.125, 0.25), down(0.75, 0.75)],
        TraceArgs::default(),
    );
    assert!(recs[0].hit());
    assert_eq!(recs[0].t(), 2.0);
    assert_eq!(
        recs[0].hit_kind(),
        0xFE,
        "counter-clockwise seen from the origin: front"
    );
    let b = recs[0].barycentrics();
    assert!(
        (b[0] - 0.25).abs() < 1e-4 && (b[1] - 0.5).abs() < 1e-4,
        "{b:?}"
    );
    assert!(recs[1].hit());
    assert_eq!(recs[1].t(), 3.0);
    assert_eq!(recs[1].hit_kind(), 0xFF, "seen from below: back");
    assert!(recs[2].missed(), "outside the triangle: {:?}", recs[2]);
    assert_eq!(recs[2].data(), 100, "miss record 0's data");
}

#[test]
fn t_interval_is_open_and_direction_signs_of_zero_do_not_matter() {
    let r = rig(&UNIT, Accuracy::ROBUST);
    let base = Ray::new([0.25, 0.25, 1.0], [0.0, 0.0, -1.0]);
    let negzero = Ray::new([0.25, 0.25, 1.0], [-0.0, -0.0, -1.0]);
    let recs = r.trace(
        &[
            base.interval(0.0, 1.0),
            base.interval(1.0, 2.0),
            base.interval(0.5, 1.5),
            negzero,
            base.interval(-0.0, 1.5),
        ],
        TraceArgs::default(),
    );
    assert!(recs[0].missed(), "t = tmax is outside (tmin, tmax)");
    assert!(recs[1].missed(), "t = tmin is outside (tmin, tmax)");
    assert!(recs[2].hit());
    assert!(recs[3].hit(), "-0.0 direction components equal +0.0");
    assert!(recs[4].hit(), "tmin = -0.0 is valid");
}

#[test]
fn invalid_rays_run_no_program() {
    let r = rig(&UNIT, Accuracy::ROBUST);
    let ok = Ray::new([0.25, 0.25, 1.0], [0.0, 0.0, -1.0]);
    let recs = r.trace(
        &[
            Ray {
                origin: [f32::NAN, 0.25, 1.0],
                ..ok
            },
            Ray {
                direction: [0.0, f32::INFINITY, -1.0],
                ..ok
            },
            ok.interval(-1.0, 5.0),
            ok.interval(3.0, 2.0),
            ok.interval(0.0, f32::NAN),
            ok.interval(f32::NAN, 1.0),
            Ray {
                direction: [0.0, 0.0, 0.0],
                ..ok
            },
            ok.interval(0.0, f32::INFINITY),
        ],
        TraceArgs::default(),
    );
    for (i, rec) in recs[..6].iter().enumerate() {
        assert!(
            rec.untouched(),
            "invalid ray {i} must run no program: {rec:?}"
        );
    }
    assert!(recs[6].missed(), "a zero direction is valid and misses");
    assert!(recs[7].hit(), "tmax = +inf is valid");
}

/// A closed UV sphere of radius about 1 with radially jittered vertices (the leak test of
/// docs/numerics.md), as triangles, and its shared edges.
/// An edge: its two end points.
type Edge = ([f32; 3], [f32; 3]);

fn jittered_sphere(rings: usize, segments: usize) -> (Vec<[f32; 3]>, Vec<Edge>) {
    let mut seed = 0x9E3779B9u32;
    let mut rand = move || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed as f32 / u32::MAX as f32
    };
    let mut grid = vec![[0.0f32; 3]; (rings + 1) * segments];
    for r in 0..=rings {
        for s in 0..segments {
            let theta = r as f32 / rings as f32 * std::f32::consts::PI;
            let phi = s as f32 / segments as f32 * std::f32::consts::TAU;
            let radius = if r == 0 || r == rings {
                1.0
            } else {
                1.0 + 0.5 * rand()
            };
            grid[r * segments + s] = [
                radius * theta.sin() * phi.cos(),
                radius * theta.sin() * phi.sin(),
                radius * theta.cos(),
            ];
        }
    }
    for s in 1..segments {
        grid[s] = grid[0];
        grid[rings * segments + s] = grid[rings * segments];
    }
    let mut tris = Vec::new();
    let mut edges = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let a = grid[r * segments + s];
            let b = grid[r * segments + (s + 1) % segments];
            let c = grid[(r + 1) * segments + s];
            let d = grid[(r + 1) * segments + (s + 1) % segments];
            tris.extend_from_slice(&[a, c, d, a, d, b]);
            edges.push((a, d));
            edges.push((c, d));
        }
    }
    (tris, edges)
}

#[test]
fn watertight_rays_through_shared_edges_and_vertices_never_leak() {
    let (vertices, edges) = jittered_sphere(12, 16);
    let mut rays = Vec::new();
    let origins = [
        [0.1f32, 0.2, -0.3],
        [-0.4, 0.1, 0.2],
        [0.0, 0.0, 0.0],
        [0.3, -0.3, 0.1],
    ];
    for (a, b) in &edges {
        for s in [0.0f32, 0.25, 0.5, 0.75] {
            let target: [f32; 3] = std::array::from_fn(|i| a[i] + s * (b[i] - a[i]));
            for o in origins {
                rays.push(Ray::new(o, std::array::from_fn(|i| target[i] - o[i])));
            }
        }
    }
    let robust = rig(&vertices, Accuracy::ROBUST).trace(&rays, TraceArgs::default());
    let leaks = robust.iter().filter(|r| !r.hit()).count();
    assert_eq!(
        leaks,
        0,
        "watertight: {leaks} of {} rays leaked out of a closed mesh",
        rays.len()
    );
    // The same rays leak through Möller–Trumbore: the test can tell the two apart.
    let fast = rig(&vertices, Accuracy::FAST).trace(&rays, TraceArgs::default());
    let fast_leaks = fast.iter().filter(|r| !r.hit()).count();
    assert!(
        fast_leaks > 0,
        "Möller–Trumbore was expected to leak on these rays"
    );
}

#[test]
fn culling_flags_drop_faces() {
    let r = rig(&UNIT, Accuracy::ROBUST);
    let down = Ray::new([0.25, 0.25, 1.0], [0.0, 0.0, -1.0]);
    let up = Ray::new([0.25, 0.25, -1.0], [0.0, 0.0, 1.0]);
    let cull_back = TraceArgs {
        flags: RayFlags::CULL_BACK_FACING_TRIANGLES.0,
        ..Default::default()
    };
    let recs = r.trace(&[down, up], cull_back);
    assert!(recs[0].hit() && recs[1].missed());
    let cull_front = TraceArgs {
        flags: RayFlags::CULL_FRONT_FACING_TRIANGLES.0,
        ..Default::default()
    };
    let recs = r.trace(&[down, up], cull_front);
    assert!(recs[0].missed() && recs[1].hit());
    let opaque_culled = TraceArgs {
        flags: RayFlags::DISABLE_ANYHIT.0 | RayFlags::CULL_DISABLED_ANYHIT.0,
        ..Default::default()
    };
    assert!(r.trace(&[down], opaque_culled)[0].missed());
    let skip_ch = TraceArgs {
        flags: RayFlags::DISABLE_CLOSESTHIT.0,
        ..Default::default()
    };
    assert!(
        r.trace(&[down], skip_ch)[0].untouched(),
        "a hit without closest-hit runs nothing"
    );
}

#[test]
fn both_accuracy_settings_find_the_same_clear_hits() {
    let grid: Vec<[f32; 3]> = (0..8)
        .flat_map(|i| quad(i as f32, i as f32 + 1.0, 0.0, 1.0, i as f32 * 0.1))
        .collect();
    for accuracy in [Accuracy::ROBUST, Accuracy::FAST] {
        let r = rig(&grid, accuracy);
        let rays: Vec<Ray> = (0..32)
            .map(|k| Ray::new([k as f32 * 0.25 + 0.1, 0.4, 5.0], [0.0, 0.0, -1.0]))
            .collect();
        let recs = r.trace(&rays, TraceArgs::default());
        for (k, rec) in recs.iter().enumerate() {
            assert!(rec.hit(), "{accuracy:?} ray {k}");
            let cell = (k as f32 * 0.25 + 0.1).floor();
            assert!(
                (rec.t() - (5.0 - cell * 0.1)).abs() < 1e-5,
                "{accuracy:?} ray {k}: t {}",
                rec.t()
            );
            assert_eq!(rec.prim() / 2, cell as u32);
        }
    }
}
