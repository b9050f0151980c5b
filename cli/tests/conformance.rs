//! `optik conformance`: the catalog as JSON, and a run of one case on the CPU backend.

use std::collections::BTreeSet;
use std::process::Command;

fn optik(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_optik"))
        .args(args)
        .output()
        .expect("run optik")
}

#[test]
fn list_json_has_at_least_85_cases_in_11_groups() {
    let out = optik(&["conformance", "--list", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let cases = doc["cases"].as_array().expect("a `cases` array");
    let mut groups = BTreeSet::new();
    let mut names = BTreeSet::new();
    for c in cases {
        let name = c["name"].as_str().expect("a name");
        let group = c["group"].as_str().expect("a group");
        assert!(
            name.starts_with(&format!("{group}.")),
            "{name} is not in its group {group}"
        );
        assert!(
            c["records"].as_array().is_some_and(|r| !r.is_empty()),
            "no recorded channels: {c}"
        );
        assert!(c["tolerance"].is_string(), "{c}");
        assert!(names.insert(name.to_string()), "{name} listed twice");
        groups.insert(group.to_string());
    }
    assert!(cases.len() >= 85, "{} cases", cases.len());
    assert!(groups.len() >= 11, "{} groups: {groups:?}", groups.len());
    let numerics = names.iter().filter(|n| n.starts_with("numerics.")).count();
    assert!(numerics >= 25, "{numerics} numerics cases");
}

#[test]
fn runs_a_case_on_the_cpu_and_reports_json() {
    let out = optik(&[
        "conformance",
        "--backend",
        "cpu",
        "--filter",
        "flags.facing_hitkind",
        "--json",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let cases = doc["cases"].as_array().expect("a `cases` array");
    assert_eq!(cases.len(), 1, "{doc}");
    assert_eq!(cases[0]["name"], "flags.facing_hitkind");
    assert_eq!(cases[0]["backend"], "cpu");
    assert_eq!(cases[0]["status"], "pass", "{doc}");
    assert_eq!(doc["passed"], 1);
    assert!(out.status.success());
}

#[test]
fn unknown_backend_is_a_clear_error() {
    let out = optik(&["conformance", "--backend", "metal"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("unknown backend `metal`"), "{err}");
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("optik-cli-conf-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("create a temporary folder");
    dir
}

/// The one case's JSON result for `args` (run on the CPU backend).
fn one_case(extra: &[&str]) -> (Option<i32>, serde_json::Value) {
    let mut args = vec![
        "conformance",
        "--backend",
        "cpu",
        "--filter",
        "flags.facing_hitkind",
        "--json",
    ];
    args.extend_from_slice(extra);
    let out = optik(&args);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    (out.status.code(), doc["cases"][0].clone())
}

#[test]
fn a_missing_reference_fails_the_case() {
    let empty = temp_dir("empty");
    let (code, case) = one_case(&["--references", empty.to_str().unwrap()]);
    assert_eq!(case["status"], "fail", "{case}");
    let detail = case["detail"].as_str().unwrap_or_default();
    assert!(
        detail.contains("no reference flags.facing_hitkind.exr in"),
        "{detail}"
    );
    assert_eq!(code, Some(1));
    std::fs::remove_dir_all(&empty).ok();
}

#[test]
fn a_corrupt_reference_fails_the_case() {
    let dir = temp_dir("corrupt");
    std::fs::write(dir.join("flags.facing_hitkind.exr"), b"not an EXR file").unwrap();
    let (code, case) = one_case(&["--references", dir.to_str().unwrap()]);
    assert_eq!(case["status"], "fail", "{case}");
    let detail = case["detail"].as_str().unwrap_or_default();
    assert!(
        detail.contains("unreadable reference: cannot read"),
        "{detail}"
    );
    assert_eq!(code, Some(1));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_copied_binary_keeps_its_references() {
    let dir = temp_dir("moved");
    let moved = dir.join("optik");
    std::fs::copy(env!("CARGO_BIN_EXE_optik"), &moved).expect("copy the binary");
    let out = Command::new(&moved)
        .args([
            "conformance",
            "--backend",
            "cpu",
            "--filter",
            "flags.facing_hitkind",
            "--json",
        ])
        .current_dir(&dir)
        .output()
        .expect("run the copied optik");
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(doc["cases"][0]["status"], "pass", "{doc}");
    assert!(
        doc["cases"][0]["detail"]
            .as_str()
            .is_some_and(|d| d.ends_with("match the oracle and the references")),
        "{doc}"
    );
    assert!(out.status.success());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn references_that_are_not_a_folder_are_a_usage_error() {
    let out = optik(&["conformance", "--references", "/nonexistent/refs"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--references /nonexistent/refs: not a folder"),
        "{err}"
    );
}
