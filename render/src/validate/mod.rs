//! Statistical comparison of two Monte Carlo renders, as Mitsuba 3's render tests do it.
//!
//! Each render is an [`Estimate`]: per pixel channel the mean of `n` samples and the
//! per-sample variance. [`z_test`] runs a Welch z-test on every pixel channel,
//! `z = |m1 - m2| / sqrt(v1/n1 + v2/n2)`, `p = 2 (1 - Φ(z))`, with the Šidák-corrected level
//! `α = 1 - (1 - 0.01)^(1 / pixel_count)`, and passes when at least 99.75 % of the pixel
//! channels have `p > α` (Mitsuba's `test_renders.py` rule). Welch's form rather than
//! Mitsuba's reference-only variance lets optik's estimator be noisier than Mitsuba's (other
//! sampling, no identical random numbers) while still requiring the same expected value.
//!
//! One guard: the tested render's per-sample variance `v1` is taken as at least the
//! reference's `v2`. A render of few samples (lavapipe runs 16) underestimates the variance of
//! heavy-tailed pixels (a rare path to the light that its samples missed), which inflates `z`
//! where nothing is wrong; the reference's variance, from thousands of samples, bounds it.
//! Mitsuba's own test uses only the reference's variance for the same reason. The guard can
//! only lower `z`, and only where optik would be less noisy than Mitsuba.
//!
//! [`files`] reads references (`<scene>_mean.exr`, `<scene>_var.exr`, `<scene>.json`) and writes
//! the failure artefacts (both means, the error mask, the p-values).

pub mod files;

/// Mitsuba's significance level for a whole image, before the Šidák correction.
pub const SIGNIFICANCE: f64 = 0.01;

/// Mitsuba's share of pixel channels that must pass.
pub const PASS_SHARE: f64 = 0.9975;

/// Per-sample variances below this are raised to it (Mitsuba's `max(ref_var, 1e-4)`): pixels
/// that every sample sees alike (background, a directly seen constant emitter) would otherwise
/// divide a float rounding difference by zero.
pub const VARIANCE_FLOOR: f64 = 1e-4;

/// A Monte Carlo estimate of an RGB image: per pixel channel the sample mean and the
/// per-sample variance, from `samples` samples per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 3` means, RGB interleaved, row 0 at the top.
    pub mean: Vec<f32>,
    /// `width * height * 3` per-sample variances (`E[x²] - E[x]²`), laid out as `mean`.
    pub variance: Vec<f32>,
    /// Samples per pixel behind each mean.
    pub samples: u32,
}

impl Estimate {
    /// An estimate from means and per-sample variances, checked for matching sizes.
    pub fn new(
        width: u32,
        height: u32,
        mean: Vec<f32>,
        variance: Vec<f32>,
        samples: u32,
    ) -> Result<Estimate, ValidateError> {
        let expected = width as usize * height as usize * 3;
        if width == 0 || height == 0 {
            return Err(ValidateError(format!(
                "an estimate needs at least one pixel, this one is {width}×{height}"
            )));
        }
        if mean.len() != expected || variance.len() != expected {
            return Err(ValidateError(format!(
                "a {width}×{height} RGB estimate needs {expected} means and variances, \
                 got {} means and {} variances",
                mean.len(),
                variance.len()
            )));
        }
        if samples == 0 {
            return Err(ValidateError(
                "an estimate needs at least one sample per pixel".into(),
            ));
        }
        Ok(Estimate {
            width,
            height,
            mean,
            variance,
            samples,
        })
    }

    /// An estimate from the first and second moments (means of `x` and of `x²`), the form
    /// Mitsuba's `moment` integrator writes; the variance is `m2 - m1²`, clamped at 0 against
    /// rounding.
    pub fn from_moments(
        width: u32,
        height: u32,
        m1: Vec<f32>,
        m2: &[f32],
        samples: u32,
    ) -> Result<Estimate, ValidateError> {
        if m2.len() != m1.len() {
            return Err(ValidateError(format!(
                "first and second moments differ in length: {} and {}",
                m1.len(),
                m2.len()
            )));
        }
        let variance = m1
            .iter()
            .zip(m2)
            .map(|(a, b)| (b - a * a).max(0.0))
            .collect();
        Estimate::new(width, height, m1, variance, samples)
    }

    /// Pixels in the image.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// Why a comparison could not be made (not a failed test: see [`ZTestOutcome::passed`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ValidateError(pub String);

impl std::fmt::Display for ValidateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ValidateError {}

/// The result of [`z_test`].
#[derive(Clone, Debug, PartialEq)]
pub struct ZTestOutcome {
    /// Whether the share of passing pixel channels reached [`PASS_SHARE`].
    pub passed: bool,
    /// The Šidák-corrected per-channel level `α`.
    pub alpha: f64,
    /// Share of pixel channels with `p > α`.
    pub pass_share: f64,
    /// Pixel channels with `p <= α`.
    pub failing: usize,
    /// Per pixel channel p-values, laid out as [`Estimate::mean`].
    pub p_values: Vec<f64>,
    /// The smallest p-value and the pixel (x, y) and channel (0 = R) where it occurs.
    pub worst: (f64, u32, u32, usize),
}

impl std::fmt::Display for ZTestOutcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (p, x, y, c) = self.worst;
        write!(
            f,
            "{}: {:.3} % of pixel channels pass (need {:.2} %), {} fail at α = {:.3e}; \
             smallest p = {:.3e} at pixel ({x}, {y}) channel {}",
            if self.passed { "pass" } else { "FAIL" },
            100.0 * self.pass_share,
            100.0 * PASS_SHARE,
            self.failing,
            self.alpha,
            p,
            ["R", "G", "B"][c]
        )
    }
}

/// The two-sided p-value of a standard normal statistic: `2 (1 - Φ(|z|)) = erfc(|z| / √2)`,
/// computed with `erfc` so that tiny p-values (the Šidák level is ~1e-6) keep their precision.
pub fn two_sided_p(z: f64) -> f64 {
    libm::erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// The Šidák-corrected level for `pixel_count` independent per-pixel tests at overall level
/// `significance`.
pub fn sidak_alpha(significance: f64, pixel_count: usize) -> f64 {
    // 1 - (1 - s)^(1/n) loses every digit to cancellation for large n; -expm1(ln1p(-s)/n) keeps them.
    -((-significance).ln_1p() / pixel_count as f64).exp_m1()
}

/// Welch's per-pixel z-test of the render `a` against the reference `b` with Mitsuba's Šidák
/// correction and 99.75 % rule (and the variance guard of the module documentation). Errors
/// only when the images differ in size; a mismatch of values is a failed outcome.
pub fn z_test(a: &Estimate, b: &Estimate) -> Result<ZTestOutcome, ValidateError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(ValidateError(format!(
            "cannot compare a {}×{} image with a {}×{} one",
            a.width, a.height, b.width, b.height
        )));
    }
    let pixels = a.pixel_count();
    let alpha = sidak_alpha(SIGNIFICANCE, pixels);
    let (na, nb) = (f64::from(a.samples), f64::from(b.samples));
    let mut worst = (f64::INFINITY, 0, 0, 0);
    let mut failing = 0;
    let p_values: Vec<f64> = (0..pixels * 3)
        .map(|i| {
            let (ma, mb) = (f64::from(a.mean[i]), f64::from(b.mean[i]));
            let vb = f64::from(b.variance[i]).max(VARIANCE_FLOOR);
            let va = f64::from(a.variance[i]).max(vb);
            // A NaN or infinite mean is a broken render: give it p = 0 so that it counts as a failure.
            let p = if ma.is_finite() && mb.is_finite() {
                two_sided_p((ma - mb).abs() / (va / na + vb / nb).sqrt())
            } else {
                0.0
            };
            if p <= alpha {
                failing += 1;
            }
            if p < worst.0 {
                let pixel = (i / 3) as u32;
                worst = (p, pixel % a.width, pixel / a.width, i % 3);
            }
            p
        })
        .collect();
    let pass_share = 1.0 - failing as f64 / (pixels * 3) as f64;
    Ok(ZTestOutcome {
        passed: pass_share >= PASS_SHARE,
        alpha,
        pass_share,
        failing,
        p_values,
        worst,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (SplitMix64) so the tests need no random crate.
    struct SplitMix(u64);

    impl SplitMix {
        fn next_f64(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Renders a synthetic "image": pixel channel i has expected value `truth(i)` and each sample
    /// is that value times an exponential variate (mean 1), like a path tracer's noisy, positive
    /// estimates.
    fn estimate(seed: u64, size: u32, samples: u32, truth: impl Fn(usize) -> f64) -> Estimate {
        let mut rng = SplitMix(seed);
        let count = (size * size * 3) as usize;
        let (mut m1, mut m2) = (vec![0.0f32; count], vec![0.0f32; count]);
        for i in 0..count {
            let (mut s1, mut s2) = (0.0, 0.0);
            for _ in 0..samples {
                let x = truth(i) * -(1.0 - rng.next_f64()).ln();
                s1 += x;
                s2 += x * x;
            }
            m1[i] = (s1 / f64::from(samples)) as f32;
            m2[i] = (s2 / f64::from(samples)) as f32;
        }
        Estimate::from_moments(size, size, m1, &m2, samples).unwrap()
    }

    fn scene(i: usize) -> f64 {
        0.2 + 0.6 * ((i / 3) % 7) as f64 / 7.0 + 0.1 * (i % 3) as f64
    }

    #[test]
    fn p_values_match_the_normal_distribution() {
        assert!((two_sided_p(0.0) - 1.0).abs() < 1e-15);
        assert!((two_sided_p(1.959_963_984_540_054) - 0.05).abs() < 1e-12);
        assert!((two_sided_p(-2.575_829_303_548_901) - 0.01).abs() < 1e-12);
        // Far in the tail, where 1 - Φ(z) computed directly would be 0.
        assert!((two_sided_p(10.0) / 1.523_970_604_832_105e-23 - 1.0).abs() < 1e-9);
    }

    #[test]
    fn sidak_level_matches_its_definition() {
        let a = sidak_alpha(0.01, 48 * 48);
        assert!(
            (a - (1.0 - 0.99f64.powf(1.0 / 2304.0))).abs() < 1e-15,
            "{a}"
        );
        assert!((sidak_alpha(0.01, 1) - 0.01).abs() < 1e-15);
    }

    #[test]
    fn two_estimates_of_the_same_image_pass() {
        for seed in 0..4 {
            let a = estimate(seed, 32, 64, scene);
            let b = estimate(1000 + seed, 32, 512, scene);
            let outcome = z_test(&a, &b).unwrap();
            assert!(outcome.passed, "seed {seed}: {outcome}");
        }
    }

    #[test]
    fn a_biased_estimate_fails() {
        let a = estimate(1, 32, 1024, scene);
        let b = estimate(2, 32, 4096, |i| scene(i) * 1.1);
        let outcome = z_test(&a, &b).unwrap();
        assert!(!outcome.passed, "{outcome}");
    }

    #[test]
    fn a_five_percent_change_fails_at_high_sample_counts() {
        // The teeth test's premise: with enough samples, a 5 % albedo change is no longer noise.
        let a = estimate(3, 32, 4096, scene);
        let b = estimate(4, 32, 4096, |i| scene(i) * 1.05);
        let outcome = z_test(&a, &b).unwrap();
        assert!(!outcome.passed, "{outcome}");
    }

    #[test]
    fn a_few_broken_pixels_within_the_quarter_percent_pass_and_more_fail() {
        let a = estimate(5, 32, 256, scene);
        let mut b = estimate(6, 32, 256, scene);
        // 0.25 % of 3072 channels is 7.68: 7 wildly wrong channels still pass, 9 do not.
        for i in 0..7 {
            b.mean[i * 101] = 100.0;
        }
        let outcome = z_test(&a, &b).unwrap();
        assert!(outcome.passed, "{outcome}");
        b.mean[900] = f32::NAN;
        b.mean[1000] = 100.0;
        let outcome = z_test(&a, &b).unwrap();
        assert!(!outcome.passed, "{outcome}");
        assert!(outcome.failing >= 9, "{outcome}");
    }

    #[test]
    fn a_render_that_missed_rare_samples_is_judged_by_the_reference_variance() {
        // 16 samples of a pixel whose radiance is 0 except with probability 1/64 (then 64):
        // most such renders see only zeros and report mean 0, variance 0.
        let reference = Estimate::new(1, 1, vec![1.0; 3], vec![63.0; 3], 100_000).unwrap();
        let unlucky = Estimate::new(1, 1, vec![0.0; 3], vec![0.0; 3], 16).unwrap();
        let outcome = z_test(&unlucky, &reference).unwrap();
        assert!(outcome.passed, "{outcome}");
        // A clearly wrong mean still fails: 16 samples of variance 63 give a standard error of 2.
        let wrong = Estimate::new(1, 1, vec![12.0; 3], vec![0.0; 3], 16).unwrap();
        let outcome = z_test(&wrong, &reference).unwrap();
        assert!(!outcome.passed, "{outcome}");
    }

    #[test]
    fn mismatched_inputs_are_errors_naming_the_sizes() {
        let a = estimate(7, 4, 4, scene);
        let b = estimate(8, 8, 4, scene);
        let e = z_test(&a, &b).unwrap_err();
        assert!(e.0.contains("4×4") && e.0.contains("8×8"), "{e}");
        let e = Estimate::new(2, 2, vec![0.0; 12], vec![0.0; 11], 1).unwrap_err();
        assert!(e.0.contains("12 means") || e.0.contains("needs 12"), "{e}");
        let e = Estimate::new(1, 1, vec![0.0; 3], vec![0.0; 3], 0).unwrap_err();
        assert!(e.0.contains("at least one sample"), "{e}");
    }
}
