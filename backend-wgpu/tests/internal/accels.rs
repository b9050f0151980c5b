//! Acceleration structure lifecycle: updates, compaction, memory reports, and scenes split
//! across several storage bindings.

use crate::common::*;
use optik_api::*;
use optik_wgpu::WgpuDeviceExt;

#[test]
fn scenes_larger_than_one_storage_binding_are_split() {
    // 64 KiB per binding: a 64×64 grid of quads (8192 triangles) spans several.
    let dev = optik_wgpu::WgpuBackend::with_options(optik_wgpu::WgpuOptions {
        max_storage_binding: Some(64 * 1024),
        ..Default::default()
    })
    .map(optik_wgpu::WgpuDevice::new)
    .unwrap();
    let d: &dyn Device = &dev;
    let n = 64;
    let vertices: Vec<[f32; 3]> = (0..n * n)
        .flat_map(|k| {
            let (x, y) = ((k % n) as f32, (k / n) as f32);
            quad(x, x + 1.0, y, y + 1.0, (k % 7) as f32 * 0.125)
        })
        .collect();
    let gas = triangles(d, &vertices, GeometryFlags::NONE);
    assert!(
        d.accel_size(gas).unwrap() > 4 * 64 * 1024,
        "the structure spans several bindings"
    );
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let p = pipeline(d, &g, 1);
    let src = dev.kernel_source(p).unwrap();
    assert!(
        src.contains("_optik_scene4"),
        "the kernel binds every chunk"
    );
    let table = numbered_sbt(d, &g);
    let rays: Vec<Ray> = (0..n * n)
        .step_by(37)
        .map(|k| {
            Ray::new(
                [(k % n) as f32 + 0.7, (k / n) as f32 + 0.2, 5.0],
                [0.0, 0.0, -1.0],
            )
        })
        .collect();
    let recs = trace_rays(
        d,
        p,
        &table,
        d.traversable_handle(gas).unwrap(),
        &rays,
        TraceArgs::default(),
    );
    for (i, rec) in recs.iter().enumerate() {
        let k = i * 37;
        assert!(rec.hit(), "ray {i}");
        assert_eq!(
            rec.prim() / 2,
            k as u32,
            "ray {i} hit quad {}",
            rec.prim() / 2
        );
        assert!((rec.t() - (5.0 - (k % 7) as f32 * 0.125)).abs() < 1e-5);
    }
}
