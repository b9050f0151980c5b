//! The device: probing, properties from the driver, pipeline features, the on-disk pipeline
//! cache, textures.

use crate::common::*;
use optik_api::*;
use optik_vulkan::VulkanOptions;

#[test]
fn probe_lists_devices_with_their_properties() {
    let devices = optik_vulkan::probe().unwrap();
    let usable: Vec<_> = devices.iter().filter(|d| d.usable()).collect();
    assert!(!usable.is_empty(), "{devices:?}");
    let d = usable[0];
    assert!(d.extensions.ray_tracing_pipeline && d.extensions.acceleration_structure);
    assert!(
        d.shader_group_handle_size >= 32
            && d.max_ray_recursion_depth >= 1
            && d.max_shader_group_stride >= 4096
    );
    let text = d.to_string();
    for needle in [
        "handle size",
        "max recursion depth",
        "max stride",
        "max instances",
        "usable by optik",
    ] {
        assert!(text.contains(needle), "{needle} missing from:\n{text}");
    }
    let dev = device();
    let p = dev.properties();
    assert_eq!(p.backend, BackendKind::Vulkan);
    assert_eq!(p.max_trace_depth, d.max_ray_recursion_depth.min(31));
    assert_eq!(
        p.max_launch_size,
        1 << 31,
        "launches are split into dispatches"
    );
    assert_eq!(
        p.max_sbt_record_stride,
        (d.max_shader_group_stride + 32 - d.shader_group_handle_size) / 16 * 16
    );
}

#[test]
fn pipelines_compile_what_the_scene_and_programs_use() {
    let dev = device();
    let src = format!(
        "{RAY_HEADER}{}",
        r#"
fn raygen__rg() {
    var p: RtPayload;
    rt_trace(params.handle, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[0] = p[0] + p[2];
}
fn closesthit__ch() { rt_set_payload(1u, 1u); }
"#
    );
    let m = dev.module(&src);
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ch = dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__ch")));
    let _gas = dev.triangles(&[[0.0; 3]; 3], GeometryFlags::NONE);
    let p = dev.pipeline(&[rg, ch], 1);
    let f = dev.pipeline_features(p).unwrap();
    assert_eq!(f.primitive_types, PrimitiveTypeFlags::TRIANGLE);
    assert_eq!(f.traversable_graph, TraversableGraph::SingleGas);
    assert!(!f.motion && !f.any_hit && !f.intersection && !f.direct_callables);
    assert_eq!(f.exceptions, ExceptionFlags::NONE);
    assert_eq!(f.num_payload_values, 3);
}

#[test]
fn the_pipeline_cache_is_kept_on_disk() {
    let dir = std::env::temp_dir().join(format!("optik-vulkan-cache-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let options = VulkanOptions {
        validation: true,
        device: None,
        force_staging: false,
        pipeline_cache: true,
        cache_dir: Some(dir.clone()),
        max_dispatch_invocations: None,
        driver_triangles: None,
    };
    let path = {
        let dev = device_with_options(options.clone());
        let m = dev.module("fn raygen__rg() { }");
        let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
        dev.pipeline(&[rg], 1);
        dev.pipeline_cache_path().expect("a cache file")
    };
    let file = std::fs::read(&path).expect("the cache was written");
    let data = optik_api::cache::checked_payload(b"optikvk1", &file).expect("a whole checked file");
    assert!(data.len() >= 32, "a Vulkan pipeline cache header");
    assert_eq!(
        u32::from_le_bytes(data[4..8].try_into().unwrap()),
        1,
        "header version one"
    );
    // A second device loads it and works as before.
    let pipeline = |options: VulkanOptions| {
        let dev = device_with_options(options);
        let m = dev.module("fn raygen__rg() { }");
        let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
        dev.pipeline(&[rg], 1);
    };
    pipeline(options.clone());
    // A damaged file (a torn write, bit rot) is no cache: the driver never sees it, the
    // device works, and its save replaces the file with a whole one.
    let mut damaged = std::fs::read(&path).unwrap();
    let last = damaged.len() - 1;
    damaged[last] ^= 0xff;
    std::fs::write(&path, &damaged).unwrap();
    pipeline(options.clone());
    let file = std::fs::read(&path).unwrap();
    assert!(
        optik_api::cache::checked_payload(b"optikvk1", &file).is_some(),
        "the damaged file was replaced"
    );
    std::fs::write(&path, &damaged[..damaged.len() / 2]).unwrap();
    pipeline(options);
    let _ = std::fs::remove_dir_all(&dir);
    let off = VulkanOptions {
        validation: true,
        device: None,
        force_staging: false,
        pipeline_cache: false,
        cache_dir: Some(std::env::temp_dir()),
        max_dispatch_invocations: None,
        driver_triangles: None,
    };
    assert!(
        device_with_options(off).pipeline_cache_path().is_none(),
        "OPTIK_CACHE_DISABLE keeps it off disk"
    );
}

#[test]
fn naming_a_device_that_does_not_exist_lists_the_devices() {
    let options = VulkanOptions {
        validation: false,
        device: Some("no such gpu".into()),
        force_staging: false,
        pipeline_cache: false,
        cache_dir: None,
        max_dispatch_invocations: None,
        driver_triangles: None,
    };
    let e = optik_vulkan::VulkanBackend::open(&options)
        .map(optik_vulkan::VulkanDevice::new)
        .err()
        .expect("no device has that name");
    assert_eq!(e.kind(), ErrorKind::InvalidArgument);
    assert!(
        e.message().contains("no such gpu") && e.message().contains("[0]"),
        "{e}"
    );
}

/// NVIDIA's driver fails `vkCreateInstance` after about 29 create/destroy rounds in one
/// process; optik keeps its instances for the process's life, so devices can be opened and
/// dropped any number of times (a long test run does this).
#[test]
fn devices_open_and_drop_any_number_of_times() {
    for round in 0..40 {
        let options = VulkanOptions {
            validation: false,
            device: None,
            force_staging: false,
            pipeline_cache: false,
            cache_dir: None,
            max_dispatch_invocations: None,
            driver_triangles: None,
        };
        if let Err(e) =
            optik_vulkan::VulkanBackend::open(&options).map(optik_vulkan::VulkanDevice::new)
        {
            panic!(
                "opening the device for the {}th time failed: {e}",
                round + 1
            );
        }
    }
}
