//! The `direct` and `aov` integrators.

use super::*;
use crate::scene::{Aov, AovKind, DirectSettings};
use crate::validate::{self, Estimate};

fn direct(emitter_samples: u32, bsdf_samples: u32) -> Integrator {
    Integrator::Direct(DirectSettings {
        emitter_samples,
        bsdf_samples,
        hide_emitters: false,
    })
}

fn estimate(f: &Frame) -> Estimate {
    Estimate::new(
        f.width,
        f.height,
        f.mean.iter().flatten().copied().collect(),
        f.variance
            .as_ref()
            .unwrap()
            .iter()
            .flatten()
            .copied()
            .collect(),
        f.spp,
    )
    .unwrap()
}

/// In the emitting furnace, direct illumination is le + a · le whatever the mix of light and
/// BSDF samples (each strategy alone and MIS of both are unbiased).
#[test]
fn direct_in_the_furnace_is_one_bounce() {
    let d = cpu(2);
    let opts = RenderOptions {
        spp: Some(64),
        ..RenderOptions::default()
    };
    for (ne, nb) in [(1, 1), (1, 0), (0, 1), (3, 1), (1, 4)] {
        let f = render(
            d.as_ref(),
            &furnace(Vec3::ZERO, 1.0, 0.5, 1.0, direct(ne, nb)),
            &opts,
        )
        .unwrap();
        let m = image_mean(&f);
        assert!(
            (m - Vec3::splat(1.5)).abs().max_element() < 0.03,
            "emitter_samples {ne}, bsdf_samples {nb}: {m}"
        );
        assert_eq!(f.stats.features.integrator, "direct");
    }
    let bad = furnace(Vec3::ZERO, 1.0, 0.5, 1.0, direct(0, 0));
    assert!(render(d.as_ref(), &bad, &opts).is_err());
}

/// Direct illumination equals the path integrator limited to two segments (as Mitsuba's
/// direct equals path with max_depth 2 in expectation), with any sample counts; and it
/// differs from three segments (the test has teeth).
#[test]
fn direct_matches_path_of_depth_two() {
    let d = cpu(2);
    let opts = RenderOptions {
        spp: Some(256),
        want_variance: true,
        ..RenderOptions::default()
    };
    let mut scene = cornell(Vec3::ZERO);
    scene.integrator = path(Some(2), false);
    let reference = render(d.as_ref(), &scene, &opts).unwrap();
    for (ne, nb) in [(1, 1), (2, 3)] {
        scene.integrator = direct(ne, nb);
        let f = render(
            d.as_ref(),
            &scene,
            &RenderOptions {
                seed: Some(99),
                ..opts.clone()
            },
        )
        .unwrap();
        let outcome = validate::z_test(&estimate(&f), &estimate(&reference)).unwrap();
        assert!(outcome.passed, "({ne}, {nb}): {outcome}");
    }
    scene.integrator = path(Some(3), false);
    let deeper = render(d.as_ref(), &scene, &opts).unwrap();
    let outcome = validate::z_test(&estimate(&deeper), &estimate(&reference)).unwrap();
    assert!(!outcome.passed, "three segments passed as two: {outcome}");
}

/// Mitsuba's aov integrator: albedo, shading normal and depth of the first hit, as layers
/// named after the entries with Mitsuba's channel names; the main image repeats the first.
#[test]
fn aov_integrator_writes_albedo_normal_and_depth() {
    let mut scene = cornell(Vec3::ZERO);
    scene.integrator = Integrator::Aov(vec![
        Aov {
            name: "alb".into(),
            kind: AovKind::Albedo,
        },
        Aov {
            name: "nn".into(),
            kind: AovKind::ShadingNormal,
        },
        Aov {
            name: "dd".into(),
            kind: AovKind::Depth,
        },
    ]);
    let f = render(
        cpu(2).as_ref(),
        &scene,
        &RenderOptions {
            spp: Some(4),
            ..RenderOptions::default()
        },
    )
    .unwrap();
    let names: Vec<(&str, Vec<&str>)> = f
        .aovs
        .iter()
        .map(|a| {
            (
                a.name.as_str(),
                a.channels.iter().map(|c| c.as_str()).collect(),
            )
        })
        .collect();
    assert_eq!(
        names,
        [
            ("alb", vec!["R", "G", "B"]),
            ("nn", vec!["X", "Y", "Z"]),
            ("dd", vec!["T"])
        ]
    );
    // Pixel (8, 8) sees the back wall (z = 1, facing -z) from z = -3.4 near the axis.
    let c = 8 * 16 + 8;
    let albedo = &f.aovs[0].data[3 * c..3 * c + 3];
    assert!(albedo.iter().all(|v| (v - 0.7).abs() < 1e-5), "{albedo:?}");
    let n = &f.aovs[1].data[3 * c..3 * c + 3];
    assert!((n[2] + 1.0).abs() < 1e-4, "{n:?}");
    let t = f.aovs[2].data[c];
    assert!(t > 4.4 && t < 4.45, "depth {t}");
    assert_eq!(f.mean[c], [albedo[0], albedo[1], albedo[2]]);
    assert_eq!(f.stats.features.integrator, "aov");
    let exr = crate::output::exr_bytes(&f).unwrap();
    assert!(exr.windows(4).any(|w| w == b"dd.T"));
}
