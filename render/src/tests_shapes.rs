//! Spheres, instances, bitmap textures and masks against analytic values and against
//! equivalent flattened scenes.

use super::*;
use crate::camera::half_fov_tangents;
use crate::scene::{Image, Instance, ShapeGroup, Sphere, shapes};
use crate::validate::{self, Estimate};
use glam::{Mat3, Vec2};

fn sphere(name: &str, center: Vec3, radius: f32, material: u32) -> Sphere {
    Sphere {
        name: name.into(),
        center,
        radius,
        rotation: Mat3::IDENTITY,
        material,
        emission: None,
        flip_normals: false,
    }
}

/// A camera at the origin looking down +z, `size`² pixels, box filter.
fn looking_z(size: u32, spp: u32, integrator: Integrator) -> Scene {
    Scene {
        film: Film {
            width: size,
            height: size,
            filter: Filter::Box,
        },
        sampler: Sampler {
            sample_count: spp,
            seed: 3,
        },
        integrator,
        ..Scene::default()
    }
}

fn px(f: &Frame, x: u32, y: u32) -> Vec3 {
    Vec3::from_array(f.mean[(y * f.width + x) as usize])
}

fn block_mean(f: &Frame, x0: u32, y0: u32, n: u32) -> Vec3 {
    let mut s = Vec3::ZERO;
    for y in y0..y0 + n {
        for x in x0..x0 + n {
            s += px(f, x, y);
        }
    }
    s / (n * n) as f32
}

pub(super) fn estimate(f: &Frame) -> Estimate {
    Estimate::new(
        f.width,
        f.height,
        f.mean.iter().flatten().copied().collect(),
        f.variance
            .as_ref()
            .expect("variance asked for")
            .iter()
            .flatten()
            .copied()
            .collect(),
        f.spp,
    )
    .unwrap()
}

pub(super) fn with_variance(spp: u32) -> RenderOptions {
    RenderOptions {
        spp: Some(spp),
        want_variance: true,
        ..RenderOptions::default()
    }
}

/// A diffuse sphere of albedo a under a constant environment of radiance 1 reflects exactly
/// a (it is convex: every bounce leaves for the environment); the background is 1.
#[test]
fn diffuse_sphere_in_a_constant_environment_reflects_its_albedo() {
    let a = Vec3::new(0.2, 0.5, 0.3);
    let mut s = looking_z(16, 256, path(None, false));
    s.spheres
        .push(sphere("ball", Vec3::new(0.0, 0.0, 5.0), 1.0, 0));
    s.materials.push(diffuse(a));
    s.emitters.push(crate::scene::Emitter::Constant {
        radiance: Vec3::ONE,
    });
    let f = render(cpu(2).as_ref(), &s, &with_variance(256)).unwrap();
    let centre = block_mean(&f, 6, 6, 4);
    assert!((centre - a).abs().max_element() < 0.02, "sphere {centre}");
    assert_eq!(px(&f, 0, 0), Vec3::ONE, "background");
    assert!(f.stats.features.spheres && f.stats.features.uses_ias());
    assert!(
        f.stats
            .programs
            .contains(&"closesthit__diffuse_sphere".to_string()),
        "{:?}",
        f.stats.programs
    );
}

/// A sphere light above a diffuse wall: the wall's radiance is a · Le · sin²α · cos θ (α the
/// half angle of the visible cap, θ the angle of its centre from the wall's normal), through
/// next-event estimation of the cap and emitter hits weighed by the same pdf.
#[test]
fn a_sphere_light_lights_a_wall_as_its_visible_cap() {
    let a = 0.8;
    let le = Vec3::new(4.0, 2.0, 1.0);
    let mut s = looking_z(16, 512, path(Some(2), false));
    s.meshes.push(quad(
        "wall",
        Vec3::new(0.0, 0.0, 10.0),
        -Vec3::Z,
        10.0,
        0,
        None,
    ));
    let c = Vec3::new(0.0, 4.5, 7.0);
    let r = 0.5;
    let mut light = sphere("light", c, r, 1);
    light.emission = Some(Texture::Constant(le));
    s.spheres.push(light);
    s.materials.push(diffuse(Vec3::splat(a)));
    s.materials.push(diffuse(Vec3::ZERO));
    let f = render(cpu(2).as_ref(), &s, &with_variance(512)).unwrap();
    let (tx, ty) = half_fov_tangents(&s.camera, 16, 16);
    let mut worst: f32 = 0.0;
    for (x, y) in [(8, 8), (4, 10), (12, 13), (2, 2), (8, 3)] {
        let pos = Vec2::new((x as f32 + 0.5) / 16.0, (y as f32 + 0.5) / 16.0);
        let d = Vec3::new((1.0 - 2.0 * pos.x) * tx, (1.0 - 2.0 * pos.y) * ty, 1.0);
        let p = d * 10.0;
        let v = c - p;
        let sin_a = r / v.length();
        let cos_t = v.normalize().dot(-Vec3::Z);
        let expect = a * le * sin_a * sin_a * cos_t;
        let got = px(&f, x, y);
        let rel = ((got - expect).abs() / expect).max_element();
        worst = worst.max(rel);
    }
    assert!(worst < 0.05, "worst relative error {worst}");
}

/// From inside an emitting sphere whose normals point inwards: a black-walled room of
/// radiance 1 everywhere; a diffuse ball in it reflects its albedo (the inside branch of
/// sphere light sampling, by area).
#[test]
fn inside_a_flipped_emitting_sphere() {
    let mut s = looking_z(12, 256, path(Some(2), false));
    let mut room = sphere("room", Vec3::ZERO, 20.0, 1);
    room.flip_normals = true;
    room.emission = Some(Texture::Constant(Vec3::ONE));
    s.spheres.push(room);
    s.spheres
        .push(sphere("ball", Vec3::new(0.0, 0.0, 6.0), 1.5, 0));
    s.materials.push(diffuse(Vec3::splat(0.5)));
    s.materials.push(diffuse(Vec3::ZERO));
    let f = render(cpu(2).as_ref(), &s, &with_variance(256)).unwrap();
    let ball = block_mean(&f, 5, 5, 2);
    assert!(
        (ball - Vec3::splat(0.5)).abs().max_element() < 0.03,
        "ball {ball}"
    );
    assert!((px(&f, 0, 0) - Vec3::ONE).abs().max_element() < 1e-6);
}

/// A group placed twice through the IAS renders as the same shapes placed in the world by
/// hand (a top-level area light included), by the z-test of the validation suite.
#[test]
fn instances_render_as_their_flattened_shapes() {
    let mut group = ShapeGroup {
        name: "group".into(),
        ..ShapeGroup::default()
    };
    let mut cube = shapes::cube();
    shapes::transform_mesh(&mut cube, &Mat4::from_scale(Vec3::splat(0.7)));
    cube.name = "cube".into();
    group.meshes.push(cube);
    let mut ball = sphere("ball", Vec3::new(-1.0, 0.0, 0.0), 0.5, 1);
    ball.rotation = Mat3::from_rotation_y(0.3);
    group.spheres.push(ball);
    let places = [
        Mat4::from_translation(Vec3::new(-1.0, 0.0, 6.0)),
        Mat4::from_translation(Vec3::new(1.5, 0.5, 7.0))
            * Mat4::from_rotation_y(0.8)
            * Mat4::from_scale(Vec3::splat(1.5)),
    ];
    let mut base = looking_z(16, 128, path(Some(3), false));
    base.materials = vec![diffuse(Vec3::new(0.2, 0.5, 0.3)), diffuse(Vec3::splat(0.8))];
    base.meshes.push(quad(
        "light",
        Vec3::new(0.0, 4.0, 6.0),
        -Vec3::Y,
        1.0,
        1,
        Some(Vec3::splat(10.0)),
    ));
    base.emitters.push(crate::scene::Emitter::Constant {
        radiance: Vec3::splat(0.2),
    });
    let mut instanced = base.clone();
    instanced.groups.push(group.clone());
    for m in places {
        instanced.instances.push(Instance {
            group: 0,
            to_world: m,
        });
    }
    let mut flat = base;
    for m in places {
        for mesh in &group.meshes {
            let mut mesh = mesh.clone();
            shapes::transform_mesh(&mut mesh, &m);
            flat.meshes.push(mesh);
        }
        for s in &group.spheres {
            let scale = m.x_axis.truncate().length();
            let mut s = s.clone();
            s.center = m.transform_point3(s.center);
            s.radius *= scale;
            s.rotation = Mat3::from_mat4(m) * (1.0 / scale) * s.rotation;
            flat.spheres.push(s);
        }
    }
    let d = cpu(2);
    let a = render(d.as_ref(), &instanced, &with_variance(128)).unwrap();
    let opts = RenderOptions {
        seed: Some(11),
        ..with_variance(128)
    };
    let b = render(d.as_ref(), &flat, &opts).unwrap();
    assert!(a.stats.features.instancing && !b.stats.features.instancing);
    let outcome = validate::z_test(&estimate(&a), &estimate(&b)).unwrap();
    assert!(outcome.passed, "{outcome}");
    assert!(image_mean(&a).max_element() > 0.05, "the shapes are lit");
    // The same scene with a 10 % darker cube must be told apart (the test has teeth).
    let mut darker = flat.clone();
    darker.materials[0] = diffuse(Vec3::new(0.2, 0.5, 0.3) * 0.9);
    let c = render(d.as_ref(), &darker, &with_variance(512)).unwrap();
    let outcome = validate::z_test(&estimate(&a), &estimate(&c)).unwrap();
    assert!(!outcome.passed, "a darker cube passed: {outcome}");
}

#[test]
fn emitters_inside_shape_groups_are_refused() {
    let mut s = looking_z(4, 1, path(Some(2), false));
    s.materials.push(diffuse(Vec3::ONE));
    let mut m = quad("lamp", Vec3::ZERO, Vec3::Z, 1.0, 0, Some(Vec3::ONE));
    m.name = "lamp".into();
    s.groups.push(ShapeGroup {
        name: "g".into(),
        meshes: vec![m],
        spheres: vec![],
    });
    s.instances.push(Instance {
        group: 0,
        to_world: Mat4::IDENTITY,
    });
    let e = render(cpu(1).as_ref(), &s, &RenderOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("lamp") && e.contains("instanced"), "{e}");
}

/// A 2x1 image: red on the left (u < 0.5), green on the right.
fn two_texels() -> Image {
    Image {
        path: "two.png".into(),
        width: 2,
        height: 1,
        texels: vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
        alpha: None,
    }
}

fn albedo_at(f: &Frame, x: u32, y: u32) -> Vec3 {
    let i = ((y * f.width + x) * 3) as usize;
    Vec3::from_slice(&f.aovs[0].data[i..i + 3])
}

/// Mitsuba's sphere uv: φ / 2π in the sphere's own frame, so the image's left half covers
/// +y (φ < π); rotating the sphere by π about z swaps the halves. Nearest lookups.
#[test]
fn sphere_uv_follows_its_frame_and_bitmaps_look_up_nearest() {
    for (angle, top, bottom) in [
        (0.0, Vec3::X, Vec3::Y),
        (std::f32::consts::PI, Vec3::Y, Vec3::X),
    ] {
        let mut s = looking_z(16, 2, path(Some(1), false));
        let mut ball = sphere("ball", Vec3::new(0.0, 0.0, 5.0), 1.5, 0);
        ball.rotation = Mat3::from_rotation_z(angle);
        s.spheres.push(ball);
        s.images.push(two_texels());
        s.materials.push(Bsdf::Diffuse {
            reflectance: Texture::Bitmap {
                image: 0,
                to_uv: Mat3::IDENTITY,
                bilinear: false,
                wrap: crate::scene::WrapMode::Repeat,
            },
        });
        let f = render(
            cpu(2).as_ref(),
            &s,
            &RenderOptions {
                spp: Some(2),
                want_aovs: true,
                ..RenderOptions::default()
            },
        )
        .unwrap();
        assert!(f.stats.features.bitmap);
        // Image row 0 is the top (+y).
        assert_eq!(albedo_at(&f, 8, 5), top, "rotation {angle}: top");
        assert_eq!(albedo_at(&f, 8, 10), bottom, "rotation {angle}: bottom");
    }
}

/// Bilinear lookups as Mitsuba's: texel centres at half-integers, wrapping around (repeat).
#[test]
fn bilinear_bitmaps_blend_between_texel_centres() {
    let mut s = looking_z(8, 1, path(Some(1), false));
    let mut wall = shapes::rectangle();
    // uv = ((x + 1) / 2, (y + 1) / 2): a 10-unit square at z = 4 (wider than the view).
    shapes::transform_mesh(
        &mut wall,
        &(Mat4::from_translation(Vec3::new(0.0, 0.0, 4.0))
            * Mat4::from_scale(Vec3::new(10.0, 10.0, 1.0))
            * Mat4::from_rotation_y(std::f32::consts::PI)),
    );
    s.meshes.push(wall);
    s.images.push(two_texels());
    s.materials.push(Bsdf::Diffuse {
        reflectance: Texture::Bitmap {
            image: 0,
            to_uv: Mat3::IDENTITY,
            bilinear: true,
            wrap: crate::scene::WrapMode::Repeat,
        },
    });
    let f = render(
        cpu(1).as_ref(),
        &s,
        &RenderOptions {
            spp: Some(1),
            want_aovs: true,
            ..RenderOptions::default()
        },
    )
    .unwrap();
    // Every pixel's albedo is red·(1 - w) + green·w for some w: a blend of the two texels,
    // and the blend changes across the image (bilinear, not nearest).
    let mut ws = Vec::new();
    for x in 0..8 {
        let c = albedo_at(&f, x, 4);
        assert!((c.x + c.y - 1.0).abs() < 1e-4 && c.z == 0.0, "{c}");
        ws.push(c.y);
    }
    let distinct = ws.windows(2).filter(|w| (w[0] - w[1]).abs() > 1e-3).count();
    assert!(distinct >= 5, "{ws:?}");
    assert!(ws.iter().any(|w| *w > 0.05 && *w < 0.95), "{ws:?}");
}

/// Mitsuba's (Dr.Jit's) wrap modes on a 2x1 image looked up at u = -0.25 (nearest: texel
/// column -1): repeat takes column 1, mirror column 0, clamp column 0; at u = 1.75 (column 3)
/// repeat takes 1, mirror 0 (3 reflects to 0), clamp 1.
#[test]
fn wrap_modes_follow_mitsuba() {
    use crate::scene::WrapMode;
    let (red, green) = (Vec3::X, Vec3::Y);
    for (wrap, at_minus, at_plus) in [
        (WrapMode::Repeat, green, green),
        (WrapMode::Mirror, red, red),
        (WrapMode::Clamp, red, green),
    ] {
        for (u, expect) in [(-0.25f32, at_minus), (1.75, at_plus)] {
            let mut s = looking_z(4, 1, path(Some(1), false));
            let mut wall = shapes::rectangle();
            shapes::transform_mesh(
                &mut wall,
                &(Mat4::from_translation(Vec3::new(0.0, 0.0, 4.0))
                    * Mat4::from_scale(Vec3::new(10.0, 10.0, 1.0))
                    * Mat4::from_rotation_y(std::f32::consts::PI)),
            );
            s.meshes.push(wall);
            s.images.push(two_texels());
            // Every hit looks up (u, 0.5): to_uv maps any uv to that point.
            let to_uv = Mat3::from_cols(Vec3::ZERO, Vec3::ZERO, Vec3::new(u, 0.5, 1.0));
            s.materials.push(Bsdf::Diffuse {
                reflectance: Texture::Bitmap {
                    image: 0,
                    to_uv,
                    bilinear: false,
                    wrap,
                },
            });
            let f = render(
                cpu(1).as_ref(),
                &s,
                &RenderOptions {
                    spp: Some(1),
                    want_aovs: true,
                    ..RenderOptions::default()
                },
            )
            .unwrap();
            assert_eq!(albedo_at(&f, 1, 1), expect, "{wrap:?} at u = {u}");
        }
    }
}

/// Mitsuba's mask: a surface of opacity o in front of a constant environment of radiance 1
/// shows (1 - o) · 1 + o · a (the diffuse square lit by the environment); shadow rays pass
/// through it in the same proportion.
#[test]
fn masks_let_light_through_in_proportion() {
    let o = 0.3;
    let a = 0.5;
    let mut s = looking_z(8, 1024, path(Some(2), false));
    s.meshes.push(quad(
        "leaf",
        Vec3::new(0.0, 0.0, 4.0),
        -Vec3::Z,
        10.0,
        0,
        None,
    ));
    s.materials.push(Bsdf::Mask {
        opacity: Texture::Constant(Vec3::splat(o)),
        inner: Box::new(diffuse(Vec3::splat(a))),
    });
    s.emitters.push(crate::scene::Emitter::Constant {
        radiance: Vec3::ONE,
    });
    let f = render(cpu(2).as_ref(), &s, &with_variance(1024)).unwrap();
    assert!(f.stats.features.masks);
    assert!(f.stats.programs.contains(&"anyhit__mask".to_string()));
    let m = image_mean(&f);
    let expect = (1.0 - o) + o * a;
    assert!((m - Vec3::splat(expect)).abs().max_element() < 0.02, "{m}");

    // A floor under a half-transparent roof, lit by a directional light from above: the
    // floor receives (1 - o) of the light through shadow rays.
    let mut s = looking_z(8, 512, path(Some(2), false));
    s.camera.to_world = Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
    s.meshes.push(quad(
        "floor",
        Vec3::new(0.0, -5.0, 0.0),
        Vec3::Y,
        50.0,
        1,
        None,
    ));
    s.meshes.push(quad(
        "roof",
        Vec3::new(0.0, 2.0, 0.0),
        -Vec3::Y,
        50.0,
        0,
        None,
    ));
    s.materials.push(Bsdf::Mask {
        opacity: Texture::Constant(Vec3::splat(o)),
        inner: Box::new(diffuse(Vec3::ZERO)),
    });
    s.materials.push(diffuse(Vec3::splat(a)));
    s.emitters.push(crate::scene::Emitter::Directional {
        direction: -Vec3::Y,
        irradiance: Vec3::ONE,
    });
    let mut closed = s.clone();
    let f = render(cpu(2).as_ref(), &s, &with_variance(512)).unwrap();
    // The camera looks down from between roof and floor: it sees the floor directly.
    let m = image_mean(&f);
    let expect = (1.0 - o) * a * INV_PI_F32;
    assert!(
        ((m - Vec3::splat(expect)).abs() / expect).max_element() < 0.04,
        "{m} vs {expect}"
    );
    // Opaque roof: nothing arrives.
    closed.materials[0] = diffuse(Vec3::ZERO);
    let f = render(cpu(2).as_ref(), &closed, &with_variance(16)).unwrap();
    assert_eq!(image_mean(&f), Vec3::ZERO);
}

const INV_PI_F32: f32 = std::f32::consts::FRAC_1_PI;
