//! Spot and envmap emitters against analytic values.

use super::*;
use crate::camera::half_fov_tangents;
use crate::scene::{Emitter, Image};
use glam::Vec2;

/// The world point a pixel centre sees on the plane y = `floor_y` from a camera at the
/// origin looking down -y (to_world = rotation about x by π/2).
fn floor_point(s: &Scene, x: f32, y: f32, floor_y: f32) -> Vec3 {
    let (tx, ty) = half_fov_tangents(&s.camera, s.film.width, s.film.height);
    let pos = Vec2::new(x / s.film.width as f32, y / s.film.height as f32);
    let local = Vec3::new((1.0 - 2.0 * pos.x) * tx, (1.0 - 2.0 * pos.y) * ty, 1.0);
    let d = s.camera.to_world.transform_vector3(local);
    d * (floor_y / d.y)
}

fn floor_scene(spp: u32, a: f32) -> Scene {
    let mut s = Scene {
        camera: Camera {
            to_world: Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2),
            fov_degrees: 60.0,
            ..Camera::default()
        },
        film: Film {
            width: 16,
            height: 16,
            filter: Filter::Box,
        },
        sampler: Sampler {
            sample_count: spp,
            seed: 5,
        },
        integrator: path(Some(2), false),
        ..Scene::default()
    };
    s.meshes.push(quad(
        "floor",
        Vec3::new(0.0, -2.0, 0.0),
        Vec3::Y,
        40.0,
        0,
        None,
    ));
    s.materials.push(diffuse(Vec3::splat(a)));
    s
}

/// Mitsuba's spot: a floor under a spot light pointing down has radiance
/// a / π · I · falloff(θ) · cos / d², with falloff 1 inside beam_width, 0 beyond cutoff_angle
/// and linear in the angle between.
#[test]
fn spot_light_falls_off_as_mitsuba() {
    let a = 0.6;
    let mut s = floor_scene(64, a);
    let light_pos = Vec3::new(0.0, 1.0, 0.0);
    let (cutoff, beam) = (20.0f32, 10.0f32);
    s.emitters.push(Emitter::Spot {
        // Pointing down -y: its local +z is world -y.
        to_world: Mat4::from_translation(light_pos)
            * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2),
        intensity: Vec3::new(10.0, 5.0, 2.0),
        cutoff_angle: cutoff,
        beam_width: beam,
    });
    let f = render(cpu(2).as_ref(), &s, &with_variance(64)).unwrap();
    assert!(f.stats.features.emitters.contains("spot"));
    let radiance = |p: Vec3| {
        let v = light_pos - p;
        let angle = v.normalize().dot(Vec3::Y).acos().to_degrees();
        let fall = if angle >= cutoff {
            0.0
        } else if angle <= beam {
            1.0
        } else {
            (cutoff - angle).to_radians() / (cutoff - beam).to_radians()
        };
        (
            a / std::f32::consts::PI * fall * v.normalize().y / v.length_squared(),
            angle,
        )
    };
    let mut seen = [false; 3];
    for y in 0..16 {
        for x in 0..16 {
            // The pixel's mean over its footprint (the box filter), on a 16x16 grid.
            let mut mean = 0.0;
            for k in 0..256 {
                let sx = x as f32 + ((k % 16) as f32 + 0.5) / 16.0;
                let sy = y as f32 + ((k / 16) as f32 + 0.5) / 16.0;
                mean += radiance(floor_point(&s, sx, sy, -2.0)).0 / 256.0;
            }
            let (centre, angle) = radiance(floor_point(&s, x as f32 + 0.5, y as f32 + 0.5, -2.0));
            let fall = if centre == 0.0 {
                0.0
            } else if angle <= beam {
                1.0
            } else {
                0.5
            };
            let expect = Vec3::new(10.0, 5.0, 2.0) * mean;
            let got = Vec3::from_array(f.mean[(y * 16 + x) as usize]);
            // Within a pixel the radiance varies (jittered samples): allow 4 standard errors.
            let var = Vec3::from_array(f.variance.as_ref().unwrap()[(y * 16 + x) as usize]);
            let tol = (var / 64.0).powf(0.5) * 4.0 + expect * 0.01 + Vec3::splat(1e-6);
            assert!(
                (got - expect).abs().cmple(tol).all(),
                "pixel ({x}, {y}) at {angle:.1}°: {got} vs {expect} (tolerance {tol})"
            );
            seen[if fall == 0.0 {
                0
            } else if fall == 1.0 {
                1
            } else {
                2
            }] = true;
        }
    }
    assert_eq!(
        seen, [true; 3],
        "the image covers the beam, the falloff and the dark"
    );
}

/// An envmap of two rows: radiance varies linearly in θ between the top row (θ = 0, +y) and
/// the bottom row (θ = π). A floor facing +y receives E = ∫ L(θ) cos θ dω over the upper
/// hemisphere and shows a E / π; the map seen directly is L at the view direction. Both
/// sampling techniques meet through MIS, so a pdf that disagrees with the sampling shows.
#[test]
fn envmap_lights_a_floor_by_its_radiance_integral() {
    let (l0, l1) = (Vec3::new(3.0, 2.0, 1.0), Vec3::new(0.2, 0.1, 0.05));
    let scale = 1.5;
    let img = Image {
        path: "two-rows.exr".into(),
        width: 4,
        height: 2,
        texels: vec![l0, l0, l0, l0, l1, l1, l1, l1],
        alpha: None,
    };
    let a = 0.5;
    let mut s = floor_scene(256, a);
    s.images.push(img);
    s.emitters.push(Emitter::EnvMap {
        image: 0,
        scale,
        to_world: Mat4::IDENTITY,
    });
    let f = render(cpu(2).as_ref(), &s, &with_variance(256)).unwrap();
    assert!(f.stats.features.emitters.contains("envmap"));
    // E = 2π ∫_0^{π/2} L(θ) cos θ sin θ dθ, L(θ) = l0 + (l1 - l0) θ / π.
    let n = 2000;
    let mut e = Vec3::ZERO;
    for k in 0..n {
        let t = (k as f32 + 0.5) / n as f32 * std::f32::consts::FRAC_PI_2;
        let l = l0 + (l1 - l0) * (t / std::f32::consts::PI);
        e += l * (t.cos() * t.sin()) * (std::f32::consts::FRAC_PI_2 / n as f32);
    }
    e *= 2.0 * std::f32::consts::PI * scale;
    let expect = e * (a / std::f32::consts::PI);
    let m = image_mean(&f);
    assert!(
        ((m - expect).abs() / expect).max_element() < 0.03,
        "floor {m} vs {expect}"
    );
    // Looking up at the sky: the map's radiance in each pixel's direction.
    let mut sky = floor_scene(1, a);
    sky.meshes.clear();
    sky.camera.to_world = Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    sky.images = s.images.clone();
    sky.emitters = s.emitters.clone();
    let f = render(cpu(1).as_ref(), &sky, &RenderOptions::default()).unwrap();
    let (tx, ty) = half_fov_tangents(&sky.camera, 16, 16);
    for (x, y) in [(8, 8), (0, 0), (15, 3)] {
        let local = Vec3::new(
            (1.0 - 2.0 * (x as f32 + 0.5) / 16.0) * tx,
            (1.0 - 2.0 * (y as f32 + 0.5) / 16.0) * ty,
            1.0,
        );
        let d = sky.camera.to_world.transform_vector3(local).normalize();
        let t = d.y.clamp(-1.0, 1.0).acos();
        let expect = (l0 + (l1 - l0) * (t / std::f32::consts::PI)) * scale;
        let got = Vec3::from_array(f.mean[(y * 16 + x) as usize]);
        // The pixel integrates a small range of θ around its centre.
        assert!(
            ((got - expect).abs() / expect).max_element() < 0.02,
            "sky pixel ({x}, {y}): {got} vs {expect}"
        );
    }
}

/// A constant envmap behaves as the constant emitter: a diffuse sphere reflects a · L.
#[test]
fn a_uniform_envmap_is_a_constant_environment() {
    let c = Vec3::new(0.5, 1.0, 2.0);
    let mut s = floor_scene(128, 0.5);
    s.meshes.clear();
    s.camera.to_world = Mat4::IDENTITY;
    s.spheres.push(crate::scene::Sphere {
        name: "ball".into(),
        center: Vec3::new(0.0, 0.0, 4.0),
        radius: 1.0,
        rotation: glam::Mat3::IDENTITY,
        material: 0,
        emission: None,
        flip_normals: false,
    });
    s.images.push(Image {
        path: "flat.exr".into(),
        width: 8,
        height: 4,
        texels: vec![c; 32],
        alpha: None,
    });
    s.emitters.push(Emitter::EnvMap {
        image: 0,
        scale: 1.0,
        to_world: Mat4::from_rotation_x(0.7),
    });
    let f = render(cpu(2).as_ref(), &s, &with_variance(128)).unwrap();
    let centre = Vec3::from_array(f.mean[8 * 16 + 8]);
    assert!(
        ((centre - c * 0.5).abs() / c).max_element() < 0.03,
        "{centre}"
    );
    assert!((Vec3::from_array(f.mean[0]) - c).abs().max_element() < 1e-5);
}

fn with_variance(spp: u32) -> RenderOptions {
    RenderOptions {
        spp: Some(spp),
        want_variance: true,
        ..RenderOptions::default()
    }
}
