//! The `img` group: end-to-end images compared with idiff's thresholds.

use super::util::*;
use crate::case::*;
use crate::compare::IdiffOptions;
use crate::kit::{Ray, StdCase, float_channel, hit_group, sphere_group};
use crate::oracle::exec::Ctx;
use crate::oracle::model::Models;
use crate::scene::{Aabbs, Curves, Gas, GeomInput, Node, Scene, Spheres, Triangles};
use crate::tolerance::Tolerance;
use optik::{
    BuiltinIntersector, CurveEndcaps, CurveType, GeometryFlags, MotionFlags, MotionOptions,
    PipelineLinkOptions,
};

/// Every case of the `img` group.
pub fn cases() -> Vec<Case> {
    vec![debug_aov_per_primitive(), course_scenes()]
}

/// A pinhole camera's rays, host-computed (so every backend traces the same `f32` rays).
fn camera(width: u32, height: u32, eye: [f64; 3], look: [f64; 3], fov_y: f64) -> Vec<Ray> {
    let f = {
        let d = [look[0] - eye[0], look[1] - eye[1], look[2] - eye[2]];
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        [d[0] / l, d[1] / l, d[2] / l]
    };
    let up = [0.0, 0.0, 1.0];
    let r = {
        let c = [
            f[1] * up[2] - f[2] * up[1],
            f[2] * up[0] - f[0] * up[2],
            f[0] * up[1] - f[1] * up[0],
        ];
        let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        [c[0] / l, c[1] / l, c[2] / l]
    };
    let u = [
        r[1] * f[2] - r[2] * f[1],
        r[2] * f[0] - r[0] * f[2],
        r[0] * f[1] - r[1] * f[0],
    ];
    let h = (fov_y / 2.0).tan();
    let aspect = width as f64 / height as f64;
    let mut rays = Vec::new();
    for j in 0..height {
        for i in 0..width {
            let sx = (2.0 * (i as f64 + 0.5) / width as f64 - 1.0) * h * aspect;
            let sy = (1.0 - 2.0 * (j as f64 + 0.5) / height as f64) * h;
            let d: [f64; 3] = std::array::from_fn(|k| f[k] + sx * r[k] + sy * u[k]);
            rays.push(Ray::new(v32(eye), v32(d)));
        }
    }
    rays
}

/// AOV closest-hit programs: R = facing-weighted shade of the geometric normal, G = the
/// surface parameter (barycentric u, sphere latitude, curve u), B = a hash of the primitive
/// index, A = 1; miss writes a constant background.
const AOV_WGSL: &str = r#"
fn prim_shade(p: u32) -> f32 {
    return f32((p * 2654435761u) >> 24u) / 255.0;
}

fn write_rgba(c: vec4<f32>) {
    out[slot(0u)] = bitcast<u32>(c.x);
    out[slot(1u)] = bitcast<u32>(c.y);
    out[slot(2u)] = bitcast<u32>(c.z);
    out[slot(3u)] = bitcast<u32>(c.w);
}

fn closesthit__aov_tri() {
    let v = rt_triangle_vertices();
    let n = normalize(cross(v[1] - v[0], v[2] - v[0]));
    let d = normalize(rt_object_ray_direction());
    write_rgba(vec4<f32>(abs(dot(n, d)), rt_triangle_barycentrics().x, prim_shade(rt_primitive_index()), 1.0));
}

fn closesthit__aov_sphere() {
    let s = rt_sphere();
    let p = rt_object_ray_origin() + rt_ray_tmax() * rt_object_ray_direction();
    let n = (p - s.xyz) / s.w;
    let d = normalize(rt_object_ray_direction());
    write_rgba(vec4<f32>(abs(dot(n, d)), 0.5 + 0.5 * n.z, prim_shade(rt_primitive_index()), 1.0));
}

fn closesthit__aov_custom() {
    write_rgba(vec4<f32>(0.25 + bitcast<f32>(rt_get_attribute(1u)), 0.5, prim_shade(rt_primitive_index()), 1.0));
}

fn closesthit__aov_curve() {
    write_rgba(vec4<f32>(0.75, rt_curve_parameter(), prim_shade(rt_primitive_index()), 1.0));
}

fn miss__aov() {
    write_rgba(vec4<f32>(0.05, 0.05, 0.1, 1.0));
}

fn intersection__aov_sphere() {
    let s = prims[rt_primitive_index()];
    let o = rt_object_ray_origin();
    let d = rt_object_ray_direction();
    let f = o - s.xyz;
    let a = dot(d, d);
    let b = dot(f, d);
    let c = dot(f, f) - s.w * s.w;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return;
    }
    let t = (-b - sqrt(disc)) / a;
    let p = o + t * d;
    var attrs: RtAttributes;
    attrs[1] = bitcast<u32>(0.5 * abs(dot((p - s.xyz) / s.w, normalize(d))));
    let accepted = rt_report_intersection(t, 0u, attrs);
}
"#;

fn aov_models() -> Models {
    fn shade(p: u32) -> f32 {
        (p.wrapping_mul(2_654_435_761) >> 24) as f32 / 255.0
    }
    fn write_rgba(ctx: &mut Ctx<'_, '_>, c: [f32; 4]) {
        let s = ctx.linear_index() as usize * 32;
        for (k, v) in c.into_iter().enumerate() {
            ctx.write(2, s + k, v.to_bits());
        }
    }
    fn norm(v: [f32; 3]) -> [f32; 3] {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    }
    fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    let mut m = Models::new();
    m.add("closesthit__aov_tri", |ctx| {
        let v = ctx.triangle_vertices();
        let e1 = [v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]];
        let e2 = [v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]];
        let n = norm([
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ]);
        let d = norm(ctx.object_ray_direction());
        let c = [
            dot(n, d).abs(),
            ctx.triangle_barycentrics()[0],
            shade(ctx.primitive_index()),
            1.0,
        ];
        write_rgba(ctx, c);
        Ok(())
    });
    m.add("closesthit__aov_sphere", |ctx| {
        let s = ctx.sphere();
        let (o, d, t) = (
            ctx.object_ray_origin(),
            ctx.object_ray_direction(),
            ctx.ray_tmax(),
        );
        let p: [f32; 3] = std::array::from_fn(|k| o[k] + t * d[k]);
        let n: [f32; 3] = std::array::from_fn(|k| (p[k] - s[k]) / s[3]);
        let c = [
            dot(n, norm(d)).abs(),
            0.5 + 0.5 * n[2],
            shade(ctx.primitive_index()),
            1.0,
        ];
        write_rgba(ctx, c);
        Ok(())
    });
    m.add("closesthit__aov_custom", |ctx| {
        let c = [
            0.25 + f32::from_bits(ctx.get_attribute(1)),
            0.5,
            shade(ctx.primitive_index()),
            1.0,
        ];
        write_rgba(ctx, c);
        Ok(())
    });
    m.add("closesthit__aov_curve", |ctx| {
        let c = [
            0.75,
            ctx.curve_parameter(),
            shade(ctx.primitive_index()),
            1.0,
        ];
        write_rgba(ctx, c);
        Ok(())
    });
    m.add("miss__aov", |ctx| {
        write_rgba(ctx, [0.05, 0.05, 0.1, 1.0]);
        Ok(())
    });
    m.add("intersection__aov_sphere", |ctx| {
        let prim = ctx.primitive_index() as usize;
        let sp: [f32; 4] = std::array::from_fn(|k| ctx.read_f32(3, prim * 4 + k));
        let (o, d) = (ctx.object_ray_origin(), ctx.object_ray_direction());
        let f = [o[0] - sp[0], o[1] - sp[1], o[2] - sp[2]];
        let (a, b, c) = (dot(d, d), dot(f, d), dot(f, f) - sp[3] * sp[3]);
        let disc = b * b - a * c;
        if disc < 0.0 {
            return Ok(());
        }
        let t = (-b - disc.sqrt()) / a;
        let p: [f32; 3] = std::array::from_fn(|k| o[k] + t * d[k]);
        let n: [f32; 3] = std::array::from_fn(|k| (p[k] - sp[k]) / sp[3]);
        let mut attrs = [0u32; 8];
        attrs[1] = (0.5 * dot(n, norm(d)).abs()).to_bits();
        ctx.report_intersection(t, 0, attrs)?;
        Ok(())
    });
    m
}

fn rgba_channels() -> Vec<ChannelSpec> {
    ["R", "G", "B", "A"]
        .iter()
        .enumerate()
        .map(|(k, n)| float_channel(n, k, Tolerance::M3))
        .collect()
}

fn debug_aov_per_primitive() -> Case {
    let (w, h) = (48u32, 48u32);
    let f = GeometryFlags::DISABLE_ANYHIT;
    let mut scene = Scene::default();
    let mesh = icosphere(2);
    let tri = scene.add(Node::Gas(Gas {
        build_flags: optik::BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        ..mesh.gas(f)
    }));
    let sphere_data: Vec<[f32; 4]> = vec![
        [-0.6, 0.0, 0.0, 0.5],
        [0.6, 0.2, 0.0, 0.4],
        [0.0, -0.5, 0.3, 0.35],
    ];
    let custom = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        sphere_data
            .iter()
            .map(|s| {
                [
                    s[0] - s[3],
                    s[1] - s[3],
                    s[2] - s[3],
                    s[0] + s[3],
                    s[1] + s[3],
                    s[2] + s[3],
                ]
            })
            .collect(),
        f,
    ))])));
    let builtin = scene.add(Node::Gas(Gas::new(vec![GeomInput::Spheres(Spheres {
        centres: vec![sphere_data.iter().map(|s| [s[0], s[1], s[2]]).collect()],
        radii: vec![sphere_data.iter().map(|s| s[3]).collect()],
        single_radius: false,
        flags: vec![f],
        sbt_offsets: None,
        prim_index_offset: 0,
    })])));
    let curve = scene.add(Node::Gas(Gas::new(vec![GeomInput::Curves(Curves {
        points: vec![vec![
            [-0.8, 0.0, -0.3],
            [-0.3, 0.4, 0.0],
            [0.2, -0.3, 0.2],
            [0.8, 0.2, 0.0],
        ]],
        radii: vec![vec![0.12; 4]],
        segments: vec![0, 1, 2],
        flag: f,
        endcaps: CurveEndcaps::On,
        prim_index_offset: 0,
    })])));
    let far_mesh = mesh.placed(1.0, [1.0e5, 1.0e5, 0.0]);
    let far = scene.add(Node::Gas(Gas {
        build_flags: optik::BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        ..far_mesh.gas(f)
    }));
    let mut moving = Triangles::mesh(mesh.vertices.clone(), mesh.triangles.clone(), f);
    moving.keys.push(
        mesh.vertices
            .iter()
            .map(|v| [v[0] + 0.4, v[1], v[2]])
            .collect(),
    );
    let mblur = scene.add(Node::Gas(Gas {
        build_flags: optik::BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        motion: Some(MotionOptions {
            num_keys: 2,
            flags: MotionFlags::NONE,
            time_begin: 0.0,
            time_end: 1.0,
        }),
        ..Gas::new(vec![GeomInput::Triangles(moving)])
    }));
    let view = |at: [f64; 3], time: f32| -> Vec<Ray> {
        camera(w, h, [at[0] + 0.3, at[1] - 3.0, at[2] + 0.6], at, 0.8)
            .into_iter()
            .map(|r| r.at_time(time))
            .collect()
    };
    let mut curve_group = hit_group(Some("closesthit__aov_curve"), None, None);
    curve_group.builtin = Some(BuiltinIntersector::Curve(CurveType::RoundLinear));
    let groups = vec![
        hit_group(Some("closesthit__aov_tri"), None, None),
        hit_group(
            Some("closesthit__aov_custom"),
            None,
            Some("intersection__aov_sphere"),
        ),
        HitGroupDesc {
            closest_hit: Some("closesthit__aov_sphere".into()),
            ..sphere_group()
        },
        curve_group,
    ];
    let records = (0..4).map(|k| SbtEntry::new(k, vec![k as u32])).collect();
    let offset = |rays: Vec<Ray>, o: u32| {
        rays.into_iter()
            .map(|r| Ray { sbt_offset: o, ..r })
            .collect::<Vec<_>>()
    };
    let mut case = StdCase::new(
        Group::Img,
        "debug_aov_per_primitive",
        "debug AOV images (normal shade, surface parameter, primitive hash) per primitive kind: triangles, intersection-program spheres, built-in spheres, linear curves, a mesh at 1e5, a motion-blurred mesh at t = 0.5; idiff I-det thresholds, NaN/Inf gate (Embree's tests/primitives debug shaders)",
        &[Rule::FrontFace],
        scene,
        None,
    )
    .hits(groups, records)
    .launch_on(Some(tri), w, view([0.0; 3], 0.0))
    .launch_on(Some(custom), w, offset(view([0.0; 3], 0.0), 1))
    .launch_on(Some(builtin), w, offset(view([0.0; 3], 0.0), 2))
    .launch_on(Some(curve), w, offset(view([0.0; 3], 0.0), 3))
    .launch_on(Some(far), w, view([1.0e5, 1.0e5, 0.0], 0.0))
    .launch_on(Some(mblur), w, view([0.2, 0.0, 0.0], 0.5))
    .record(rgba_channels());
    case.miss_groups = vec![Some("miss__aov".into())];
    case.prims = sphere_data;
    case.more_wgsl = Some((AOV_WGSL.into(), aov_models()));
    case.judgement = Judgement::Image(IdiffOptions::I_DET);
    case.build()
}

/// The optix7course examples as images: 02 a raygen test pattern, 04 two cubes, 05 per-object
/// colours from the SBT with normal shading, 06 two meshes, 09 shadow rays towards a light.
const COURSE_WGSL: &str = r#"
fn raygen__course() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    if r.aux == 1u {
        // Example 02: a colour pattern from the launch index.
        let i = rt_launch_index();
        let c = vec3<f32>(f32(i.x % 256u) / 255.0, f32(i.y % 256u) / 255.0, f32((i.x + i.y) % 256u) / 255.0);
        out[slot(0u)] = bitcast<u32>(c.x);
        out[slot(1u)] = bitcast<u32>(c.y);
        out[slot(2u)] = bitcast<u32>(c.z);
        out[slot(3u)] = bitcast<u32>(1.0);
        return;
    }
    var p: RtPayload;
    p[2] = r.aux;
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, 0u, 2u, 0u, &p);
    out[slot(0u)] = p[3];
    out[slot(1u)] = p[4];
    out[slot(2u)] = p[5];
    out[slot(3u)] = bitcast<u32>(1.0);
}

fn closesthit__course() {
    let v = rt_triangle_vertices();
    let n = normalize(cross(v[1] - v[0], v[2] - v[0]));
    let d = normalize(rt_world_ray_direction());
    var shade = 0.2 + 0.8 * abs(dot(n, d));
    if rt_get_payload(2u) == 9u {
        let p = rt_world_ray_origin() + rt_ray_tmax() * rt_world_ray_direction();
        let light = vec3<f32>(-2.0, -3.0, 5.0);
        let l = light - p;
        var s: RtPayload;
        rt_trace(params.handle, rt_offset_ray(p, select(-n, n, dot(n, d) < 0.0)), l, 0.0, 1.0, 0.0, 0xFFu,
                 RT_RAY_FLAG_DISABLE_ANYHIT | RT_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RT_RAY_FLAG_DISABLE_CLOSESTHIT, 1u, 2u, 1u, &s);
        shade = shade * (0.3 + 0.7 * f32(s[0]));
    }
    rt_set_payload(3u, bitcast<u32>(shade * rt_sbt_data_f32(1u)));
    rt_set_payload(4u, bitcast<u32>(shade * rt_sbt_data_f32(2u)));
    rt_set_payload(5u, bitcast<u32>(shade * rt_sbt_data_f32(3u)));
}

fn miss__course() {
    rt_set_payload(3u, bitcast<u32>(0.1));
    rt_set_payload(4u, bitcast<u32>(0.1));
    rt_set_payload(5u, bitcast<u32>(0.2));
}

fn miss__course_shadow() {
    rt_set_payload(0u, 1u);
}
"#;

fn course_models() -> Models {
    fn norm(v: [f32; 3]) -> [f32; 3] {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    }
    fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    let mut m = Models::new();
    m.add("raygen__course", |ctx| {
        let id = ctx.linear_index() as usize;
        if id as u32 >= ctx.param(2) {
            return Ok(());
        }
        let w: Vec<u32> = (0..16).map(|k| ctx.read(1, id * 16 + k)).collect();
        let s = id * 32;
        if w[14] == 1 {
            let i = ctx.launch_index();
            let c = [
                (i[0] % 256) as f32 / 255.0,
                (i[1] % 256) as f32 / 255.0,
                ((i[0] + i[1]) % 256) as f32 / 255.0,
                1.0,
            ];
            for (k, v) in c.into_iter().enumerate() {
                ctx.write(2, s + k, v.to_bits());
            }
            return Ok(());
        }
        let g = |k: usize| f32::from_bits(w[k]);
        let mut p = [0u32; 8];
        p[2] = w[14];
        let handle = [ctx.param(0), ctx.param(1)];
        ctx.trace(
            handle,
            [g(0), g(1), g(2)],
            [g(4), g(5), g(6)],
            g(3),
            g(7),
            g(8),
            w[9],
            w[10],
            0,
            2,
            0,
            &mut p,
        )?;
        for k in 0..3 {
            ctx.write(2, s + k, p[3 + k]);
        }
        ctx.write(2, s + 3, 1.0f32.to_bits());
        Ok(())
    });
    m.add("closesthit__course", |ctx| {
        let v = ctx.triangle_vertices();
        let e1 = [v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]];
        let e2 = [v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]];
        let n = norm([
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ]);
        let d = norm(ctx.world_ray_direction());
        let mut shade = 0.2 + 0.8 * dot(n, d).abs();
        if ctx.get_payload(2) == 9 {
            let (o, wd, t) = (
                ctx.world_ray_origin(),
                ctx.world_ray_direction(),
                ctx.ray_tmax(),
            );
            let p: [f32; 3] = std::array::from_fn(|k| o[k] + t * wd[k]);
            let light = [-2.0f32, -3.0, 5.0];
            let l: [f32; 3] = std::array::from_fn(|k| light[k] - p[k]);
            let facing = if dot(n, d) < 0.0 { n } else { n.map(|c| -c) };
            let spawn = ctx.offset_ray(p, facing);
            let mut s = [0u32; 8];
            let handle = [ctx.param(0), ctx.param(1)];
            ctx.trace(
                handle,
                spawn,
                l,
                0.0,
                1.0,
                0.0,
                0xFF,
                1 | 4 | 8,
                1,
                2,
                1,
                &mut s,
            )?;
            shade *= 0.3 + 0.7 * s[0] as f32;
        }
        for k in 0..3 {
            let c = (shade * ctx.sbt_data_f32(1 + k as u32)).to_bits();
            ctx.set_payload(3 + k as u32, c);
        }
        Ok(())
    });
    m.add("miss__course", |ctx| {
        ctx.set_payload(3, 0.1f32.to_bits());
        ctx.set_payload(4, 0.1f32.to_bits());
        ctx.set_payload(5, 0.2f32.to_bits());
        Ok(())
    });
    m.add("miss__course_shadow", |ctx| {
        ctx.set_payload(0, 1);
        Ok(())
    });
    m
}

fn course_scenes() -> Case {
    let (w, h) = (64u32, 48u32);
    let f = GeometryFlags::DISABLE_ANYHIT;
    let mut scene = Scene::default();
    let floor = terrain(1, |_, _| 0.0).placed(8.0, [-4.0, -4.0, 0.0]);
    let cube_a = cube(-0.5, 0.5).placed(1.0, [-0.8, 0.0, 0.5]);
    let cube_b = cube(-0.5, 0.5).placed(0.8, [0.9, 0.5, 0.4]);
    let rnd = |m: &crate::catalog::util::Mesh| {
        Triangles::mesh(m.vertices.clone(), m.triangles.clone(), f)
    };
    let two_cubes = scene.add(Node::Gas(Gas {
        build_flags: optik::BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        ..Gas::new(vec![
            GeomInput::Triangles(rnd(&cube_a)),
            GeomInput::Triangles(rnd(&cube_b)),
        ])
    }));
    let world = scene.add(Node::Gas(Gas {
        build_flags: optik::BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS,
        ..Gas::new(vec![
            GeomInput::Triangles(rnd(&cube_a)),
            GeomInput::Triangles(rnd(&cube_b)),
            GeomInput::Triangles(rnd(&floor)),
            GeomInput::Triangles(rnd(&icosphere(2).placed(0.5, [0.0, -1.2, 0.5]))),
        ])
    }));
    let eye = [1.5, -5.0, 3.0];
    let rays = |aux: u32| {
        camera(w, h, eye, [0.0, 0.0, 0.3], 0.7)
            .into_iter()
            .map(|r| Ray { aux, ..r })
            .collect::<Vec<_>>()
    };
    // Ray type 0 (radiance) records with colours, ray type 1 (shadow): SBT stride 2.
    let colours: [[f32; 3]; 4] = [
        [0.9, 0.3, 0.2],
        [0.2, 0.7, 0.3],
        [0.7, 0.7, 0.7],
        [0.3, 0.4, 0.9],
    ];
    let mut records = Vec::new();
    for (k, c) in colours.iter().enumerate() {
        records.push(SbtEntry::new(
            0,
            vec![2 * k as u32, c[0].to_bits(), c[1].to_bits(), c[2].to_bits()],
        ));
        records.push(SbtEntry::new(0, vec![2 * k as u32 + 1, 0, 0, 0]));
    }
    let mut case = StdCase::new(
        Group::Img,
        "course_scenes",
        "the optix7course examples as images: 02 raygen pattern, 04 two cubes, 05 SBT colours with normal shading, 06 several meshes, 09 shadow rays (DISABLE_ANYHIT | TERMINATE_ON_FIRST_HIT | DISABLE_CLOSESTHIT, miss index 1) from rt_offset_ray; idiff I-det",
        &[Rule::SbtIndex, Rule::OffsetRay],
        scene,
        None,
    )
    .hits(vec![hit_group(Some("closesthit__course"), None, None)], records)
    .launch_on(Some(two_cubes), w, rays(1))
    .launch_on(Some(two_cubes), w, rays(4))
    .launch_on(Some(two_cubes), w, rays(5))
    .launch_on(Some(world), w, rays(6))
    .launch_on(Some(world), w, rays(9))
    .record(rgba_channels());
    case.miss_groups = vec![
        Some("miss__course".into()),
        Some("miss__course_shadow".into()),
    ];
    case.miss_records = vec![SbtEntry::new(0, vec![0]), SbtEntry::new(1, vec![1])];
    case.raygen = "raygen__course";
    case.more_wgsl = Some((COURSE_WGSL.into(), course_models()));
    case.link = PipelineLinkOptions {
        max_trace_depth: 2,
        ..Default::default()
    };
    case.judgement = Judgement::Image(IdiffOptions::I_DET);
    case.build()
}
