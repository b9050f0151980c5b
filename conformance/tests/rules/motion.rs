//! Motion past the catalog: moving curves (vertex and radius keys), nested motion chains, and
//! pipelines compiled without motion (key 0 everywhere, time 0).

use optik::*;
use optik_conformance::kit::rig::*;

#[test]
fn moving_curves_follow_their_keys() {
    on_every_backend("motion: moving curves", |_, d| {
        // A linear segment from (0, 0, 0) to (1, 0, 0), radius 0.25, moving +2 in x and
        // growing to radius 0.5 over times [0, 1].
        let key = |dx: f32| buffer(d, &[[dx, 0.0, 0.0], [dx + 1.0, 0.0, 0.0]]);
        let radius = |r: f32| buffer(d, &[r, r]);
        let curves = CurveArray {
            curve_type: CurveType::RoundLinear,
            num_primitives: 1,
            vertex_buffers: vec![BufferView::new(key(0.0)), BufferView::new(key(2.0))],
            num_vertices: 2,
            vertex_stride: 0,
            width_buffers: vec![BufferView::new(radius(0.25)), BufferView::new(radius(0.5))],
            width_stride: 0,
            index_buffer: BufferView::new(buffer(d, &[0u32])),
            index_stride: 0,
            flag: GeometryFlags::DISABLE_ANYHIT,
            primitive_index_offset: 0,
            endcaps: CurveEndcaps::Default,
        };
        let options = AccelBuildOptions {
            motion: Some(MotionOptions {
                num_keys: 2,
                flags: MotionFlags::NONE,
                time_begin: 0.0,
                time_end: 1.0,
            }),
            ..Default::default()
        };
        let gas = d
            .accel_build(&options, &[BuildInput::Curves(curves)])
            .unwrap();
        let m = module(
            d,
            &format!(
                "{RAY_LIST}\nfn closesthit__curve() {{ rt_set_payload(0u, 1u); rt_set_payload(1u, bitcast<u32>(rt_ray_tmax())); rt_set_payload(2u, rt_primitive_index()); }}\n"
            ),
        );
        let g = groups(
            d,
            &[
                raygen(m, "raygen__rays"),
                miss(m, "miss__rec"),
                ProgramGroupDesc::HitGroup {
                    closest_hit: Some(ProgramRef::new(m, "closesthit__curve")),
                    any_hit: None,
                    intersection: None,
                    builtin: BuiltinIntersector::Curve(CurveType::RoundLinear),
                },
            ],
        );
        let p = pipeline(d, &g, 1);
        let table = numbered_sbt(d, &g);
        let handle = d.traversable_handle(gas).unwrap();
        let down = |x: f32| Ray::new([x, 0.0, 5.0], [0.0, 0.0, -1.0]);
        let at = |time: f32, rays: &[Ray]| {
            let args = TraceArgs {
                time,
                ..Default::default()
            };
            trace_rays(d, p, &table, handle, rays, args)
        };
        let key0 = at(0.0, &[down(0.5)]);
        assert!(key0[0].hit(), "key 0: {:?}", key0[0]);
        assert!(
            (key0[0].t() - 4.75).abs() < 1e-4,
            "radius 0.25 at key 0: t {}",
            key0[0].t()
        );
        let half = at(0.5, &[down(1.5), down(0.5)]);
        assert!(half[0].hit(), "halfway: {:?}", half[0]);
        assert!(
            (half[0].t() - 4.625).abs() < 1e-4,
            "radius 0.375 halfway: t {}",
            half[0].t()
        );
        assert!(half[1].missed(), "moved away: {:?}", half[1]);
        let key1 = at(1.0, &[down(2.5)]);
        assert!(key1[0].hit(), "key 1: {:?}", key1[0]);
        assert!((key1[0].t() - 4.5).abs() < 1e-4, "t {}", key1[0].t());
    });
}

/// Closest-hit for the nested chain: hit, t, primitive, the object-to-world translation (x
/// and y), the instance id, the object-space origin's x and the ray's time.
const CHAIN_CH: &str = r#"
fn closesthit__chain() {
    let m = rt_object_to_world();
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_primitive_index());
    rt_set_payload(3u, bitcast<u32>(m[3].x));
    rt_set_payload(4u, rt_instance_id());
    rt_set_payload(5u, bitcast<u32>(m[3].y));
    rt_set_payload(6u, bitcast<u32>(rt_object_ray_origin().x));
    rt_set_payload(7u, bitcast<u32>(rt_ray_time()));
}
fn miss__time() {
    rt_set_payload(0u, 2u);
    rt_set_payload(7u, bitcast<u32>(rt_ray_time()));
}
"#;

#[test]
fn nested_motion_chains_and_pipelines_without_motion() {
    on_every_backend("motion: nested chains", |_, d| {
        let two_keys = MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: 0.0,
            time_end: 1.0,
        };
        // A triangle (0,0) (1,0) (0,1) at z = 0 moving by +2 in x from key 0 to key 1.
        let k0 = buffer(d, &[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let k1 = buffer(d, &[[2.0f32, 0.0, 0.0], [3.0, 0.0, 0.0], [2.0, 1.0, 0.0]]);
        let mut t = TriangleArray::new(BufferView::new(k0), 3, GeometryFlags::DISABLE_ANYHIT);
        t.vertex_buffers.push(BufferView::new(k1));
        let moving = d
            .accel_build(
                &AccelBuildOptions {
                    motion: Some(two_keys),
                    ..Default::default()
                },
                &[BuildInput::Triangles(t)],
            )
            .unwrap();
        let ias_of = |inst: Instance| {
            let ib = buffer(d, &[inst]);
            d.accel_build(
                &AccelBuildOptions::default(),
                &[BuildInput::Instances(InstanceArray {
                    instances: BufferView::new(ib),
                    num_instances: 1,
                })],
            )
            .unwrap()
        };
        // An instance (+10 in y) over a matrix motion (+10 in y, still) over a matrix motion
        // (+0 -> +4 in x) over an instance (+1 in x, id 5) over the moving triangle.
        let mut inner = Instance::new(d.traversable_handle(moving).unwrap());
        inner.transform[3] = 1.0;
        inner.instance_id = 5;
        let inner_ias = ias_of(inner);
        let mut m1 = IDENTITY_3X4;
        m1[3] = 4.0;
        let motion = d
            .create_transform(&TransformDesc::MatrixMotion {
                child: d.traversable_handle(inner_ias).unwrap(),
                motion: two_keys,
                keys: vec![IDENTITY_3X4, m1],
            })
            .unwrap();
        let mut lift = IDENTITY_3X4;
        lift[7] = 10.0;
        let outer_motion = d
            .create_transform(&TransformDesc::MatrixMotion {
                child: d.traversable_handle(motion).unwrap(),
                motion: two_keys,
                keys: vec![lift, lift],
            })
            .unwrap();
        let mut outer = Instance::new(d.traversable_handle(outer_motion).unwrap());
        outer.transform[7] = 10.0;
        let handle = d.traversable_handle(ias_of(outer)).unwrap();
        let m = module(d, &format!("{RAY_LIST}{CHAIN_CH}"));
        let g = groups(
            d,
            &[
                raygen(m, "raygen__rays"),
                miss(m, "miss__time"),
                closest_hit(m, "closesthit__chain"),
            ],
        );
        let table = numbered_sbt(d, &g);
        let down = |x: f32| Ray::new([x, 20.25, 5.0], [0.0, 0.0, -1.0]);
        // At t: x offset 1 + 4t (transforms) + 2t (vertices); y offset 20.
        let cast = |p: Pipeline| {
            let at = |time: f32, rays: &[Ray]| {
                let args = TraceArgs {
                    time,
                    ..Default::default()
                };
                trace_rays(d, p, &table, handle, rays, args)
            };
            let mut out = at(0.0, &[down(1.25)]);
            out.extend(at(0.5, &[down(1.25 + 3.0), down(1.25)]));
            out.extend(at(1.0, &[down(1.25 + 6.0)]));
            out
        };
        let f = |w: u32| f32::from_bits(w);
        let p = pipeline(d, &g, 1);
        let out = cast(p);
        let hits: Vec<bool> = out.iter().map(|r| r.hit()).collect();
        assert_eq!(hits, [true, true, false, true], "with motion: {out:?}");
        let r = out[1];
        assert_eq!(r.words[4], 5, "the instance closest to the geometry");
        assert_eq!(
            f(r.words[3]),
            1.0 + 2.0,
            "object_to_world: the instance and the motion at t = 0.5"
        );
        assert_eq!(f(r.words[5]), 20.0);
        assert_eq!(
            f(r.words[6]),
            0.25 + 1.0,
            "object space of the moving triangle"
        );
        // A pipeline compiled without motion uses key 0 everywhere and a time of 0.
        let still = d
            .create_pipeline(
                &PipelineCompileOptions {
                    uses_motion_blur: Setting::Value(false),
                    ..Default::default()
                },
                &PipelineLinkOptions {
                    max_trace_depth: 1,
                    ..Default::default()
                },
                &g.all(),
            )
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(!d.pipeline_features(still).unwrap().motion);
        let out = cast(still);
        let hits: Vec<bool> = out.iter().map(|r| r.hit()).collect();
        assert_eq!(hits, [true, false, true, false], "without motion: {out:?}");
        assert_eq!(f(out[2].words[7]), 0.0, "rt_ray_time without motion");
    });
}
