//! The benchmark mode: what specialising the pipeline to the scene saves. The same scene is
//! rendered with the specialised pipeline and with one that compiles every effect
//! ([`Effects::All`]), in interleaved runs on one device, and the time ratio is reported with
//! a z-test showing that both pipelines render the same image.

use crate::error::RenderError;
use crate::plan::{Effects, PipelinePlan};
use crate::render::{Frame, RenderOptions, Renderer};
use crate::scene::Scene;
use crate::validate::{self, Estimate, ZTestOutcome};
use optik::{BackendKind, Device, FeatureSet};

/// How to benchmark.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BenchmarkOptions {
    /// Samples per pixel of each timed run (`None`: the scene's).
    pub spp: Option<u32>,
    /// Seed of the per-pixel random numbers (`None`: the scene's).
    pub seed: Option<u32>,
    /// Timed runs of each pipeline, after one untimed warm-up run of each.
    pub rounds: u32,
}

impl Default for BenchmarkOptions {
    fn default() -> Self {
        BenchmarkOptions {
            spp: None,
            seed: None,
            rounds: 5,
        }
    }
}

/// One pipeline's side of the benchmark.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchmarkSide {
    /// The pipeline it built.
    pub plan: PipelinePlan,
    /// The traversal features the device compiled.
    pub compiled: FeatureSet,
    /// Launch seconds of each timed run, in run order.
    pub seconds: Vec<f64>,
    /// The last run's image (with variance).
    pub frame: Frame,
}

/// What the benchmark measured on one device.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchmarkResult {
    /// The device's backend.
    pub backend: BackendKind,
    /// Samples per pixel of each run.
    pub spp: u32,
    /// The specialised pipeline.
    pub specialised: BenchmarkSide,
    /// The all-effects pipeline.
    pub all_effects: BenchmarkSide,
    /// The per-pixel z-test of the two images (they must agree in expectation).
    pub agreement: ZTestOutcome,
}

impl BenchmarkResult {
    /// The all-effects time over the specialised time of each round (runs are paired in
    /// order, so slow drift of the machine affects both sides of a pair alike).
    pub fn ratios(&self) -> Vec<f64> {
        self.all_effects
            .seconds
            .iter()
            .zip(&self.specialised.seconds)
            .map(|(a, s)| a / s.max(1e-12))
            .collect()
    }

    /// The median of [`BenchmarkResult::ratios`]: above 1 when specialising saves time.
    pub fn ratio(&self) -> f64 {
        median(&self.ratios())
    }

    /// One line: backend, ratio with its spread, median times and the z-test.
    pub fn summary(&self) -> String {
        let r = self.ratios();
        let (lo, hi) = r
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            });
        format!(
            "{}: all-effects / specialised time {:.3} (rounds {lo:.3} to {hi:.3}); median {:.4} s vs \
             {:.4} s at {} spp; images agree: {}",
            self.backend,
            self.ratio(),
            median(&self.all_effects.seconds),
            median(&self.specialised.seconds),
            self.spp,
            self.agreement
        )
    }
}

/// The median of `v` (0 when empty).
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Renders `scene` on `device` with both pipelines, `options.rounds` times each, interleaved
/// (specialised first in even rounds, all-effects first in odd ones), after a warm-up run of
/// each; compares the last images of both with the per-pixel z-test.
pub fn benchmark(
    device: &dyn Device,
    scene: &Scene,
    options: &BenchmarkOptions,
) -> Result<BenchmarkResult, RenderError> {
    if options.rounds == 0 {
        return Err(RenderError::Invalid(
            "0 benchmark rounds: expected at least 1".into(),
        ));
    }
    let render_options = RenderOptions {
        spp: options.spp,
        seed: options.seed,
        want_variance: true,
        ..Default::default()
    };
    let mut sides = [
        Renderer::new(device, scene, &render_options, Effects::Scene)?,
        Renderer::new(device, scene, &render_options, Effects::All)?,
    ];
    let spp = sides[0].spp();
    let mut seconds = [Vec::new(), Vec::new()];
    for round in 0..=options.rounds {
        let order = if round % 2 == 0 { [0, 1] } else { [1, 0] };
        for i in order {
            let r = &mut sides[i];
            r.restart()?;
            r.accumulate(spp, &mut |_| {})?;
            // Round 0 warms caches, JIT and driver state up; it is not timed.
            if round > 0 {
                seconds[i].push(r.render_seconds());
            }
        }
    }
    let [spec, all] = sides;
    let side = |r: &Renderer, seconds: Vec<f64>| -> Result<BenchmarkSide, RenderError> {
        Ok(BenchmarkSide {
            plan: r.plan().clone(),
            compiled: r.compiled_features()?,
            seconds,
            frame: r.frame()?,
        })
    };
    let [s0, s1] = seconds;
    let specialised = side(&spec, s0)?;
    let all_effects = side(&all, s1)?;
    let agreement = validate::z_test(
        &estimate(&specialised.frame)?,
        &estimate(&all_effects.frame)?,
    )
    .map_err(|e| RenderError::Invalid(format!("comparing the two images: {e}")))?;
    Ok(BenchmarkResult {
        backend: device.backend(),
        spp,
        specialised,
        all_effects,
        agreement,
    })
}

/// A frame as the z-test's estimate (mean, variance of one sample, sample count).
pub fn estimate(frame: &Frame) -> Result<Estimate, RenderError> {
    let variance = frame.variance.as_ref().ok_or_else(|| {
        RenderError::Invalid(format!(
            "a {} spp image has no variance: the z-test needs at least 2 samples per pixel",
            frame.spp
        ))
    })?;
    Estimate::new(
        frame.width,
        frame.height,
        frame.mean.iter().flatten().copied().collect(),
        variance.iter().flatten().copied().collect(),
        frame.spp,
    )
    .map_err(|e| RenderError::Invalid(e.to_string()))
}
