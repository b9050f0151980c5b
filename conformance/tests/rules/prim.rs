//! Built-in primitives past the catalog: curves of every basis (the same straight tube;
//! cubic B-splines within the stated tolerance, open ends unless end caps are on), opacity
//! micromaps above subdivision level 0 (micro-triangle states in OptiX's and Vulkan's order;
//! every state, both formats and the special indices under every opacity flag of rays,
//! instances and geometries) and pipelines that disallow micromaps.

use optik::*;
use optik_conformance::kit::rig::*;

/// A raygen tracing rays from a buffer (origin, direction) down to closest-hit, which records
/// hit, t, primitive, hit kind and the curve parameter; the any-hit counts its calls.
const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, flags: u32, b: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read> rays: array<vec4<f32>>;

fn raygen__rays() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 2u;
    p[5] = 0u;
    rt_trace(params.handle, rays[2u * i].xyz, rays[2u * i + 1u].xyz, 0.0, 1e30, 0.0, 0xFFu, params.flags, params.b, 1u, 0u, &p);
    for (var k = 0u; k < 8u; k = k + 1u) {
        out[8u * i + k] = p[k];
    }
}

fn closesthit__curve() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_primitive_index());
    rt_set_payload(3u, rt_hit_kind());
    rt_set_payload(4u, bitcast<u32>(rt_curve_parameter()));
}

fn closesthit__hit() {
    rt_set_payload(0u, 1u);
}

fn anyhit__count() {
    rt_set_payload(5u, rt_get_payload(5u) + 1u);
}

fn miss__none() {
    rt_set_payload(0u, 2u);
}
"#;

/// Launches one index per ray of `p` over `gas`; returns the 8 words each recorded.
fn trace(
    d: &dyn Device,
    p: Pipeline,
    table: &ShaderBindingTable,
    gas: Accel,
    flags: RayFlags,
    sbt_offset: u32,
    rays: &[([f32; 3], [f32; 3])],
) -> Vec<[u32; 8]> {
    let words: Vec<[f32; 4]> = rays
        .iter()
        .flat_map(|(o, v)| [[o[0], o[1], o[2], 0.0], [v[0], v[1], v[2], 0.0]])
        .collect();
    let rb = buffer(d, &words);
    let out = d.create_buffer((rays.len() * 32) as u64).unwrap();
    d.launch(
        p,
        &params(d.traversable_handle(gas).unwrap(), &[flags.0, sbt_offset]),
        &[Resource::buffer(1, out), Resource::buffer(2, rb)],
        table,
        LaunchSize::new(rays.len() as u32, 1, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    read::<u32>(d, out)
        .chunks_exact(8)
        .map(|c| c.try_into().unwrap())
        .collect()
}

/// A pipeline of [`PROGRAMS`] with the hit groups `hits` makes from the module, one record
/// each.
fn rig(
    d: &dyn Device,
    hits: impl Fn(Module) -> Vec<ProgramGroupDesc>,
) -> (Pipeline, ShaderBindingTable) {
    let m = module(d, PROGRAMS);
    let mut descs = vec![raygen(m, "raygen__rays"), miss(m, "miss__none")];
    descs.extend(hits(m));
    let g = groups(d, &descs);
    (pipeline(d, &g, 1), sbt(d, &g, &[]))
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

fn curve_gas(d: &dyn Device, curve_type: CurveType, xs: &[f32], endcaps: CurveEndcaps) -> Accel {
    let points: Vec<[f32; 3]> = xs.iter().map(|&x| [x, 0.0, 0.0]).collect();
    let vb = buffer(d, &points);
    let wb = buffer(d, &vec![0.1f32; xs.len()]);
    let per = curve_type.control_points() as usize;
    let segments: Vec<u32> = (0..=(xs.len() - per) as u32).collect();
    let ib = buffer(d, &segments);
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
    d.accel_build(&AccelBuildOptions::default(), &[input])
        .unwrap()
}

#[test]
fn curves_of_every_basis_hit_the_same_straight_tube() {
    on_every_backend("prim: curves of every basis", |_, d| {
        // A straight strand along x at y = 0, z = 5, radius 0.2: every basis describes the
        // same straight tube, so rays up +z at y = 0.05 hit at t = 5 - sqrt(0.2² - 0.05²).
        let bases = [
            CurveType::RoundLinear,
            CurveType::RoundQuadraticBSpline,
            CurveType::RoundCubicBSpline,
            CurveType::RoundCatmullRom,
        ];
        let gases = bases.map(|curve_type| {
            let points: Vec<[f32; 3]> = (0..8).map(|i| [i as f32, 0.0, 5.0]).collect();
            let per = curve_type.control_points();
            let segments: Vec<u32> = (0..=(8 - per)).collect();
            let input = CurveArray {
                curve_type,
                num_primitives: segments.len() as u32,
                vertex_buffers: vec![BufferView::new(buffer(d, &points))],
                num_vertices: 8,
                vertex_stride: 0,
                width_buffers: vec![BufferView::new(buffer(d, &[0.2f32; 8]))],
                width_stride: 0,
                index_buffer: BufferView::new(buffer(d, &segments)),
                index_stride: 0,
                flag: GeometryFlags::DISABLE_ANYHIT,
                primitive_index_offset: 0,
                endcaps: CurveEndcaps::Default,
            };
            d.accel_build(&AccelBuildOptions::default(), &[BuildInput::Curves(input)])
                .unwrap()
        });
        // One pipeline: hit record k holds the intersector of basis k.
        let (p, table) = rig(d, |m| {
            bases
                .iter()
                .map(|&curve_type| ProgramGroupDesc::HitGroup {
                    closest_hit: Some(ProgramRef::new(m, "closesthit__curve")),
                    any_hit: None,
                    intersection: None,
                    builtin: BuiltinIntersector::Curve(curve_type),
                })
                .collect()
        });
        // The strand's centre runs over x in [first, last] of the evaluated segments.
        let rays: Vec<([f32; 3], [f32; 3])> = (0..40)
            .map(|i| ([1.6 + i as f32 * 0.1, 0.05, 0.0], [0.0, 0.0, 1.0]))
            .collect();
        let want = 5.0 - (0.04f64 - 0.0025).sqrt();
        for (k, (curve_type, gas)) in bases.iter().zip(gases).enumerate() {
            let out = trace(d, p, &table, gas, RayFlags::NONE, k as u32, &rays);
            for (i, o) in out.iter().enumerate() {
                assert_eq!(o[0], 1, "{curve_type:?}: ray {i} missed");
                let t = f32::from_bits(o[1]) as f64;
                assert!((t - want).abs() < 1e-3, "{curve_type:?}: t {t} vs {want}");
                let u = f32::from_bits(o[4]);
                assert!(
                    (0.0..=1.0).contains(&u),
                    "{curve_type:?}: curve parameter {u}"
                );
                assert_eq!(o[3], 0xFE, "{curve_type:?}: hit kind");
            }
        }
    });
}

#[test]
fn cubic_curves_within_tolerance_and_open_ends() {
    on_every_backend("prim: cubic B-spline curves", |_, d| {
        let down = [0.0, 0.0, -1.0];
        let rays = [
            ([0.5, 0.0, 5.0], down),
            ([-0.05, 0.0, 5.0], down),
            ([3.0, 0.0, 5.0], down),
        ];
        // Collinear, evenly spaced B-spline points: the segment is the line from x = 0 to 1.
        let curve = CurveType::RoundCubicBSpline;
        let cases =
            [(CurveEndcaps::Default, false), (CurveEndcaps::On, true)].map(|(caps, end_hit)| {
                (
                    curve_gas(d, curve, &[-1.0, 0.0, 1.0, 2.0], caps),
                    caps,
                    end_hit,
                )
            });
        // One pipeline, created after both structures, for both.
        let (p, table) = rig(d, |m| {
            vec![ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(m, "closesthit__curve")),
                any_hit: None,
                intersection: None,
                builtin: BuiltinIntersector::Curve(curve),
            }]
        });
        for (gas, caps, end_hit) in cases {
            let out = trace(d, p, &table, gas, RayFlags::NONE, 0, &rays);
            assert_eq!(out[0][0], 1, "end caps {caps:?}");
            let t = f32::from_bits(out[0][1]);
            assert!(close(t, 4.9, 1e-4), "t {t}");
            let u = f32::from_bits(out[0][4]);
            assert!(close(u, 0.5, 1e-3), "curve parameter {u}");
            assert_eq!(out[1][0] == 1, end_hit, "end caps {caps:?}");
            assert_eq!(out[2][0], 2);
        }
    });
}

const TRANSPARENT: u8 = 0;
const OPAQUE: u8 = 1;
const UNKNOWN_TRANSPARENT: u8 = 2;
const UNKNOWN_OPAQUE: u8 = 3;

/// The unit triangle with a level-1 four-state micromap of `states` (micro-triangles 0..4).
fn micromap_gas(d: &dyn Device, states: [u8; 4]) -> Accel {
    let vb = buffer(d, &[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let data = vec![states[0] | (states[1] << 2) | (states[2] << 4) | (states[3] << 6)];
    let array = d
        .create_opacity_micromap_array(&OpacityMicromapArrayDesc {
            micromaps: vec![OpacityMicromapDesc {
                byte_offset: 0,
                subdivision_level: 1,
                format: OpacityMicromapFormat::FourState,
            }],
            data,
        })
        .unwrap();
    let ib = buffer(d, &[0i32]);
    let mut input = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::NONE);
    input.opacity_micromap = Some(TriangleOpacityMicromap {
        array,
        index_buffer: Some(BufferView::new(ib)),
        index_size_in_bytes: 4,
        index_stride: 0,
        base_index: 0,
    });
    d.accel_build(
        &AccelBuildOptions::default(),
        &[BuildInput::Triangles(input)],
    )
    .unwrap()
}

#[test]
fn micro_triangle_states_follow_the_bird_curve() {
    on_every_backend("prim: micromap level 1", |_, d| {
        let first = micromap_gas(d, [TRANSPARENT, OPAQUE, TRANSPARENT, TRANSPARENT]);
        let second = micromap_gas(
            d,
            [OPAQUE, TRANSPARENT, UNKNOWN_OPAQUE, UNKNOWN_TRANSPARENT],
        );
        let (p, table) = rig(d, |m| {
            vec![ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(m, "closesthit__hit")),
                any_hit: Some(ProgramRef::new(m, "anyhit__count")),
                intersection: None,
                builtin: BuiltinIntersector::Triangle,
            }]
        });
        assert!(d.pipeline_features(p).unwrap().opacity_micromaps);
        // Centroids of the four level-1 micro-triangles: OptiX's and Vulkan's numbering puts
        // the middle (inverted) one at index 1; then the corners at vertex 0, 1 and 2.
        let rays: Vec<([f32; 3], [f32; 3])> = [
            [1.0 / 3.0, 1.0 / 3.0],
            [1.0 / 6.0, 1.0 / 6.0],
            [2.0 / 3.0, 1.0 / 6.0],
            [1.0 / 6.0, 2.0 / 3.0],
        ]
        .iter()
        .map(|q| ([q[0], q[1], 1.0], [0.0, 0.0, -1.0]))
        .collect();
        let hits = |gas: Accel| -> Vec<(bool, u32)> {
            trace(d, p, &table, gas, RayFlags::NONE, 0, &rays)
                .iter()
                .map(|w| (w[0] == 1, w[5]))
                .collect()
        };
        assert_eq!(
            hits(first),
            vec![(true, 0), (false, 0), (false, 0), (false, 0)],
            "only the opaque middle is hit, without any-hit"
        );
        let out = hits(second);
        assert!(!out[0].0, "the middle is transparent now");
        assert!(
            out[1..].iter().all(|c| c.0),
            "opaque or unknown corners are hit: {out:?}"
        );
        assert_eq!(
            out[1..].iter().map(|c| c.1).sum::<u32>(),
            2,
            "the two unknown corners ran any-hit: {out:?}"
        );
    });
}

#[test]
fn pipelines_that_disallow_micromaps_ignore_them() {
    on_every_backend("prim: pipelines that disallow micromaps", |_, d| {
        let array = d
            .create_opacity_micromap_array(&OpacityMicromapArrayDesc {
                micromaps: vec![],
                data: vec![],
            })
            .unwrap();
        let vb = buffer(d, &[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let mut t = TriangleArray::new(BufferView::new(vb), 3, GeometryFlags::DISABLE_ANYHIT);
        // One fully transparent triangle (special index -1, through an index buffer).
        let index = buffer(d, &[-1i32]);
        t.opacity_micromap = Some(TriangleOpacityMicromap {
            array,
            index_buffer: Some(BufferView::new(index)),
            index_size_in_bytes: 4,
            index_stride: 0,
            base_index: 0,
        });
        let gas = d
            .accel_build(&AccelBuildOptions::default(), &[BuildInput::Triangles(t)])
            .unwrap();
        // The array can go: structures keep their own copy of its states.
        d.destroy_micromap_array(array).unwrap();
        let m = module(d, PROGRAMS);
        let g = groups(
            d,
            &[
                raygen(m, "raygen__rays"),
                miss(m, "miss__none"),
                ProgramGroupDesc::HitGroup {
                    closest_hit: Some(ProgramRef::new(m, "closesthit__hit")),
                    any_hit: Some(ProgramRef::new(m, "anyhit__count")),
                    intersection: None,
                    builtin: BuiltinIntersector::Triangle,
                },
            ],
        );
        let table = sbt(d, &g, &[]);
        let rays = [([0.25, 0.25, 1.0], [0.0, 0.0, -1.0])];
        for (allow, hit) in [(Setting::Auto, false), (Setting::Value(false), true)] {
            let options = PipelineCompileOptions {
                allow_opacity_micromaps: allow,
                ..Default::default()
            };
            let p = d
                .create_pipeline(&options, &PipelineLinkOptions::default(), &g.all())
                .unwrap_or_else(|e| panic!("{e}"));
            let out = trace(d, p, &table, gas, RayFlags::NONE, 0, &rays);
            assert_eq!(
                (out[0][0], out[0][5]),
                (if hit { 1 } else { 2 }, 0),
                "allow_opacity_micromaps {allow:?}: hit {hit}, no any-hit"
            );
        }
    });
}

/// Traces one ray per entry of a buffer (origin x, y at z = 5 straight down, ray flags as
/// bits) into an instance structure; closest-hit records primitive and instance, any-hit
/// counts its calls.
const OPACITY_PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, n: u32, pad0: u32, pad1: u32, pad2: u32, pad3: u32, pad4: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read> rays: array<f32>;

fn raygen__rg() {
    let i = rt_launch_index().x;
    if (i >= params.n) {
        return;
    }
    var p: RtPayload;
    p[0] = 0xFFFFu;
    p[1] = 0u;
    rt_trace(params.handle, vec3<f32>(rays[3u * i], rays[3u * i + 1u], 5.0), vec3<f32>(0.0, 0.0, -1.0),
        0.0, 100.0, 0.0, 0xFFu, bitcast<u32>(rays[3u * i + 2u]), 0u, 1u, 0u, &p);
    out[2u * i] = p[0];
    out[2u * i + 1u] = p[1];
}

fn closesthit__ch() {
    rt_set_payload(0u, rt_primitive_index() * 16u + rt_instance_id());
}

fn anyhit__ah() {
    rt_set_payload(1u, rt_get_payload(1u) + 1u);
}

fn miss__ms() {
}
"#;

/// Packs micromap states `bits` bits each, the lowest bits first.
fn pack_states(states: &[u32], bits: u32) -> Vec<u8> {
    let mut out = vec![0u8; (states.len() * bits as usize).div_ceil(8)];
    for (i, s) in states.iter().enumerate() {
        let bit = i * bits as usize;
        out[bit / 8] |= (*s as u8) << (bit % 8);
    }
    out
}

/// The centroid of micro-triangle `index` at `level`, in barycentrics (u, v).
fn centroid(index: u32, level: u32) -> (f32, f32) {
    let c = optik_accel::micromap::micro_triangle(index, level);
    (
        ((c[0][0] + c[1][0] + c[2][0]) / 3.0) as f32,
        ((c[0][1] + c[1][1] + c[2][1]) / 3.0) as f32,
    )
}

#[test]
fn micromap_states_decide_opacity_with_every_flag() {
    use optik::semantics::opacity::{CandidateFate, MicromapState, resolve};
    on_every_backend("prim: micromap states under every opacity flag", |_, d| {
        // Level 2 (16 micro-triangles), every state four times. Micromap 0 is four-state,
        // micromap 1 two-state (the states' low bit).
        let states: Vec<u32> = (0..16).map(|i| (i * 7 + 3) % 4).collect();
        let mut data = pack_states(&states, 2);
        let two_state_at = data.len() as u32;
        data.extend(pack_states(
            &states.iter().map(|s| s & 1).collect::<Vec<_>>(),
            1,
        ));
        let array = d
            .create_opacity_micromap_array(&OpacityMicromapArrayDesc {
                micromaps: vec![
                    OpacityMicromapDesc {
                        byte_offset: 0,
                        subdivision_level: 2,
                        format: OpacityMicromapFormat::FourState,
                    },
                    OpacityMicromapDesc {
                        byte_offset: two_state_at,
                        subdivision_level: 2,
                        format: OpacityMicromapFormat::TwoState,
                    },
                ],
                data,
            })
            .unwrap();
        // Six unit triangles side by side (x = 2k): micromap 0, micromap 1, then the special
        // indices -1..-4.
        let indices: [i32; 6] = [0, 1, -1, -2, -3, -4];
        let vertices: Vec<[f32; 3]> = (0..indices.len())
            .flat_map(|k| {
                let x = 2.0 * k as f32;
                [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0]]
            })
            .collect();
        let vb = buffer(d, &vertices);
        let ib = buffer(d, &indices);
        let gas_of = |flags: GeometryFlags| {
            let mut t = TriangleArray::new(BufferView::new(vb), vertices.len() as u32, flags);
            t.opacity_micromap = Some(TriangleOpacityMicromap {
                array,
                index_buffer: Some(BufferView::new(ib)),
                index_size_in_bytes: 4,
                index_stride: 0,
                base_index: 0,
            });
            d.accel_build(&AccelBuildOptions::default(), &[BuildInput::Triangles(t)])
                .unwrap()
        };
        let geometries = [GeometryFlags::NONE, GeometryFlags::DISABLE_ANYHIT];
        let instance_flags = [
            InstanceFlags::NONE,
            InstanceFlags::FORCE_OPACITY_MICROMAP_2_STATE,
            InstanceFlags::DISABLE_OPACITY_MICROMAPS,
            InstanceFlags::DISABLE_ANYHIT,
            InstanceFlags::ENFORCE_ANYHIT,
        ];
        // Instance (g, f) at y = 2 (g * 5 + f), id g * 5 + f.
        let mut instances = Vec::new();
        for (g, geometry) in geometries.iter().enumerate() {
            let child = d.traversable_handle(gas_of(*geometry)).unwrap();
            for (f, flags) in instance_flags.iter().enumerate() {
                let id = (g * instance_flags.len() + f) as u32;
                let mut inst = Instance::new(child);
                inst.transform[7] = 2.0 * id as f32;
                inst.instance_id = id;
                inst.flags = flags.0;
                instances.push(inst);
            }
        }
        let ias = d
            .accel_build(
                &AccelBuildOptions::default(),
                &[BuildInput::Instances(InstanceArray {
                    instances: BufferView::new(buffer(d, &instances)),
                    num_instances: instances.len() as u32,
                })],
            )
            .unwrap();
        let ray_flags = [
            RayFlags::NONE,
            RayFlags::FORCE_OPACITY_MICROMAP_2_STATE,
            RayFlags::ENFORCE_ANYHIT,
            RayFlags::DISABLE_ANYHIT,
            RayFlags::CULL_DISABLED_ANYHIT,
            RayFlags::CULL_ENFORCED_ANYHIT,
        ];
        let m = module(d, OPACITY_PROGRAMS);
        let g = groups(
            d,
            &[
                raygen(m, "raygen__rg"),
                miss(m, "miss__ms"),
                ProgramGroupDesc::HitGroup {
                    closest_hit: Some(ProgramRef::new(m, "closesthit__ch")),
                    any_hit: Some(ProgramRef::new(m, "anyhit__ah")),
                    intersection: None,
                    builtin: BuiltinIntersector::Triangle,
                },
            ],
        );
        let p = pipeline(d, &g, 1);
        assert!(d.pipeline_features(p).unwrap().opacity_micromaps);
        let table = sbt(d, &g, &[]);
        // Every ray flag × instance × triangle × micro-triangle, with the fate
        // `semantics::opacity::resolve` gives it.
        let mut rays: Vec<f32> = Vec::new();
        let mut expected = Vec::new();
        for rf in ray_flags {
            for (g, geometry) in geometries.iter().enumerate() {
                for (f, flags) in instance_flags.iter().enumerate() {
                    let id = (g * instance_flags.len() + f) as u32;
                    for (k, index) in indices.iter().enumerate() {
                        for micro in 0..16 {
                            let (u, v) = centroid(micro, 2);
                            rays.extend_from_slice(&[
                                2.0 * k as f32 + u,
                                2.0 * id as f32 + v,
                                f32::from_bits(rf.0),
                            ]);
                            let state = match index {
                                0 => states[micro as usize],
                                1 => states[micro as usize] & 1,
                                special => (-special - 1) as u32,
                            };
                            let omm = (!flags.contains(InstanceFlags::DISABLE_OPACITY_MICROMAPS))
                                .then(|| MicromapState::from_code(state));
                            let fate = resolve(*geometry, *flags, rf, omm);
                            expected.push((
                                fate,
                                k as u32 * 16 + id,
                                format!(
                                    "ray {rf:?}, geometry {geometry:?}, instance {flags:?}, micromap index {index}, micro-triangle {micro} (state {state})"
                                ),
                            ));
                        }
                    }
                }
            }
        }
        let n = expected.len() as u32;
        let out = d.create_buffer(u64::from(n) * 8).unwrap();
        let ray_buffer = buffer(d, &rays);
        d.launch(
            p,
            &params(d.traversable_handle(ias).unwrap(), &[n]),
            &[Resource::buffer(1, out), Resource::buffer(2, ray_buffer)],
            &table,
            LaunchSize::new(n, 1, 1),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let out: Vec<u32> = read(d, out);
        let mismatches: Vec<String> = expected
            .iter()
            .enumerate()
            .filter_map(|(k, (fate, hit, what))| {
                let got = (out[2 * k], out[2 * k + 1]);
                let want = match fate {
                    CandidateFate::Culled => (0xFFFF, 0),
                    CandidateFate::Opaque => (*hit, 0),
                    CandidateFate::NonOpaque => (*hit, 1),
                };
                (got != want).then(|| format!("{what}: got {got:?}, want {want:?} ({fate:?})"))
            })
            .collect();
        assert!(
            mismatches.is_empty(),
            "{} of {n} rays differ:\n{}",
            mismatches.len(),
            mismatches[..mismatches.len().min(20)].join("\n")
        );
    });
}
