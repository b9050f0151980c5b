//! The benchmark entry points run and their numbers are sane (timing itself is for the GPU
//! machine; lavapipe only checks that it works), and the traffic counters count what the
//! layout says a ray reads.

use crate::common::*;
use optik_api::*;
use optik_wgpu::bench::{BenchConfig, TrafficCounts};
use optik_wgpu::{WgpuBackend, WgpuDevice, WgpuDeviceExt};

fn small_config() -> BenchConfig {
    BenchConfig {
        width: 64,
        height: 32,
        repeats: 1,
        accuracy: Accuracy::ROBUST,
        bandwidth_bytes: 1 << 20,
        traffic: true,
        camera: None,
    }
}

#[test]
fn bench_trace_reports_both_ray_kinds() {
    let (v, i) = optik_wgpu::bench::bumpy_sphere(16);
    let report = optik_wgpu::bench::bench_trace(&v, &i, &small_config()).unwrap();
    assert_eq!(report.triangles, 16 * 32 * 2);
    assert_eq!(report.timings.len(), 2);
    let primary = &report.timings[0];
    assert_eq!(primary.rays, 64 * 32);
    // The camera frames the sphere: a good share of pixels hit, not all.
    assert!(
        primary.hits > 200 && primary.hits < primary.rays,
        "{report}"
    );
    // Origins inside the sphere's box: most random rays hit the closed surface.
    let incoherent = &report.timings[1];
    assert!(incoherent.hits > incoherent.rays / 2, "{report}");
    assert!(incoherent.wall_seconds > 0.0 && primary.mrays_per_second() > 0.0);
    assert!(report.to_string().contains("incoherent"));
    assert!(report.stack_entries.unwrap() >= 8, "{report}");
    // One trace per ray, at least the root node each, and bytes that add up.
    for t in &report.timings {
        let c = t.traffic.unwrap();
        assert_eq!(c.traces, t.rays, "{report}");
        assert!(c.nodes >= t.rays && c.primitives > 0, "{report}");
        let per_ray = t.bytes_per_ray().unwrap();
        assert!(per_ray >= 128.0 + 16.0, "{report}");
        assert!(t.achieved_gbps().unwrap() > 0.0);
    }
    // Incoherent rays from inside a closed surface visit more of the tree than camera rays.
    assert!(
        report.timings[1].bytes_per_ray() > report.timings[0].bytes_per_ray(),
        "{report}"
    );
    let b = report.bandwidth.as_ref().unwrap();
    assert!(b.read_gbps > 0.0 && b.copy_gbps > 0.0, "{report}");
    assert_eq!(b.bytes, 1 << 20);
    assert!(report.to_string().contains("B/ray"), "{report}");
}

#[test]
fn bench_device_runs_the_same_rays_through_the_public_api() {
    let (v, i) = optik_wgpu::bench::bumpy_sphere(16);
    let dev = device();
    let report = optik_wgpu::bench::bench_device(dev.as_ref(), &v, &i, &small_config()).unwrap();
    let direct = optik_wgpu::bench::bench_trace(
        &v,
        &i,
        &BenchConfig {
            traffic: false,
            bandwidth_bytes: 0,
            ..small_config()
        },
    )
    .unwrap();
    // The same rays give the same hits, whichever way they are launched.
    for (a, b) in report.timings.iter().zip(&direct.timings) {
        assert_eq!(a.hits, b.hits, "{report}\n{direct}");
        assert!(a.gpu_seconds.is_none() && a.traffic.is_none());
    }
    assert!(direct.bandwidth.is_none());
    assert!(report.timing_method.contains("wall clock"));
    // A camera inside the closed sphere: every primary ray hits.
    let inside = optik_wgpu::bench::bench_device(
        dev.as_ref(),
        &v,
        &i,
        &BenchConfig {
            camera: Some(optik_wgpu::bench::Camera {
                eye: [0.0, 0.0, 0.0],
                view: [0.0, 0.0, -1.0],
                horizontal_fov_degrees: 90.0,
            }),
            ..small_config()
        },
    )
    .unwrap();
    assert_eq!(inside.timings[0].hits, inside.timings[0].rays, "{inside}");
    assert!(inside.to_string().contains("90.0 deg"), "{inside}");
}

/// One ray through the structure `accel` counted by the instrumented kernel.
fn count_one_ray(dev: &WgpuDevice, accel: Accel, ray: Ray) -> (TrafficCounts, Rec) {
    let d: &dyn Device = dev;
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let p = pipeline(d, &g, 1);
    let table = numbered_sbt(d, &g);
    let h = d.traversable_handle(accel).unwrap();
    let rays = buffer(
        d,
        &[
            [ray.origin[0], ray.origin[1], ray.origin[2], ray.tmin],
            [
                ray.direction[0],
                ray.direction[1],
                ray.direction[2],
                ray.tmax,
            ],
        ],
    );
    let out = d.create_buffer(32).unwrap();
    let mut words = h.to_words().to_vec();
    words.extend_from_slice(&[0, 0, 1, 0, 0xFF, 0]);
    let counts = optik_wgpu::bench::launch_counted(
        dev,
        p,
        bytemuck::cast_slice(&words),
        &[Resource::buffer(1, out), Resource::buffer(2, rays)],
        &table,
        LaunchSize::new(1, 1, 1),
    )
    .unwrap();
    let rec = Rec {
        words: read::<u32>(d, out).try_into().unwrap(),
    };
    // The normal kernel never carries the counters, even after a counted launch.
    let source = dev.kernel_source(p).unwrap();
    assert!(
        !source.contains("_optik_count"),
        "counters in a normal kernel"
    );
    (counts, rec)
}

#[test]
fn counts_match_the_layout() {
    let dev = WgpuBackend::new().map(WgpuDevice::new).unwrap();
    let gas = triangles(&dev, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    // A miss outside the structure's box: the root node and the header, nothing else.
    let (miss, rec) = count_one_ray(&dev, gas, Ray::new([5.0, 5.0, 1.0], [0.0, 0.0, -1.0]));
    assert!(rec.missed(), "{rec:?}");
    assert_eq!(miss.traces, 1);
    assert_eq!(miss.handle_reads, 1);
    assert_eq!(miss.nodes, 1, "{miss:?}");
    assert_eq!(miss.primitives, 0, "{miss:?}");
    // Two header words (_optik_enter) and the node's eight.
    assert_eq!(miss.arena_fetches, 2 + 8, "{miss:?}");
    assert_eq!(miss.memory_bytes(), 16 * (10 + 1));
    // A hit: every fetch is a header word, a node word or a triangle record's (three).
    let (hit, rec) = count_one_ray(&dev, gas, Ray::new([0.25, 0.5, 1.0], [0.0, 0.0, -1.0]));
    assert!(rec.hit(), "{rec:?}");
    assert!(hit.primitives >= 1, "{hit:?}");
    assert_eq!(
        hit.arena_fetches,
        2 + 8 * hit.nodes + 3 * hit.primitives,
        "{hit:?}"
    );
    assert_eq!(hit.node_bytes(), 128 * hit.nodes);
    assert_eq!(
        hit.other_arena_bytes(),
        16 * (2 + 3 * hit.primitives),
        "{hit:?}"
    );
    // Every entry pushed is popped, plus the root entry the traversal starts with.
    assert_eq!(hit.stack_pops, hit.stack_pushes + 1, "{hit:?}");
    assert_eq!(hit.stack_bytes(), 8 * (2 * hit.stack_pushes + 1));
}

#[test]
fn instance_traffic_is_counted() {
    let dev = WgpuBackend::new().map(WgpuDevice::new).unwrap();
    let d: &dyn Device = &dev;
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let child = d.traversable_handle(gas).unwrap();
    // Two instances of the quad, at z = 0 and z = -0.5: the ray enters the near one; the
    // far one's entry is popped beyond the hit and skipped unread.
    let instances = [0.0f32, -0.5].map(|z| Instance {
        transform: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, z],
        ..Instance::new(child)
    });
    let b = buffer(d, &instances);
    let ias = d
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Instances(InstanceArray {
                instances: BufferView::new(b),
                num_instances: 2,
            })],
        )
        .unwrap();
    let (c, rec) = count_one_ray(&dev, ias, Ray::new([0.25, 0.5, 1.0], [0.0, 0.0, -1.0]));
    assert!(rec.hit() && rec.t() == 1.0, "{rec:?}");
    assert_eq!(c.traces, 1);
    assert_eq!(c.instances, 1, "{c:?}");
    // The root's handle and the entered instance's child.
    assert_eq!(c.handle_reads, 2, "{c:?}");
    // The IAS's header words (2) when the walk starts; the instance's flags word for its
    // mask (1) when its leaf is popped; its child link, world-to-object rows and flags word
    // (5: the object-to-world rows are read only for a hit's frame) and its child's header
    // words (2) when its marker builds its level; nodes of both levels (8 each), triangles
    // (3 each); the instance's ids word for the one candidate (1: read from the path, not
    // carried in the level); the IAS's header words again (2) when the walk leaves the
    // instance (levels are built from the world ray, not saved).
    assert_eq!(
        c.arena_fetches,
        2 + 1 + (5 + 2) + 8 * c.nodes + 3 * c.primitives + 1 + 2,
        "{c:?}"
    );
    assert!(c.nodes >= 2, "{c:?}");
    assert_eq!(c.instance_bytes(), 80);
    // The two level markers and the child's root entry are pushes too: all are popped.
    assert_eq!(c.stack_pops, c.stack_pushes + 1, "{c:?}");
    assert!(c.stack_pushes >= 2 + 2, "{c:?}");
}

#[test]
fn normal_pipelines_contain_no_counters() {
    let dev = WgpuBackend::new().map(WgpuDevice::new).unwrap();
    let d: &dyn Device = &dev;
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let h = d.traversable_handle(gas).unwrap();
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let p = pipeline(d, &g, 1);
    let table = numbered_sbt(d, &g);
    let recs = trace_rays(
        d,
        p,
        &table,
        h,
        &[Ray::new([0.25, 0.5, 1.0], [0.0, 0.0, -1.0])],
        TraceArgs::default(),
    );
    assert!(recs[0].hit());
    let source = dev.kernel_source(p).unwrap();
    assert!(
        source.contains("fn _optik_traverse"),
        "not the traversal kernel"
    );
    for word in ["_optik_count", "_optik_counters", "atomic"] {
        assert!(!source.contains(word), "`{word}` in a normal kernel");
    }
}
