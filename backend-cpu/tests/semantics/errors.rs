//! Device-level error paths: every bad input is an error that names what was wrong.

use crate::kit::*;
use optik_api::*;

/// A minimal pipeline: raygen and a miss group, and the groups' handles.
fn minimal(kit: &Kit) -> (Pipeline, ProgramGroup, ProgramGroup, ProgramGroup) {
    let m = kit.module(vec![
        ("raygen__main", program(|_| {})),
        ("miss__main", program(|_| {})),
        ("closesthit__main", program(|_| {})),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    (
        kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]),
        rg,
        ms,
        hg,
    )
}

fn launch_err(kit: &Kit, p: Pipeline, sbt: &ShaderBindingTable) -> Error {
    kit.dev
        .launch(p, &[], &[], sbt, LaunchSize::new(1, 1, 1))
        .unwrap_err()
}

#[test]
fn bad_sbt_headers_name_the_record() {
    let kit = Kit::new();
    let (p, rg, ms, hg) = minimal(&kit);
    // Garbage in the second hit record.
    let mut sbt = kit.sbt(
        Rec::new(rg),
        &[Rec::new(ms)],
        &[Rec::new(hg), Rec::new(hg)],
        &[],
        None,
    );
    let region = sbt.hitgroup.unwrap();
    kit.dev
        .write_buffer(region.buffer, region.stride as u64, &[0xAB; 32])
        .unwrap();
    let e = launch_err(&kit, p, &sbt);
    assert!(
        e.message().contains("sbt.hitgroup record 1")
            && e.message().contains("sbt_record_pack_header"),
        "{e}"
    );
    // A miss group's header in a hit record.
    sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(ms)], &[], None);
    let e = launch_err(&kit, p, &sbt);
    assert!(
        e.message().contains("sbt.hitgroup record 0") && e.message().contains("names a miss group"),
        "{e}"
    );
    // A group that is not part of the pipeline.
    let m = kit.module(vec![("miss__other", program(|_| {}))]);
    let other = kit.miss(m, "miss__other");
    sbt = kit.sbt(Rec::new(rg), &[Rec::new(other)], &[], &[], None);
    let e = launch_err(&kit, p, &sbt);
    assert!(
        e.message().contains("sbt.miss record 0")
            && e.message().contains("not one of this pipeline's groups"),
        "{e}"
    );
    // A header of another device.
    let foreign = Kit::new();
    let (_, frg, _, _) = minimal(&foreign);
    let header = foreign.dev.sbt_record_pack_header(frg).unwrap();
    sbt = kit.sbt(Rec::new(rg), &[], &[], &[], None);
    kit.dev.write_buffer(sbt.raygen.buffer, 0, &header).unwrap();
    let e = launch_err(&kit, p, &sbt);
    assert!(
        e.message().contains("sbt.raygen") && e.message().contains("not of this device"),
        "{e}"
    );
    // Misaligned and out-of-range regions.
    sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    let mut bad = sbt;
    bad.hitgroup = Some(SbtRegion {
        stride: 40,
        ..sbt.hitgroup.unwrap()
    });
    assert!(
        launch_err(&kit, p, &bad)
            .message()
            .contains("sbt.hitgroup.stride is 40")
    );
    bad.hitgroup = Some(SbtRegion {
        count: 5,
        ..sbt.hitgroup.unwrap()
    });
    assert!(
        launch_err(&kit, p, &bad)
            .message()
            .contains("lie outside the buffer")
    );
}

#[test]
fn limits_buffers_and_foreign_handles() {
    let kit = Kit::new();
    let (p, rg, _, _) = minimal(&kit);
    let sbt = kit.sbt(Rec::new(rg), &[], &[], &[], None);
    let e = kit
        .dev
        .launch(p, &[], &[], &sbt, LaunchSize::new(1 << 20, 1 << 20, 1))
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::LimitExceeded, "{e}");
    // A zero-sized launch is a no-op, not an error.
    kit.dev
        .launch(p, &[], &[], &sbt, LaunchSize::new(0, 4, 4))
        .unwrap();
    // Buffers: ranges, foreign and destroyed handles.
    let b = kit.dev.create_buffer(16).unwrap();
    let e = kit.dev.write_buffer(b, 8, &[0; 16]).unwrap_err();
    assert!(
        e.message().contains("outside the buffer of 16 bytes"),
        "{e}"
    );
    assert!(kit.dev.write_buffer(b, u64::MAX, &[0; 2]).is_err());
    assert!(kit.dev.read_buffer(b, 0, &mut [0; 17]).is_err());
    let other = Kit::new();
    let foreign = other.dev.create_buffer(16).unwrap();
    let e = kit.dev.write_buffer(foreign, 0, &[0; 4]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidHandle);
    assert!(e.message().contains("belongs to device"), "{e}");
    kit.dev.destroy_buffer(b).unwrap();
    assert!(
        kit.dev
            .buffer_size(b)
            .unwrap_err()
            .message()
            .contains("destroyed")
    );
    assert!(kit.dev.create_buffer(u64::MAX).is_err());
    // Build inputs: a vertex buffer too small, a foreign buffer, a bad index.
    let small = kit.buffer(&[0.0f32; 8]);
    let input = |buf: Buffer, n: u32| {
        BuildInput::Triangles(TriangleArray::new(
            BufferView::new(buf),
            n,
            GeometryFlags::NONE,
        ))
    };
    let e = kit
        .dev
        .accel_build(&AccelBuildOptions::default(), &[input(small, 3)])
        .unwrap_err();
    assert!(e.message().contains("vertex_buffers[0]"), "{e}");
    let e = kit
        .dev
        .accel_build(&AccelBuildOptions::default(), &[input(foreign, 3)])
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidHandle);
    let verts = kit.buffer(&[[0.0f32; 3]; 3]);
    let idx = kit.buffer(&[0u32, 1, 7]);
    let bad_index = TriangleArray::new(BufferView::new(verts), 3, GeometryFlags::NONE)
        .with_indices(BufferView::new(idx), 1);
    let e = kit
        .dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Triangles(bad_index)],
        )
        .unwrap_err();
    assert!(e.message().contains("vertex index 7"), "{e}");
    // Traversable handles: of another device (a launch just misses; see instances.rs),
    // destroyed accels as arguments.
    let a = kit
        .dev
        .accel_build(&AccelBuildOptions::default(), &[input(verts, 3)])
        .unwrap();
    kit.dev.destroy_accel(a).unwrap();
    assert_eq!(
        kit.dev.traversable_handle(a).unwrap_err().kind(),
        ErrorKind::InvalidHandle
    );
    assert!(kit.dev.accel_compact(a).is_err());
    // Pipelines: destroyed, and options that contradict the groups.
    kit.dev.destroy_pipeline(p).unwrap();
    assert_eq!(
        kit.dev
            .launch(p, &[], &[], &sbt, LaunchSize::new(1, 1, 1))
            .unwrap_err()
            .kind(),
        ErrorKind::InvalidHandle
    );
    let m = kit.module(vec![("closesthit__s", program(|_| {}))]);
    let spheres = kit.hit_builtin(
        m,
        Some("closesthit__s"),
        None,
        None,
        BuiltinIntersector::Sphere,
    );
    let options = PipelineCompileOptions {
        primitive_types: Setting::Value(PrimitiveTypeFlags::TRIANGLE),
        ..Default::default()
    };
    let e = kit
        .dev
        .create_pipeline(&options, &PipelineLinkOptions::default(), &[rg, spheres])
        .unwrap_err();
    assert!(e.message().contains("built-in intersector"), "{e}");
}

#[test]
fn program_groups_check_names_and_kinds() {
    let kit = Kit::new();
    let m = kit.module(vec![("miss__main", program(|_| {}))]);
    let e = kit
        .dev
        .create_program_groups(&[ProgramGroupDesc::Raygen(ProgramRef::new(m, "raygen__nope"))])
        .unwrap_err();
    assert!(e.message().contains("no program of that name"), "{e}");
    let e = kit
        .dev
        .create_program_groups(&[ProgramGroupDesc::Raygen(ProgramRef::new(m, "miss__main"))])
        .unwrap_err();
    assert!(e.message().contains("is a miss program"), "{e}");
    let desc = optik_cpu::NativeModuleDesc {
        programs: vec![("shade".into(), program(|_| {}))],
        ..Default::default()
    };
    let e = kit.dev.create_native_module(desc).unwrap_err();
    assert!(e.message().contains("no program prefix"), "{e}");
    kit.dev.destroy_module(m).unwrap();
    let e = kit
        .dev
        .create_program_groups(&[ProgramGroupDesc::Miss(Some(ProgramRef::new(
            m,
            "miss__main",
        )))])
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidHandle);
    // A WGSL module compiles through the front end; errors carry file:line:column.
    let e = kit
        .dev
        .create_module(
            &Default::default(),
            &Default::default(),
            &ProgramSource::new("bad.wgsl", "fn raygen__x() { let a: u32 = 1.5; }"),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Compile, "{e}");
    assert!(e.to_string().contains("bad.wgsl:1:"), "{e}");
}
