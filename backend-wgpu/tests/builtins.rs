//! Built-in spheres and curves.
mod common;
use common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, a: u32, b: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read> rays: array<vec4<f32>>;

fn raygen__rays() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 2u;
    rt_trace(params.handle, rays[2u * i].xyz, rays[2u * i + 1u].xyz, 0.0, 1e30, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    for (var k = 0u; k < 8u; k = k + 1u) {
        out[8u * i + k] = p[k];
    }
}

fn closesthit__sphere() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_primitive_index());
    rt_set_payload(3u, rt_hit_kind());
    let s = rt_sphere();
    rt_set_payload(4u, bitcast<u32>(s.x));
    rt_set_payload(5u, bitcast<u32>(s.w));
}

fn closesthit__curve() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_primitive_index());
    rt_set_payload(3u, rt_hit_kind());
    rt_set_payload(4u, bitcast<u32>(rt_curve_parameter()));
}

fn miss__none() {
    rt_set_payload(0u, 2u);
}
"#;

fn trace(
    dev: &dyn Device,
    gas: Accel,
    ch: &str,
    builtin: BuiltinIntersector,
    rays: &[([f32; 3], [f32; 3])],
) -> Vec<[u32; 8]> {
    let m = module(dev, PROGRAMS);
    let g = groups(
        dev,
        &[
            raygen(m, "raygen__rays"),
            miss(m, "miss__none"),
            ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(m, ch)),
                any_hit: None,
                intersection: None,
                builtin,
            },
        ],
    );
    let p = pipeline(dev, &g, 1);
    let table = sbt(dev, &g, &[]);
    let words: Vec<[f32; 4]> = rays
        .iter()
        .flat_map(|(o, d)| [[o[0], o[1], o[2], 0.0], [d[0], d[1], d[2], 0.0]])
        .collect();
    let rb = buffer(dev, &words);
    let out = dev.create_buffer((rays.len() * 32) as u64).unwrap();
    dev.launch(
        p,
        &params(dev.traversable_handle(gas).unwrap(), &[]),
        &[Resource::buffer(1, out), Resource::buffer(2, rb)],
        &table,
        LaunchSize::new(rays.len() as u32, 1, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    read::<u32>(dev, out)
        .chunks_exact(8)
        .map(|c| c.try_into().unwrap())
        .collect()
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn spheres_from_outside_and_inside() {
    let dev = device();
    let dev = dev.as_ref();
    let centres = buffer(dev, &[[0.0f32, 0.0, 0.0], [3.0, 0.0, 0.0]]);
    let radii = buffer(dev, &[1.0f32, 0.5]);
    let input = BuildInput::Spheres(SphereArray {
        vertex_buffers: vec![BufferView::new(centres)],
        vertex_stride: 0,
        num_vertices: 2,
        radius_buffers: vec![BufferView::new(radii)],
        radius_stride: 0,
        single_radius: false,
        flags: vec![GeometryFlags::NONE],
        sbt_index_offsets: None,
        primitive_index_offset: 10,
    });
    let gas = dev
        .accel_build(&AccelBuildOptions::default(), &[input])
        .unwrap();
    let down = [0.0, 0.0, -1.0];
    let out = trace(
        dev,
        gas,
        "closesthit__sphere",
        BuiltinIntersector::Sphere,
        &[
            ([0.0, 0.0, 5.0], down),
            ([3.0, 0.0, 5.0], down),
            ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            ([1.6, 0.0, 5.0], down),
        ],
    );
    assert_eq!(out[0][0], 1);
    assert!(close(f32::from_bits(out[0][1]), 4.0, 1e-5));
    assert_eq!(out[0][2], 10, "primitive index with its offset");
    assert_eq!(out[0][3], 0xFE, "from outside: front");
    assert_eq!(
        (f32::from_bits(out[0][4]), f32::from_bits(out[0][5])),
        (0.0, 1.0),
        "rt_sphere"
    );
    assert!(close(f32::from_bits(out[1][1]), 4.5, 1e-5) && out[1][2] == 11);
    assert_eq!(out[2][0], 1, "a ray from inside hits the far side");
    assert!(close(f32::from_bits(out[2][1]), 1.0, 1e-5));
    assert_eq!(out[2][3], 0xFF, "from inside: back");
    assert_eq!(out[3][0], 2, "between the spheres");
}

fn curve_gas(dev: &dyn Device, curve_type: CurveType, xs: &[f32], endcaps: CurveEndcaps) -> Accel {
    let points: Vec<[f32; 3]> = xs.iter().map(|&x| [x, 0.0, 0.0]).collect();
    let vb = buffer(dev, &points);
    let wb = buffer(dev, &vec![0.1f32; xs.len()]);
    let per = curve_type.control_points() as usize;
    let segments: Vec<u32> = (0..=(xs.len() - per) as u32).collect();
    let ib = buffer(dev, &segments);
    let input = BuildInput::Curves(CurveArray {
        curve_type,
        num_primitives: segments.len() as u32,
        vertex_buffers: vec![BufferView::new(vb)],
        num_vertices: xs.len() as u32,
        vertex_stride: 0,
        width_buffers: vec![BufferView::new(wb)],
        width_stride: 0,
        index_buffer: BufferView::new(ib),
        index_stride: 0,
        flag: GeometryFlags::NONE,
        primitive_index_offset: 0,
        endcaps,
    });
    dev.accel_build(&AccelBuildOptions::default(), &[input])
        .unwrap()
}

#[test]
fn linear_curves_are_round_with_caps() {
    let dev = device();
    let dev = dev.as_ref();
    let gas = curve_gas(
        dev,
        CurveType::RoundLinear,
        &[-1.0, 1.0],
        CurveEndcaps::Default,
    );
    let down = [0.0, 0.0, -1.0];
    let out = trace(
        dev,
        gas,
        "closesthit__curve",
        BuiltinIntersector::Curve(CurveType::RoundLinear),
        &[
            ([0.5, 0.0, 5.0], down),
            ([1.05, 0.0, 5.0], down),
            ([0.5, 0.2, 5.0], down),
            ([0.5, 0.05, 5.0], down),
        ],
    );
    assert_eq!(out[0][0], 1);
    assert!(
        close(f32::from_bits(out[0][1]), 4.9, 1e-5),
        "{}",
        f32::from_bits(out[0][1])
    );
    assert!(
        close(f32::from_bits(out[0][4]), 0.75, 1e-5),
        "curve parameter"
    );
    assert_eq!(out[0][3], 0xFE);
    assert_eq!(out[1][0], 1, "the round cap at the end");
    let cap_z = (0.01f32 - 0.0025).sqrt();
    assert!(close(f32::from_bits(out[1][1]), 5.0 - cap_z, 1e-5));
    assert_eq!(out[2][0], 2, "beyond the radius");
    let side_z = (0.01f32 - 0.0025).sqrt();
    assert!(
        close(f32::from_bits(out[3][1]), 5.0 - side_z, 1e-5),
        "round cross-section"
    );
}

#[test]
fn cubic_curves_within_tolerance_and_open_ends() {
    let dev = device();
    let dev = dev.as_ref();
    let down = [0.0, 0.0, -1.0];
    let rays = [
        ([0.5, 0.0, 5.0], down),
        ([-0.05, 0.0, 5.0], down),
        ([3.0, 0.0, 5.0], down),
    ];
    // Collinear, evenly spaced B-spline points: the segment is the line from x = 0 to 1.
    for (caps, end_hit) in [(CurveEndcaps::Default, false), (CurveEndcaps::On, true)] {
        let gas = curve_gas(
            dev,
            CurveType::RoundCubicBSpline,
            &[-1.0, 0.0, 1.0, 2.0],
            caps,
        );
        let out = trace(
            dev,
            gas,
            "closesthit__curve",
            BuiltinIntersector::Curve(CurveType::RoundCubicBSpline),
            &rays,
        );
        assert_eq!(out[0][0], 1);
        assert!(
            close(f32::from_bits(out[0][1]), 4.9, 1e-4),
            "{}",
            f32::from_bits(out[0][1])
        );
        assert!(
            close(f32::from_bits(out[0][4]), 0.5, 1e-3),
            "curve parameter {}",
            f32::from_bits(out[0][4])
        );
        assert_eq!(out[1][0] == 1, end_hit, "end caps {caps:?}");
        assert_eq!(out[2][0], 2);
    }
}
