//! Every validation error path, each asserting what its message names.

use super::*;
use optik_api::accel::*;
use optik_api::flags::*;
use optik_api::handle::{DeviceId, Handle, RawHandle};
use optik_api::launch::{SamplerDesc, TextureFormat};

fn props() -> DeviceProperties {
    DeviceProperties {
        max_trace_depth: 31,
        max_traversable_graph_depth: 8,
        max_primitives_per_build_input: 1000,
        max_instances_per_ias: 100,
        max_instance_id: 1 << 24,
        max_sbt_offset: 1 << 24,
        num_bits_instance_visibility_mask: 8,
        max_sbt_records_per_build_input: 4,
        sbt_record_header_size: 32,
        sbt_record_alignment: 16,
        max_sbt_record_stride: 4096,
        max_payload_values: 32,
        max_attribute_values: 8,
        max_launch_size: 1 << 20,
        max_buffer_size: 1 << 30,
        max_binding_size: 1 << 27,
        backend: optik_api::device::BackendKind::Cpu,
        device_name: "test".into(),
        driver: "test".into(),
    }
}

fn buf(slot: u32) -> Buffer {
    Buffer::from_raw(RawHandle {
        device: DeviceId(1),
        slot,
        generation: 0,
    })
}

/// Buffer `slot` has `slot * 100` bytes; slot 9 is destroyed.
fn sizes(b: Buffer) -> Result<u64> {
    if b.raw().slot == 9 {
        return Err(Error::new(
            optik_api::ErrorKind::InvalidHandle,
            "buffer handle was destroyed",
        ));
    }
    Ok(b.raw().slot as u64 * 100)
}

fn expect_err(r: Result<impl std::fmt::Debug>, needles: &[&str]) -> Error {
    let e = r.expect_err("validation should fail");
    for n in needles {
        assert!(
            e.message().contains(n),
            "message {:?} lacks {:?}",
            e.message(),
            n
        );
    }
    e
}

fn tri(vertices: u32) -> TriangleArray {
    TriangleArray::new(BufferView::new(buf(10)), vertices, GeometryFlags::NONE)
}

fn build(inputs: &[BuildInput]) -> Result<usize> {
    build_inputs(&AccelBuildOptions::default(), inputs, &props(), &sizes)
}

#[test]
fn buffer_ranges() {
    assert!(buffer_range("x", buf(1), 0, 100, &sizes).is_ok());
    expect_err(
        buffer_range("vertices", buf(1), 50, 51, &sizes),
        &["vertices", "50..101", "100 bytes"],
    );
    expect_err(buffer_range("v", buf(1), u64::MAX, 2, &sizes), &["outside"]);
    expect_err(
        buffer_range("v", buf(9), 0, 1, &sizes),
        &["v: ", "destroyed"],
    );
}

#[test]
fn build_input_shapes() {
    expect_err(build(&[]), &["build inputs are empty"]);
    let aabb = BuildInput::CustomPrimitives(CustomPrimitiveArray::new(
        BufferView::new(buf(10)),
        1,
        GeometryFlags::NONE,
    ));
    expect_err(
        build(&[BuildInput::Triangles(tri(3)), aabb]),
        &["build_inputs[1] is custom primitives", "one kind of input"],
    );
    expect_err(
        build(&[BuildInput::Triangles(tri(3003))]),
        &["1001 triangles", "at most 1000"],
    );
    let mut t = tri(3);
    t.flags.clear();
    expect_err(build(&[BuildInput::Triangles(t)]), &["flags is empty"]);
    let mut t = tri(3);
    t.flags = vec![GeometryFlags::NONE; 5];
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["5 SBT records", "at most 4"],
    );
    let mut t = tri(3);
    t.flags = vec![GeometryFlags::NONE; 2];
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["sbt_index_offsets is missing", "2 SBT records"],
    );
}

#[test]
fn triangle_inputs() {
    assert_eq!(build(&[BuildInput::Triangles(tri(9))]).unwrap(), 1);
    expect_err(
        build(&[BuildInput::Triangles(tri(4))]),
        &["num_vertices is 4", "multiple of 3"],
    );
    expect_err(
        build(&[BuildInput::Triangles(tri(90))]),
        &["vertex_buffers[0]", "90 vertices", "1000 bytes"],
    );
    let mut t = tri(3);
    t.vertex_stride = 8;
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["vertex_stride is 8", "at least 12"],
    );
    let mut t = tri(3);
    t.vertex_stride = 14;
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["vertex_stride is 14", "multiple of 4"],
    );
    let mut t = tri(3);
    t.vertex_buffers[0].offset = 2;
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["vertex_buffers[0].offset is 2"],
    );
    let t = tri(3).with_indices(BufferView::new(buf(1)), 10);
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["indices (10 triangles)", "100 bytes"],
    );
    let mut t = tri(3).with_indices(BufferView::new(buf(1)), 1);
    if let Some(ix) = &mut t.indices {
        ix.stride = 6;
    }
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["indices.stride is 6", "at least 12"],
    );
    let mut t = tri(3);
    t.pre_transform = Some(BufferView::at(buf(1), 64));
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["pre_transform", "64..112"],
    );
    let mut t = tri(3);
    t.flags = vec![GeometryFlags::NONE; 2];
    t.sbt_index_offsets = Some(SbtIndexOffsets {
        buffer: BufferView::new(buf(1)),
        size_in_bytes: 3,
        stride: 0,
    });
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["size_in_bytes is 3", "1, 2 or 4"],
    );
    let mut t = tri(3);
    t.flags = vec![GeometryFlags::NONE; 2];
    t.sbt_index_offsets = Some(SbtIndexOffsets {
        buffer: BufferView::new(buf(1)),
        size_in_bytes: 4,
        stride: 2,
    });
    expect_err(
        build(&[BuildInput::Triangles(t)]),
        &["stride is 2", "at least size_in_bytes"],
    );
}

#[test]
fn motion_keys_must_match() {
    let opts = AccelBuildOptions {
        motion: Some(MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: 0.0,
            time_end: 1.0,
        }),
        ..Default::default()
    };
    expect_err(
        build_inputs(&opts, &[BuildInput::Triangles(tri(3))], &props(), &sizes),
        &["gives 1 motion key buffers", "ask for 2"],
    );
    let bad = AccelBuildOptions {
        motion: Some(MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: 1.0,
            time_end: 0.0,
        }),
        ..Default::default()
    };
    expect_err(
        build_inputs(&bad, &[BuildInput::Triangles(tri(3))], &props(), &sizes),
        &["time_begin 1 is after time_end 0"],
    );
    let nan = AccelBuildOptions {
        motion: Some(MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: f32::NAN,
            time_end: 0.0,
        }),
        ..Default::default()
    };
    expect_err(
        build_inputs(&nan, &[BuildInput::Triangles(tri(3))], &props(), &sizes),
        &["must be finite"],
    );
}

#[test]
fn other_inputs() {
    let mut c = CustomPrimitiveArray::new(BufferView::new(buf(1)), 5, GeometryFlags::NONE);
    expect_err(
        build(&[BuildInput::CustomPrimitives(c.clone())]),
        &["aabb_buffers[0] (5 AABBs)"],
    );
    c.num_primitives = 1;
    c.stride = 20;
    expect_err(
        build(&[BuildInput::CustomPrimitives(c)]),
        &["stride is 20", "at least 24"],
    );
    let s = SphereArray {
        vertex_buffers: vec![BufferView::new(buf(10))],
        vertex_stride: 0,
        num_vertices: 2,
        radius_buffers: vec![],
        radius_stride: 0,
        single_radius: false,
        flags: vec![GeometryFlags::NONE],
        sbt_index_offsets: None,
        primitive_index_offset: 0,
    };
    expect_err(
        build(&[BuildInput::Spheres(s.clone())]),
        &["radius_buffers has 0 buffers"],
    );
    let mut s = s;
    s.radius_buffers = vec![BufferView::at(buf(1), 96)];
    expect_err(
        build(&[BuildInput::Spheres(s)]),
        &["radius_buffers[0]", "96..104"],
    );
    let curve = CurveArray {
        curve_type: CurveType::RoundLinear,
        num_primitives: 2,
        vertex_buffers: vec![BufferView::new(buf(10))],
        num_vertices: 3,
        vertex_stride: 0,
        width_buffers: vec![BufferView::new(buf(10))],
        width_stride: 2,
        index_buffer: BufferView::new(buf(10)),
        index_stride: 0,
        flag: GeometryFlags::NONE,
        primitive_index_offset: 0,
        endcaps: CurveEndcaps::Default,
    };
    expect_err(
        build(&[BuildInput::Curves(curve.clone())]),
        &["width 2", "4-aligned"],
    );
    let mut c1 = curve.clone();
    c1.width_stride = 0;
    let mut c2 = c1.clone();
    c2.curve_type = CurveType::RoundCubicBSpline;
    expect_err(
        build(&[BuildInput::Curves(c1), BuildInput::Curves(c2)]),
        &["curve type RoundCubicBSpline", "one curve type"],
    );
    let inst = |n| {
        BuildInput::Instances(InstanceArray {
            instances: BufferView::new(buf(1)),
            num_instances: n,
        })
    };
    expect_err(build(&[inst(2)]), &["2 instances of 80 bytes", "100 bytes"]);
    expect_err(build(&[inst(101)]), &["101 instances", "at most 100"]);
    expect_err(build(&[inst(1), inst(1)]), &["exactly one instance input"]);
    let misaligned = BuildInput::Instances(InstanceArray {
        instances: BufferView::at(buf(10), 8),
        num_instances: 1,
    });
    expect_err(
        build(&[misaligned]),
        &["instances.offset is 8", "multiple of 16"],
    );
}

#[test]
fn updates_keep_kinds_and_counts() {
    let built = AccelBuildOptions {
        flags: BuildFlags::ALLOW_UPDATE,
        ..Default::default()
    };
    let upd = AccelBuildOptions {
        operation: BuildOperation::Update,
        ..built
    };
    let a = [BuildInput::Triangles(tri(3))];
    assert!(update(&built, &a, &upd, &a).is_ok());
    expect_err(update(&built, &a, &built, &a), &["operation = Update"]);
    expect_err(
        update(&AccelBuildOptions::default(), &a, &upd, &a),
        &["without BuildFlags::ALLOW_UPDATE"],
    );
    expect_err(
        update(&built, &a, &upd, &[BuildInput::Triangles(tri(6))]),
        &["update input 0", "2 primitives"],
    );
    expect_err(
        update(&built, &a, &upd, &[]),
        &["0 build inputs", "built from 1"],
    );
}

#[test]
fn transforms() {
    let child = TraversableHandle(5);
    let ok = TransformDesc::Static {
        child,
        object_to_world: IDENTITY_3X4,
        world_to_object: IDENTITY_3X4,
    };
    assert!(transform(&ok).is_ok());
    let mut m = IDENTITY_3X4;
    m[3] = 2.0;
    let bad_inverse = TransformDesc::Static {
        child,
        object_to_world: m,
        world_to_object: IDENTITY_3X4,
    };
    expect_err(transform(&bad_inverse), &["not the inverse"]);
    let mut nan = IDENTITY_3X4;
    nan[0] = f32::NAN;
    expect_err(
        transform(&TransformDesc::Static {
            child,
            object_to_world: nan,
            world_to_object: nan,
        }),
        &["finite"],
    );
    let motion = MotionOptions {
        num_keys: 2,
        flags: MotionFlags::NONE,
        time_begin: 0.0,
        time_end: 1.0,
    };
    expect_err(
        transform(&TransformDesc::MatrixMotion {
            child,
            motion,
            keys: vec![IDENTITY_3X4],
        }),
        &["num_keys is 2 and 1 keys"],
    );
    expect_err(
        transform(&TransformDesc::MatrixMotion {
            child,
            motion,
            keys: vec![IDENTITY_3X4, [0.0; 12]],
        }),
        &["key 1", "not invertible"],
    );
    let bad_q = SrtData {
        qw: 0.5,
        ..SrtData::identity()
    };
    expect_err(
        transform(&TransformDesc::SrtMotion {
            child,
            motion,
            keys: vec![SrtData::identity(), bad_q],
        }),
        &["key 1", "unit quaternion"],
    );
    let flags = MotionOptions {
        flags: MotionFlags(8),
        ..motion
    };
    expect_err(
        transform(&TransformDesc::SrtMotion {
            child,
            motion: flags,
            keys: vec![SrtData::identity(); 2],
        }),
        &["unknown bits 0x8"],
    );
}

#[test]
fn micromaps() {
    let ok = OpacityMicromapArrayDesc {
        micromaps: vec![OpacityMicromapDesc {
            byte_offset: 0,
            subdivision_level: 2,
            format: OpacityMicromapFormat::FourState,
        }],
        data: vec![0; 4],
    };
    assert!(micromap_array(&ok).is_ok());
    let mut big = ok.clone();
    big.micromaps[0].subdivision_level = 13;
    expect_err(
        micromap_array(&big),
        &["subdivision_level is 13", "at most 12"],
    );
    let mut short = ok.clone();
    short.micromaps[0].subdivision_level = 3;
    expect_err(micromap_array(&short), &["needs 16 bytes", "4 bytes"]);
}

#[test]
fn launch_sizes() {
    assert!(launch_size(LaunchSize::new(0, 5, 5), &props()).is_ok());
    assert!(launch_size(LaunchSize::new(1024, 1024, 1), &props()).is_ok());
    expect_err(
        launch_size(LaunchSize::new(1025, 1024, 1), &props()),
        &["1025x1024x1", "limit of 1048576"],
    );
}

fn region(slot: u32, offset: u64, stride: u32, count: u32) -> SbtRegion {
    SbtRegion {
        buffer: buf(slot),
        offset,
        stride,
        count,
    }
}

#[test]
fn sbt_shapes() {
    let rec = optik_api::sbt::SbtRecord {
        buffer: buf(10),
        offset: 0,
    };
    let good = ShaderBindingTable {
        raygen: rec,
        exception: None,
        miss: Some(region(10, 32, 32, 2)),
        hitgroup: None,
        callables: None,
    };
    assert!(sbt(&good, &props(), &sizes).is_ok());
    let t = ShaderBindingTable {
        raygen: optik_api::sbt::SbtRecord {
            buffer: buf(10),
            offset: 8,
        },
        ..good
    };
    expect_err(
        sbt(&t, &props(), &sizes),
        &["sbt.raygen.offset is 8", "multiple of 16"],
    );
    let t = ShaderBindingTable {
        raygen: optik_api::sbt::SbtRecord {
            buffer: buf(10),
            offset: 992,
        },
        ..good
    };
    expect_err(sbt(&t, &props(), &sizes), &["sbt.raygen", "992..1024"]);
    let t = ShaderBindingTable {
        miss: Some(region(10, 0, 24, 1)),
        ..good
    };
    expect_err(
        sbt(&t, &props(), &sizes),
        &["sbt.miss.stride is 24", "32-byte header"],
    );
    let t = ShaderBindingTable {
        miss: Some(region(10, 0, 40, 1)),
        ..good
    };
    expect_err(
        sbt(&t, &props(), &sizes),
        &["sbt.miss.stride is 40", "multiple of 16"],
    );
    let t = ShaderBindingTable {
        hitgroup: Some(region(100, 0, 8192, 1)),
        ..good
    };
    expect_err(
        sbt(&t, &props(), &sizes),
        &["sbt.hitgroup.stride is 8192", "at most 4096"],
    );
    let t = ShaderBindingTable {
        hitgroup: Some(region(10, 0, 64, 20)),
        ..good
    };
    expect_err(
        sbt(&t, &props(), &sizes),
        &["sbt.hitgroup (20 records of stride 64)", "1000 bytes"],
    );
    let t = ShaderBindingTable {
        callables: Some(region(10, 4, 32, 1)),
        ..good
    };
    expect_err(sbt(&t, &props(), &sizes), &["sbt.callables.offset is 4"]);
    let t = ShaderBindingTable {
        exception: Some(optik_api::sbt::SbtRecord {
            buffer: buf(9),
            offset: 0,
        }),
        ..good
    };
    expect_err(sbt(&t, &props(), &sizes), &["sbt.exception", "destroyed"]);
}

#[test]
fn launch_bindings_checks() {
    // Build real binding infos through the front end.
    let src = optik_api::device::ProgramSource::new(
        "b.wgsl",
        "struct P { a: vec4<f32> }\n@group(0) @binding(0) var<uniform> params: P;\n@group(0) @binding(1) var<storage, read_write> out: array<u32>;\n@group(0) @binding(2) var tex: texture_2d<f32>;\n@group(0) @binding(3) var smp: sampler;\nfn raygen__a() { out[0] = u32(params.a.x) + u32(textureSampleLevel(tex, smp, vec2<f32>(0.0), 0.0).x); }\n",
    );
    let m = crate::frontend::compile(&src, 1).unwrap();
    let b = &m.bindings;
    let tex = optik_api::handle::Texture::from_raw(RawHandle {
        device: DeviceId(1),
        slot: 0,
        generation: 0,
    });
    let good = [
        Resource::buffer(1, buf(1)),
        Resource::Texture {
            binding: 2,
            texture: tex,
        },
        Resource::Sampler {
            binding: 3,
            sampler: SamplerDesc::default(),
        },
    ];
    assert!(launch_bindings(&[0; 16], &good, b, &sizes).is_ok());
    expect_err(
        launch_bindings(&[0; 8], &good, b, &sizes),
        &["params is 8 bytes", "needs 16 bytes"],
    );
    expect_err(
        launch_bindings(&[0; 16], &good[1..], b, &sizes),
        &["no resource given for binding 1 (`out`)"],
    );
    let swapped = [
        Resource::buffer(1, buf(1)),
        Resource::Sampler {
            binding: 2,
            sampler: SamplerDesc::default(),
        },
        good[2],
    ];
    expect_err(
        launch_bindings(&[0; 16], &swapped, b, &sizes),
        &["binding 2 (`tex`) is a texture", "a sampler was given"],
    );
    let dup = [good[0], good[1], good[2], Resource::buffer(1, buf(1))];
    expect_err(
        launch_bindings(&[0; 16], &dup, b, &sizes),
        &["binding 1 is given twice"],
    );
    let zero = [good[0], good[1], good[2], Resource::buffer(0, buf(1))];
    expect_err(
        launch_bindings(&[0; 16], &zero, b, &sizes),
        &["binding 0 is the launch parameters"],
    );
    let out_of_range = [
        Resource::Buffer {
            binding: 1,
            buffer: buf(1),
            offset: 64,
            size: Some(64),
        },
        good[1],
        good[2],
    ];
    expect_err(
        launch_bindings(&[0; 16], &out_of_range, b, &sizes),
        &["binding 1 (`out`)", "64..128"],
    );
    let odd = [
        Resource::Buffer {
            binding: 1,
            buffer: buf(1),
            offset: 0,
            size: Some(6),
        },
        good[1],
        good[2],
    ];
    expect_err(
        launch_bindings(&[0; 16], &odd, b, &sizes),
        &["multiples of 4"],
    );
    let destroyed = [Resource::buffer(1, buf(9)), good[1], good[2]];
    expect_err(
        launch_bindings(&[0; 16], &destroyed, b, &sizes),
        &["binding 1", "destroyed"],
    );
}

#[test]
fn textures_and_buffers() {
    let d = TextureDesc {
        width: 2,
        height: 2,
        format: TextureFormat::Rgba8Unorm,
    };
    assert!(texture(&d).is_ok() && texture_data(&d, &[0; 16]).is_ok());
    expect_err(texture(&TextureDesc { width: 0, ..d }), &["0x2"]);
    expect_err(texture_data(&d, &[0; 15]), &["15 bytes", "holds 16"]);
    assert!(buffer_create(1 << 30, &props()).is_ok());
    expect_err(
        buffer_create((1 << 30) + 1, &props()),
        &["1073741825 bytes", "largest buffer"],
    );
}
