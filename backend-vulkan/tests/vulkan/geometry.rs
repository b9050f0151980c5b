//! Triangle inputs: every vertex format (converted on the host where Vulkan lacks it), index
//! formats and strides, pre-transforms, NaN triangles, per-record face culling, vertex access;
//! refits and compaction.

use crate::common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
// Ray i goes down at (x_i, 0.25) from z = 5; x from the raygen record.
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 0u;
    rt_trace(params.handle, vec3<f32>(rt_sbt_data_f32(i), 0.25, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 100.0, 0.0, 0xFFu, rt_sbt_data_u32(16u), 0u, 1u, 0u, &p);
    for (var k = 0u; k < 14u; k++) {
        out[i * 14u + k] = p[k];
    }
}

fn closesthit__ch() {
    let b = rt_triangle_barycentrics();
    let v = rt_triangle_vertices();
    rt_set_payload(0u, rt_primitive_index() + 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, bitcast<u32>(b.x));
    rt_set_payload(3u, bitcast<u32>(b.y));
    for (var k = 0u; k < 3u; k++) {
        rt_set_payload(4u + k * 3u, bitcast<u32>(v[k].x));
        rt_set_payload(5u + k * 3u, bitcast<u32>(v[k].y));
        rt_set_payload(6u + k * 3u, bitcast<u32>(v[k].z));
    }
    rt_set_payload(13u, rt_sbt_gas_index());
}

fn miss__ms() {
    rt_set_payload(0u, 0xFFFFu);
}
"#;

fn setup(dev: &TestDevice) -> Basic {
    basic(dev, PROGRAMS)
}

/// Traces rays at `xs` (at most 16) with ray `flags`; 14 words per ray.
fn trace(dev: &TestDevice, s: &Basic, gas: Accel, xs: &[f32], flags: u32) -> Vec<[u32; 14]> {
    let mut words: Vec<u32> = xs.iter().map(|x| x.to_bits()).collect();
    words.resize(16, 0);
    words.push(flags);
    let mut table = Table::new(s.rg);
    table.raygen = (s.rg, &words);
    table.stride = 128;
    table.miss.push((s.ms, &[]));
    table.hit = vec![(s.ch, &[]), (s.ch, &[])];
    let sbt = table.build(dev);
    let w = run_rays(
        dev,
        s.pipeline,
        &sbt,
        dev.traversable_handle(gas).unwrap(),
        xs.len() as u32,
        14,
        &[],
    );
    w.chunks(14)
        .map(|c| std::array::from_fn(|k| c[k]))
        .collect()
}

fn f(bits: u32) -> f32 {
    f32::from_bits(bits)
}

fn half(v: f32) -> [u8; 2] {
    half::f16::from_f32(v).to_bits().to_le_bytes()
}

#[test]
fn every_vertex_format_and_index_format_gives_the_same_hits() {
    let dev = device();
    let s = setup(&dev);
    // Triangle (0,0,0) (1,0,0) (0,1,0), given as vertex 1, 2, 3 of four (vertex 0 unused),
    // indexed through u16 and u32 indices with padded strides.
    let pos = [
        [9.0f32, 9.0, 9.0],
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let encode = |format: VertexFormat| -> (Vec<u8>, u32) {
        let mut bytes = Vec::new();
        let stride = format.size() + format.alignment();
        for p in pos {
            let start = bytes.len();
            match format {
                VertexFormat::Float3 => p.iter().for_each(|c| bytes.extend(c.to_le_bytes())),
                VertexFormat::Float2 => p[..2].iter().for_each(|c| bytes.extend(c.to_le_bytes())),
                VertexFormat::Half3 => p.iter().for_each(|c| bytes.extend(half(*c))),
                VertexFormat::Half2 => p[..2].iter().for_each(|c| bytes.extend(half(*c))),
                VertexFormat::Snorm16x3 => p.iter().for_each(|c| {
                    bytes.extend(((c.clamp(-1.0, 1.0) * 32767.0) as i16).to_le_bytes())
                }),
                VertexFormat::Snorm16x2 => p[..2].iter().for_each(|c| {
                    bytes.extend(((c.clamp(-1.0, 1.0) * 32767.0) as i16).to_le_bytes())
                }),
            }
            bytes.resize(start + stride as usize, 0);
        }
        (bytes, stride)
    };
    let u16_indices = dev.buffer_with(
        &[1u16, 2, 3, 0]
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect::<Vec<_>>(),
    );
    let u32_indices = dev.u32_buffer(&[1, 2, 3, 0]);
    for format in [
        VertexFormat::Float3,
        VertexFormat::Float2,
        VertexFormat::Half3,
        VertexFormat::Half2,
        VertexFormat::Snorm16x3,
        VertexFormat::Snorm16x2,
    ] {
        for (indices, index_format, stride) in [
            (u16_indices, IndexFormat::U16x3, 8),
            (u32_indices, IndexFormat::U32x3, 16),
        ] {
            let (bytes, vstride) = encode(format);
            let vb = dev.buffer_with(&bytes);
            let mut t = TriangleArray::new(BufferView::new(vb), 4, GeometryFlags::DISABLE_ANYHIT);
            t.vertex_format = format;
            t.vertex_stride = vstride;
            t.indices = Some(TriangleIndices {
                buffer: BufferView::new(indices),
                format: index_format,
                stride,
                num_triangles: 1,
            });
            let options = AccelBuildOptions {
                flags: BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
                ..Default::default()
            };
            let gas = dev
                .accel_build(&options, &[BuildInput::Triangles(t)])
                .unwrap_or_else(|e| panic!("{format:?}: {e}"));
            let out = trace(&dev, &s, gas, &[0.25, 1.5], 0);
            assert_eq!(out[0][0], 1, "{format:?} {index_format:?}");
            assert_eq!(f(out[0][1]), 5.0);
            assert!(
                (f(out[0][2]) - 0.25).abs() < 1e-6 && (f(out[0][3]) - 0.25).abs() < 1e-6,
                "{format:?}: barycentrics"
            );
            let v: Vec<f32> = out[0][4..13].iter().map(|b| f(*b)).collect();
            assert_eq!(
                v,
                vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
                "{format:?}: vertices (decoded as the CPU backend does)"
            );
            assert_eq!(out[1][0], 0xFFFF);
        }
    }
}

/// The accuracy settings with different triangle paths: optik's triangle stage (the
/// default) and the driver's triangles.
pub fn triangle_paths() -> [Accuracy; 2] {
    [
        Accuracy::ROBUST,
        Accuracy {
            triangle: TriangleTest::Driver,
            box_test: BoxTest::Conservative,
        },
    ]
}

#[test]
fn pre_transform_nan_triangles_and_per_record_culling() {
    let dev = device();
    for accuracy in triangle_paths() {
        dev.set_accuracy(accuracy).unwrap();
        pre_transform_nan_triangles_and_per_record_culling_with(&dev, accuracy);
    }
}

fn pre_transform_nan_triangles_and_per_record_culling_with(dev: &TestDevice, accuracy: Accuracy) {
    let s = setup(dev);
    // Input 0: two triangles sharing vertices; the second has a NaN vertex of its own.
    let v = [
        0.0f32,
        0.0,
        0.0,
        1.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
        1.0,
        1.0,
        0.0,
        f32::NAN,
        0.5,
        0.0,
    ];
    let vb = dev.f32_buffer(&v);
    let ib = dev.u32_buffer(&[0, 1, 2, 1, 4, 2]);
    // Moved by +2 in x with a pre-transform.
    let m = dev.f32_buffer(&[1.0, 0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let mut t0 = TriangleArray::new(BufferView::new(vb), 5, GeometryFlags::DISABLE_ANYHIT)
        .with_indices(BufferView::new(ib), 2);
    t0.pre_transform = Some(BufferView::new(m));
    // Input 1: a clockwise triangle (back-facing from +z) with face culling disabled, at x = 4.
    let vb1 = dev.f32_buffer(&[4.0, 0.0, 0.0, 4.0, 1.0, 0.0, 5.0, 0.0, 0.0]);
    let t1 = TriangleArray::new(
        BufferView::new(vb1),
        3,
        GeometryFlags::DISABLE_ANYHIT | GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING,
    );
    // Input 2: the same clockwise triangle at x = 6, culled normally.
    let vb2 = dev.f32_buffer(&[6.0, 0.0, 0.0, 6.0, 1.0, 0.0, 7.0, 0.0, 0.0]);
    let t2 = TriangleArray::new(BufferView::new(vb2), 3, GeometryFlags::DISABLE_ANYHIT);
    let gas = dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[
                BuildInput::Triangles(t0),
                BuildInput::Triangles(t1),
                BuildInput::Triangles(t2),
            ],
        )
        .unwrap();
    let out = trace(
        dev,
        &s,
        gas,
        &[2.25, 2.9, 0.25, 4.25, 6.25],
        RayFlags::CULL_BACK_FACING_TRIANGLES.0,
    );
    assert_eq!(out[0][0], 1, "the pre-transform moved triangle 0 to x = 2");
    assert_eq!(
        out[1][0], 0xFFFF,
        "the NaN triangle never hits (its neighbour kept its shared vertices)"
    );
    assert_eq!(out[2][0], 0xFFFF);
    assert_eq!(
        (out[3][0], out[3][13]),
        (1, 1),
        "culling disabled on record 1 of the GAS (SBT GAS index kept)"
    );
    assert_eq!(out[4][0], 0xFFFF, "record 2 is culled");
    if accuracy.triangle == TriangleTest::Driver {
        // The vertex table was not kept (no ALLOW_RANDOM_VERTEX_ACCESS): zeros, as OptiX.
        assert_eq!(&out[0][4..7], &[0, 0, 0]);
    } else {
        // optik's triangle stage keeps the vertices it tests (as the CPU backend).
        assert_eq!(&out[0][4..7], &[2.0f32.to_bits(), 0, 0]);
    }
    dev.destroy_accel(gas).unwrap();
    dev.destroy_pipeline(s.pipeline).unwrap();
}

#[test]
fn refit_and_compaction_keep_results_and_handles() {
    let dev = device();
    let s = setup(&dev);
    let vb = dev.f32_buffer(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let input = |vb: Buffer| {
        BuildInput::Triangles(TriangleArray::new(
            BufferView::new(vb),
            3,
            GeometryFlags::DISABLE_ANYHIT,
        ))
    };
    let options = AccelBuildOptions {
        flags: BuildFlags::ALLOW_UPDATE | BuildFlags::ALLOW_COMPACTION,
        ..Default::default()
    };
    let sizes = dev.accel_memory_usage(&options, &[input(vb)]).unwrap();
    assert!(
        sizes.output_size_in_bytes > 0
            && sizes.temp_size_in_bytes > 0
            && sizes.temp_update_size_in_bytes > 0
    );
    let gas = dev.accel_build(&options, &[input(vb)]).unwrap();
    let inst = Instance::new(dev.traversable_handle(gas).unwrap());
    let ias = dev.instances(&[inst]);
    let h = dev.traversable_handle(gas).unwrap();
    assert_eq!(f(trace(&dev, &s, ias, &[0.25], 0)[0][1]), 5.0);
    // Refit: the triangle moves up to z = 1; the IAS over it follows.
    dev.write_buffer(
        vb,
        0,
        bytemuck::cast_slice(&[0.0f32, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0]),
    )
    .unwrap();
    let update = AccelBuildOptions {
        operation: BuildOperation::Update,
        ..options
    };
    dev.accel_update(gas, &update, &[input(vb)]).unwrap();
    assert_eq!(
        dev.traversable_handle(gas).unwrap(),
        h,
        "a refit keeps the handle"
    );
    assert_eq!(f(trace(&dev, &s, gas, &[0.25], 0)[0][1]), 4.0);
    assert_eq!(
        f(trace(&dev, &s, ias, &[0.25], 0)[0][1]),
        4.0,
        "the instance structure follows its refit child"
    );
    // Compaction: a new structure with the same hits, no larger.
    let compact = dev.accel_compact(gas).unwrap();
    assert_ne!(dev.traversable_handle(compact).unwrap(), h);
    assert!(dev.accel_size(compact).unwrap() <= dev.accel_size(gas).unwrap());
    assert_eq!(f(trace(&dev, &s, compact, &[0.25], 0)[0][1]), 4.0);
    dev.destroy_accel(gas).unwrap();
    assert_eq!(
        f(trace(&dev, &s, compact, &[0.25], 0)[0][1]),
        4.0,
        "the copy outlives the original"
    );
    // Updates need ALLOW_UPDATE; compaction needs ALLOW_COMPACTION.
    let plain = dev
        .accel_build(&AccelBuildOptions::default(), &[input(vb)])
        .unwrap();
    assert!(
        dev.accel_update(plain, &update, &[input(vb)])
            .unwrap_err()
            .message()
            .contains("ALLOW_UPDATE")
    );
    assert!(
        dev.accel_compact(plain)
            .unwrap_err()
            .message()
            .contains("ALLOW_COMPACTION")
    );
}

#[test]
fn empty_structures_and_null_children_miss() {
    let dev = device();
    let s = setup(&dev);
    let empty_gas = dev.triangles(&[], GeometryFlags::NONE);
    assert_eq!(trace(&dev, &s, empty_gas, &[0.25], 0)[0][0], 0xFFFF);
    let empty_ias = dev.instances(&[]);
    assert_eq!(trace(&dev, &s, empty_ias, &[0.25], 0)[0][0], 0xFFFF);
    let null_child = dev.instances(&[Instance::new(TraversableHandle::NULL)]);
    assert_eq!(trace(&dev, &s, null_child, &[0.25], 0)[0][0], 0xFFFF);
    // Compacting an instance structure gives an equal copy with its own handle.
    let gas = dev.triangles(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        GeometryFlags::DISABLE_ANYHIT,
    );
    let instances = [Instance::new(dev.traversable_handle(gas).unwrap())];
    // Without ALLOW_COMPACTION an instance structure is refused as on every backend.
    let plain = dev.instances(&instances);
    let e = dev.accel_compact(plain).unwrap_err();
    assert!(e.message().contains("ALLOW_COMPACTION"), "{e}");
    let b = dev.buffer_with(bytemuck::cast_slice(&instances));
    let ias = dev
        .accel_build(
            &AccelBuildOptions {
                flags: BuildFlags::ALLOW_COMPACTION,
                ..Default::default()
            },
            &[BuildInput::Instances(InstanceArray {
                instances: BufferView::new(b),
                num_instances: 1,
            })],
        )
        .unwrap();
    let copy = dev.accel_compact(ias).unwrap();
    assert_ne!(
        dev.traversable_handle(copy).unwrap(),
        dev.traversable_handle(ias).unwrap()
    );
    assert_eq!(trace(&dev, &s, copy, &[0.25], 0)[0][0], 1);
}
