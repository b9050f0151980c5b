//! SBT record selection: per-primitive offsets, instance offsets, ray offset and stride,
//! miss indices; the bits that count.

use crate::kit::*;
use optik_api::semantics::sbt_index;
use optik_api::*;

#[test]
fn hit_record_index_uses_per_primitive_offsets() {
    let kit = Kit::new();
    for offset_size in [1u32, 2, 4] {
        // Input 0: 4 triangles, 3 records, offsets [2, 0, 1, 2] (strided 8 bytes);
        // input 1: 2 triangles, 1 record. Triangle k sits at x = 10 k.
        let tri = |k: u32| {
            let x = 10.0 * k as f32;
            vec![
                [x - 1.0, -1.0, 5.0],
                [x - 1.0, 3.0, 5.0],
                [x + 3.0, -1.0, 5.0],
            ]
        };
        let v0: Vec<[f32; 3]> = (0..4).flat_map(tri).collect();
        let v1: Vec<[f32; 3]> = (4..6).flat_map(tri).collect();
        let offsets = [2u32, 0, 1, 2];
        let mut bytes = vec![0u8; 32];
        for (i, o) in offsets.iter().enumerate() {
            bytes[i * 8..i * 8 + offset_size as usize]
                .copy_from_slice(&o.to_le_bytes()[..offset_size as usize]);
        }
        let ob = kit.buffer(&bytes);
        let mut input0 = TriangleArray::new(
            BufferView::new(kit.buffer(&v0)),
            12,
            GeometryFlags::DISABLE_ANYHIT,
        );
        input0.flags = vec![GeometryFlags::DISABLE_ANYHIT; 3];
        input0.sbt_index_offsets = Some(SbtIndexOffsets {
            buffer: BufferView::new(ob),
            size_in_bytes: offset_size,
            stride: 8,
        });
        let mut input1 = TriangleArray::new(
            BufferView::new(kit.buffer(&v1)),
            6,
            GeometryFlags::DISABLE_ANYHIT,
        );
        input1.primitive_index_offset = 100;
        let gas = kit.build(
            AccelBuildOptions::default(),
            &[BuildInput::Triangles(input0), BuildInput::Triangles(input1)],
        );
        let mut inst = Instance::new(gas);
        inst.sbt_offset = 5;
        let root = kit.instances(&[inst]);
        let log = Log::default();
        let (l1, l2) = (log.clone(), log.clone());
        // Ray (k, offset, stride) combinations, with high bits that must not count.
        let cases: Vec<(u32, u32, u32)> = (0..6)
            .flat_map(|k| [(k, 0, 1), (k, 1, 2), (k, 0x13, 0x22), (k, 3, 0)])
            .collect();
        let rays = cases.clone();
        let m = kit.module(vec![
            (
                "raygen__main",
                program(move |c| {
                    let (k, off, stride) = rays[c.launch_index()[0] as usize];
                    let r = Ray {
                        sbt_offset: off,
                        sbt_stride: stride,
                        ..Ray::new([10.0 * k as f32, 0.0, 0.0], [0.0, 0.0, 1.0])
                    };
                    trace_ray(c, root, r, &mut [0]);
                }),
            ),
            (
                "closesthit__main",
                program(move |c| {
                    l1.put(
                        c,
                        "ch",
                        &[
                            c.sbt_data_u32(0) as f64,
                            c.sbt_gas_index() as f64,
                            c.primitive_index() as f64,
                        ],
                    )
                }),
            ),
            ("miss__main", program(move |c| l2.put(c, "miss", &[]))),
        ]);
        let rg = kit.raygen(m, "raygen__main");
        let ms = kit.miss(m, "miss__main");
        let hg = kit.hit(m, Some("closesthit__main"), None, None);
        let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
        let hit: Vec<Rec> = (0..64u32).map(|i| Rec::with_u32(hg, &[i])).collect();
        let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &hit, &[], None);
        kit.launch(p, &sbt, cases.len() as u32);
        for (x, &(k, off, stride)) in cases.iter().enumerate() {
            let gas_index = if k < 4 { offsets[k as usize] } else { 3 };
            let want = sbt_index::hit_record_index(5, gas_index, off, stride);
            let prim = if k < 4 { k } else { 100 + k - 4 };
            assert_eq!(
                log.get(x as u32, "ch"),
                Some(vec![want as f64, gas_index as f64, prim as f64]),
                "offset size {offset_size}, triangle {k}, ray offset {off:#x} stride {stride:#x}"
            );
        }
    }
}

#[test]
fn miss_index_keeps_sixteen_bits() {
    let kit = Kit::new();
    let log = Log::default();
    let (l1, l2) = (log.clone(), log.clone());
    let indices = [0u32, 1, 2, 0x1_0002, 0xFFFF_0001];
    let m = kit.module(vec![
        (
            "raygen__main",
            program(move |c| {
                let r = Ray {
                    miss: indices[c.launch_index()[0] as usize],
                    ..Ray::new([0.0; 3], [0.0, 0.0, 1.0])
                };
                trace_ray(c, TraversableHandle::NULL, r, &mut [0]);
            }),
        ),
        (
            "miss__a",
            program(move |c| l1.put(c, "miss", &[c.sbt_data_u32(0) as f64])),
        ),
        (
            "miss__b",
            program(move |c| l2.put(c, "miss", &[100.0 + c.sbt_data_u32(0) as f64])),
        ),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let a = kit.miss(m, "miss__a");
    let b = kit.miss(m, "miss__b");
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, a, b]);
    let sbt = kit.sbt(
        Rec::new(rg),
        &[
            Rec::with_u32(a, &[0]),
            Rec::with_u32(b, &[1]),
            Rec::with_u32(a, &[2]),
        ],
        &[],
        &[],
        None,
    );
    kit.launch(p, &sbt, 5);
    let want = [0.0, 101.0, 2.0, 2.0, 101.0];
    for (x, w) in want.iter().enumerate() {
        assert_eq!(
            log.get(x as u32, "miss"),
            Some(vec![*w]),
            "miss index {:#x}",
            indices[x]
        );
    }
}
