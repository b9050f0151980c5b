//! The modes on small scenes on the CPU backend: `--features`' plan against what is built,
//! the all-effects pipeline against the specialised one, convergence and its plot, and the
//! renderer's progressive accumulation they rely on.

use super::benchmark::{BenchmarkOptions, benchmark, median};
use super::convergence::{accuracy_name, accuracy_settings, convergence, rel_mse, sample_counts};
use super::plot::{PLOT_SIZE, plot_png, plot_rgb};
use crate::geometry::Primitive;
use crate::material::BsdfKind;
use crate::plan::{Effects, PipelinePlan};
use crate::tests::{cornell, cpu};
use crate::{RenderOptions, Renderer, programs};
use glam::Vec3;
use optik::{Accuracy, BackendKind};

/// The small Cornell box at `size`² pixels.
fn small_cornell(size: u32) -> crate::scene::Scene {
    let mut s = cornell(Vec3::ZERO);
    s.film.width = size;
    s.film.height = size;
    s
}

#[test]
fn the_plan_is_what_the_renderer_builds_and_the_device_compiles() {
    let d = cpu(2);
    let scene = small_cornell(8);
    let opts = RenderOptions::default();
    let spec = Renderer::new(d.as_ref(), &scene, &opts, Effects::Scene).unwrap();
    let plan = spec.plan();
    assert_eq!(*plan, PipelinePlan::new(&scene, false, Effects::Scene));
    assert_eq!(
        plan.programs,
        [
            "raygen__path",
            "miss__radiance",
            "miss__shadow",
            "closesthit__diffuse"
        ]
    );
    let text = plan.describe();
    for line in [
        "programs: raygen__path, miss__radiance, miss__shadow, closesthit__diffuse",
        "  bsdfs: diffuse",
        "  shadow rays (next-event estimation): true",
        "  payload registers: 26",
        "  traversable graph: auto",
        "pipeline: specialised",
    ] {
        assert!(text.contains(line), "`{line}` missing from:\n{text}");
    }
    assert!(!text.contains("compiled features"), "{text}");
    // optik's Auto specialisation, resolved by the device: one GAS of triangles.
    let compiled = spec.compiled_features().unwrap().names();
    assert!(compiled.contains(&"triangles".to_string()), "{compiled:?}");
    assert!(compiled.contains(&"single-gas".to_string()), "{compiled:?}");
    assert!(!compiled.contains(&"motion".to_string()), "{compiled:?}");

    let all = Renderer::new(d.as_ref(), &scene, &opts, Effects::All).unwrap();
    let plan = all.plan();
    for kind in BsdfKind::all() {
        for primitive in [Primitive::Triangles, Primitive::Spheres] {
            let name = programs::closest_hit_name(kind, None, primitive);
            assert!(plan.programs.contains(&name), "{name}: {:?}", plan.programs);
        }
    }
    for primitive in [Primitive::Triangles, Primitive::Spheres] {
        let name = programs::any_hit_name(primitive);
        assert!(plan.programs.contains(&name), "{name}: {:?}", plan.programs);
    }
    assert!(plan.features.shadow_rays && plan.features.environment);
    assert_eq!(plan.features.payload_values, 32);
    let text = plan.describe();
    assert!(text.contains("compiled features:\n"), "{text}");
    assert!(text.contains("  traversable graph: any-graph"), "{text}");
    let compiled = all.compiled_features().unwrap();
    assert!(compiled.motion, "{:?}", compiled.names());
    assert_eq!(compiled.num_payload_values, 32);
    assert!(compiled.names().contains(&"any-graph".to_string()));
}

#[test]
fn every_listed_program_is_defined_in_the_generated_module() {
    let scene = small_cornell(8);
    for effects in [Effects::Scene, Effects::All] {
        let plan = PipelinePlan::new(&scene, false, effects);
        let module = programs::path_module(&plan.features);
        for p in &plan.programs {
            assert!(
                module.contains(&format!("fn {p}(")),
                "{p} is not in the module"
            );
        }
        // Closest-hit programs are generated per kind compiled: none unlisted.
        for line in module.lines() {
            if let Some(rest) = line.strip_prefix("fn closesthit__") {
                let name = format!("closesthit__{}", rest.split('(').next().unwrap_or(""));
                assert!(plan.programs.contains(&name), "{name} not listed");
            }
        }
    }
}

#[test]
fn every_bsdf_source_belongs_to_a_kind() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/wgsl");
    let kinds = BsdfKind::all();
    let mut found = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if !(name.starts_with("bsdf_") && name.ends_with(".wgsl")) {
            continue;
        }
        found += 1;
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            kinds.iter().any(|k| k.wgsl() == text),
            "{name} is not the source of any kind in BsdfKind::all() ({kinds:?}): the \
             all-effects pipeline would leave it out"
        );
    }
    assert!(found >= 1, "no bsdf_*.wgsl in {}", dir.display());
    let mut sorted = kinds.clone();
    sorted.dedup();
    assert_eq!(sorted, kinds, "BsdfKind::all() repeats a kind");
}

#[test]
fn accumulation_does_not_depend_on_how_samples_are_split() {
    let d = cpu(2);
    let scene = small_cornell(8);
    let opts = RenderOptions {
        spp: Some(8),
        samples_per_launch: Some(64),
        ..Default::default()
    };
    let mut r = Renderer::new(d.as_ref(), &scene, &opts, Effects::Scene).unwrap();
    assert!(r.frame().is_err(), "no samples yet");
    r.accumulate(3, &mut |_| {}).unwrap();
    r.accumulate(5, &mut |_| {}).unwrap();
    let split = r.frame().unwrap();
    assert_eq!(split.spp, 8);
    r.restart().unwrap();
    assert_eq!(r.done(), 0);
    r.accumulate(8, &mut |_| {}).unwrap();
    let whole = r.frame().unwrap();
    assert_eq!(split.mean, whole.mean);
    let plain = crate::render(d.as_ref(), &scene, &opts).unwrap();
    assert_eq!(plain.mean, whole.mean);
}

#[test]
fn the_all_effects_pipeline_renders_a_statistically_equal_image() {
    let d = cpu(2);
    let scene = small_cornell(12);
    let result = benchmark(
        d.as_ref(),
        &scene,
        &BenchmarkOptions {
            spp: Some(64),
            seed: Some(3),
            rounds: 2,
        },
    )
    .unwrap();
    println!("{}", result.summary());
    assert!(result.agreement.passed, "{}", result.agreement);
    assert_eq!(result.specialised.seconds.len(), 2);
    assert_eq!(result.ratios().len(), 2);
    assert!(result.ratio() > 0.0 && result.ratio().is_finite());
    assert_eq!(result.backend, BackendKind::Cpu);
    assert_eq!(result.all_effects.plan.effects, Effects::All);
    // Both pipelines on independent random numbers (different seeds), enough samples that a
    // 5 % brighter image fails the same test.
    let render = |effects, seed| {
        let opts = RenderOptions {
            spp: Some(1024),
            seed: Some(seed),
            want_variance: true,
            ..Default::default()
        };
        let mut r = Renderer::new(d.as_ref(), &scene, &opts, effects).unwrap();
        r.accumulate(1024, &mut |_| {}).unwrap();
        r.frame().unwrap()
    };
    let spec = render(Effects::Scene, 11);
    let all = render(Effects::All, 12);
    let estimate = |f: &crate::Frame| super::benchmark::estimate(f).unwrap();
    let z = crate::validate::z_test(&estimate(&spec), &estimate(&all)).unwrap();
    println!("independent seeds: {z}");
    assert!(z.passed, "{z}");
    let mut brighter = all.clone();
    brighter.mean.iter_mut().flatten().for_each(|v| *v *= 1.05);
    let z = crate::validate::z_test(&estimate(&spec), &estimate(&brighter)).unwrap();
    assert!(!z.passed, "a 5 % brighter image passes: {z}");
    assert!(
        benchmark(
            d.as_ref(),
            &scene,
            &BenchmarkOptions {
                rounds: 0,
                ..Default::default()
            }
        )
        .is_err()
    );
}

#[test]
fn medians_and_sample_counts() {
    assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
    assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    assert_eq!(sample_counts(1), [1]);
    assert_eq!(sample_counts(4), [1, 2, 4]);
    assert_eq!(sample_counts(5), [1, 2, 4, 5]);
    assert_eq!(rel_mse(&[[1.0, 1.0, 1.0]], &[[1.0, 1.0, 1.0]]), 0.0);
    // (2 − 1)² / (1 + 0.01) in one channel of three.
    let r = rel_mse(&[[2.0, 1.0, 1.0]], &[[1.0, 1.0, 1.0]]);
    assert!((r - 1.0 / 1.01 / 3.0).abs() < 1e-12, "{r}");
    assert_eq!(accuracy_name(Accuracy::ROBUST), "watertight+conservative");
    for a in accuracy_settings() {
        assert_eq!(Accuracy::parse(&accuracy_name(a)), Some(a));
    }
    assert_eq!(accuracy_settings().len(), 6);
}

#[test]
fn convergence_falls_with_samples_for_every_accuracy_the_cpu_runs() {
    let d = cpu(2);
    let scene = small_cornell(8);
    let reference = crate::render(
        d.as_ref(),
        &scene,
        &RenderOptions {
            spp: Some(1024),
            seed: Some(99),
            ..Default::default()
        },
    )
    .unwrap()
    .mean;
    let before = optik::Device::accuracy(d.as_ref());
    let c = convergence(
        d.as_ref(),
        &scene,
        &reference,
        32,
        Some(1),
        &accuracy_settings(),
    )
    .unwrap();
    assert_eq!(
        optik::Device::accuracy(d.as_ref()),
        before,
        "accuracy restored"
    );
    // The CPU backend runs optik's two triangle tests with both box tests, not the driver's.
    assert_eq!(c.curves.len(), 4, "{:?}", c.refused);
    assert_eq!(c.refused.len(), 2);
    for curve in &c.curves {
        let spp: Vec<u32> = curve.points.iter().map(|p| p.spp).collect();
        assert_eq!(spp, [1, 2, 4, 8, 16, 32]);
        let first = curve.points[0];
        let last = curve.points[curve.points.len() - 1];
        println!(
            "{}: relMSE {:.4} at 1 spp ({:.4} s) -> {:.5} at 32 spp ({:.4} s)",
            accuracy_name(curve.accuracy),
            first.rel_mse,
            first.seconds,
            last.rel_mse,
            last.seconds
        );
        // A few fireflies make small images' error noisy from one count to the next; over 32
        // times the samples it must still fall clearly.
        assert!(
            last.rel_mse < first.rel_mse * 0.5,
            "32 times the samples should cut the error: {first:?} -> {last:?}"
        );
        assert!(
            curve
                .points
                .windows(2)
                .all(|w| w[1].seconds >= w[0].seconds)
        );
    }
    // Each point is the image a plain render at that sample count gives (the default
    // accuracy's curve comes first).
    assert_eq!(c.curves[0].accuracy, Accuracy::ROBUST);
    for p in &c.curves[0].points {
        let plain = crate::render(
            d.as_ref(),
            &scene,
            &RenderOptions {
                spp: Some(p.spp),
                seed: Some(1),
                ..Default::default()
            },
        )
        .unwrap();
        // Equal up to the order of float sums (launches split samples differently).
        let plain = rel_mse(&plain.mean, &reference);
        assert!(
            (plain - p.rel_mse).abs() < 1e-6 * plain,
            "at {} spp: {plain} vs {}",
            p.spp,
            p.rel_mse
        );
    }
    let wrong = convergence(d.as_ref(), &scene, &reference[1..], 4, None, &[]);
    assert!(
        wrong
            .unwrap_err()
            .to_string()
            .contains("reference has 63 pixels")
    );

    // The plot: curve colours on white, written as a PNG of the documented size.
    let (rgb, legend) = plot_rgb(&c.curves).unwrap();
    assert_eq!(legend.curves.len(), 4);
    assert!(legend.curves[0].starts_with("blue circles: cpu watertight+conservative"));
    // Alone, since curves of equal error and time cover it (seen in CI under load).
    let (first, _) = plot_rgb(&c.curves[..1]).unwrap();
    let blue = first
        .chunks_exact(3)
        .filter(|p| *p == [31, 119, 180])
        .count();
    assert!(blue > 50, "the first curve is drawn: {blue} blue pixels");
    assert!(
        rgb.chunks_exact(3).any(|p| p != [255, 255, 255]),
        "the plot is drawn"
    );
    let dir = std::env::temp_dir().join(format!("optik-plot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("convergence.png");
    plot_png(&c.curves, &path).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let info = decoder.read_info().unwrap();
    assert_eq!(
        (info.info().width, info.info().height),
        (PLOT_SIZE.0, PLOT_SIZE.1)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
