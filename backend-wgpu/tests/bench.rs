//! The benchmark entry point runs and its numbers are sane (timing itself is for the GPU
//! machine; lavapipe only checks that it works).

#[test]
fn bench_trace_reports_both_ray_kinds() {
    let (v, i) = optik_wgpu::bench::bumpy_sphere(16);
    let report =
        optik_wgpu::bench::bench_trace(&v, &i, 64, 32, 1, optik_api::Accuracy::ROBUST).unwrap();
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
    assert!(report.stack_entries >= 8, "{report}");
}
