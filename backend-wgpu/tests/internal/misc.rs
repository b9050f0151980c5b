//! Programs from several modules, vertex and index formats, vertex data access, textures,
//! 3D launch indices, instance flag precedence, scenes that grow after linking.

use crate::common::*;
use optik_api::*;
use optik_wgpu::WgpuDeviceExt;

#[test]
fn scenes_that_grow_after_linking_get_bigger_kernels() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let d: &dyn Device = &dev;
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    // Linked for any graph while only a GAS exists: the stack is sized for it.
    let p = d
        .create_pipeline(
            &PipelineCompileOptions {
                traversable_graph: Setting::Value(TraversableGraph::Any),
                ..Default::default()
            },
            &PipelineLinkOptions::default(),
            &g.all(),
        )
        .unwrap();
    let before = dev.kernel_source(p).unwrap();
    // Now three levels of instances.
    let mut top = d.traversable_handle(gas).unwrap();
    for level in 0..3 {
        let shift = level as f32;
        top = one_instance(
            d,
            top,
            [1.0, 0.0, 0.0, shift, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        );
    }
    let after = dev.kernel_source(p).unwrap();
    let levels = |s: &str| {
        s.lines()
            .find(|l| l.starts_with("const _OPTIK_LEVELS"))
            .map(str::to_string)
    };
    assert_ne!(
        levels(&before),
        levels(&after),
        "the level array grew with the scene"
    );
    let table = numbered_sbt(d, &g);
    // Shifted by 0 + 1 + 2 = 3 in x.
    let recs = trace_rays(
        d,
        p,
        &table,
        top,
        &[
            Ray::new([3.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
            Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
        ],
        TraceArgs::default(),
    );
    assert!(recs[0].hit() && recs[1].missed());
}
