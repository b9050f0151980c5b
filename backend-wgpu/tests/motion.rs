//! Motion: geometry keys, matrix and SRT motion transforms, vanish flags.
mod common;
use common::*;
use optik_api::*;

fn motion(flags: MotionFlags) -> MotionOptions {
    MotionOptions {
        num_keys: 2,
        flags,
        time_begin: 0.0,
        time_end: 1.0,
    }
}

fn trace_at(dev: &dyn Device, top: TraversableHandle, x: f32, y: f32, time: f32) -> Rec {
    let m = module(dev, RAY_LIST);
    let g = ray_list_groups(dev, m, 1, &[]);
    let p = pipeline(dev, &g, 1);
    let table = numbered_sbt(dev, &g);
    let args = TraceArgs {
        time,
        ..Default::default()
    };
    trace_rays(
        dev,
        p,
        &table,
        top,
        &[Ray::new([x, y, 5.0], [0.0, 0.0, -1.0])],
        args,
    )[0]
}

/// Traces several (x, y, time) rays with one pipeline.
fn trace_all(dev: &dyn Device, top: TraversableHandle, rays: &[(f32, f32, f32)]) -> Vec<bool> {
    let m = module(dev, RAY_LIST);
    let g = ray_list_groups(dev, m, 1, &[]);
    let p = pipeline(dev, &g, 1);
    let table = numbered_sbt(dev, &g);
    rays.iter()
        .map(|&(x, y, time)| {
            let args = TraceArgs {
                time,
                ..Default::default()
            };
            trace_rays(
                dev,
                p,
                &table,
                top,
                &[Ray::new([x, y, 5.0], [0.0, 0.0, -1.0])],
                args,
            )[0]
            .hit()
        })
        .collect()
}

#[test]
fn triangle_keys_interpolate_and_vanish_flags() {
    for (flags, before, after) in [
        (MotionFlags::NONE, true, true),
        (
            MotionFlags::START_VANISH | MotionFlags::END_VANISH,
            false,
            false,
        ),
    ] {
        let dev = device();
        let d = dev.as_ref();
        let k0 = buffer(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0));
        let k1 = buffer(d, &quad(2.0, 3.0, 0.0, 1.0, 0.0));
        let mut input = TriangleArray::new(BufferView::new(k0), 6, GeometryFlags::NONE);
        input.vertex_buffers.push(BufferView::new(k1));
        let gas = d
            .accel_build(
                &AccelBuildOptions {
                    motion: Some(motion(flags)),
                    ..Default::default()
                },
                &[BuildInput::Triangles(input)],
            )
            .unwrap();
        let top = d.traversable_handle(gas).unwrap();
        let hits = trace_all(
            d,
            top,
            &[
                (0.5, 0.5, 0.0),
                (0.5, 0.5, 1.0),
                (2.5, 0.5, 1.0),
                (1.5, 0.5, 0.5),
                (0.5, 0.5, 0.5),
                (0.5, 0.5, -1.0),
                (2.5, 0.5, 2.0),
            ],
        );
        assert_eq!(&hits[..5], &[true, false, true, true, false], "{flags:?}");
        assert_eq!(hits[5], before, "before time_begin with {flags:?}");
        assert_eq!(hits[6], after, "after time_end with {flags:?}");
    }
}

#[test]
fn matrix_and_srt_motion_transforms() {
    let dev = device();
    let d = dev.as_ref();
    // A 1×1 quad centred at (2.5, 0).
    let gas = triangles(d, &quad(2.0, 3.0, -0.5, 0.5, 0.0), GeometryFlags::NONE);
    let child = d.traversable_handle(gas).unwrap();
    let shift = |x: f32| [1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let matrix = d
        .create_transform(&TransformDesc::MatrixMotion {
            child,
            motion: motion(MotionFlags::NONE),
            keys: vec![shift(0.0), shift(4.0)],
        })
        .unwrap();
    let m = d.traversable_handle(matrix).unwrap();
    let hits = trace_all(
        d,
        m,
        &[
            (2.5, 0.0, 0.0),
            (4.5, 0.0, 0.5),
            (2.5, 0.0, 0.5),
            (6.5, 0.0, 1.0),
        ],
    );
    assert_eq!(hits, vec![true, true, false, true], "matrix keys lerp");

    // SRT: a quarter turn about z. At half time (nlerp) the quad has turned 45°.
    let half = std::f32::consts::FRAC_PI_4;
    let srt = d
        .create_transform(&TransformDesc::SrtMotion {
            child,
            motion: motion(MotionFlags::NONE),
            keys: vec![
                SrtData::identity(),
                SrtData {
                    qz: half.sin(),
                    qw: half.cos(),
                    ..SrtData::identity()
                },
            ],
        })
        .unwrap();
    let s = d.traversable_handle(srt).unwrap();
    let diag = 2.5 * std::f32::consts::FRAC_1_SQRT_2;
    let hits = trace_all(
        d,
        s,
        &[
            (2.5, 0.0, 0.0),
            (0.0, 2.5, 1.0),
            (diag, diag, 0.5),
            (2.5, 0.0, 0.5),
        ],
    );
    assert_eq!(
        hits,
        vec![true, true, true, false],
        "SRT keys rotate the quad"
    );

    // The same motion transform under an instance.
    let b = buffer(d, &[Instance::new(s)]);
    let ias = d
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Instances(InstanceArray {
                instances: BufferView::new(b),
                num_instances: 1,
            })],
        )
        .unwrap();
    let top = d.traversable_handle(ias).unwrap();
    let rec = trace_at(d, top, diag, diag, 0.5);
    assert!(rec.hit(), "an instance over an SRT motion transform");
}

#[test]
fn moving_spheres() {
    let dev = device();
    let d = dev.as_ref();
    let c0 = buffer(d, &[[0.0f32, 0.0, 0.0]]);
    let c1 = buffer(d, &[[2.0f32, 0.0, 0.0]]);
    let r = buffer(d, &[0.25f32]);
    let input = BuildInput::Spheres(SphereArray {
        vertex_buffers: vec![BufferView::new(c0), BufferView::new(c1)],
        vertex_stride: 0,
        num_vertices: 1,
        radius_buffers: vec![BufferView::new(r), BufferView::new(r)],
        radius_stride: 0,
        single_radius: true,
        flags: vec![GeometryFlags::NONE],
        sbt_index_offsets: None,
        primitive_index_offset: 0,
    });
    let gas = d
        .accel_build(
            &AccelBuildOptions {
                motion: Some(motion(MotionFlags::NONE)),
                ..Default::default()
            },
            &[input],
        )
        .unwrap();
    let m = module(d, RAY_LIST);
    let g = groups(
        d,
        &[
            raygen(m, "raygen__rays"),
            miss(m, "miss__rec"),
            ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(m, "closesthit__rec")),
                any_hit: None,
                intersection: None,
                builtin: BuiltinIntersector::Sphere,
            },
        ],
    );
    let p = pipeline(d, &g, 1);
    let table = numbered_sbt(d, &g);
    let top = d.traversable_handle(gas).unwrap();
    let at = |x: f32, time: f32| {
        trace_rays(
            d,
            p,
            &table,
            top,
            &[Ray::new([x, 0.0, 5.0], [0.0, 0.0, -1.0])],
            TraceArgs {
                time,
                ..Default::default()
            },
        )[0]
    };
    assert!(at(1.0, 0.5).hit());
    assert!((at(1.0, 0.5).t() - 4.75).abs() < 1e-5);
    assert!(at(1.0, 0.0).missed());
    assert!(at(2.0, 1.0).hit());
}
