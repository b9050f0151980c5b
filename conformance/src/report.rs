//! Reports of a run: the text table, the JSON documents of README.md ("Rules"), and the HTML page
//! with PNG thumbnails of outputs, references and differences.

use crate::case::{Case, Rule};
use crate::exrio;
use crate::image::{ChannelKind, RecordImage};
use crate::runner::{CaseResult, Status};
use optik::BackendKind;
use serde_json::json;
use std::collections::BTreeMap;
use std::path::Path;

/// `0.12×` for an error ratio, `exact` for 0.
fn ratio_text(r: Option<f64>) -> String {
    match r {
        None => String::new(),
        Some(0.0) => "exact".into(),
        Some(r) => format!("{r:.2}× tol"),
    }
}

/// The default output: one row per case, one column per backend, then the reasons for
/// skips and the details of failures.
pub fn table(results: &[CaseResult], backends: &[BackendKind]) -> String {
    let mut rows: BTreeMap<(usize, String), BTreeMap<BackendKind, &CaseResult>> = BTreeMap::new();
    let order: Vec<String> = {
        let mut seen = Vec::new();
        for r in results {
            if !seen.contains(&r.name) {
                seen.push(r.name.clone());
            }
        }
        seen
    };
    for r in results {
        let i = order.iter().position(|n| *n == r.name).unwrap_or(0);
        rows.entry((i, r.name.clone()))
            .or_default()
            .insert(r.backend, r);
    }
    let name_w = order.iter().map(|n| n.len()).max().unwrap_or(4).max(4);
    let col_w = 18;
    let mut s = format!("{:name_w$}", "case");
    for b in backends {
        s.push_str(&format!("  {:col_w$}", b.name()));
    }
    s.push('\n');
    let mut skip_reasons: BTreeMap<(BackendKind, String), usize> = BTreeMap::new();
    let mut failures = Vec::new();
    for ((_, name), cells) in &rows {
        s.push_str(&format!("{name:name_w$}"));
        for b in backends {
            let cell = match cells.get(b) {
                None => "-".to_string(),
                Some(r) => match r.status {
                    Status::Pass => format!("pass {}", ratio_text(r.max_error)),
                    Status::Fail => {
                        failures.push(format!("{name} on {}: {}", b.name(), r.detail));
                        format!("FAIL {}", ratio_text(r.max_error.filter(|e| *e > 0.0)))
                    }
                    Status::Skip => {
                        *skip_reasons.entry((*b, r.detail.clone())).or_default() += 1;
                        "skip".to_string()
                    }
                },
            };
            s.push_str(&format!("  {:col_w$}", cell.trim_end()));
        }
        s.push('\n');
    }
    let (p, f, k) = counts(results);
    s.push_str(&format!("\n{p} passed, {f} failed, {k} skipped\n"));
    if !skip_reasons.is_empty() {
        s.push_str("\nskipped:\n");
        for ((b, reason), n) in &skip_reasons {
            s.push_str(&format!("  {} ({n} case(s)): {reason}\n", b.name()));
        }
    }
    if !failures.is_empty() {
        s.push_str("\nfailures:\n");
        for f in &failures {
            s.push_str(&format!("  {f}\n"));
        }
    }
    s
}

/// (passed, failed, skipped).
pub fn counts(results: &[CaseResult]) -> (usize, usize, usize) {
    let n = |s: Status| results.iter().filter(|r| r.status == s).count();
    (n(Status::Pass), n(Status::Fail), n(Status::Skip))
}

/// The `--json` document.
pub fn json(results: &[CaseResult]) -> serde_json::Value {
    let (p, f, k) = counts(results);
    json!({
        "cases": results.iter().map(|r| json!({
            "name": r.name,
            "group": r.group,
            "backend": r.backend.name(),
            "status": r.status.name(),
            "detail": r.detail,
            "max_error": r.max_error,
        })).collect::<Vec<_>>(),
        "passed": p,
        "failed": f,
        "skipped": k,
    })
}

/// The `--list --json` document.
pub fn list_json(cases: &[Case]) -> serde_json::Value {
    json!({
        "cases": cases.iter().map(|c| json!({
            "name": c.name,
            "group": c.group.name(),
            "records": c.record.channels.iter().map(|ch| ch.name.clone()).collect::<Vec<_>>(),
            "tolerance": c.tolerance_text(),
            "launches": c.launches.len(),
            "guards": c.guards.iter().map(|g| format!("{g:?}")).collect::<Vec<_>>(),
            "summary": c.summary,
        })).collect::<Vec<_>>()
    })
}

/// `--list` as text: one line per case.
pub fn list_text(cases: &[Case]) -> String {
    let w = cases.iter().map(|c| c.name.len()).max().unwrap_or(4);
    cases
        .iter()
        .map(|c| format!("{:w$}  {}\n", c.name, c.summary))
        .collect()
}

/// The oracle's view of a case: per launch, the ambiguous records with their reasons and
/// admissible records (at most 40 listed per launch).
pub fn explain(case: &Case) -> String {
    let mut s = format!("{}: {}\n", case.name, case.summary);
    match crate::runner::expectations(case) {
        Err(e) => s.push_str(&format!("  the oracle cannot evaluate it: {e}\n")),
        Ok(es) => {
            for (k, e) in es.iter().enumerate() {
                s.push_str(&format!(
                    "  launch {k}: {} records, {} ambiguous\n",
                    e.admissible.len(),
                    e.ambiguous_count()
                ));
                for (i, adm) in e
                    .admissible
                    .iter()
                    .enumerate()
                    .filter(|(_, a)| a.len() > 1)
                    .take(40)
                {
                    let fields = |r: &Vec<u32>| {
                        case.record
                            .channels
                            .iter()
                            .map(|c| match c.kind {
                                ChannelKind::Uint => {
                                    format!("{}={}", c.name, r.get(c.word).copied().unwrap_or(0))
                                }
                                ChannelKind::Float => format!(
                                    "{}={:e}",
                                    c.name,
                                    f32::from_bits(r.get(c.word).copied().unwrap_or(0))
                                ),
                            })
                            .collect::<Vec<_>>()
                            .join(" ")
                    };
                    s.push_str(&format!(
                        "    record {i} ({}): {}\n",
                        e.reasons[i].join(", "),
                        adm.iter().map(fields).collect::<Vec<_>>().join("  |  ")
                    ));
                }
            }
        }
    }
    s
}

/// The cases guarding each rule of DESIGN.md §4 and §5.
pub fn rules_text(cases: &[Case]) -> String {
    let mut s = String::new();
    for rule in Rule::ALL {
        let names: Vec<&str> = cases
            .iter()
            .filter(|c| c.guards.contains(&rule))
            .map(|c| c.name.as_str())
            .collect();
        s.push_str(&format!(
            "{}\n    {}\n",
            rule.text(),
            if names.is_empty() {
                "(none)".into()
            } else {
                names.join(", ")
            }
        ));
    }
    s
}

/// A colour per distinct record (hash of the integer channels), darkened for misses;
/// RGB(A) float images are shown as they are.
fn preview_rgb(img: &RecordImage) -> Vec<[u8; 3]> {
    let n = img.pixel_count();
    if let (Some(r), Some(g), Some(b)) = (img.channel("R"), img.channel("G"), img.channel("B")) {
        let q = |bits: u32| {
            let v = f32::from_bits(bits);
            (if v.is_finite() {
                v.clamp(0.0, 1.0)
            } else {
                1.0
            } * 255.0
                + 0.5) as u8
        };
        return (0..n)
            .map(|i| [q(r.values[i]), q(g.values[i]), q(b.values[i])])
            .collect();
    }
    let ints: Vec<_> = img
        .channels
        .iter()
        .filter(|c| c.kind == ChannelKind::Uint)
        .collect();
    let floats: Vec<_> = img
        .channels
        .iter()
        .filter(|c| c.kind == ChannelKind::Float)
        .collect();
    let range = |c: &crate::image::Channel| {
        c.values
            .iter()
            .map(|b| f32::from_bits(*b))
            .filter(|v| v.is_finite())
            .fold((f32::MAX, f32::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)))
    };
    let ranges: Vec<(f32, f32)> = floats.iter().map(|c| range(c)).collect();
    (0..n)
        .map(|i| {
            let miss = img.channel("hit").is_some_and(|c| c.values[i] == 0);
            let mut h: u64 = 0xcbf2_9ce4_8422_2325;
            for c in &ints {
                h = (h ^ c.values[i] as u64).wrapping_mul(0x100_0000_01b3);
            }
            let mut shade = 1.0f32;
            if let (Some(c), Some((lo, hi))) = (floats.first(), ranges.first()) {
                let v = f32::from_bits(c.values[i]);
                if v.is_finite() && hi > lo {
                    shade = 0.45 + 0.55 * (1.0 - (v - lo) / (hi - lo));
                }
            }
            if miss {
                return [24, 24, 32];
            }
            let base = if ints.is_empty() {
                [200u8, 200, 200]
            } else {
                [
                    (h >> 8) as u8 | 0x40,
                    (h >> 24) as u8 | 0x40,
                    (h >> 40) as u8 | 0x40,
                ]
            };
            base.map(|c| (c as f32 * shade) as u8)
        })
        .collect()
}

/// Writes a PNG thumbnail of `img` atomically (optik_io::output): upscaled (nearest, whole factors) towards 160 pixels, at most 256.
pub fn write_png(path: &Path, img: &RecordImage) -> Result<(), String> {
    let rgb = preview_rgb(img);
    let (w, h) = (img.width.max(1), img.height.max(1));
    let scale = (160.0 / w.max(h) as f64).clamp(1.0, 16.0).floor() as usize;
    let (mut tw, mut th) = (w * scale, h * scale);
    let shrink = (tw.max(th) as f64 / 256.0).max(1.0);
    tw = ((tw as f64 / shrink) as usize).max(1);
    th = ((th as f64 / shrink) as usize).max(1);
    let mut data = Vec::with_capacity(tw * th * 3);
    for y in 0..th {
        for x in 0..tw {
            let sx = ((x as f64 * shrink) as usize / scale).min(w - 1);
            let sy = ((y as f64 * shrink) as usize / scale).min(h - 1);
            data.extend_from_slice(&rgb[sy * w + sx]);
        }
    }
    optik_io::output::write_atomically(path, |w| {
        let mut enc = png::Encoder::new(w, tw as u32, th as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(&data)
            .map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
    .map_err(|e| e.to_string())
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Creates `dir` if needed and checks that files can be written in it: run before any case,
/// so an unwritable `--out` fails at once rather than after the whole suite.
pub fn prepare_out_dir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    optik_io::output::check_folder_writable(dir).map_err(|e| e.to_string())
}

/// Writes `DIR/<case>/<backend>.exr`, `reference.exr`, `expected.exr`, `diff-<backend>.exr`
/// (with `.launch<k>` before `.exr` for multi-launch cases), PNG thumbnails beside them, and
/// `DIR/index.html`.
pub fn write_out_dir(
    dir: &Path,
    results: &[CaseResult],
    backends: &[BackendKind],
) -> Result<(), String> {
    prepare_out_dir(dir)?;
    let mut names: Vec<&str> = Vec::new();
    for r in results {
        if !names.contains(&r.name.as_str()) {
            names.push(&r.name);
        }
    }
    let mut html = String::from(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>optik conformance</title>\n<style>\n\
         body{font-family:sans-serif;background:#111;color:#ddd;margin:16px}\n\
         table{border-collapse:collapse}td,th{border:1px solid #333;padding:4px;vertical-align:top;font-size:12px}\n\
         th{background:#222}.pass{color:#6c6}.fail{color:#f55;font-weight:bold}.skip{color:#999}\n\
         img{image-rendering:pixelated;border:1px solid #444;max-width:160px;max-height:160px}.detail{max-width:320px;font-size:11px;color:#aaa}\n\
         figure{display:inline-block;margin:2px;text-align:center}figcaption{font-size:10px;color:#888}\n\
         </style></head><body>\n<h1>optik conformance</h1>\n",
    );
    let (p, f, k) = counts(results);
    html.push_str(&format!(
        "<p>{p} passed, {f} failed, {k} skipped. Thumbnails: one colour per distinct record, darker for larger t, \
         near-black for misses. Differences: <span style=\"color:#f55\">red</span> failed, \
         <span style=\"color:#6c6\">green</span> within tolerance, <span style=\"color:#77f\">blue</span> another admissible answer of an ambiguous ray.</p>\n"
    ));
    html.push_str("<table><tr><th>case</th><th>expected (oracle)</th><th>reference</th>");
    for b in backends {
        html.push_str(&format!("<th>{}</th>", b.name()));
    }
    html.push_str("</tr>\n");
    for name in names {
        let case_dir = dir.join(name);
        std::fs::create_dir_all(&case_dir)
            .map_err(|e| format!("cannot create {}: {e}", case_dir.display()))?;
        let of_case: Vec<&CaseResult> = results.iter().filter(|r| r.name == name).collect();
        let Some(first) = of_case.first() else {
            continue;
        };
        let multi = first.launches.len() > 1;
        let suffix = |k: usize| {
            if multi {
                format!(".launch{k}")
            } else {
                String::new()
            }
        };
        let mut expected_cell = String::new();
        let mut reference_cell = String::new();
        for (k, l) in first.launches.iter().enumerate() {
            let stem = format!("expected{}", suffix(k));
            exrio::write(&case_dir.join(format!("{stem}.exr")), &l.expected)?;
            write_png(&case_dir.join(format!("{stem}.png")), &l.expected)?;
            expected_cell.push_str(&format!(
                "<figure><img src=\"{name}/{stem}.png\"><figcaption>{}</figcaption></figure>",
                escape(&l.stem)
            ));
            match &l.reference {
                Some(r) => {
                    let stem = format!("reference{}", suffix(k));
                    exrio::write(&case_dir.join(format!("{stem}.exr")), r)?;
                    write_png(&case_dir.join(format!("{stem}.png")), r)?;
                    reference_cell
                        .push_str(&format!("<figure><img src=\"{name}/{stem}.png\"></figure>"));
                }
                None => reference_cell.push_str("<span class=\"skip\">none</span> "),
            }
        }
        html.push_str(&format!("<tr><td><b>{}</b><br><span class=\"detail\">{}</span></td><td>{expected_cell}</td><td>{reference_cell}</td>", escape(name), escape(&first.group)));
        for b in backends {
            let Some(r) = of_case.iter().find(|r| r.backend == *b) else {
                html.push_str("<td></td>");
                continue;
            };
            let mut cell = format!(
                "<span class=\"{}\">{}</span> {}<br>",
                r.status.name(),
                if r.status == Status::Fail {
                    "FAIL"
                } else {
                    r.status.name()
                },
                ratio_text(r.max_error.filter(|e| *e > 0.0 || r.status == Status::Pass))
            );
            for (k, l) in r.launches.iter().enumerate() {
                if let Some(o) = &l.output {
                    let stem = format!("{}{}", b.name(), suffix(k));
                    exrio::write(&case_dir.join(format!("{stem}.exr")), o)?;
                    write_png(&case_dir.join(format!("{stem}.png")), o)?;
                    cell.push_str(&format!("<figure><img src=\"{name}/{stem}.png\"><figcaption>output</figcaption></figure>"));
                }
                if let Some(d) = &l.diff {
                    let stem = format!("diff-{}{}", b.name(), suffix(k));
                    exrio::write(&case_dir.join(format!("{stem}.exr")), d)?;
                    write_png(&case_dir.join(format!("{stem}.png")), d)?;
                    cell.push_str(&format!("<figure><img src=\"{name}/{stem}.png\"><figcaption>difference</figcaption></figure>"));
                }
            }
            cell.push_str(&format!(
                "<div class=\"detail\">{}</div>",
                escape(&r.detail)
            ));
            html.push_str(&format!("<td>{cell}</td>"));
        }
        html.push_str("</tr>\n");
    }
    html.push_str("</table></body></html>\n");
    optik_io::output::write_bytes(&dir.join("index.html"), html.as_bytes())
        .map_err(|e| e.to_string())
}
