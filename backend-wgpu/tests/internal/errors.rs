//! Bad input is an error naming what was wrong, never a panic; device loss is reported.

use crate::common::*;
use optik_api::*;

#[test]
fn buffer_errors() {
    let dev = device();
    let d = dev.as_ref();
    let max = d.properties().max_buffer_size;
    assert_eq!(
        d.create_buffer(max + 1).unwrap_err().kind(),
        ErrorKind::LimitExceeded
    );
    let b = d.create_buffer(16).unwrap();
    let e = d.write_buffer(b, 12, &[0; 8]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidArgument);
    assert!(e.message().contains("16 bytes"), "{e}");
    // Unaligned writes and reads work.
    d.write_buffer(b, 3, &[1, 2, 3, 4, 5]).unwrap();
    let mut out = [0u8; 7];
    d.read_buffer(b, 2, &mut out).unwrap();
    assert_eq!(out, [0, 1, 2, 3, 4, 5, 0]);
    d.destroy_buffer(b).unwrap();
    assert_eq!(
        d.buffer_size(b).unwrap_err().kind(),
        ErrorKind::InvalidHandle
    );
    let other = device();
    let foreign = other.create_buffer(4).unwrap();
    let e = d.buffer_size(foreign).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidHandle);
    assert!(e.message().contains("belongs to"), "{e}");
}

#[test]
fn acceleration_structure_errors() {
    let dev = device();
    let d = dev.as_ref();
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let vb = buffer(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0));
    let input = BuildInput::Triangles(TriangleArray::new(
        BufferView::new(vb),
        6,
        GeometryFlags::NONE,
    ));
    let e = d
        .accel_update(
            gas,
            &AccelBuildOptions {
                operation: BuildOperation::Update,
                ..Default::default()
            },
            std::slice::from_ref(&input),
        )
        .unwrap_err();
    assert!(e.message().contains("ALLOW_UPDATE"), "{e}");
    assert!(
        d.accel_compact(gas)
            .unwrap_err()
            .message()
            .contains("ALLOW_COMPACTION")
    );
    let bad = Instance::new(TraversableHandle(0xDEAD_BEEF_0000_0007));
    let ib = buffer(d, &[bad]);
    let e = d
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Instances(InstanceArray {
                instances: BufferView::new(ib),
                num_instances: 1,
            })],
        )
        .unwrap_err();
    assert!(
        e.message().contains("instances[0]") && e.message().contains("not a live"),
        "{e}"
    );
    // Graphs deeper than the device's limit are refused.
    let limit = d.properties().max_traversable_graph_depth;
    let mut top = d.traversable_handle(gas).unwrap();
    let mut refused = None;
    for level in 1..=limit {
        let t = d.create_transform(&TransformDesc::Static {
            child: top,
            object_to_world: IDENTITY_3X4,
            world_to_object: IDENTITY_3X4,
        });
        match t {
            Ok(t) => top = d.traversable_handle(t).unwrap(),
            Err(e) => {
                refused = Some((level, e));
                break;
            }
        }
    }
    let (level, e) = refused.expect("a graph deeper than the limit was accepted");
    assert_eq!(level, limit, "{level} levels of transforms over a GAS");
    assert_eq!(e.kind(), ErrorKind::LimitExceeded);
    let short = TriangleArray::new(BufferView::new(vb), 600, GeometryFlags::NONE);
    let e = d
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Triangles(short)],
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidArgument);
}

#[test]
fn device_loss_is_an_error_not_a_panic() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let memory = dev.memory();
    let d: &dyn Device = &dev;
    let b = d.create_buffer(16).unwrap();
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let p = pipeline(d, &g, 1);
    let table = numbered_sbt(d, &g);
    let h = d.traversable_handle(gas).unwrap();
    dev.lose_device_for_testing();
    let e = d.create_buffer(16).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::DeviceLost, "{e}");
    assert!(e.message().contains("open a new device"), "{e}");
    assert_eq!(
        d.write_buffer(b, 0, &[0; 4]).unwrap_err().kind(),
        ErrorKind::DeviceLost
    );
    let mut out = [0u8; 4];
    assert_eq!(
        d.read_buffer(b, 0, &mut out).unwrap_err().kind(),
        ErrorKind::DeviceLost
    );
    let e = d
        .launch(
            p,
            &params(h, &[0, 1, 0, 0xFF, 0, 0]),
            &[Resource::buffer(1, b), Resource::buffer(2, b)],
            &table,
            LaunchSize::new(1, 1, 1),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::DeviceLost, "{e}");
    let vb = d.create_buffer(72);
    assert_eq!(vb.unwrap_err().kind(), ErrorKind::DeviceLost);
    assert_eq!(
        d.destroy_accel(gas).unwrap_err().kind(),
        ErrorKind::DeviceLost
    );
    assert_eq!(d.synchronize().unwrap_err().kind(), ErrorKind::DeviceLost);
    // Dropping a lost device frees everything without panicking.
    drop(dev);
    assert_eq!(memory.live_allocations(), 0);
}

/// A raygen-only pipeline writing `linear index + 1` at each launch index.
fn index_writer(d: &dyn Device) -> (Pipeline, ShaderBindingTable) {
    let m = module(
        d,
        &format!(
            "{HEADER}\nfn raygen__index() {{\n    let id = rt_launch_index();\n    let dim = rt_launch_dimensions();\n    let i = (id.z * dim.y + id.y) * dim.x + id.x;\n    out[i] = i + 1u;\n}}\n"
        ),
    );
    let g = groups(d, &[raygen(m, "raygen__index")]);
    let p = pipeline(d, &g, 1);
    let table = sbt(d, &g, &[]);
    (p, table)
}

#[test]
fn launches_are_split_over_the_workgroup_grid_or_refused_naming_the_limit() {
    // Two workgroups of 64 per dimension: at most 2 x 2 x 64 = 256 invocations.
    let dev = optik_wgpu::WgpuBackend::with_options(optik_wgpu::WgpuOptions {
        max_workgroups_per_dimension: Some(2),
        ..Default::default()
    })
    .map(optik_wgpu::WgpuDevice::new)
    .unwrap();
    let d: &dyn Device = &dev;
    let (p, table) = index_writer(d);
    let h = TraversableHandle::NULL;
    // 250 invocations: four workgroups laid out 2 x 2, every index written exactly once.
    let words = run(d, p, &table, &params(h, &[]), 25, 10, 250);
    assert_eq!(words, (1..=250).collect::<Vec<u32>>());
    let out = d.create_buffer(4 * 300).unwrap();
    let e = d
        .launch(
            p,
            &params(h, &[]),
            &[Resource::buffer(1, out)],
            &table,
            LaunchSize::new(30, 10, 1),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::LimitExceeded, "{e}");
    for named in ["30 x 10 x 1 = 300 invocations", "5 workgroups", "2 x 2"] {
        assert!(e.message().contains(named), "`{named}` missing: {e}");
    }
    // The refused launch changed nothing.
    assert_eq!(read::<u32>(d, out), vec![0; 300]);
}

#[test]
fn a_launch_past_one_row_of_workgroups_runs_with_the_adapters_limits() {
    // More invocations than one row of workgroups holds: the grid takes a second row.
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let d: &dyn Device = &dev;
    let per_dim = dev.limits().max_compute_workgroups_per_dimension;
    let n = per_dim * 64 + 4099;
    let (p, table) = index_writer(d);
    let words = run(
        d,
        p,
        &table,
        &params(TraversableHandle::NULL, &[]),
        n,
        1,
        n as usize,
    );
    let wrong = words.iter().enumerate().find(|&(i, &w)| w != i as u32 + 1);
    assert_eq!(wrong, None, "launch of {n}: (index, word) wrong");
}

#[test]
fn storage_bindings_over_the_adapter_limit_are_refused() {
    let dev = optik_wgpu::WgpuBackend::with_options(optik_wgpu::WgpuOptions {
        max_storage_binding: Some(64 << 10),
        ..Default::default()
    })
    .map(optik_wgpu::WgpuDevice::new)
    .unwrap();
    let d: &dyn Device = &dev;
    let (p, table) = index_writer(d);
    let big = d.create_buffer(128 << 10).unwrap();
    let e = d
        .launch(
            p,
            &params(TraversableHandle::NULL, &[]),
            &[Resource::buffer(1, big)],
            &table,
            LaunchSize::new(4, 1, 1),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::LimitExceeded, "{e}");
    assert!(
        e.message().contains("binding 1") && e.message().contains("65536"),
        "{e}"
    );
    // A view within the limit works.
    d.launch(
        p,
        &params(TraversableHandle::NULL, &[]),
        &[Resource::Buffer {
            binding: 1,
            buffer: big,
            offset: 0,
            size: Some(64 << 10),
        }],
        &table,
        LaunchSize::new(4, 1, 1),
    )
    .unwrap();
    let mut first = [0u8; 16];
    d.read_buffer(big, 0, &mut first).unwrap();
    assert_eq!(bytemuck::cast::<[u8; 16], [u32; 4]>(first), [1, 2, 3, 4]);
}

#[test]
fn kernels_needing_more_storage_bindings_than_the_adapter_has_are_refused() {
    // The RAY_LIST kernel binds 5 storage buffers: the SBT, the handle table, one scene
    // chunk and the user's two.
    let dev = optik_wgpu::WgpuBackend::with_options(optik_wgpu::WgpuOptions {
        max_storage_buffers_per_stage: Some(4),
        ..Default::default()
    })
    .map(optik_wgpu::WgpuDevice::new)
    .unwrap();
    let d: &dyn Device = &dev;
    let _gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let e = d
        .create_pipeline(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions::default(),
            &g.all(),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::LimitExceeded, "{e}");
    assert!(
        e.message().contains("needs 5 storage buffer bindings") && e.message().contains("allows 4"),
        "{e}"
    );
}

#[test]
fn gpu_memory_is_freed_with_its_owners_and_the_device() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let memory = dev.memory();
    let d: &dyn Device = &dev;
    // The empty device: the scene arena's first chunk.
    let (base_count, base_bytes) = (memory.live_allocations(), memory.live_bytes());
    assert!(base_count >= 1 && base_bytes > 0);
    assert_eq!(memory.arena_bytes_in_use(), 0);
    let b = d.create_buffer(1 << 20).unwrap();
    assert_eq!(memory.live_allocations(), base_count + 1);
    assert_eq!(memory.live_bytes(), base_bytes + (1 << 20));
    d.destroy_buffer(b).unwrap();
    assert_eq!(
        (memory.live_allocations(), memory.live_bytes()),
        (base_count, base_bytes)
    );
    let t = d
        .create_texture(&TextureDesc {
            width: 8,
            height: 4,
            format: TextureFormat::Rgba8Unorm,
        })
        .unwrap();
    assert_eq!(memory.live_bytes(), base_bytes + 8 * 4 * 4);
    d.destroy_texture(t).unwrap();
    assert_eq!(memory.live_bytes(), base_bytes);
    // Structures take arena space and give it back; the arena's chunks stay for reuse.
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let used = memory.arena_bytes_in_use();
    assert!(used > 0);
    let gas2 = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 1.0), GeometryFlags::NONE);
    assert!(memory.arena_bytes_in_use() > used);
    d.destroy_accel(gas2).unwrap();
    assert_eq!(memory.arena_bytes_in_use(), used);
    d.destroy_accel(gas).unwrap();
    assert_eq!(memory.arena_bytes_in_use(), 0);
    // Dropping the device frees what is still alive: buffers, structures, the arena.
    let _kept = d.create_buffer(4096).unwrap();
    let _kept_gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    assert!(memory.live_allocations() > base_count);
    drop(dev);
    assert_eq!(memory.live_allocations(), 0);
    assert_eq!(memory.live_bytes(), 0);
    assert_eq!(memory.arena_bytes_in_use(), 0);
}
