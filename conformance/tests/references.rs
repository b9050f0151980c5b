//! The blessed references hold no NaN or infinity (checked with the suite's own reader and
//! gate always, and with OpenImageIO's `oiiotool --stats` where it is installed), and every
//! reference belongs to a case of the catalog. The checkers themselves are tested on a file
//! they must reject.

use optik_conformance::compare::nan_inf_gate;
use optik_conformance::exrio;
use optik_conformance::image::{Channel, ChannelKind, RecordImage};
use optik_conformance::{catalog, runner};
use std::path::Path;
use std::process::Command;

/// Whether OpenImageIO's `oiiotool` runs here (`scripts/setup` installs it; a machine
/// without it still gets the Rust check).
fn have_oiiotool() -> bool {
    let found = Command::new("oiiotool").arg("--version").output().is_ok();
    if !found {
        eprintln!("oiiotool is not installed (apt-get install openimageio-tools): Rust check only");
    }
    found
}

/// NaN and infinity counts that `oiiotool --stats` reports for `path` (its `Stats NanCount:`
/// and `Stats InfCount:` lines, summed over channels).
fn oiio_nan_inf(path: &Path) -> (u64, u64) {
    let out = Command::new("oiiotool")
        .arg("--stats")
        .arg(path)
        .output()
        .expect("run oiiotool");
    let text = String::from_utf8_lossy(&out.stdout);
    let sum = |key: &str| -> u64 {
        text.lines()
            .filter_map(|l| l.split_once(key).map(|(_, rest)| rest))
            .flat_map(|rest| {
                rest.split_whitespace()
                    .filter_map(|w| w.parse::<u64>().ok())
                    .collect::<Vec<_>>()
            })
            .sum()
    };
    assert!(
        text.contains("NanCount"),
        "oiiotool --stats printed no NanCount for {}:\n{text}",
        path.display()
    );
    (sum("NanCount:"), sum("InfCount:"))
}

#[test]
fn the_checker_rejects_nan_and_inf() {
    let dir = std::env::temp_dir().join(format!("optik-refs-{}", std::process::id()));
    let path = dir.join("bad.exr");
    let image = RecordImage {
        width: 4,
        height: 1,
        channels: vec![
            Channel {
                name: "t".into(),
                kind: ChannelKind::Float,
                values: [1.0f32, f32::NAN, f32::INFINITY, f32::NAN]
                    .iter()
                    .map(|v| v.to_bits())
                    .collect(),
            },
            Channel {
                name: "prim".into(),
                kind: ChannelKind::Uint,
                values: vec![1, 2, 3, 4],
            },
        ],
    };
    exrio::write(&path, &image).unwrap();
    assert!(nan_inf_gate(&exrio::read(&path).unwrap()).is_err());
    if have_oiiotool() {
        assert_eq!(oiio_nan_inf(&path), (2, 1));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn references_are_finite_and_belong_to_cases() {
    let dir = runner::default_references_dir();
    let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (the references are committed; `optik conformance bless` writes them)",
            dir.display()
        )
    });
    let oiio = have_oiiotool();
    let stems: Vec<String> = catalog::all()
        .iter()
        .flat_map(|c| {
            (0..c.launches.len())
                .map(|k| c.launch_stem(k))
                .collect::<Vec<_>>()
        })
        .collect();
    let mut problems = Vec::new();
    let mut checked = 0;
    for entry in entries.flatten() {
        let path = entry.path();
        if path.extension().and_then(|e| e.to_str()) != Some("exr") {
            continue;
        }
        let name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default()
            .to_string();
        let known = stems.iter().any(|s| {
            name == *s
                || ["cpu", "wgpu", "vulkan"]
                    .iter()
                    .any(|b| name == format!("{s}.{b}"))
        });
        if !known {
            problems.push(format!(
                "{}: no case of the catalog has this reference",
                path.display()
            ));
        }
        match exrio::read(&path) {
            Ok(image) => {
                if let Err(e) = nan_inf_gate(&image) {
                    problems.push(format!("{}: {e}", path.display()));
                }
            }
            Err(e) => problems.push(e),
        }
        let (nan, inf) = if oiio { oiio_nan_inf(&path) } else { (0, 0) };
        if nan + inf > 0 {
            problems.push(format!(
                "{}: oiiotool counts {nan} NaN and {inf} Inf",
                path.display()
            ));
        }
        checked += 1;
    }
    eprintln!("checked {checked} references");
    assert!(checked > 0, "{}: no reference EXR", dir.display());
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn every_launch_of_every_case_has_a_reference_and_the_binary_carries_them() {
    let embedded = runner::References::Embedded;
    let source = runner::References::Dir(runner::default_references_dir());
    // The build embeds exactly the committed files.
    assert_eq!(embedded.names(), source.names());
    let mut missing = Vec::new();
    for case in catalog::all() {
        for k in 0..case.launches.len() {
            let name = embedded.name_for(&case, k, None);
            match embedded.read(&name) {
                Ok(Some(_)) => {}
                Ok(None) => missing.push(format!("{name}: missing")),
                Err(e) => missing.push(e),
            }
        }
    }
    assert!(
        missing.is_empty(),
        "cases without a readable reference (a run fails them; `optik conformance bless` writes them):\n{}",
        missing.join("\n")
    );
}
