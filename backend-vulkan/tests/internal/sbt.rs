//! Shader binding table: SBT offset, stride and miss index with garbage in the high bits,
//! record data, per-primitive SBT records flattened into geometries (SBT GAS index,
//! primitive index remap and offset), and miss indices past the table.

use crate::common::*;
use optik_api::*;

fn tri_at(k: f32) -> [[f32; 3]; 3] {
    [[k, 0.0, 0.0], [k + 1.0, 0.0, 0.0], [k, 1.0, 0.0]]
}

/// Hits past the hit records under debug exceptions raise INVALID_HIT_SBT (as the CPU
/// backend does when it looks a candidate's record up); without them they are hits without
/// programs, except custom primitives, which need an intersection program to be hit at all.
#[test]
fn hit_indices_past_the_table_raise_invalid_hit_sbt_under_debug_exceptions() {
    let src = r#"
fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 7u;
    out[2u * i + 1u] = 0u;
    // Ray i meets primitive kind i (triangle, sphere, custom box) at x = 3 i; record 9.
    rt_trace(params.handle, vec3<f32>(3.0 * f32(i) + 0.25, 0.25, 5.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 9u, 0u, 0u, &p);
    out[2u * i] = p[0];
}
fn closesthit__ch() { rt_set_payload(0u, 1u); }
fn miss__ms() { rt_set_payload(0u, 2u); }
fn intersection__is() {
    var a: RtAttributes;
    rt_report_intersection(1.0, 0u, a);
}
fn exception__ex() {
    out[2u * rt_launch_index().x + 1u] = bitcast<u32>(rt_exception_code());
}
"#;
    let invalid_hit = semantics::exception::INVALID_HIT_SBT as u32;
    let driver = Accuracy {
        triangle: TriangleTest::Driver,
        box_test: BoxTest::Conservative,
    };
    for accuracy in [Accuracy::ROBUST, driver] {
        for debug in [false, true] {
            let dev = device();
            dev.set_accuracy(accuracy).unwrap();
            let tri = dev.triangles(&tri_at(0.0), GeometryFlags::DISABLE_ANYHIT);
            let mut handles = vec![dev.traversable_handle(tri).unwrap()];
            if accuracy == Accuracy::ROBUST {
                // optik's own primitives: one group serves every kind past the table.
                let centre = dev.f32_buffer(&[3.25, 0.25, 0.0]);
                let radius = dev.f32_buffer(&[0.5]);
                let spheres = SphereArray {
                    vertex_buffers: vec![BufferView::new(centre)],
                    vertex_stride: 0,
                    num_vertices: 1,
                    radius_buffers: vec![BufferView::new(radius)],
                    radius_stride: 0,
                    single_radius: true,
                    flags: vec![GeometryFlags::DISABLE_ANYHIT],
                    sbt_index_offsets: None,
                    primitive_index_offset: 0,
                };
                let s = dev
                    .accel_build(
                        &AccelBuildOptions::default(),
                        &[BuildInput::Spheres(spheres)],
                    )
                    .unwrap();
                let b = dev.aabbs(
                    &[[6.0, 0.0, -1.0, 7.0, 1.0, 1.0]],
                    GeometryFlags::DISABLE_ANYHIT,
                );
                handles.extend([s, b].map(|a| dev.traversable_handle(a).unwrap()));
            }
            let ias = dev.instances(
                &handles
                    .iter()
                    .map(|h| Instance::new(*h))
                    .collect::<Vec<_>>(),
            );
            let m = dev.module(&format!("{RAY_HEADER}{src}"));
            let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
            let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
            let ch = dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__ch")));
            let is = dev.group(ProgramGroupDesc::HitGroup {
                closest_hit: Some(prog(m, "closesthit__ch")),
                any_hit: None,
                intersection: Some(prog(m, "intersection__is")),
                builtin: BuiltinIntersector::Triangle,
            });
            let ex = dev.group(ProgramGroupDesc::Exception(prog(m, "exception__ex")));
            let exceptions = if debug {
                ExceptionFlags::DEBUG
            } else {
                ExceptionFlags::NONE
            };
            let options = PipelineCompileOptions {
                exception_flags: Setting::Value(exceptions),
                ..Default::default()
            };
            // Native triangles share the records past the table with AABB kinds only in a
            // pipeline without them (one Vulkan group serves one geometry type).
            let (groups, hits) = if accuracy == Accuracy::ROBUST {
                (vec![rg, ms, ch, is, ex], vec![(ch, &[][..]), (is, &[][..])])
            } else {
                (vec![rg, ms, ch, ex], vec![(ch, &[][..])])
            };
            let pipeline = dev
                .create_pipeline(&options, &PipelineLinkOptions::default(), &groups)
                .unwrap();
            let mut table = Table::new(rg);
            table.miss.push((ms, &[]));
            table.hit = hits;
            table.exception = Some((ex, &[]));
            let sbt = table.build(&dev);
            let n = handles.len() as u32;
            let w = run_rays(
                &dev,
                pipeline,
                &sbt,
                dev.traversable_handle(ias).unwrap(),
                n,
                2,
                &[],
            );
            let what = format!("{:?}, debug {debug}", accuracy.triangle);
            let got: Vec<(u32, u32)> = w.chunks(2).map(|c| (c[0], c[1])).collect();
            // Triangle and sphere: a hit without programs, or the exception (the launch
            // index ends: the payload is not copied back). Custom box: never hit without
            // an intersection program, or the exception at its box.
            let want: Vec<(u32, u32)> = if debug {
                vec![(0, invalid_hit); n as usize]
            } else {
                [(7, 0), (7, 0), (2, 0)][..n as usize].to_vec()
            };
            assert_eq!(got, want, "{what}");
        }
    }
}
