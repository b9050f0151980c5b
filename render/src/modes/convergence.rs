//! The convergence mode: what accuracy costs, in images. For each triangle test × box test the
//! device offers, one progressive render is read at doubling sample counts (1, 2, 4, …) and
//! each image's relative MSE against a reference is paired with the launch time spent so far.
//!
//! Relative MSE is the mean over pixels and channels of `(x − r)² / (r² + 0.01)` (the form
//! Rousselle et al. and the denoising literature use: bright pixels do not dominate, and the
//! 0.01 keeps black pixels finite).

use crate::error::RenderError;
use crate::plan::Effects;
use crate::render::{RenderOptions, Renderer};
use crate::scene::Scene;
use optik::{Accuracy, BackendKind, BoxTest, Device, TriangleTest};

/// ε in the relative MSE's denominator.
pub const REL_MSE_EPSILON: f64 = 0.01;

/// Every accuracy setting of optik's API: each triangle test with each box test. Devices
/// refuse the ones they cannot run (the driver's triangles outside Vulkan; on Vulkan, what the
/// driver does not offer).
pub fn accuracy_settings() -> Vec<Accuracy> {
    let mut v = Vec::new();
    for triangle in [
        TriangleTest::Watertight,
        TriangleTest::MollerTrumbore,
        TriangleTest::Driver,
    ] {
        for box_test in [BoxTest::Conservative, BoxTest::Plain] {
            v.push(Accuracy { triangle, box_test });
        }
    }
    v
}

/// `watertight+conservative`, `mt+plain`, …: the names `Accuracy::parse` and `optik trace
/// --accuracy` take.
pub fn accuracy_name(a: Accuracy) -> String {
    let t = match a.triangle {
        TriangleTest::Watertight => "watertight",
        TriangleTest::MollerTrumbore => "mt",
        TriangleTest::Driver => "driver",
    };
    let b = match a.box_test {
        BoxTest::Conservative => "conservative",
        BoxTest::Plain => "plain",
    };
    format!("{t}+{b}")
}

/// Relative MSE of `image` against `reference` (both linear RGB, same size).
pub fn rel_mse(image: &[[f32; 3]], reference: &[[f32; 3]]) -> f64 {
    let mut sum = 0.0f64;
    for (p, r) in image.iter().zip(reference) {
        for c in 0..3 {
            let (x, r) = (p[c] as f64, r[c] as f64);
            sum += (x - r) * (x - r) / (r * r + REL_MSE_EPSILON);
        }
    }
    sum / (3 * image.len().max(1)) as f64
}

/// One measurement: the image after `spp` samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConvergencePoint {
    /// Samples per pixel.
    pub spp: u32,
    /// Launch seconds spent to reach them.
    pub seconds: f64,
    /// Relative MSE against the reference.
    pub rel_mse: f64,
}

/// One accuracy setting's curve on one device.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergenceCurve {
    /// The device's backend.
    pub backend: BackendKind,
    /// The accuracy setting.
    pub accuracy: Accuracy,
    /// Points at doubling sample counts.
    pub points: Vec<ConvergencePoint>,
}

/// What one device measured: a curve per accuracy setting it runs, and the settings it
/// refused, with its reason.
#[derive(Clone, Debug, PartialEq)]
pub struct Convergence {
    /// The curves.
    pub curves: Vec<ConvergenceCurve>,
    /// Settings the device refused.
    pub refused: Vec<(Accuracy, String)>,
}

/// The sample counts of a convergence run up to `max_spp`: powers of two, then `max_spp`.
pub fn sample_counts(max_spp: u32) -> Vec<u32> {
    let mut v = Vec::new();
    let mut n = 1u32;
    while n < max_spp {
        v.push(n);
        n = n.saturating_mul(2);
    }
    v.push(max_spp.max(1));
    v
}

/// Measures `scene` on `device` for each of `accuracies` up to `max_spp` samples per pixel
/// against `reference` (linear RGB, the scene's film size, row 0 at the top). The device's
/// accuracy is restored afterwards.
pub fn convergence(
    device: &dyn Device,
    scene: &Scene,
    reference: &[[f32; 3]],
    max_spp: u32,
    seed: Option<u32>,
    accuracies: &[Accuracy],
) -> Result<Convergence, RenderError> {
    let pixels = scene.film.width as usize * scene.film.height as usize;
    if reference.len() != pixels {
        return Err(RenderError::Invalid(format!(
            "the reference has {} pixels; the scene's {}x{} film needs {pixels}",
            reference.len(),
            scene.film.width,
            scene.film.height
        )));
    }
    if max_spp == 0 {
        return Err(RenderError::Invalid(
            "0 samples per pixel: expected at least 1".into(),
        ));
    }
    let before = device.accuracy();
    let result = measure(device, scene, reference, max_spp, seed, accuracies);
    let restored = device.set_accuracy(before);
    let out = result?;
    restored.map_err(|source| RenderError::Device {
        during: "restoring the device's accuracy".into(),
        source,
    })?;
    Ok(out)
}

fn measure(
    device: &dyn Device,
    scene: &Scene,
    reference: &[[f32; 3]],
    max_spp: u32,
    seed: Option<u32>,
    accuracies: &[Accuracy],
) -> Result<Convergence, RenderError> {
    let options = RenderOptions {
        spp: Some(max_spp),
        seed,
        ..Default::default()
    };
    let mut out = Convergence {
        curves: Vec::new(),
        refused: Vec::new(),
    };
    for &accuracy in accuracies {
        if let Err(e) = device.set_accuracy(accuracy) {
            out.refused.push((accuracy, e.to_string()));
            continue;
        }
        // Accuracy applies to pipelines created after it is set: a new renderer per setting.
        let mut r = Renderer::new(device, scene, &options, Effects::Scene)?;
        // One untimed sample first: first launches pay for compilation and caches.
        r.accumulate(1, &mut |_| {})?;
        r.restart()?;
        let mut points = Vec::new();
        for spp in sample_counts(max_spp) {
            r.accumulate(spp - r.done(), &mut |_| {})?;
            let frame = r.frame()?;
            points.push(ConvergencePoint {
                spp,
                seconds: r.render_seconds(),
                rel_mse: rel_mse(&frame.mean, reference),
            });
        }
        out.curves.push(ConvergenceCurve {
            backend: device.backend(),
            accuracy,
            points,
        });
    }
    Ok(out)
}
