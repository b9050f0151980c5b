//! Engine tests on small hand-built scenes: analytic furnaces for the integrator's semantics,
//! determinism across thread counts and backends, far-from-origin invariance, the probe,
//! features and outputs.

use crate::probe::{self, BsdfQuery};
use crate::scene::{
    Bsdf, Camera, Film, Filter, Integrator, Mesh, PathSettings, Sampler, Scene, Texture,
};
use crate::{Frame, RenderOptions, render};
use glam::{Mat4, Vec3};
use optik::{BackendChoice, BackendKind, Device, OpenOptions};

pub(crate) fn cpu(threads: usize) -> Box<dyn Device> {
    optik::open_with(
        BackendChoice::Named(BackendKind::Cpu),
        &OpenOptions {
            threads: Some(threads),
        },
    )
    .expect("the CPU backend opens")
}

/// A square of half-size `s` at `c` facing `n` (counter-clockwise seen from the front).
fn quad(name: &str, c: Vec3, n: Vec3, s: f32, material: u32, emission: Option<Vec3>) -> Mesh {
    let u = n.any_orthonormal_vector() * s;
    let v = n.cross(u);
    Mesh {
        name: name.into(),
        positions: vec![c - u - v, c + u - v, c + u + v, c - u + v],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
        emission: emission.map(Texture::Constant),
        ..Mesh::default()
    }
}

fn diffuse(r: Vec3) -> Bsdf {
    Bsdf::Diffuse {
        reflectance: Texture::Constant(r),
    }
}

fn path(max_depth: Option<u32>, hide_emitters: bool) -> Integrator {
    Integrator::Path(PathSettings {
        max_depth,
        rr_depth: 5,
        hide_emitters,
    })
}

/// A closed cube of half-size `s` around `c`, every inner face a diffuse emitter: the radiance
/// everywhere is `le · Σ_{k<max_depth} albedo^k`, whatever the geometry.
fn furnace(c: Vec3, s: f32, albedo: f32, le: f32, integrator: Integrator) -> Scene {
    let axes = [Vec3::X, Vec3::Y, Vec3::Z];
    let mut meshes = Vec::new();
    for a in axes {
        for sign in [-1.0, 1.0] {
            let n = -a * sign;
            meshes.push(quad(
                "wall",
                c + a * sign * s,
                n,
                s,
                0,
                Some(Vec3::splat(le)),
            ));
        }
    }
    Scene {
        camera: Camera {
            to_world: Mat4::from_translation(c),
            ..Camera::default()
        },
        film: Film {
            width: 8,
            height: 8,
            filter: Filter::Box,
        },
        sampler: Sampler {
            sample_count: 16,
            seed: 1,
        },
        integrator,
        meshes,
        materials: vec![diffuse(Vec3::splat(albedo))],
        ..Scene::default()
    }
}

/// A Cornell box of half-size `s` (open towards the camera) with a light under the ceiling,
/// shifted by `o`.
fn cornell_at(o: Vec3, s: f32) -> Scene {
    let w = Vec3::splat(0.7);
    let meshes = vec![
        quad("floor", o + Vec3::new(0.0, -s, 0.0), Vec3::Y, s, 0, None),
        quad("ceiling", o + Vec3::new(0.0, s, 0.0), -Vec3::Y, s, 0, None),
        quad("back", o + Vec3::new(0.0, 0.0, s), -Vec3::Z, s, 0, None),
        quad("left", o + Vec3::new(s, 0.0, 0.0), -Vec3::X, s, 1, None),
        quad("right", o + Vec3::new(-s, 0.0, 0.0), Vec3::X, s, 2, None),
        quad(
            "light",
            o + Vec3::new(0.0, 0.99 * s, 0.0),
            -Vec3::Y,
            0.3 * s,
            0,
            Some(Vec3::splat(8.0)),
        ),
    ];
    Scene {
        camera: Camera {
            to_world: Mat4::from_translation(o + Vec3::new(0.0, 0.0, -3.4 * s)),
            fov_degrees: 40.0,
            ..Camera::default()
        },
        film: Film {
            width: 16,
            height: 16,
            filter: Filter::Box,
        },
        sampler: Sampler {
            sample_count: 8,
            seed: 7,
        },
        integrator: path(Some(4), false),
        meshes,
        materials: vec![
            diffuse(w),
            diffuse(Vec3::new(0.7, 0.1, 0.1)),
            diffuse(Vec3::new(0.1, 0.7, 0.1)),
        ],
        ..Scene::default()
    }
}

pub(crate) fn cornell(o: Vec3) -> Scene {
    cornell_at(o, 1.0)
}

fn image_mean(f: &Frame) -> Vec3 {
    f.mean.iter().map(|p| Vec3::from_array(*p)).sum::<Vec3>() / f.mean.len() as f32
}

#[test]
fn furnace_matches_the_path_integrators_series() {
    let d = cpu(2);
    // max_depth 1: only the emitters seen directly, exactly.
    let f = render(
        d.as_ref(),
        &furnace(Vec3::ZERO, 1.0, 0.5, 1.0, path(Some(1), false)),
        &RenderOptions::default(),
    )
    .unwrap();
    assert!(
        f.mean.iter().flatten().all(|v| *v == 1.0),
        "{:?}",
        &f.mean[..4]
    );
    // max_depth 3: 1 + 0.5 + 0.25 through emission, NEE and MIS together.
    let opts = RenderOptions {
        spp: Some(64),
        want_variance: true,
        ..RenderOptions::default()
    };
    let f = render(
        d.as_ref(),
        &furnace(Vec3::ZERO, 1.0, 0.5, 1.0, path(Some(3), false)),
        &opts,
    )
    .unwrap();
    let m = image_mean(&f);
    assert!(
        (m - Vec3::splat(1.75)).abs().max_element() < 0.03,
        "mean {m}"
    );
    assert!(
        f.variance
            .as_ref()
            .unwrap()
            .iter()
            .flatten()
            .any(|v| *v > 0.0)
    );
    // Hidden emitters drop the first term only.
    let f = render(
        d.as_ref(),
        &furnace(Vec3::ZERO, 1.0, 0.5, 1.0, path(Some(3), true)),
        &opts,
    )
    .unwrap();
    let m = image_mean(&f);
    assert!(
        (m - Vec3::splat(0.75)).abs().max_element() < 0.03,
        "hidden: mean {m}"
    );
    // Past rr_depth, Russian roulette keeps the expectation: Σ 0.5^k for k < 8.
    let f = render(
        d.as_ref(),
        &furnace(Vec3::ZERO, 1.0, 0.5, 1.0, path(Some(8), false)),
        &opts,
    )
    .unwrap();
    let expect = (0..8).map(|k| 0.5f32.powi(k)).sum::<f32>();
    let m = image_mean(&f);
    assert!(
        (m - Vec3::splat(expect)).abs().max_element() < 0.05,
        "rr: mean {m}, expected {expect}"
    );
}

#[test]
fn same_seed_is_bit_identical_across_thread_counts() {
    let scene = cornell(Vec3::ZERO);
    let opts = RenderOptions::default();
    let a = render(cpu(1).as_ref(), &scene, &opts).unwrap();
    let b = render(cpu(2).as_ref(), &scene, &opts).unwrap();
    assert_eq!(a.mean, b.mean);
    // Launch batching does not change the image either.
    let c = render(
        cpu(2).as_ref(),
        &scene,
        &RenderOptions {
            samples_per_launch: Some(256),
            ..opts.clone()
        },
    )
    .unwrap();
    assert_eq!(a.mean, c.mean);
    let other = render(
        cpu(2).as_ref(),
        &scene,
        &RenderOptions {
            seed: Some(8),
            ..opts
        },
    )
    .unwrap();
    assert_ne!(a.mean, other.mean);
    assert!(image_mean(&a).max_element() > 0.01, "the box is lit");
}

/// Robust offsets (`rt_offset_ray`) scale with the position's magnitude, as float precision
/// does: a scene of a few hundred units moved 1e5 away renders the same.
#[test]
fn far_from_origin_renders_the_same() {
    let opts = RenderOptions {
        spp: Some(32),
        ..RenderOptions::default()
    };
    let d = cpu(2);
    let near = image_mean(&render(d.as_ref(), &cornell_at(Vec3::ZERO, 300.0), &opts).unwrap());
    let far_scene = cornell_at(Vec3::new(1e5, -1e5, 1e5), 300.0);
    let far = image_mean(&render(d.as_ref(), &far_scene, &opts).unwrap());
    assert!(
        ((near - far).abs() / near).max_element() < 0.05,
        "near {near}, far {far}"
    );
    // A furnace far away loses no energy to self-intersection.
    let opts = RenderOptions {
        spp: Some(64),
        ..RenderOptions::default()
    };
    let f = render(
        d.as_ref(),
        &furnace(Vec3::splat(1e5), 300.0, 0.5, 1.0, path(Some(3), false)),
        &opts,
    )
    .unwrap();
    let m = image_mean(&f);
    assert!(
        (m - Vec3::splat(1.75)).abs().max_element() < 0.03,
        "far furnace: mean {m}"
    );
}

#[test]
fn wgpu_agrees_with_cpu() {
    let Ok(g) = optik::open(BackendChoice::Named(BackendKind::Wgpu)) else {
        eprintln!("wgpu backend unavailable here; skipped");
        return;
    };
    let scene = cornell(Vec3::ZERO);
    let opts = RenderOptions::default();
    let a = image_mean(&render(cpu(2).as_ref(), &scene, &opts).unwrap());
    let b = image_mean(&render(g.as_ref(), &scene, &opts).unwrap());
    assert!(
        ((a - b).abs() / a).max_element() < 0.02,
        "cpu {a}, wgpu {b}"
    );
}

#[test]
fn diffuse_probe_is_lambert() {
    let d = cpu(1);
    let b = diffuse(Vec3::new(0.2, 0.4, 0.6));
    let s = 0.6f32.sqrt();
    let queries = [
        BsdfQuery {
            wi: [0.0, 0.0, 1.0],
            wo: [0.0, 0.8, 0.6],
            uv: [0.0, 0.0],
        },
        BsdfQuery {
            wi: [0.0, s, -(0.4f32.sqrt())],
            wo: [0.0, 0.0, 1.0],
            uv: [0.0, 0.0],
        },
        BsdfQuery {
            wi: [0.0, 0.0, 1.0],
            wo: [0.0, 0.8, -0.6],
            uv: [0.0, 0.0],
        },
    ];
    let v = probe::bsdf(d.as_ref(), &b, &queries).unwrap();
    let pi = std::f32::consts::PI;
    for (c, r) in [0.2f32, 0.4, 0.6].iter().enumerate() {
        assert!((v[0].value[c] - r / pi * 0.6).abs() < 1e-6);
    }
    assert!((v[0].pdf - 0.6 / pi).abs() < 1e-6);
    assert_eq!(
        v[1].value, [0.0; 3],
        "back side is black (one-sided diffuse)"
    );
    assert_eq!(v[2].pdf, 0.0);
    let samples = [[0.5, 0.1, 0.2], [0.1, 0.9, 0.7], [0.3, 0.5, 0.5]];
    let out = probe::bsdf_sample(d.as_ref(), &b, [0.0, 0.0, 1.0], [0.0, 0.0], &samples).unwrap();
    for o in &out {
        let wo = Vec3::from_array(o.wo);
        assert!((wo.length() - 1.0).abs() < 1e-5 && wo.z > 0.0);
        assert!((o.pdf - wo.z / pi).abs() < 1e-5);
        assert!(
            (Vec3::from_array(o.weight) - Vec3::new(0.2, 0.4, 0.6))
                .abs()
                .max_element()
                < 1e-6
        );
        assert!(!o.delta);
    }
    assert!(
        probe::bsdf_sample(
            d.as_ref(),
            &b,
            [0.0, 0.0, 1.0],
            [0.0; 2],
            &[[1.0, 0.0, 0.0]]
        )
        .is_err()
    );
}

#[test]
fn features_follow_the_scene() {
    let d = cpu(1);
    let scene = cornell(Vec3::ZERO);
    let f = render(
        d.as_ref(),
        &scene,
        &RenderOptions {
            spp: Some(1),
            ..RenderOptions::default()
        },
    )
    .unwrap();
    let feat = &f.stats.features;
    assert_eq!(
        feat.bsdf_kinds.iter().map(|k| k.name()).collect::<Vec<_>>(),
        ["diffuse"]
    );
    assert!(feat.shadow_rays && feat.emitters.contains("area"));
    assert!(f.stats.programs.contains(&"miss__shadow".to_string()));
    assert!(
        f.stats
            .programs
            .contains(&"closesthit__diffuse".to_string())
    );
    // Paths of one segment need no next-event estimation: no shadow ray type is compiled.
    let mut direct_only = scene.clone();
    direct_only.integrator = path(Some(1), false);
    let f = render(
        d.as_ref(),
        &direct_only,
        &RenderOptions {
            spp: Some(1),
            ..RenderOptions::default()
        },
    )
    .unwrap();
    assert!(!f.stats.features.shadow_rays);
    assert!(!f.stats.programs.contains(&"miss__shadow".to_string()));
    assert!(f.stats.features.describe().contains("bsdfs: diffuse"));
}

#[test]
fn the_light_sampler_compiles_only_the_kinds_present() {
    const SAMPLERS: [&str; 6] = [
        "TRIANGLE",
        "SPHERE",
        "POINT",
        "SPOT",
        "DIRECTIONAL",
        "CONSTANT",
    ];
    let sampler_of = |scene: &Scene| {
        let f = crate::features::RenderFeatures::of(scene, false);
        let module = crate::programs::path_module(&f);
        let on = |kind: &str| {
            let decl = |v: bool| format!("const SAMPLE_{kind}: bool = {v};");
            match (module.contains(&decl(true)), module.contains(&decl(false))) {
                (true, false) => true,
                (false, true) => false,
                _ => panic!("path_module declares SAMPLE_{kind} once, true or false"),
            }
        };
        (f, SAMPLERS.map(on))
    };
    // The Cornell box: one emitting mesh.
    let mut scene = cornell(Vec3::ZERO);
    let (f, on) = sampler_of(&scene);
    assert_eq!(on, [true, false, false, false, false, false]);
    assert!(f.describe().contains("area emitters on: triangles\n"));
    // A point light added: its sampler joins.
    scene.emitters.push(crate::scene::Emitter::Point {
        position: Vec3::new(0.0, 0.5, 0.0),
        intensity: Vec3::ONE,
    });
    let (_, on) = sampler_of(&scene);
    assert_eq!(on, [true, false, true, false, false, false]);
    // Every effect compiles every sampler.
    let every = crate::features::RenderFeatures::of(&scene, false).with_every_effect();
    let module = crate::programs::path_module(&every);
    for kind in SAMPLERS {
        assert!(
            module.contains(&format!("const SAMPLE_{kind}: bool = true;")),
            "{kind}"
        );
    }
}

#[test]
fn delta_bsdfs_compile_their_programs_without_shadow_rays() {
    let d = cpu(1);
    let mut scene = cornell(Vec3::ZERO);
    let white = Texture::Constant(Vec3::ONE);
    scene.materials = vec![
        Bsdf::Conductor {
            eta: Vec3::ZERO,
            k: Vec3::ONE,
            specular_reflectance: white.clone(),
        },
        Bsdf::Dielectric {
            int_ior: 1.5,
            ext_ior: 1.0,
            specular_reflectance: white.clone(),
            specular_transmittance: white.clone(),
        },
        Bsdf::ThinDielectric {
            int_ior: 1.5,
            ext_ior: 1.0,
            specular_reflectance: white.clone(),
            specular_transmittance: white,
        },
    ];
    let f = render(
        d.as_ref(),
        &scene,
        &RenderOptions {
            spp: Some(2),
            ..RenderOptions::default()
        },
    )
    .unwrap();
    let feat = &f.stats.features;
    // Mitsuba's path integrator samples emitters only at BSDFs with a smooth lobe.
    assert!(!feat.shadow_rays);
    assert_eq!(
        f.stats.programs,
        [
            "raygen__path",
            "miss__radiance",
            "closesthit__conductor",
            "closesthit__dielectric",
            "closesthit__thindielectric"
        ]
    );
    let text = feat.describe();
    assert!(
        text.contains("bsdfs: conductor, dielectric, thindielectric"),
        "{text}"
    );
    assert!(text.contains("shared bsdf code: fresnel\n"), "{text}");
    // The emitter is still reached by BSDF sampling through the mirrors and glass.
    assert!(image_mean(&f).max_element() > 0.0);
}

#[test]
fn twosided_accepts_one_reflective_bsdf() {
    let diffuse = Bsdf::Diffuse {
        reflectance: Texture::Constant(Vec3::splat(0.5)),
    };
    let glass = Bsdf::Dielectric {
        int_ior: 1.5,
        ext_ior: 1.0,
        specular_reflectance: Texture::Constant(Vec3::ONE),
        specular_transmittance: Texture::Constant(Vec3::ONE),
    };
    let two = |front: &Bsdf, back: &Bsdf| Bsdf::TwoSided {
        front: Box::new(front.clone()),
        back: Box::new(back.clone()),
    };
    let e = crate::material::encode(&two(&diffuse, &diffuse), &[], "m").unwrap();
    assert_eq!(e.kind, crate::material::BsdfKind::Diffuse);
    assert!(e.back.is_none());
    let err = crate::material::encode(&two(&glass, &glass), &[], "mesh `b`").unwrap_err();
    assert!(err.to_string().contains("without transmission"), "{err}");
    // Either side transmissive is refused, as Mitsuba refuses it.
    let err = crate::material::encode(&two(&diffuse, &glass), &[], "mesh `c`").unwrap_err();
    assert!(
        err.to_string().contains("twosided around dielectric"),
        "{err}"
    );
}

fn rough_plastic(albedo: f32, alpha: f32) -> Bsdf {
    Bsdf::RoughPlastic {
        diffuse_reflectance: Texture::Constant(Vec3::new(albedo, 0.5, 0.25)),
        specular_reflectance: Texture::Constant(Vec3::ONE),
        int_ior: 1.5,
        ext_ior: 1.0,
        nonlinear: false,
        roughness: crate::scene::Roughness {
            distribution: crate::scene::Microfacet::Ggx,
            alpha_u: alpha,
            alpha_v: alpha,
        },
    }
}

/// Mitsuba's `twosided` with two children: from above the front BSDF, from below the back one
/// with both directions mirrored. Two roughplastics of different roughness make each side read
/// its own table.
#[test]
fn twosided_with_two_bsdfs_shades_each_side_with_its_own() {
    let d = cpu(1);
    let front = rough_plastic(0.8, 0.1);
    let back = rough_plastic(0.3, 0.6);
    let pair = Bsdf::TwoSided {
        front: Box::new(front.clone()),
        back: Box::new(back.clone()),
    };
    let e = crate::material::encode(&pair, &[], "m").unwrap();
    assert_eq!(
        (e.kind, e.back.as_ref().map(|b| b.kind)),
        (
            crate::material::BsdfKind::RoughPlastic,
            Some(crate::material::BsdfKind::RoughPlastic)
        )
    );
    let mirror = |v: [f32; 3]| [v[0], v[1], -v[2]];
    let up = |x: f32, y: f32| Vec3::new(x, y, 1.0).normalize().to_array();
    let queries: Vec<BsdfQuery> = [
        (0.1, 0.2, -0.3, 0.4),
        (0.9, -0.1, 0.2, 0.2),
        (-2.0, 0.5, 0.1, -1.5),
    ]
    .iter()
    .map(|&(a, b, c, e)| BsdfQuery {
        wi: up(a, b),
        wo: up(c, e),
        uv: [0.5, 0.5],
    })
    .collect();
    let below: Vec<BsdfQuery> = queries
        .iter()
        .map(|q| BsdfQuery {
            wi: mirror(q.wi),
            wo: mirror(q.wo),
            uv: q.uv,
        })
        .collect();
    let pair_above = probe::bsdf(d.as_ref(), &pair, &queries).unwrap();
    let pair_below = probe::bsdf(d.as_ref(), &pair, &below).unwrap();
    let front_values = probe::bsdf(d.as_ref(), &front, &queries).unwrap();
    let back_values = probe::bsdf(d.as_ref(), &back, &queries).unwrap();
    assert_eq!(pair_above, front_values);
    assert_eq!(pair_below, back_values);
    assert_ne!(
        front_values, back_values,
        "the two sides must differ for the test to mean anything"
    );
    // Grazing: neither side.
    let grazing = probe::bsdf(
        d.as_ref(),
        &pair,
        &[BsdfQuery {
            wi: [1.0, 0.0, 0.0],
            wo: up(0.2, 0.1),
            uv: [0.5, 0.5],
        }],
    )
    .unwrap();
    assert_eq!(grazing[0].value, [0.0; 3]);
    // Sampling from below: the back BSDF's sample, mirrored.
    let u = [[0.3, 0.6, 0.2], [0.9, 0.1, 0.8]];
    let wi = up(0.3, -0.2);
    let back_samples = probe::bsdf_sample(d.as_ref(), &back, wi, [0.5, 0.5], &u).unwrap();
    let pair_samples = probe::bsdf_sample(d.as_ref(), &pair, mirror(wi), [0.5, 0.5], &u).unwrap();
    for (p, b) in pair_samples.iter().zip(&back_samples) {
        assert_eq!(p.wo, mirror(b.wo));
        assert_eq!((p.weight, p.pdf), (b.weight, b.pdf));
    }
    let front_samples = probe::bsdf_sample(d.as_ref(), &front, wi, [0.5, 0.5], &u).unwrap();
    let pair_samples = probe::bsdf_sample(d.as_ref(), &pair, wi, [0.5, 0.5], &u).unwrap();
    assert_eq!(pair_samples, front_samples);
}

/// Walls with a different BSDF on each side render, from either side, as one-sided walls of
/// that side's BSDF: the pair's closest-hit program and the back material in the SBT record.
/// The GPU backends that open here render the pair's walls as the CPU does.
#[test]
fn a_twosided_pair_renders_each_side_as_its_bsdf() {
    let d = cpu(2);
    let d = d.as_ref();
    let red = Bsdf::Diffuse {
        reflectance: Texture::Constant(Vec3::new(0.8, 0.1, 0.1)),
    };
    let shiny = rough_plastic(0.2, 0.3);
    let estimate_on = |d: &dyn Device, scene: &Scene| {
        let f = render(d, scene, &shapes::with_variance(64)).unwrap();
        (shapes::estimate(&f), f.stats.programs)
    };
    let estimate_of = |scene: &Scene| estimate_on(d, scene);
    // The Cornell box's walls as seen from inside (their fronts); flipping their normals
    // shows their back sides instead.
    let with_walls = |bsdf: &Bsdf, flip: bool| {
        let mut scene = cornell(Vec3::ZERO);
        let index = scene.materials.len() as u32;
        scene.materials.push(bsdf.clone());
        for m in scene.meshes.iter_mut().filter(|m| m.emission.is_none()) {
            m.material = index;
            m.flip_normals ^= flip;
        }
        scene
    };
    let pair = Bsdf::TwoSided {
        front: Box::new(red.clone()),
        back: Box::new(shiny.clone()),
    };
    let (fronts, programs) = estimate_of(&with_walls(&pair, false));
    let hit_programs: Vec<&String> = programs
        .iter()
        .filter(|p| p.starts_with("closesthit__"))
        .collect();
    // The light keeps its own diffuse material.
    assert_eq!(
        hit_programs,
        [
            "closesthit__diffuse",
            "closesthit__twosided_diffuse_roughplastic"
        ]
    );
    let (backs, _) = estimate_of(&with_walls(&pair, true));
    let (red_walls, _) = estimate_of(&with_walls(&red, false));
    let (shiny_walls, _) = estimate_of(&with_walls(&shiny, false));
    let agree = |a: &crate::validate::Estimate, b: &crate::validate::Estimate| {
        crate::validate::z_test(a, b).unwrap().passed
    };
    assert!(agree(&fronts, &red_walls));
    assert!(agree(&backs, &shiny_walls));
    // The check has teeth: the two sides differ.
    assert!(!agree(&backs, &red_walls));
    for kind in [BackendKind::Wgpu, BackendKind::Vulkan] {
        let Ok(gpu) = optik::open(BackendChoice::Named(kind)) else {
            eprintln!("{kind} backend unavailable here; skipped");
            continue;
        };
        for (flip, cpu_estimate) in [(false, &fronts), (true, &backs)] {
            let (e, _) = estimate_on(gpu.as_ref(), &with_walls(&pair, flip));
            assert!(agree(&e, cpu_estimate), "{kind}, flipped {flip}");
        }
    }
}

#[test]
fn aovs_hold_albedo_and_normal_of_the_first_hit() {
    let d = cpu(2);
    let scene = cornell(Vec3::ZERO);
    let f = render(
        d.as_ref(),
        &scene,
        &RenderOptions {
            spp: Some(2),
            want_aovs: true,
            ..RenderOptions::default()
        },
    )
    .unwrap();
    let albedo = &f.aovs[0];
    let normal = &f.aovs[1];
    // The centre pixel sees the white back wall, facing the camera (-z).
    let centre = (8 * 16 + 8) * 3;
    assert!(
        (albedo.data[centre] - 0.7).abs() < 1e-5,
        "{:?}",
        &albedo.data[centre..centre + 3]
    );
    assert!((normal.data[centre + 2] + 1.0).abs() < 1e-4);
}

#[test]
fn bad_inputs_are_errors() {
    let d = cpu(1);
    let mut s = cornell(Vec3::ZERO);
    s.meshes[0].indices.push([0, 1, 9]);
    let e = render(d.as_ref(), &s, &RenderOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("vertex index 9"), "{e}");
    let mut s = cornell(Vec3::ZERO);
    s.meshes[0].material = 42;
    assert!(render(d.as_ref(), &s, &RenderOptions::default()).is_err());
    let s = cornell(Vec3::ZERO);
    assert!(
        render(
            d.as_ref(),
            &s,
            &RenderOptions {
                spp: Some(0),
                ..RenderOptions::default()
            }
        )
        .is_err()
    );
}

#[test]
fn outputs_encode() {
    let d = cpu(2);
    let f = render(
        d.as_ref(),
        &cornell(Vec3::ZERO),
        &RenderOptions {
            spp: Some(1),
            want_aovs: true,
            ..RenderOptions::default()
        },
    )
    .unwrap();
    let exr = crate::output::exr_bytes(&f).unwrap();
    let path = std::env::temp_dir().join(format!("optik-render-test-{}.exr", std::process::id()));
    std::fs::write(&path, exr).unwrap();
    let img = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    let names: Vec<String> = img.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert!(
        names.contains(&"R".to_string()) && names.contains(&"albedo.R".to_string()),
        "{names:?}"
    );
    let png = crate::output::png_bytes(&f).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    assert_eq!(crate::output::srgb8(1.0), 255);
    assert_eq!(crate::output::srgb8(0.0), 0);
    assert_eq!(crate::output::srgb8(0.5), 188);
}

#[path = "tests_shapes.rs"]
mod shapes;

#[path = "tests_emitters.rs"]
mod emitters;

#[path = "tests_integrators.rs"]
mod integrators;
