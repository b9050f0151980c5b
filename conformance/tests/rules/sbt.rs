//! Records past the tables: a hit or miss whose record index lies past the hit or miss
//! records runs no program; under debug exceptions it raises `INVALID_HIT_SBT` or
//! `INVALID_MISS_SBT` (DESIGN.md §4, docs/*-backend.md).

use optik::*;
use optik_conformance::kit::rig::*;

#[test]
fn records_past_the_tables_run_nothing_or_raise_under_debug() {
    on_every_backend("sbt: records past the tables", |_, d| {
        let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
        let handle = d.traversable_handle(gas).unwrap();
        let src = format!(
            "{RAY_LIST}\nfn exception__code() {{ out[8u * rt_launch_index().x + 7u] = bitcast<u32>(rt_exception_code()); }}\n"
        );
        let m = module(d, &src);
        let g = ray_list_groups(
            d,
            m,
            2,
            &[ProgramGroupDesc::Exception(ProgramRef::new(
                m,
                "exception__code",
            ))],
        );
        // Ray 0 hits the quad, ray 1 misses it.
        let rays = [
            Ray::new([0.75, 0.25, 1.0], [0.0, 0.0, -1.0]),
            Ray::new([5.0, 0.5, 1.0], [0.0, 0.0, -1.0]),
        ];
        let table = numbered_sbt(d, &g);
        // Past the tables, one at a time (a backend may check the miss index when the trace
        // starts, as Vulkan does, so a ray past both may raise either).
        let past_hit = TraceArgs {
            sbt_offset: 2,
            ..Default::default()
        };
        let past_miss = TraceArgs {
            miss_index: 1,
            ..Default::default()
        };
        for debug in [false, true] {
            let options = PipelineCompileOptions {
                exception_flags: if debug {
                    Setting::Value(ExceptionFlags::DEBUG)
                } else {
                    Setting::Auto
                },
                ..Default::default()
            };
            let p = d
                .create_pipeline(
                    &options,
                    &PipelineLinkOptions {
                        max_trace_depth: 1,
                        ..Default::default()
                    },
                    &g.all(),
                )
                .unwrap_or_else(|e| panic!("{e}"));
            // In range: hit record 1, miss record 0.
            let inside = TraceArgs {
                sbt_offset: 1,
                ..Default::default()
            };
            let recs = trace_rays(d, p, &table, handle, &rays, inside);
            assert!(recs[0].hit() && recs[0].data() == 1, "{:?}", recs[0]);
            assert!(recs[1].missed() && recs[1].data() == 100, "{:?}", recs[1]);
            let hit = trace_rays(d, p, &table, handle, &rays, past_hit)[0];
            let miss = trace_rays(d, p, &table, handle, &rays, past_miss)[1];
            let recs = [hit, miss];
            if debug {
                assert_eq!(
                    recs[0].words[7] as i32,
                    semantics::exception::INVALID_HIT_SBT,
                    "hit record 2 of 2 under DEBUG"
                );
                assert_eq!(
                    recs[1].words[7] as i32,
                    semantics::exception::INVALID_MISS_SBT,
                    "miss record 1 of 1 under DEBUG"
                );
            } else {
                assert!(
                    recs[0].untouched(),
                    "hit record 2 of 2: no closest-hit runs: {:?}",
                    recs[0]
                );
                assert!(
                    recs[1].untouched(),
                    "miss record 1 of 1: no miss program runs: {:?}",
                    recs[1]
                );
            }
        }
    });
}

#[test]
fn per_primitive_offsets_past_the_records_are_errors() {
    on_every_backend("sbt: per-primitive offsets past the records", |_, d| {
        let vb = buffer(d, &[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let offsets = buffer(d, &[3u8, 0, 0, 0]);
        let mut input = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::NONE);
        input.flags = vec![GeometryFlags::NONE; 2];
        input.sbt_index_offsets = Some(SbtIndexOffsets {
            buffer: BufferView::new(offsets),
            size_in_bytes: 1,
            stride: 0,
        });
        let e = d
            .accel_build(
                &AccelBuildOptions::default(),
                &[BuildInput::Triangles(input)],
            )
            .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidArgument, "{e}");
        assert!(e.message().contains("sbt_index_offsets[0] is 3"), "{e}");
    });
}
