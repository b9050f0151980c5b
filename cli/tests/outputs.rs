//! Output paths are checked before the work: `conformance --out` and `bench-report --json` in
//! a folder that cannot be written fail at once (exit status 2), without running anything.

use std::process::Command;

fn optik(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_optik"))
        .args(args)
        .output()
        .expect("run optik")
}

#[test]
fn conformance_out_in_an_unwritable_folder_fails_at_once() {
    let dir = tempfile::tempdir().unwrap();
    // A folder below a plain file can never be created, whoever runs the test.
    let file = dir.path().join("plain-file");
    std::fs::write(&file, b"x").unwrap();
    let out = file.join("report");
    let o = optik(&[
        "conformance",
        "--backend",
        "cpu",
        "--out",
        &out.to_string_lossy(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--out"), "{e}");
    assert!(
        !e.contains("[1/"),
        "cases ran before the output was checked: {e}"
    );
}

#[test]
fn bench_report_json_in_a_missing_folder_fails_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("missing").join("figures.json");
    let o = optik(&[
        "bench-report",
        "--no-embree",
        "--json",
        &json.to_string_lossy(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("does not exist"), "{e}");
    assert!(
        o.stdout.is_empty(),
        "measured before the output was checked"
    );
}
