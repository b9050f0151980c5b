//! `optik compile` end to end: listings of valid modules, and errors at the user's
//! `FILE:LINE:COLUMN`.

use std::process::Command;

fn optik(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_optik"))
        .args(args)
        .output()
        .expect("run optik");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A module written for one test; its folder is removed when the test drops it.
struct TempModule {
    _dir: tempfile::TempDir,
    path: std::path::PathBuf,
}

impl std::ops::Deref for TempModule {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.path
    }
}

fn write_temp(name: &str, text: &str) -> TempModule {
    let dir = tempfile::Builder::new()
        .prefix("optik-cli-test-")
        .tempdir()
        .unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    TempModule { _dir: dir, path }
}

#[test]
fn lists_programs_of_a_valid_module() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/wgsl/first_triangle.wgsl"
    );
    let (code, out, err) = optik(&["compile", path]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains(": 3 programs"), "{out}");
    let raygen = out
        .lines()
        .find(|l| l.contains("raygen__camera"))
        .expect(&out);
    assert!(raygen.trim_start().starts_with("raygen"), "{raygen}");
    assert!(
        raygen.contains("rt_launch_index") && raygen.contains("rt_trace"),
        "{raygen}"
    );
    let ch = out
        .lines()
        .find(|l| l.contains("closesthit__shade"))
        .expect(&out);
    assert!(
        ch.contains("closest-hit")
            && ch.contains("rt_set_payload")
            && ch.contains("rt_triangle_barycentrics"),
        "{ch}"
    );
    assert!(
        out.lines()
            .any(|l| l.contains("miss") && l.contains("miss__background")),
        "{out}"
    );
}

#[test]
fn type_error_points_at_line_and_column() {
    let path = write_temp(
        "type_error.wgsl",
        "fn raygen__a() {\n    let x: f32 = 1.0;\n    let y: u32 = x;\n}\n",
    );
    let (code, _, err) = optik(&["compile", path.to_str().unwrap()]);
    assert_eq!(code, 1);
    let first = err.lines().next().unwrap_or("");
    let prefix = format!("{}:3:", path.display());
    assert!(first.starts_with(&prefix), "{err}");
    assert!(
        err.contains("    let y: u32 = x;"),
        "the source line is shown: {err}"
    );
}

#[test]
fn set_payload_in_raygen_points_at_the_call() {
    let path = write_temp(
        "payload.wgsl",
        "fn raygen__main() {\n  var p: RtPayload;\n  rt_set_payload(0u, 1u);\n}\n",
    );
    let (code, _, err) = optik(&["compile", path.to_str().unwrap()]);
    assert_eq!(code, 1);
    let expected = format!(
        "{}:3:3: `rt_set_payload` cannot be used in a raygen program (`raygen__main`)",
        path.display()
    );
    assert!(err.starts_with(&expected), "{err}");
}

#[test]
fn unreadable_file_is_a_clear_error() {
    let (code, _, err) = optik(&["compile", "/nonexistent/x.wgsl"]);
    assert_eq!(code, 2);
    assert!(err.contains("/nonexistent/x.wgsl: cannot read"), "{err}");
}

#[test]
fn a_program_name_longer_than_65535_characters_is_listed() {
    let long = format!("raygen__{}", "a".repeat(70_000));
    let path = write_temp("long_name.wgsl", &format!("fn {long}() {{ }}\n"));
    let (code, out, err) = optik(&["compile", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains(&long), "the name is listed in full");
    assert!(
        out.contains(": 1 programs"),
        "{}",
        &out[..200.min(out.len())]
    );
}

#[test]
fn an_empty_module_says_it_found_no_programs() {
    let path = write_temp(
        "empty.wgsl",
        "// nothing here\nfn helper() -> f32 { return 1.0; }\n",
    );
    let (code, out, err) = optik(&["compile", path.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}");
    assert!(
        err.contains("empty.wgsl: no programs found") && err.contains("`raygen__`"),
        "{err}"
    );
}

#[test]
fn byte_order_mark_and_invalid_utf8() {
    let bom = write_temp("bom.wgsl", "\u{FEFF}fn raygen__a() { }\n");
    let (code, out, err) = optik(&["compile", bom.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("raygen__a"), "{out}");

    let dir = bom.parent().unwrap();
    let latin1 = dir.join("latin1.wgsl");
    std::fs::write(&latin1, b"fn raygen__a() { }\n// caf\xE9\n").unwrap();
    let (code, _, err) = optik(&["compile", latin1.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        err.starts_with(&format!(
            "{}:2:7: the file is not UTF-8: byte offset 25",
            latin1.display()
        )),
        "{err}"
    );
}

#[test]
fn errors_never_point_into_the_prelude() {
    for (name, text, line_col) in [
        (
            "unclosed.wgsl",
            "fn raygen__a() {\n    let x = 1.0;\n",
            ":1:16: this `{` is never closed",
        ),
        (
            "f32.wgsl",
            "fn f32() { }\nfn raygen__a() { }\n",
            ":1:4: a function named `f32`",
        ),
        (
            "trace.wgsl",
            "fn raygen__a() { }\nfn rt_trace() { }\n",
            ":2:4: `rt_trace` is a name of optik's device API",
        ),
    ] {
        let path = write_temp(name, text);
        let (code, _, err) = optik(&["compile", path.to_str().unwrap()]);
        assert_eq!(code, 1, "{err}");
        assert!(!err.contains("prelude>"), "{err}");
        assert!(
            err.starts_with(&format!("{}{line_col}", path.display())),
            "{err}"
        );
        assert_eq!(
            err.lines().filter(|l| l.contains(".wgsl:")).count(),
            1,
            "one error: {err}"
        );
    }
}
