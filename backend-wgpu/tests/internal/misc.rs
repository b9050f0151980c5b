//! Programs from several modules, vertex and index formats, vertex data access, textures,
//! 3D launch indices, instance flag precedence, scenes that grow after linking, extensions
//! holding the Vulkan loader.

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

/// The objects a wgpu extension locks (`Device::objects`, as `kernel_source` and the
/// benchmarks' launches do) come with the Vulkan loader held, as the device's own calls
/// hold it (`optik_core::vulkan_loader`): a device being opened or dropped elsewhere waits
/// until the guard is gone.
#[test]
fn extensions_hold_the_vulkan_loader_while_they_hold_the_objects() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let changed = AtomicBool::new(false);
    std::thread::scope(|s| {
        let objects = dev.objects();
        let changer = s.spawn(|| {
            let _changing = optik_core::vulkan_loader::changing_devices();
            changed.store(true, Ordering::SeqCst);
        });
        // Unheld, the other thread takes the lock at once; a quarter of a second is far
        // more than it needs.
        std::thread::sleep(std::time::Duration::from_millis(250));
        assert!(
            !changed.load(Ordering::SeqCst),
            "a device changed while an extension held the objects"
        );
        drop(objects);
        changer.join().unwrap();
    });
    assert!(changed.load(Ordering::SeqCst));
}
