//! Builds from every vertex and index format, pre-transforms, updates, compaction, memory
//! estimates.

use crate::kit::*;
use optik_api::*;

/// Closest-hit t and primitive index per ray, or None on a miss.
fn hits(kit: &Kit, root: TraversableHandle, rays: Vec<Ray>) -> Vec<Option<(f32, u32)>> {
    let log = Log::default();
    let l = log.clone();
    let n = rays.len() as u32;
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let r = rays[c.launch_index()[0] as usize];
                trace_ray(c, root, r, &mut [0]);
            }),
        ),
        (
            "closesthit__main",
            program(move |c| l.put(c, "ch", &[c.ray_tmax() as f64, c.primitive_index() as f64])),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, n);
    (0..n)
        .map(|x| log.get(x, "ch").map(|c| (c[0] as f32, c[1] as u32)))
        .collect()
}

#[test]
fn every_vertex_and_index_format_with_pre_transform() {
    let kit = Kit::new();
    // Two triangles in the unit square at z = 0.5 (values exact in every format).
    let verts = [
        [0.0f32, 0.0, 0.5],
        [0.0, 0.5, 0.5],
        [0.5, 0.5, 0.5],
        [0.5, 0.0, 0.5],
    ];
    let tris = [[0u16, 1, 2], [0, 2, 3]];
    // Pre-transform: scale 2 then move up by 3 → the square spans [0, 1]² at z = 4.
    let pre: Matrix3x4 = [2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 3.0];
    let pre_buffer = kit.buffer(&pre);
    let rays = vec![
        Ray::new([0.25, 0.75, 0.0], [0.0, 0.0, 1.0]),
        Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, 1.0]),
    ];
    for format in [
        VertexFormat::Float3,
        VertexFormat::Float2,
        VertexFormat::Half3,
        VertexFormat::Half2,
        VertexFormat::Snorm16x3,
        VertexFormat::Snorm16x2,
    ] {
        for index_format in [IndexFormat::U16x3, IndexFormat::U32x3] {
            // Vertices with a stride of 16 bytes.
            let mut vb = vec![0u8; 16 * 4];
            for (i, v) in verts.iter().enumerate() {
                let at = &mut vb[i * 16..];
                let comps = if matches!(
                    format,
                    VertexFormat::Float2 | VertexFormat::Half2 | VertexFormat::Snorm16x2
                ) {
                    2
                } else {
                    3
                };
                for k in 0..comps {
                    match format {
                        VertexFormat::Float3 | VertexFormat::Float2 => {
                            at[k * 4..k * 4 + 4].copy_from_slice(&v[k].to_le_bytes())
                        }
                        VertexFormat::Half3 | VertexFormat::Half2 => at[k * 2..k * 2 + 2]
                            .copy_from_slice(&half::f16::from_f32(v[k]).to_bits().to_le_bytes()),
                        _ => at[k * 2..k * 2 + 2]
                            .copy_from_slice(&((v[k] * 32767.0).round() as i16).to_le_bytes()),
                    }
                }
            }
            let mut ib = Vec::new();
            for t in tris {
                for i in t {
                    match index_format {
                        IndexFormat::U16x3 => ib.extend(i.to_le_bytes()),
                        IndexFormat::U32x3 => ib.extend((i as u32).to_le_bytes()),
                    }
                }
                ib.extend([0u8; 4]);
            }
            let isize = index_format.size();
            let input = TriangleArray {
                vertex_buffers: vec![BufferView::new(kit.buffer(&vb))],
                num_vertices: 4,
                vertex_format: format,
                vertex_stride: 16,
                indices: Some(TriangleIndices {
                    buffer: BufferView::new(kit.buffer(&ib)),
                    format: index_format,
                    stride: isize + 4,
                    num_triangles: 2,
                }),
                pre_transform: Some(BufferView::new(pre_buffer)),
                ..TriangleArray::new(
                    BufferView::new(pre_buffer),
                    0,
                    GeometryFlags::DISABLE_ANYHIT,
                )
            };
            let gas = kit.build(
                AccelBuildOptions::default(),
                &[BuildInput::Triangles(input)],
            );
            let got = hits(&kit, gas, rays.clone());
            let z = if matches!(
                format,
                VertexFormat::Float2 | VertexFormat::Half2 | VertexFormat::Snorm16x2
            ) {
                3.0
            } else {
                4.0
            };
            // 0.5 is exact in f32 and f16; snorm16 stores 16384 / 32767.
            let tolerance = if matches!(format, VertexFormat::Snorm16x3) {
                1e-4
            } else {
                0.0
            };
            for (k, h) in got.iter().enumerate() {
                let (t, prim) =
                    h.unwrap_or_else(|| panic!("{format:?} with {index_format:?}: ray {k} missed"));
                assert!(
                    (t - z).abs() <= tolerance && prim == k as u32,
                    "{format:?} with {index_format:?}: {got:?}"
                );
            }
        }
    }
}

#[test]
fn update_refits_and_keeps_the_handle() {
    let kit = Kit::new();
    let a = quad(-1.0, -1.0, 1.0, 1.0, 5.0);
    let vb = kit.buffer(&a);
    let input = |b: Buffer| {
        BuildInput::Triangles(TriangleArray::new(
            BufferView::new(b),
            6,
            GeometryFlags::DISABLE_ANYHIT,
        ))
    };
    let options = AccelBuildOptions {
        flags: BuildFlags::ALLOW_UPDATE | BuildFlags::ALLOW_COMPACTION,
        ..Default::default()
    };
    let accel = kit.dev.accel_build(&options, &[input(vb)]).unwrap();
    let handle = kit.dev.traversable_handle(accel).unwrap();
    // Both rays cross the upper-left triangle (primitive 0) of their quad.
    let rays = || {
        vec![
            Ray::new([-0.5, 0.5, 0.0], [0.0, 0.0, 1.0]),
            Ray::new([3.5, 0.5, 0.0], [0.0, 0.0, 1.0]),
        ]
    };
    assert_eq!(hits(&kit, handle, rays()), vec![Some((5.0, 0)), None]);
    // Move the quad to x in [3, 5] and z = 7.
    kit.dev
        .write_buffer(vb, 0, bytemuck::cast_slice(&quad(3.0, -1.0, 5.0, 1.0, 7.0)))
        .unwrap();
    let update = AccelBuildOptions {
        operation: BuildOperation::Update,
        ..options
    };
    kit.dev.accel_update(accel, &update, &[input(vb)]).unwrap();
    assert_eq!(kit.dev.traversable_handle(accel).unwrap(), handle);
    assert_eq!(hits(&kit, handle, rays()), vec![None, Some((7.0, 0))]);
    // Updates must match the build and need ALLOW_UPDATE.
    let two = kit.buffer(&[a.clone(), a.clone()].concat());
    let e = kit
        .dev
        .accel_update(
            accel,
            &update,
            &[BuildInput::Triangles(TriangleArray::new(
                BufferView::new(two),
                12,
                GeometryFlags::DISABLE_ANYHIT,
            ))],
        )
        .unwrap_err();
    assert!(e.message().contains("updates keep kinds and counts"), "{e}");
    let fixed = kit
        .dev
        .accel_build(&AccelBuildOptions::default(), &[input(vb)])
        .unwrap();
    let e = kit
        .dev
        .accel_update(fixed, &update, &[input(vb)])
        .unwrap_err();
    assert!(e.message().contains("ALLOW_UPDATE"), "{e}");
    let e = kit.dev.accel_compact(fixed).unwrap_err();
    assert!(e.message().contains("ALLOW_COMPACTION"), "{e}");
    // Compaction: a smaller copy that traces the same; the original stays valid.
    let compact = kit.dev.accel_compact(accel).unwrap();
    let (full, small) = (
        kit.dev.accel_size(accel).unwrap(),
        kit.dev.accel_size(compact).unwrap(),
    );
    assert!(small <= full, "compacted {small} bytes vs {full}");
    // With many primitives leaves hold several, so the tree is smaller than the estimate.
    let many: Vec<[f32; 3]> = (0..500)
        .flat_map(|i| quad(i as f32, 0.0, i as f32 + 0.5, 0.5, 1.0))
        .collect();
    let big = kit
        .dev
        .accel_build(
            &options,
            &[BuildInput::Triangles(TriangleArray::new(
                BufferView::new(kit.buffer(&many)),
                3000,
                GeometryFlags::NONE,
            ))],
        )
        .unwrap();
    let big_compact = kit.dev.accel_compact(big).unwrap();
    let (full_big, small_big) = (
        kit.dev.accel_size(big).unwrap(),
        kit.dev.accel_size(big_compact).unwrap(),
    );
    assert!(
        small_big < full_big,
        "compacted {small_big} bytes vs {full_big}"
    );
    let usage = kit.dev.accel_memory_usage(&options, &[input(vb)]).unwrap();
    assert_eq!(
        usage.output_size_in_bytes, full,
        "a build's size is its memory estimate until compacted"
    );
    let ch = kit.dev.traversable_handle(compact).unwrap();
    assert_ne!(ch, handle);
    assert_eq!(hits(&kit, ch, rays()), hits(&kit, handle, rays()));
}

#[test]
fn instance_structures_update_their_transforms() {
    let kit = Kit::new();
    let gas = kit.triangles(
        &quad(-0.5, -0.5, 0.5, 0.5, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let mut inst = Instance::new(gas);
    let ib = kit.buffer(&[inst]);
    let input = BuildInput::Instances(InstanceArray {
        instances: BufferView::new(ib),
        num_instances: 1,
    });
    let options = AccelBuildOptions {
        flags: BuildFlags::ALLOW_UPDATE,
        ..Default::default()
    };
    let accel = kit
        .dev
        .accel_build(&options, std::slice::from_ref(&input))
        .unwrap();
    let root = kit.dev.traversable_handle(accel).unwrap();
    let rays = || {
        vec![
            Ray::new([-0.25, 0.25, 0.0], [0.0, 0.0, 1.0]),
            Ray::new([19.75, 0.25, 0.0], [0.0, 0.0, 1.0]),
        ]
    };
    assert_eq!(hits(&kit, root, rays()), vec![Some((5.0, 0)), None]);
    inst.transform[3] = 20.0;
    kit.dev
        .write_buffer(ib, 0, bytemuck::bytes_of(&inst))
        .unwrap();
    kit.dev
        .accel_update(
            accel,
            &AccelBuildOptions {
                operation: BuildOperation::Update,
                ..options
            },
            &[input],
        )
        .unwrap();
    assert_eq!(hits(&kit, root, rays()), vec![None, Some((5.0, 0))]);
}
