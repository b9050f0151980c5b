//! The image comparator: OpenImageIO `idiff`'s semantics plus the NaN/Inf gate idiff lacks.
//!
//! idiff's rules, as the installed `idiff` 2.4 applies them (checked against it by `tests/idiff_agreement.rs`):
//! per pixel, a channel whose absolute difference `f` is above `fail` **and** whose relative
//! difference `f / mean(|a|, |b|)` is above `fail_relative` makes the pixel fail (once, however
//! many channels do); likewise for `warn`. Then:
//!
//! 1. at most `allow_failures` failing pixels: PASS (this beats `hard_fail`);
//! 2. more failing pixels than `fail_percent` % of all, or a difference above `hard_fail`: FAIL;
//! 3. more warning pixels than `warn_percent` %, or a difference above `hard_warn`: WARNING;
//! 4. otherwise PASS.
//!
//! idiff reads every channel as float and lets a NaN pass against anything (its comparisons
//! are false for NaN). [`compare`] therefore runs [`nan_inf_gate`] first: a NaN or infinity
//! anywhere in the output fails, and NaN is never "equal" to NaN.

use crate::image::{ChannelKind, RecordImage};

/// idiff's thresholds (the command-line options of the same names).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdiffOptions {
    /// `-fail`: absolute difference above which a pixel fails.
    pub fail: f64,
    /// `-failrelative`: relative difference that must also be exceeded (0: none).
    pub fail_relative: f64,
    /// `-failpercent`: % of pixels allowed to fail.
    pub fail_percent: f64,
    /// `-hardfail`: any difference above this fails the image.
    pub hard_fail: f64,
    /// `-allowfailures`: this many failing pixels pass whatever their error.
    pub allow_failures: u64,
    /// `-warn`.
    pub warn: f64,
    /// `-warnrelative`.
    pub warn_relative: f64,
    /// `-warnpercent`.
    pub warn_percent: f64,
    /// `-hardwarn`.
    pub hard_warn: f64,
}

impl IdiffOptions {
    /// idiff's own defaults.
    pub const IDIFF_DEFAULT: IdiffOptions = IdiffOptions {
        fail: 1e-6,
        fail_relative: 0.0,
        fail_percent: 0.0,
        hard_fail: f64::INFINITY,
        allow_failures: 0,
        warn: 1e-6,
        warn_relative: 0.0,
        warn_percent: 0.0,
        hard_warn: f64::INFINITY,
    };

    /// Every value must be equal: `-fail 0 -warn 0`.
    pub const EXACT: IdiffOptions = IdiffOptions {
        fail: 0.0,
        warn: 0.0,
        ..IdiffOptions::IDIFF_DEFAULT
    };

    /// `I-det`, deterministic images: OpenImageIO's own test-suite thresholds
    /// (`-fail 0.004 -failpercent 0.02 -hardfail 0.012 -warn 0.008 -warnpercent 0.02`).
    pub const I_DET: IdiffOptions = IdiffOptions {
        fail: 0.004,
        fail_relative: 0.0,
        fail_percent: 0.02,
        hard_fail: 0.012,
        allow_failures: 0,
        warn: 0.008,
        warn_relative: 0.0,
        warn_percent: 0.02,
        hard_warn: f64::INFINITY,
    };

    /// Absolute tolerance `abs` for every value, no percentage of failures allowed.
    pub fn absolute(abs: f64) -> IdiffOptions {
        IdiffOptions {
            fail: abs,
            warn: abs,
            ..IdiffOptions::IDIFF_DEFAULT
        }
    }

    /// The idiff command-line arguments for these thresholds.
    pub fn idiff_args(&self) -> Vec<String> {
        let mut a = Vec::new();
        let mut push = |flag: &str, v: String| {
            a.push(flag.to_string());
            a.push(v);
        };
        push("-fail", fmt_g(self.fail));
        push("-failrelative", fmt_g(self.fail_relative));
        push("-failpercent", fmt_g(self.fail_percent));
        if self.hard_fail.is_finite() {
            push("-hardfail", fmt_g(self.hard_fail));
        }
        push("-allowfailures", self.allow_failures.to_string());
        push("-warn", fmt_g(self.warn));
        push("-warnrelative", fmt_g(self.warn_relative));
        push("-warnpercent", fmt_g(self.warn_percent));
        if self.hard_warn.is_finite() {
            push("-hardwarn", fmt_g(self.hard_warn));
        }
        a
    }

    /// A short description for tables: `fail 0.004, 0.02 %, hardfail 0.012`.
    pub fn describe(&self) -> String {
        let mut s = format!("fail {}", fmt_g(self.fail));
        if self.fail_relative > 0.0 {
            s.push_str(&format!(" and rel {}", fmt_g(self.fail_relative)));
        }
        if self.fail_percent > 0.0 {
            s.push_str(&format!(", {} %", fmt_g(self.fail_percent)));
        }
        if self.hard_fail.is_finite() {
            s.push_str(&format!(", hardfail {}", fmt_g(self.hard_fail)));
        }
        if self.allow_failures > 0 {
            s.push_str(&format!(", allow {}", self.allow_failures));
        }
        s
    }
}

/// A float in the shortest form that round-trips, for command lines and messages.
fn fmt_g(v: f64) -> String {
    format!("{v}")
}

/// idiff's verdicts (its exit codes 0, 1, 2, 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Exit 0.
    Pass,
    /// Exit 1.
    Warning,
    /// Exit 2.
    Failure,
    /// Exit 3: sizes or channel counts differ.
    LayoutMismatch,
}

impl Verdict {
    /// idiff's exit code for this verdict.
    pub fn exit_code(self) -> i32 {
        match self {
            Verdict::Pass => 0,
            Verdict::Warning => 1,
            Verdict::Failure => 2,
            Verdict::LayoutMismatch => 3,
        }
    }

    /// Whether the comparison passes (a warning passes, as in idiff's own test suites).
    pub fn passes(self) -> bool {
        matches!(self, Verdict::Pass | Verdict::Warning)
    }
}

/// What a comparison found.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// The verdict, after the NaN/Inf gate for [`compare`].
    pub verdict: Verdict,
    /// Pixels over the failure threshold.
    pub failing_pixels: u64,
    /// Pixels over the warning threshold.
    pub warning_pixels: u64,
    /// Largest finite absolute difference.
    pub max_error: f64,
    /// Where it was: x, y and channel name.
    pub max_at: Option<(usize, usize, String)>,
    /// Why the NaN/Inf gate failed the output, if it did.
    pub gate: Option<String>,
}

impl Comparison {
    /// A one-line account for reports.
    pub fn summary(&self) -> String {
        if let Some(g) = &self.gate {
            return g.clone();
        }
        let at = self
            .max_at
            .as_ref()
            .map(|(x, y, c)| format!(" at ({x}, {y}) `{c}`"))
            .unwrap_or_default();
        format!(
            "{:?}: {} pixel(s) over fail, {} over warn, max error {:e}{at}",
            self.verdict, self.failing_pixels, self.warning_pixels, self.max_error
        )
    }
}

/// A channel value as idiff sees it: floats as floats. OpenImageIO converts `UINT` to float
/// by normalising to [0, 1]; callers comparing integers use `-fail 0`, where only equality
/// matters, so the integer value itself is used here.
fn value(kind: ChannelKind, bits: u32) -> f64 {
    match kind {
        ChannelKind::Uint => bits as f64,
        ChannelKind::Float => f32::from_bits(bits) as f64,
    }
}

/// Whether one difference exceeds a threshold pair, as idiff decides it:
/// `!(f <= abs) && !(rel <= relative)` (written so, as in idiff, that a NaN difference exceeds).
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn exceeds(f: f64, rel: f64, abs: f64, relative: f64) -> bool {
    !(f <= abs) && !(rel <= relative)
}

/// Compares two images with idiff's semantics only (no NaN/Inf gate): the verdict the
/// installed `idiff` gives for finite images. Channels are matched by name.
pub fn idiff_compare(a: &RecordImage, b: &RecordImage, o: &IdiffOptions) -> Comparison {
    let mut c = Comparison {
        verdict: Verdict::Pass,
        failing_pixels: 0,
        warning_pixels: 0,
        max_error: 0.0,
        max_at: None,
        gate: None,
    };
    if !a.same_layout(b) {
        c.verdict = Verdict::LayoutMismatch;
        c.gate = Some(format!(
            "layouts differ: {} vs {}",
            a.layout_text(),
            b.layout_text()
        ));
        return c;
    }
    let pairs: Vec<_> = a
        .channels
        .iter()
        .filter_map(|ca| b.channel(&ca.name).map(|cb| (ca, cb)))
        .collect();
    let npels = a.pixel_count().max(1);
    for i in 0..a.pixel_count() {
        let (mut failed, mut warned) = (false, false);
        for (ca, cb) in &pairs {
            let (x, y) = (value(ca.kind, ca.values[i]), value(cb.kind, cb.values[i]));
            if !x.is_finite() || !y.is_finite() {
                // idiff lets NaN through (every comparison with it is false); the gate in
                // `compare` is what catches it.
                continue;
            }
            let f = (x - y).abs();
            let mean = 0.5 * (x.abs() + y.abs());
            let rel = if mean > 0.0 { f / mean } else { 0.0 };
            if f > c.max_error {
                c.max_error = f;
                let (px, py) = a.position(i);
                c.max_at = Some((px, py, ca.name.clone()));
            }
            if !warned && exceeds(f, rel, o.warn, o.warn_relative) {
                warned = true;
                c.warning_pixels += 1;
            }
            if !failed && exceeds(f, rel, o.fail, o.fail_relative) {
                failed = true;
                c.failing_pixels += 1;
            }
        }
    }
    let npels = npels as f64;
    c.verdict = if c.failing_pixels <= o.allow_failures {
        Verdict::Pass
    } else if c.failing_pixels as f64 > o.fail_percent / 100.0 * npels || c.max_error > o.hard_fail
    {
        Verdict::Failure
    } else if c.warning_pixels as f64 > o.warn_percent / 100.0 * npels || c.max_error > o.hard_warn
    {
        Verdict::Warning
    } else {
        Verdict::Pass
    };
    c
}

/// The NaN/Inf gate: `Err` naming the first NaN or infinite float value and how many there
/// are. References and outputs must hold finite values only.
pub fn nan_inf_gate(image: &RecordImage) -> Result<(), String> {
    let mut count = 0usize;
    let mut first = None;
    for ch in image
        .channels
        .iter()
        .filter(|c| c.kind == ChannelKind::Float)
    {
        for (i, bits) in ch.values.iter().enumerate() {
            let v = f32::from_bits(*bits);
            if !v.is_finite() {
                count += 1;
                if first.is_none() {
                    let (x, y) = image.position(i);
                    first = Some(format!("{v} in `{}` at ({x}, {y})", ch.name));
                }
            }
        }
    }
    match first {
        None => Ok(()),
        Some(f) => Err(format!(
            "NaN/Inf gate: {count} non-finite value(s), first {f}"
        )),
    }
}

/// Compares an output with a reference: the NaN/Inf gate on both, then idiff's semantics.
/// NaN against NaN is a failure here (idiff would pass it).
pub fn compare(output: &RecordImage, reference: &RecordImage, o: &IdiffOptions) -> Comparison {
    let mut c = idiff_compare(output, reference, o);
    if c.verdict == Verdict::LayoutMismatch {
        return c;
    }
    let gate = nan_inf_gate(output)
        .map_err(|e| format!("output: {e}"))
        .and_then(|_| nan_inf_gate(reference).map_err(|e| format!("reference: {e}")));
    if let Err(e) = gate {
        c.verdict = Verdict::Failure;
        c.gate = Some(e);
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Channel;

    fn gray(values: &[f32]) -> RecordImage {
        RecordImage {
            width: values.len(),
            height: 1,
            channels: vec![Channel {
                name: "Y".into(),
                kind: ChannelKind::Float,
                values: values.iter().map(|v| v.to_bits()).collect(),
            }],
        }
    }

    #[test]
    fn thresholds_follow_idiff() {
        let a = gray(&[0.5; 16]);
        let mut v = [0.5f32; 16];
        v[3] = 0.8;
        let b = gray(&v);
        // One pixel 0.3 off, -fail 0.5: no failing pixel, so PASS (not WARNING).
        let o = IdiffOptions {
            fail: 0.5,
            ..IdiffOptions::IDIFF_DEFAULT
        };
        assert_eq!(idiff_compare(&a, &b, &o).verdict, Verdict::Pass);
        // -fail 0.1 -failpercent 50: 1/16 fails but is allowed; it also warns: WARNING.
        let o = IdiffOptions {
            fail: 0.1,
            fail_percent: 50.0,
            ..IdiffOptions::IDIFF_DEFAULT
        };
        assert_eq!(idiff_compare(&a, &b, &o).verdict, Verdict::Warning);
        // ... unless -hardfail 0.2 catches the 0.3.
        let o = IdiffOptions {
            hard_fail: 0.2,
            ..o
        };
        assert_eq!(idiff_compare(&a, &b, &o).verdict, Verdict::Failure);
        // -allowfailures 1 beats -hardfail.
        let o = IdiffOptions {
            allow_failures: 1,
            ..o
        };
        assert_eq!(idiff_compare(&a, &b, &o).verdict, Verdict::Pass);
        // -failrelative is an AND: rel = 0.3 / 0.65 = 0.46.
        let o = IdiffOptions {
            fail: 0.1,
            fail_relative: 0.5,
            ..IdiffOptions::IDIFF_DEFAULT
        };
        assert_eq!(idiff_compare(&a, &b, &o).failing_pixels, 0);
        let o = IdiffOptions {
            fail: 0.1,
            fail_relative: 0.4,
            ..IdiffOptions::IDIFF_DEFAULT
        };
        assert_eq!(idiff_compare(&a, &b, &o).verdict, Verdict::Failure);
    }

    #[test]
    fn nan_passes_idiff_but_not_the_gate() {
        let a = gray(&[0.5, 0.5, 0.5, 0.5]);
        let b = gray(&[0.5, f32::NAN, 0.5, 0.5]);
        assert_eq!(
            idiff_compare(&b, &a, &IdiffOptions::IDIFF_DEFAULT).verdict,
            Verdict::Pass
        );
        let c = compare(&b, &a, &IdiffOptions::IDIFF_DEFAULT);
        assert_eq!(c.verdict, Verdict::Failure);
        assert!(c.gate.as_deref().unwrap().contains("NaN"), "{c:?}");
        // NaN against NaN is not equal.
        assert_eq!(
            compare(&b, &b, &IdiffOptions::IDIFF_DEFAULT).verdict,
            Verdict::Failure
        );
        assert!(nan_inf_gate(&gray(&[f32::INFINITY])).is_err());
        assert!(nan_inf_gate(&gray(&[f32::MAX, -0.0, 1e-45])).is_ok());
    }

    #[test]
    fn layouts_must_match() {
        let a = gray(&[0.5; 4]);
        let b = gray(&[0.5; 5]);
        assert_eq!(
            compare(&a, &b, &IdiffOptions::EXACT).verdict,
            Verdict::LayoutMismatch
        );
    }

    #[test]
    fn idiff_arguments() {
        let args = IdiffOptions::I_DET.idiff_args().join(" ");
        assert!(
            args.contains("-fail 0.004") && args.contains("-hardfail 0.012"),
            "{args}"
        );
        assert!(
            !IdiffOptions::EXACT
                .idiff_args()
                .join(" ")
                .contains("hardfail")
        );
    }
}
