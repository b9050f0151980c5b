//! Error paths: every bad input is an error that names what was wrong, never a panic or
//! undefined behaviour on the GPU.

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
fn raygen__rg() {
    var p: RtPayload;
    rt_trace(params.handle, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    out[0] = p[0];
}
fn miss__ms() {
    rt_set_payload(0u, 1u);
}
fn closesthit__ch() {
    rt_set_payload(0u, 2u);
}
"#;

fn setup(dev: &TestDevice) -> Basic {
    basic(dev, PROGRAMS)
}

fn launch(dev: &TestDevice, s: &Basic, sbt: &ShaderBindingTable) -> Result<()> {
    let out = dev.create_buffer(16).unwrap();
    dev.launch(
        s.pipeline,
        &params(TraversableHandle::NULL, 1, 1),
        &[Resource::buffer(1, out)],
        sbt,
        LaunchSize::new(1, 1, 1),
    )
}

#[test]
fn what_the_backend_does_not_do_is_refused_with_a_reason() {
    let dev = device();
    // Box tests are the driver's, over padded boxes: only the conservative setting.
    let e = dev.set_accuracy(Accuracy::FAST).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Unsupported);
    assert!(e.message().contains("BoxTest::Plain"), "{e}");
    assert_eq!(dev.accuracy(), Accuracy::ROBUST);
    let driver = Accuracy {
        triangle: TriangleTest::Driver,
        box_test: BoxTest::Conservative,
    };
    // Native triangles cannot carry motion keys or micromaps.
    dev.set_accuracy(driver).unwrap();
    let vb = dev.f32_buffer(&[0.0; 18]);
    let mut t = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::NONE);
    t.vertex_buffers.push(BufferView::new(vb));
    let motion = AccelBuildOptions {
        motion: Some(MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: 0.0,
            time_end: 1.0,
        }),
        ..Default::default()
    };
    let e = dev
        .accel_build(&motion, &[BuildInput::Triangles(t)])
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Unsupported);
    assert!(e.message().contains("motion keys"), "{e}");
    let omm = dev
        .create_opacity_micromap_array(&OpacityMicromapArrayDesc {
            micromaps: vec![],
            data: vec![],
        })
        .unwrap();
    let mut t = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::NONE);
    t.opacity_micromap = Some(TriangleOpacityMicromap {
        array: omm,
        index_buffer: None,
        index_size_in_bytes: 4,
        index_stride: 0,
        base_index: 0,
    });
    let e = dev
        .accel_build(&AccelBuildOptions::default(), &[BuildInput::Triangles(t)])
        .unwrap_err();
    assert!(e.message().contains("opacity micromap"), "{e}");
    // Native triangles cannot move under a motion transform either.
    let gas = dev.triangles(&[[0.0; 3]; 3], GeometryFlags::NONE);
    let e = dev
        .create_transform(&TransformDesc::SrtMotion {
            child: dev.traversable_handle(gas).unwrap(),
            motion: MotionOptions {
                num_keys: 2,
                flags: MotionFlags::NONE,
                time_begin: 0.0,
                time_end: 1.0,
            },
            keys: vec![SrtData::identity(); 2],
        })
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Unsupported);
    assert!(e.message().contains("TriangleTest::Driver"), "{e}");
    // The triangle path cannot change under live triangle structures.
    let e = dev.set_accuracy(Accuracy::ROBUST).unwrap_err();
    assert!(e.message().contains("destroy them first"), "{e}");
    dev.destroy_accel(gas).unwrap();
    dev.set_accuracy(Accuracy::ROBUST).unwrap();
    let link = PipelineLinkOptions {
        max_trace_depth: 40,
        ..Default::default()
    };
    let m = dev.module("fn raygen__rg() { }");
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let e = dev
        .create_pipeline(&PipelineCompileOptions::default(), &link, &[rg])
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::LimitExceeded, "{e}");
}

#[test]
fn a_lost_device_fails_every_later_call_and_a_new_one_works() {
    let dev = device();
    let s = setup(&dev);
    let mut table = Table::new(s.rg);
    table.miss.push((s.ms, &[]));
    let sbt = table.build(&dev);
    let b = dev.create_buffer(16).unwrap();
    let gas = dev.triangles(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        GeometryFlags::NONE,
    );
    launch(&dev, &s, &sbt).unwrap();
    dev.lose_device_for_testing();
    let lost = |what: &str, r: Result<()>| {
        let e = r.unwrap_err();
        assert_eq!(e.kind(), ErrorKind::DeviceLost, "{what}: {e}");
        assert!(
            e.message().contains("open a new device")
                && e.message().contains("VK_ERROR_DEVICE_LOST"),
            "{what}: {e}"
        );
    };
    lost("create_buffer", dev.create_buffer(16).map(|_| ()));
    lost("write_buffer", dev.write_buffer(b, 0, &[0; 4]));
    lost("read_buffer", dev.read_buffer(b, 0, &mut [0; 4]));
    lost(
        "launch",
        dev.launch(
            s.pipeline,
            &params(TraversableHandle::NULL, 1, 1),
            &[Resource::buffer(1, b)],
            &sbt,
            LaunchSize::new(1, 1, 1),
        ),
    );
    lost(
        "launch_with",
        dev.launch_with(
            s.pipeline,
            &params(TraversableHandle::NULL, 1, 1),
            &[Resource::buffer(1, b)],
            &sbt,
            LaunchSize::new(1, 1, 1),
            &LaunchOptions::with_timeout(std::time::Duration::from_secs(5)),
        ),
    );
    lost(
        "traversable_handle",
        dev.traversable_handle(gas).map(|_| ()),
    );
    lost("destroy_accel", dev.destroy_accel(gas));
    lost("synchronize", dev.synchronize());
    // Dropping a lost device frees everything without a panic or a validation message; a
    // new device in the same process works.
    drop(dev);
    let dev = device();
    let s = setup(&dev);
    let mut table = Table::new(s.rg);
    table.miss.push((s.ms, &[]));
    let sbt = table.build(&dev);
    let out = run_rays(&dev, s.pipeline, &sbt, TraversableHandle::NULL, 1, 1, &[]);
    assert_eq!(out, vec![1], "the miss program ran on the new device");
}
