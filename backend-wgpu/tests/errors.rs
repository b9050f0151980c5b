//! Bad input is an error naming what was wrong, never a panic; device loss is reported.
mod common;
use common::*;
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
fn program_and_pipeline_errors() {
    let dev = device();
    let d = dev.as_ref();
    let e = d
        .create_module(
            &ModuleCompileOptions::default(),
            &PipelineCompileOptions::default(),
            &ProgramSource::new("bad.wgsl", "fn raygen__x() {\n    let a: u32 = 1.5;\n}\n"),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Compile);
    assert_eq!(e.diagnostics()[0].line, 2, "{e}");
    let m = module(d, RAY_LIST);
    let e = d
        .create_program_groups(&[closest_hit(m, "closesthit__nothere")])
        .unwrap_err();
    assert!(e.message().contains("closesthit__nothere"), "{e}");
    let e = d
        .create_program_groups(&[closest_hit(m, "miss__rec")])
        .unwrap_err();
    assert!(e.message().contains("miss program"), "{e}");
    let hit = d
        .create_program_groups(&[closest_hit(m, "closesthit__rec")])
        .unwrap();
    let e = d
        .create_pipeline(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions::default(),
            &hit,
        )
        .unwrap_err();
    assert!(e.message().contains("raygen"), "{e}");
    let g = ray_list_groups(d, m, 1, &[]);
    let e = d
        .create_pipeline(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions {
                max_trace_depth: 40,
                ..Default::default()
            },
            &g.all(),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::LimitExceeded);
}

#[test]
fn launch_errors_and_empty_launches() {
    let dev = device();
    let d = dev.as_ref();
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let p = pipeline(d, &g, 1);
    let table = numbered_sbt(d, &g);
    let h = d.traversable_handle(gas).unwrap();
    let out = d.create_buffer(64).unwrap();
    let e = d
        .launch(
            p,
            &params(h, &[]),
            &[Resource::buffer(1, out)],
            &table,
            LaunchSize::new(1, 1, 1),
        )
        .unwrap_err();
    assert!(e.message().contains("binding 2"), "{e}");
    let e = d
        .launch(
            p,
            &[0; 4],
            &[Resource::buffer(1, out), Resource::buffer(2, out)],
            &table,
            LaunchSize::new(1, 1, 1),
        )
        .unwrap_err();
    assert!(e.message().contains("params"), "{e}");
    // A zero-sized launch does nothing.
    d.launch(
        p,
        &params(h, &[]),
        &[Resource::buffer(1, out), Resource::buffer(2, out)],
        &table,
        LaunchSize::new(0, 5, 1),
    )
    .unwrap();
    let e = d
        .launch(
            p,
            &params(h, &[]),
            &[Resource::buffer(1, out), Resource::buffer(2, out)],
            &table,
            LaunchSize::new(1 << 16, 1 << 16, 1),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::LimitExceeded);
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
    let dev = optik_wgpu::WgpuDevice::new().unwrap();
    let d: &dyn Device = &dev;
    let b = d.create_buffer(16).unwrap();
    dev.lose_device_for_testing();
    let e = d.create_buffer(16).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::DeviceLost, "{e}");
    assert_eq!(
        d.write_buffer(b, 0, &[0; 4]).unwrap_err().kind(),
        ErrorKind::DeviceLost
    );
    assert_eq!(d.synchronize().unwrap_err().kind(), ErrorKind::DeviceLost);
}
