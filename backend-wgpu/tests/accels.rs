//! Acceleration structure lifecycle: updates, compaction, memory reports, and scenes split
//! across several storage bindings.
mod common;
use common::*;
use optik_api::*;

fn hits(dev: &dyn Device, top: TraversableHandle, rays: &[Ray]) -> Vec<Rec> {
    let m = module(dev, RAY_LIST);
    let g = ray_list_groups(dev, m, 1, &[]);
    let p = pipeline(dev, &g, 1);
    let table = numbered_sbt(dev, &g);
    trace_rays(dev, p, &table, top, rays, TraceArgs::default())
}

#[test]
fn update_moves_geometry_and_keeps_the_handle() {
    let dev = device();
    let d = dev.as_ref();
    let vb = buffer(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0));
    let input = BuildInput::Triangles(TriangleArray::new(
        BufferView::new(vb),
        6,
        GeometryFlags::NONE,
    ));
    let options = AccelBuildOptions {
        flags: BuildFlags::ALLOW_UPDATE,
        ..Default::default()
    };
    let gas = d
        .accel_build(&options, std::slice::from_ref(&input))
        .unwrap();
    let h = d.traversable_handle(gas).unwrap();
    let rays = [
        Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
        Ray::new([5.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
    ];
    let before = hits(d, h, &rays);
    assert!(before[0].hit() && before[1].missed());
    d.write_buffer(vb, 0, bytemuck::cast_slice(&quad(5.0, 6.0, 0.0, 1.0, 0.0)))
        .unwrap();
    let update = AccelBuildOptions {
        operation: BuildOperation::Update,
        ..options
    };
    d.accel_update(gas, &update, &[input]).unwrap();
    assert_eq!(
        d.traversable_handle(gas).unwrap(),
        h,
        "updates keep the handle"
    );
    let after = hits(d, h, &rays);
    assert!(
        after[0].missed() && after[1].hit(),
        "the refit structure follows the moved quad"
    );
}

#[test]
fn compaction_copies_and_reports_sizes() {
    let dev = device();
    let d = dev.as_ref();
    let vb = buffer(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0));
    let input = BuildInput::Triangles(TriangleArray::new(
        BufferView::new(vb),
        6,
        GeometryFlags::NONE,
    ));
    let options = AccelBuildOptions {
        flags: BuildFlags::ALLOW_COMPACTION,
        ..Default::default()
    };
    let estimate = d
        .accel_memory_usage(&options, std::slice::from_ref(&input))
        .unwrap();
    let gas = d.accel_build(&options, &[input]).unwrap();
    let size = d.accel_size(gas).unwrap();
    assert!(
        size > 0 && size <= estimate.output_size_in_bytes,
        "{size} vs {estimate:?}"
    );
    let compact = d.accel_compact(gas).unwrap();
    assert_eq!(d.accel_size(compact).unwrap(), size);
    let h = d.traversable_handle(compact).unwrap();
    assert_ne!(h, d.traversable_handle(gas).unwrap());
    d.destroy_accel(gas).unwrap();
    assert!(
        hits(d, h, &[Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0])])[0].hit(),
        "the copy stands alone"
    );
}

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
