//! Turning record buffers into images and judging them: against the oracle's admissible
//! records (every case), and against the blessed reference (when there is one).

use crate::case::{Case, Judgement, RecordLayout};
use crate::compare::{self, IdiffOptions};
use crate::image::{Channel, ChannelKind, RecordImage};
use crate::oracle::Expectation;

/// The record image of one launch from its record buffer words (channels in the case's order).
pub fn image_from_words(case: &Case, width: usize, height: usize, words: &[u32]) -> RecordImage {
    let n = width * height;
    let stride = match case.record.layout {
        RecordLayout::PerIndex { stride } => stride,
        RecordLayout::WholeBuffer { .. } => 1,
    };
    RecordImage {
        width,
        height,
        channels: case
            .record
            .channels
            .iter()
            .map(|c| Channel {
                name: c.name.clone(),
                kind: c.kind,
                values: (0..n)
                    .map(|i| words.get(i * stride + c.word).copied().unwrap_or(0))
                    .collect(),
            })
            .collect(),
    }
}

/// The oracle's canonical image of one launch (the first admissible record per pixel).
pub fn canonical_image(case: &Case, e: &Expectation) -> RecordImage {
    let n = e.width * e.height;
    RecordImage {
        width: e.width,
        height: e.height,
        channels: case
            .record
            .channels
            .iter()
            .map(|c| Channel {
                name: c.name.clone(),
                kind: c.kind,
                values: (0..n)
                    .map(|i| e.admissible[i][0].get(c.word).copied().unwrap_or(0))
                    .collect(),
            })
            .collect(),
    }
}

/// An `amb` channel: 1 where the oracle admits more than one record.
pub fn ambiguity_channel(e: &Expectation) -> Channel {
    Channel {
        name: "amb".into(),
        kind: ChannelKind::Uint,
        values: e.admissible.iter().map(|a| (a.len() > 1) as u32).collect(),
    }
}

/// The verdict on one launch.
#[derive(Clone, Debug)]
pub struct LaunchVerdict {
    /// Whether it passed.
    pub pass: bool,
    /// What went wrong, or a short account of what passed.
    pub detail: String,
    /// The worst error among matching values, as a fraction of its tolerance (0: exact).
    pub max_error: f64,
    /// Per pixel: 0 equal to the canonical record, 1 matched another admissible record,
    /// 2 within tolerance but not equal, 3 failed.
    pub pixel_state: Vec<u8>,
}

fn describe_pixel(case: &Case, out: &RecordImage, i: usize, expected: &[u32]) -> String {
    let (x, y) = out.position(i);
    let mut diffs = Vec::new();
    for (c, spec) in out.channels.iter().zip(&case.record.channels) {
        let got = c.values[i];
        let want = expected.get(spec.word).copied().unwrap_or(0);
        if !spec.tolerance.check(spec.kind, want, got).0 {
            let fmt = |v: u32| match spec.kind {
                ChannelKind::Uint => format!("{v}"),
                ChannelKind::Float => format!("{:e}", f32::from_bits(v)),
            };
            diffs.push(format!(
                "{} {} (expected {}, {})",
                spec.name,
                fmt(got),
                fmt(want),
                spec.tolerance.name()
            ));
        }
    }
    format!("({x}, {y}): {}", diffs.join(", "))
}

/// Judges one launch's output image against the oracle's expectation and, if given, the
/// reference image (checked only where the oracle is unambiguous).
pub fn judge(
    case: &Case,
    e: &Expectation,
    out: &RecordImage,
    reference: Option<&RecordImage>,
) -> LaunchVerdict {
    let n = out.pixel_count();
    let mut v = LaunchVerdict {
        pass: true,
        detail: String::new(),
        max_error: 0.0,
        pixel_state: vec![0; n],
    };
    if n != e.admissible.len() || out.width != e.width {
        v.pass = false;
        v.detail = format!(
            "output is {}×{}, the oracle expects {}×{}",
            out.width, out.height, e.width, e.height
        );
        return v;
    }
    if let Err(g) = compare::nan_inf_gate(out) {
        v.pass = false;
        v.detail = g;
        v.pixel_state.iter_mut().for_each(|s| *s = 3);
        return v;
    }
    if let Judgement::Image(options) = case.record.judgement {
        return judge_image(case, e, out, reference, &options);
    }
    let mut failures = Vec::new();
    let mut failed = 0usize;
    for i in 0..n {
        let mut best: Option<(usize, f64)> = None;
        for (k, adm) in e.admissible[i].iter().enumerate() {
            let mut worst: f64 = 0.0;
            let ok = out
                .channels
                .iter()
                .zip(&case.record.channels)
                .all(|(c, spec)| {
                    let (ok, ratio) = spec.tolerance.check(
                        spec.kind,
                        adm.get(spec.word).copied().unwrap_or(0),
                        c.values[i],
                    );
                    worst = worst.max(ratio);
                    ok
                });
            if ok && best.is_none_or(|(_, w)| worst < w) {
                best = Some((k, worst));
            }
        }
        match best {
            Some((k, worst)) => {
                v.max_error = v.max_error.max(worst);
                v.pixel_state[i] = if k > 0 {
                    1
                } else if worst > 0.0 {
                    2
                } else {
                    0
                };
            }
            None => {
                failed += 1;
                v.pixel_state[i] = 3;
                if failures.len() < 4 {
                    let amb = if e.admissible[i].len() > 1 {
                        format!(
                            " [ambiguous: {}; {} admissible]",
                            e.reasons[i].join(", "),
                            e.admissible[i].len()
                        )
                    } else {
                        String::new()
                    };
                    failures.push(format!(
                        "{}{amb}",
                        describe_pixel(case, out, i, &e.admissible[i][0])
                    ));
                }
            }
        }
    }
    if failed > 0 {
        v.pass = false;
        v.detail = format!(
            "{failed} of {n} records differ from the oracle: {}",
            failures.join("; ")
        );
        return v;
    }
    if let Some(problem) = reference.and_then(|r| against_reference(case, e, out, r)) {
        v.pass = false;
        v.detail = problem;
        return v;
    }
    let amb = e.ambiguous_count();
    v.detail = format!(
        "{n} records match{}",
        if amb > 0 {
            format!(" ({amb} ambiguous)")
        } else {
            String::new()
        }
    );
    v
}

/// Compares with the reference where the oracle admits one record; `Some(problem)` on a
/// difference beyond tolerance (a stale reference or a changed oracle).
fn against_reference(
    case: &Case,
    e: &Expectation,
    out: &RecordImage,
    r: &RecordImage,
) -> Option<String> {
    for spec in &case.record.channels {
        let (Some(oc), Some(rc)) = (out.channel(&spec.name), r.channel(&spec.name)) else {
            return Some(format!(
                "the reference lacks channel `{}`: re-bless it",
                spec.name
            ));
        };
        if rc.values.len() != oc.values.len() {
            return Some(format!(
                "the reference is {}×{}: re-bless it",
                r.width, r.height
            ));
        }
        for i in 0..oc.values.len() {
            if e.admissible[i].len() == 1
                && !spec
                    .tolerance
                    .check(spec.kind, rc.values[i], oc.values[i])
                    .0
            {
                let (x, y) = out.position(i);
                return Some(format!(
                    "matches the oracle but not the reference at ({x}, {y}) `{}`: the reference is stale, re-bless",
                    spec.name
                ));
            }
        }
    }
    None
}

/// Image judgement: per pixel, the admissible value closest to the output, then idiff's
/// thresholds (after the NaN/Inf gate, already passed).
fn judge_image(
    case: &Case,
    e: &Expectation,
    out: &RecordImage,
    reference: Option<&RecordImage>,
    o: &IdiffOptions,
) -> LaunchVerdict {
    let n = out.pixel_count();
    let mut closest = canonical_image(case, e);
    let mut pixel_state = vec![0u8; n];
    for (i, state) in pixel_state.iter_mut().enumerate() {
        if e.admissible[i].len() < 2 {
            continue;
        }
        let dist = |adm: &Vec<u32>| -> f64 {
            case.record
                .channels
                .iter()
                .zip(&out.channels)
                .map(|(spec, c)| {
                    let a = adm.get(spec.word).copied().unwrap_or(0);
                    (f32::from_bits(a) as f64 - f32::from_bits(c.values[i]) as f64).abs()
                })
                .fold(0.0, f64::max)
        };
        let (k, adm) = e.admissible[i]
            .iter()
            .enumerate()
            .min_by(|a, b| dist(a.1).total_cmp(&dist(b.1)))
            .expect("at least one admissible record");
        if k > 0 {
            *state = 1;
        }
        for (spec, c) in case.record.channels.iter().zip(closest.channels.iter_mut()) {
            c.values[i] = adm.get(spec.word).copied().unwrap_or(0);
        }
    }
    for (i, state) in pixel_state.iter_mut().enumerate() {
        let worst = closest
            .channels
            .iter()
            .zip(&out.channels)
            .map(|(e, g)| {
                (f32::from_bits(e.values[i]) as f64 - f32::from_bits(g.values[i]) as f64).abs()
            })
            .fold(0.0, f64::max);
        if worst > o.fail {
            *state = 3;
        } else if worst > 0.0 && *state == 0 {
            *state = 2;
        }
    }
    let c = compare::compare(out, &closest, o);
    let mut v = LaunchVerdict {
        pass: c.verdict.passes(),
        detail: c.summary(),
        max_error: c.max_error / o.fail.max(1e-30),
        pixel_state,
    };
    if let Some(r) = reference.filter(|_| v.pass) {
        // Where the oracle admits several records, any of them may stand in the reference
        // (it holds the canonical one): those pixels are judged against the oracle only.
        // Channels are matched by name: an EXR file keeps them in its own (sorted) order.
        let mut r = r.clone();
        if r.pixel_count() == n {
            for rc in r.channels.iter_mut() {
                let Some(oc) = out.channels.iter().find(|c| c.name == rc.name) else {
                    continue;
                };
                for (i, adm) in e.admissible.iter().enumerate().take(n) {
                    if adm.len() >= 2 {
                        rc.values[i] = oc.values[i];
                    }
                }
            }
        }
        let cr = compare::compare(out, &r, o);
        if !cr.verdict.passes() {
            v.pass = false;
            v.detail = format!(
                "matches the oracle but not the reference ({}): re-bless",
                cr.summary()
            );
        }
    }
    v
}

/// A difference image for reports: R = failed, G = within tolerance but not equal (scaled by
/// how close to the tolerance), B = matched another admissible record, A = 1.
pub fn difference_image(v: &LaunchVerdict, width: usize, height: usize) -> RecordImage {
    let mut channels: Vec<Channel> = ["R", "G", "B", "A"]
        .iter()
        .map(|n| Channel {
            name: n.to_string(),
            kind: ChannelKind::Float,
            values: vec![0; width * height],
        })
        .collect();
    for (i, s) in v.pixel_state.iter().enumerate() {
        let rgb = match s {
            3 => [1.0f32, 0.0, 0.0],
            2 => [0.0, 0.6, 0.0],
            1 => [0.0, 0.0, 0.8],
            _ => [0.0, 0.0, 0.0],
        };
        for c in 0..3 {
            channels[c].values[i] = rgb[c].to_bits();
        }
        channels[3].values[i] = 1.0f32.to_bits();
    }
    RecordImage {
        width,
        height,
        channels,
    }
}
