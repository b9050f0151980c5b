//! SBT record selection: per-primitive offsets, ray offset / stride / miss index (high bits
//! ignored), record data, and headers checked at launch.
mod common;
use common::*;
use optik_api::*;

struct Rig {
    dev: Box<dyn Device>,
    pipeline: Pipeline,
    groups: Groups,
    handle: TraversableHandle,
}

/// Input 0: the unit quad with two records (triangle 0 → record 0, triangle 1 → record 1);
/// input 1: the quad at x = 2..3 with one record (SBT GAS index 2). Six hit groups, two
/// miss groups.
fn rig() -> Rig {
    let dev = device();
    let d = dev.as_ref();
    let a = buffer(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0));
    let b = buffer(d, &quad(2.0, 3.0, 0.0, 1.0, 0.0));
    let offsets = buffer(d, &[0u8, 1, 0, 0]);
    let mut input0 = TriangleArray::new(BufferView::new(a), 6, GeometryFlags::NONE);
    input0.flags = vec![GeometryFlags::NONE, GeometryFlags::NONE];
    input0.sbt_index_offsets = Some(SbtIndexOffsets {
        buffer: BufferView::new(offsets),
        size_in_bytes: 1,
        stride: 0,
    });
    let mut input1 = TriangleArray::new(BufferView::new(b), 6, GeometryFlags::NONE);
    input1.primitive_index_offset = 100;
    let gas = d
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Triangles(input0), BuildInput::Triangles(input1)],
        )
        .unwrap();
    let m = module(d, RAY_LIST);
    let mut descs = vec![
        raygen(m, "raygen__rays"),
        miss(m, "miss__rec"),
        miss(m, "miss__rec"),
    ];
    for _ in 0..6 {
        descs.push(closest_hit(m, "closesthit__rec"));
    }
    let groups = groups(d, &descs);
    let pipeline = pipeline(d, &groups, 1);
    let handle = d.traversable_handle(gas).unwrap();
    Rig {
        dev,
        pipeline,
        groups,
        handle,
    }
}

fn rays() -> Vec<Ray> {
    let down = |x, y| Ray::new([x, y, 1.0], [0.0, 0.0, -1.0]);
    vec![
        down(0.75, 0.25),
        down(0.25, 0.75),
        // Inside the second quad's first triangle, off the diagonal it shares with the other.
        down(2.75, 0.25),
        down(5.0, 0.5),
    ]
}

#[test]
fn gas_index_and_record_formula() {
    let r = rig();
    let d = r.dev.as_ref();
    let table = numbered_sbt(d, &r.groups);
    let recs = trace_rays(
        d,
        r.pipeline,
        &table,
        r.handle,
        &rays(),
        TraceArgs::default(),
    );
    assert_eq!((recs[0].gas_index(), recs[0].data()), (0, 0));
    assert_eq!((recs[1].gas_index(), recs[1].data()), (1, 1));
    assert_eq!(
        (recs[2].gas_index(), recs[2].data(), recs[2].prim()),
        (2, 2, 100)
    );
    assert_eq!(recs[3].data(), 100, "miss record 0");
    // offset 1, stride 2: records 1, 3, 5; only the low 4 bits count (0x11 → 1, 0x12 → 2),
    // and the low 16 bits of the miss index (0x10001 → 1).
    let args = TraceArgs {
        sbt_offset: 0x11,
        sbt_stride: 0x12,
        miss_index: 0x1_0001,
        ..Default::default()
    };
    let recs = trace_rays(d, r.pipeline, &table, r.handle, &rays(), args);
    assert_eq!(
        [
            recs[0].data(),
            recs[1].data(),
            recs[2].data(),
            recs[3].data()
        ],
        [1, 3, 5, 101]
    );
    // Stride 0: every geometry uses the same record.
    let args = TraceArgs {
        sbt_offset: 4,
        sbt_stride: 0,
        ..Default::default()
    };
    let recs = trace_rays(d, r.pipeline, &table, r.handle, &rays(), args);
    assert_eq!([recs[0].data(), recs[1].data(), recs[2].data()], [4, 4, 4]);
}

#[test]
fn out_of_range_records_run_nothing() {
    let r = rig();
    let d = r.dev.as_ref();
    let table = numbered_sbt(d, &r.groups);
    let args = TraceArgs {
        sbt_offset: 6,
        miss_index: 2,
        ..Default::default()
    };
    let recs = trace_rays(d, r.pipeline, &table, r.handle, &rays(), args);
    assert!(
        recs[0].untouched(),
        "hit record 6 of 6: no closest-hit runs"
    );
    assert!(
        recs[3].untouched(),
        "miss record 2 of 2: no miss program runs"
    );
}

#[test]
fn bad_headers_are_errors_naming_the_record() {
    let r = rig();
    let d = r.dev.as_ref();
    let mut table = numbered_sbt(d, &r.groups);
    let launch = |t: &ShaderBindingTable| {
        let out = d.create_buffer(64).unwrap();
        let rb = buffer(d, &[[0.0f32; 4]; 2]);
        d.launch(
            r.pipeline,
            &params(r.handle, &[0, 0, 1, 0, 0xFF, 0]),
            &[Resource::buffer(1, out), Resource::buffer(2, rb)],
            t,
            LaunchSize::new(1, 1, 1),
        )
    };
    launch(&table).unwrap();
    // A zeroed record in the hit region.
    let hit = table.hitgroup.unwrap();
    d.write_buffer(hit.buffer, hit.offset + 2 * STRIDE as u64, &[0u8; 32])
        .unwrap();
    let e = launch(&table).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidArgument);
    assert!(e.message().contains("sbt.hitgroup record 2"), "{e}");
    // A miss group's header where a hit group's belongs.
    let header = d.sbt_record_pack_header(r.groups.miss[0]).unwrap();
    d.write_buffer(hit.buffer, hit.offset + 2 * STRIDE as u64, &header)
        .unwrap();
    let e = launch(&table).unwrap_err();
    assert!(
        e.message().contains("miss group") && e.message().contains("hit group region"),
        "{e}"
    );
    // A group of another pipeline.
    let m = module(d, RAY_LIST);
    let other = d
        .create_program_groups(&[closest_hit(m, "closesthit__rec")])
        .unwrap()[0];
    let header = d.sbt_record_pack_header(other).unwrap();
    d.write_buffer(hit.buffer, hit.offset + 2 * STRIDE as u64, &header)
        .unwrap();
    let e = launch(&table).unwrap_err();
    assert!(
        e.message().contains("not one of this pipeline's groups"),
        "{e}"
    );
    // Misaligned strides are caught by validation.
    table.hitgroup = Some(SbtRegion { stride: 40, ..hit });
    assert!(launch(&table).is_err());
}
