//! optik's renders of the validation scenes (render/validation/scenes) against Mitsuba 3.9.1's
//! reference estimates (render/validation/references), on every backend, by the per-pixel Welch
//! z-test of `optik_render::validate`; and the teeth test: a 5 % change of one albedo fails.
//!
//! A failure writes the images, error mask and p-values under
//! `$CARGO_TARGET_TMPDIR/mitsuba/<scene>-<backend>/` and names that folder.
//!
//! The Vulkan backend runs on lavapipe in CI (hundreds of times slower than a GPU), so it renders
//! fewer samples; the z-test uses optik's own variance, so a smaller sample count is still a
//! valid (if less sensitive) test.

use optik::BackendKind;
use optik_render::validate::{self, Estimate, files};
use optik_render::{RenderOptions, render};
use std::path::{Path, PathBuf};

fn validation_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("validation")
}

/// Samples per pixel optik renders on each backend: `cpu_spp` on the CPU, and by default half
/// of it on wgpu and an eighth on Vulkan (lavapipe in CI); `wgpu_spp` overrides wgpu's, for
/// scenes whose long specular paths make wgpu on lavapipe slow. `OPTIK_MITSUBA_SPP` overrides
/// them all (a deeper check: more samples make the test more sensitive).
fn spp_for(kind: BackendKind, cpu_spp: u32, wgpu_spp: Option<u32>) -> u32 {
    if let Some(spp) = std::env::var("OPTIK_MITSUBA_SPP")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        return spp;
    }
    match kind {
        BackendKind::Cpu => cpu_spp,
        BackendKind::Wgpu => wgpu_spp.unwrap_or((cpu_spp / 2).max(16)),
        BackendKind::Vulkan => (cpu_spp / 8).max(8),
    }
}

/// lavapipe, where CI runs the GPU backends, compiles each pipeline with LLVM inside a
/// coroutine (llvmpipe's compute shaders), which grows faster than linearly with the shader:
/// the wgpu megakernel of a scene with nine BSDF kinds took over three minutes on one core.
/// These tests check images statistically, not speed, so before the first device opens this
/// binary asks llvmpipe for its fast-compiling settings (no LLVM optimisation passes, 4-wide
/// vectors), unless the environment already chose: about three times faster to compile on
/// the sphere scenes. Every test calls this first; `Once` makes the others wait, so no thread
/// reads the environment while it is written.
fn fast_lavapipe_compiles() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        for (key, value) in [("GALLIVM_PERF", "nopt"), ("LP_NATIVE_VECTOR_WIDTH", "128")] {
            if std::env::var_os(key).is_none() {
                // SAFETY: no other thread of this process reads or writes the environment
                // meanwhile: every test enters this `Once` before anything else, and libtest
                // read its own variables before it started the tests.
                unsafe { std::env::set_var(key, value) };
            }
        }
    });
}

/// Loads `scene`, renders it on `kind` at `spp` after `edit` and returns optik's estimate.
fn render_scene(
    scene: &str,
    kind: BackendKind,
    spp: u32,
    edit: impl FnOnce(&mut optik_render::scene::Scene),
) -> Estimate {
    fast_lavapipe_compiles();
    let path = validation_dir().join("scenes").join(format!("{scene}.xml"));
    let mut loaded = optik_render::scene::load(&path, &[])
        .unwrap_or_else(|e| panic!("loading {}: {e}", path.display()));
    edit(&mut loaded);
    let device = optik::open_backend(kind)
        .unwrap_or_else(|e| panic!("the {kind} backend cannot run here: {}", e.message()));
    let options = RenderOptions {
        spp: Some(spp),
        seed: Some(7),
        want_variance: true,
        ..Default::default()
    };
    let frame = render(device.as_ref(), &loaded, &options)
        .unwrap_or_else(|e| panic!("rendering {scene} on {kind}: {e}"));
    let diagnostics = device.take_diagnostics();
    assert!(
        diagnostics.is_empty(),
        "{scene} on {kind}: driver messages:\n{}",
        diagnostics.join("\n")
    );
    let variance = frame
        .variance
        .unwrap_or_else(|| panic!("{scene} on {kind}: the frame has no variance although asked"));
    let mean: Vec<f32> = frame.mean.iter().flatten().copied().collect();
    let variance: Vec<f32> = variance.iter().flatten().copied().collect();
    Estimate::new(frame.width, frame.height, mean, variance, frame.spp)
        .unwrap_or_else(|e| panic!("{scene} on {kind}: {e}"))
}

/// Runs the z-test of optik against the reference; on failure writes the artefacts and returns
/// the outcome's text.
fn compare(scene: &str, tag: &str, optik: &Estimate) -> Result<String, String> {
    let reference = files::read_reference(&validation_dir().join("references"), scene)
        .unwrap_or_else(|e| panic!("{e}"));
    let outcome = validate::z_test(optik, &reference).unwrap_or_else(|e| panic!("{scene}: {e}"));
    let text = format!("{scene} ({tag}, {} spp): {outcome}", optik.samples);
    if outcome.passed {
        return Ok(text);
    }
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("mitsuba")
        .join(format!("{scene}-{tag}"));
    match files::write_failure_artefacts(&dir, scene, optik, &reference, &outcome) {
        Ok(dir) => Err(format!("{text}\nartefacts in {}", dir.display())),
        Err(e) => Err(format!("{text}\n(could not write the artefacts: {e})")),
    }
}

fn check(scene: &str, kind: BackendKind, cpu_spp: u32, wgpu_spp: Option<u32>) {
    let optik = render_scene(scene, kind, spp_for(kind, cpu_spp, wgpu_spp), |_| {});
    match compare(scene, kind.name(), &optik) {
        Ok(text) => println!("{text}"),
        Err(text) => panic!("{text}"),
    }
}

/// One test per scene and backend: `scene!(name, cpu_spp)`, or `scene!(name, cpu_spp, wgpu:
/// wgpu_spp)`.
macro_rules! scene {
    ($name:ident, $spp:expr, wgpu: $wgpu:expr) => {
        scene!(@tests $name, $spp, Some($wgpu));
    };
    ($name:ident, $spp:expr) => {
        scene!(@tests $name, $spp, None);
    };
    (@tests $name:ident, $spp:expr, $wgpu:expr) => {
        mod $name {
            use super::*;
            #[test]
            fn cpu() {
                check(stringify!($name), BackendKind::Cpu, $spp, $wgpu);
            }
            #[test]
            fn wgpu() {
                check(stringify!($name), BackendKind::Wgpu, $spp, $wgpu);
            }
            #[test]
            fn vulkan() {
                check(stringify!($name), BackendKind::Vulkan, $spp, $wgpu);
            }
        }
    };
}

scene!(cbox, 128);
scene!(cbox_smooth, 128, wgpu: 32);
scene!(cbox_rough, 128, wgpu: 16);
scene!(spheres_area, 64);
scene!(spheres_point, 64);
scene!(spheres_constant, 64);
scene!(spheres_envmap, 64);
// Spheres and instances make the wgpu backend's software traversal a larger shader: on
// lavapipe it compiles for about 40 s, so these scenes render fewer samples.
scene!(textured_diffuse, 32);
scene!(rough_dielectric, 128);
scene!(rough_plastic, 128);
scene!(instancing, 32);
scene!(infinite_mirrors, 128);
scene!(various_shapes, 64);

/// The teeth test: `scene` rendered with the diffuse albedo `albedo` scaled by 1.05 must fail
/// the z-test that the unchanged render passes at the same sample count.
fn teeth(scene: &str, albedo: [f32; 3], spp: u32) {
    use optik_render::scene::{Bsdf, Texture};
    let target = glam::Vec3::from(albedo);
    let unchanged = render_scene(scene, BackendKind::Cpu, spp, |_| {});
    if let Err(text) = compare(scene, "teeth-control", &unchanged) {
        panic!("the unchanged render must pass for the teeth test to mean anything: {text}");
    }
    let mut changed = 0;
    let brighter = render_scene(scene, BackendKind::Cpu, spp, |s| {
        for m in &mut s.materials {
            if let Bsdf::Diffuse {
                reflectance: Texture::Constant(c),
            } = m
                && (*c - target).abs().max_element() < 1e-6
            {
                *c *= 1.05;
                changed += 1;
            }
        }
    });
    assert_eq!(
        changed, 1,
        "expected one diffuse material with albedo {target} in {scene}"
    );
    match compare(scene, "teeth", &brighter) {
        Ok(text) => panic!("a 5 % brighter albedo passed: {text}"),
        Err(text) => println!("caught as expected: {text}"),
    }
}

mod teeth {
    use super::*;
    #[test]
    fn cbox_white() {
        teeth("cbox", [0.885809, 0.698859, 0.666422], 512);
    }
    #[test]
    fn spheres_constant_diffuse_sphere() {
        teeth("spheres_constant", [0.2, 0.5, 0.3], 1024);
    }
}

/// The Breakfast Room (render/validation/make_breakfast_room.py writes its committed
/// per-material PLY meshes): a checkout without them fails rather than passing unrendered.
fn check_breakfast_room(kind: BackendKind, cpu_spp: u32) {
    let meshes = validation_dir().join("scenes/breakfast_room");
    let has_meshes = std::fs::read_dir(&meshes).is_ok_and(|entries| {
        entries
            .flatten()
            .any(|e| e.path().extension().is_some_and(|x| x == "ply"))
    });
    assert!(
        has_meshes,
        "breakfast_room on {kind}: the meshes under {} are missing; they are committed (restore \
         them with git) or made by `python3 render/validation/make_breakfast_room.py` (needs the \
         project's scenes/breakfast-room folder)",
        meshes.display()
    );
    check("breakfast_room", kind, cpu_spp, None);
}

mod breakfast_room {
    use super::*;
    #[test]
    fn cpu() {
        check_breakfast_room(BackendKind::Cpu, 64);
    }
    #[test]
    fn wgpu() {
        check_breakfast_room(BackendKind::Wgpu, 64);
    }
    #[test]
    fn vulkan() {
        check_breakfast_room(BackendKind::Vulkan, 64);
    }
}
