//! Built-in spheres and curves, and opacity micromaps, through the device.

use crate::kit::*;
use optik_api::semantics::opacity::MicromapState;
use optik_api::*;

/// Traces rays at `root` with one hit group of `builtin`; logs t, hit kind and the
/// primitive data closest-hit reads.
fn run(
    kit: &Kit,
    root: TraversableHandle,
    rays: Vec<Ray>,
    builtin: BuiltinIntersector,
    any_hit: bool,
) -> Log {
    let log = Log::default();
    let (l1, l2, l3) = (log.clone(), log.clone(), log.clone());
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
            program(move |c| {
                let s = c.sphere();
                l1.put(
                    c,
                    "ch",
                    &[
                        c.ray_tmax() as f64,
                        c.hit_kind() as f64,
                        c.primitive_index() as f64,
                        s[0] as f64,
                        s[3] as f64,
                        c.curve_parameter() as f64,
                    ],
                );
            }),
        ),
        ("anyhit__main", program(move |c| l3.put(c, "ah", &[]))),
        ("miss__main", program(move |c| l2.put(c, "miss", &[]))),
    ]);
    let rg = kit.raygen(m, "raygen__main");
    let ms = kit.miss(m, "miss__main");
    let hg = kit.hit_builtin(
        m,
        Some("closesthit__main"),
        any_hit.then_some("anyhit__main"),
        None,
        builtin,
    );
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, ms, hg]);
    let sbt = kit.sbt(Rec::new(rg), &[Rec::new(ms)], &[Rec::new(hg)], &[], None);
    kit.launch(p, &sbt, n);
    log
}

#[test]
fn spheres_report_entry_exit_and_their_data() {
    let kit = Kit::new();
    let centres = [[0.0f32, 0.0, 10.0], [5.0, 0.0, 10.0], [3.0e3, 0.0, -1.0e5]];
    let radii = [2.0f32, 0.5, 1.0];
    let input = SphereArray {
        vertex_buffers: vec![BufferView::new(kit.buffer(&centres))],
        vertex_stride: 0,
        num_vertices: 3,
        radius_buffers: vec![BufferView::new(kit.buffer(&radii))],
        radius_stride: 0,
        single_radius: false,
        flags: vec![GeometryFlags::DISABLE_ANYHIT],
        sbt_index_offsets: None,
        primitive_index_offset: 0,
    };
    let gas = kit.build(AccelBuildOptions::default(), &[BuildInput::Spheres(input)]);
    let rays = vec![
        Ray::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        Ray::new([0.0, 0.0, 10.0], [0.0, 0.0, 1.0]),
        Ray::new([5.0, 0.4, 0.0], [0.0, 0.0, 1.0]),
        Ray::new([5.0, 0.6, 0.0], [0.0, 0.0, 1.0]),
        // A unit sphere 1e5 away: aimed at its centre.
        Ray::new([0.0, 0.0, 0.0], [3.0e3, 0.0, -1.0e5]),
    ];
    let log = run(&kit, gas, rays, BuiltinIntersector::Sphere, false);
    assert_eq!(
        log.get(0, "ch"),
        Some(vec![8.0, 0xFE as f64, 0.0, 0.0, 2.0, 0.0])
    );
    assert_eq!(
        log.get(1, "ch"),
        Some(vec![2.0, 0xFF as f64, 0.0, 0.0, 2.0, 0.0]),
        "from inside: the exit, a back face"
    );
    let ch = log.get(2, "ch").unwrap();
    assert!(
        (ch[0] - (10.0 - (0.25f64 - 0.16).sqrt())).abs() < 1e-5 && ch[2] == 1.0 && ch[3] == 5.0,
        "{ch:?}"
    );
    assert_eq!(log.names(3), vec!["miss"]);
    let ch = log.get(4, "ch").unwrap();
    let dist = (3.0e3f64 * 3.0e3 + 1.0e5 * 1.0e5).sqrt();
    assert!((ch[0] - (1.0 - 1.0 / dist)).abs() < 1e-6, "{ch:?}");
}

#[test]
fn curves_of_every_basis_hit_within_tolerance() {
    let kit = Kit::new();
    // A straight strand along x at y = 0, z = 5, radius 0.2: every basis describes the same
    // straight tube, so rays down -y... up +z at x hit at t = 5 - 0.2.
    for curve_type in [
        CurveType::RoundLinear,
        CurveType::RoundQuadraticBSpline,
        CurveType::RoundCubicBSpline,
        CurveType::RoundCatmullRom,
    ] {
        let points: Vec<[f32; 3]> = (0..8).map(|i| [i as f32, 0.0, 5.0]).collect();
        let widths = [0.2f32; 8];
        let per = curve_type.control_points();
        let segments: Vec<u32> = (0..=(8 - per)).collect();
        let input = CurveArray {
            curve_type,
            num_primitives: segments.len() as u32,
            vertex_buffers: vec![BufferView::new(kit.buffer(&points))],
            num_vertices: 8,
            vertex_stride: 0,
            width_buffers: vec![BufferView::new(kit.buffer(&widths))],
            width_stride: 0,
            index_buffer: BufferView::new(kit.buffer(&segments)),
            index_stride: 0,
            flag: GeometryFlags::DISABLE_ANYHIT,
            primitive_index_offset: 0,
            endcaps: CurveEndcaps::Default,
        };
        let gas = kit.build(AccelBuildOptions::default(), &[BuildInput::Curves(input)]);
        // The strand's centre runs over x in [first, last] of the evaluated segments.
        let rays: Vec<Ray> = (0..40)
            .map(|i| Ray::new([1.6 + i as f32 * 0.1, 0.05, 0.0], [0.0, 0.0, 1.0]))
            .collect();
        let log = run(
            &kit,
            gas,
            rays,
            BuiltinIntersector::Curve(curve_type),
            false,
        );
        for i in 0..40u32 {
            let ch = log
                .get(i, "ch")
                .unwrap_or_else(|| panic!("{curve_type:?}: ray {i} missed"));
            let want = 5.0 - (0.04f64 - 0.0025).sqrt();
            assert!(
                (ch[0] - want).abs() < 1e-3,
                "{curve_type:?}: t {} vs {want}",
                ch[0]
            );
            assert!((0.0..=1.0).contains(&ch[5]), "curve parameter {}", ch[5]);
            assert_eq!(ch[1], 0xFE as f64);
        }
    }
}

#[test]
fn opacity_micromaps_states_special_indices_and_overrides() {
    let kit = Kit::new();
    // Level-1 micromaps over the unit triangle (0,0)-(1,0)-(0,1) at z = 5: micro-triangle k
    // has its centroid at C[k].
    const C: [(f32, f32); 4] = [
        (1.0 / 6.0, 1.0 / 6.0),
        (1.0 / 3.0, 1.0 / 3.0),
        (2.0 / 3.0, 1.0 / 6.0),
        (1.0 / 6.0, 2.0 / 3.0),
    ];
    let desc = OpacityMicromapArrayDesc {
        micromaps: vec![
            OpacityMicromapDesc {
                byte_offset: 0,
                subdivision_level: 1,
                format: OpacityMicromapFormat::TwoState,
            },
            OpacityMicromapDesc {
                byte_offset: 1,
                subdivision_level: 1,
                format: OpacityMicromapFormat::FourState,
            },
        ],
        data: vec![0b0110, 0b11_10_01_00],
    };
    let array = kit.dev.create_opacity_micromap_array(&desc).unwrap();
    // Six triangles at x offsets 0, 2, 4, …: micromap 0, micromap 1, specials -1..-4.
    let indices = [0i32, 1, -1, -2, -3, -4];
    let mut v = Vec::new();
    for k in 0..6 {
        let x = 2.0 * k as f32;
        v.extend([[x, 0.0, 5.0], [x + 1.0, 0.0, 5.0], [x, 1.0, 5.0]]);
    }
    let mut input = TriangleArray::new(BufferView::new(kit.buffer(&v)), 18, GeometryFlags::NONE);
    input.opacity_micromap = Some(TriangleOpacityMicromap {
        array,
        index_buffer: Some(BufferView::new(kit.buffer(&indices))),
        index_size_in_bytes: 4,
        index_stride: 0,
        base_index: 0,
    });
    let gas = kit.build(
        AccelBuildOptions::default(),
        &[BuildInput::Triangles(input)],
    );
    let mut plain = Instance::new(gas);
    plain.visibility_mask = 1;
    let mut forced = Instance::new(gas);
    forced.visibility_mask = 2;
    forced.flags = InstanceFlags::FORCE_OPACITY_MICROMAP_2_STATE.0;
    let mut disabled = Instance::new(gas);
    disabled.visibility_mask = 4;
    disabled.flags = InstanceFlags::DISABLE_OPACITY_MICROMAPS.0;
    let root = kit.instances(&[plain, forced, disabled]);
    let mut rays = Vec::new();
    let mut want = Vec::new();
    let states_2 = [
        MicromapState::Transparent,
        MicromapState::Opaque,
        MicromapState::Opaque,
        MicromapState::Transparent,
    ];
    let states_4 = [
        MicromapState::Transparent,
        MicromapState::Opaque,
        MicromapState::UnknownTransparent,
        MicromapState::UnknownOpaque,
    ];
    for (mask, inst_flags) in [
        (1u32, InstanceFlags::NONE),
        (2, InstanceFlags::FORCE_OPACITY_MICROMAP_2_STATE),
        (4, InstanceFlags::DISABLE_OPACITY_MICROMAPS),
    ] {
        for ray_flags in [RayFlags::NONE, RayFlags::FORCE_OPACITY_MICROMAP_2_STATE] {
            for (tri, &index) in indices.iter().enumerate() {
                for (k, c) in C.iter().enumerate() {
                    rays.push(
                        Ray::new([2.0 * tri as f32 + c.0, c.1, 0.0], [0.0, 0.0, 1.0])
                            .mask(mask)
                            .flags(ray_flags.0),
                    );
                    let state = match index {
                        0 => states_2[k],
                        1 => states_4[k],
                        s => MicromapState::from_code((-1 - s) as u32),
                    };
                    want.push(semantics::opacity::resolve(
                        GeometryFlags::NONE,
                        inst_flags,
                        ray_flags,
                        Some(state),
                    ));
                }
            }
        }
    }
    let log = run(&kit, root, rays, BuiltinIntersector::Triangle, true);
    use semantics::opacity::CandidateFate::*;
    for (x, fate) in want.iter().enumerate() {
        let names = log.names(x as u32);
        let expected: Vec<&str> = match fate {
            Culled => vec!["miss"],
            Opaque => vec!["ch"],
            NonOpaque => vec!["ah", "ch"],
        };
        assert_eq!(names, expected, "ray {x}");
    }
    for f in [Culled, Opaque, NonOpaque] {
        assert!(want.contains(&f));
    }
}
