//! `optik info` names every backend with its availability, and the wgpu adapters found.

use std::process::Command;

/// `optik info`'s standard output.
fn info() -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_optik"))
        .arg("info")
        .output()
        .expect("run optik");
    assert!(out.status.success());
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The first line of `text` that `wanted` accepts.
fn line<'a>(text: &'a str, what: &str, wanted: impl Fn(&str) -> bool) -> &'a str {
    text.lines()
        .find(|l| wanted(l))
        .unwrap_or_else(|| panic!("no line for {what}:\n{text}"))
}

#[test]
fn lists_every_backend() {
    let text = info();
    for backend in ["cpu", "wgpu", "vulkan"] {
        let line = line(&text, backend, |l| l.trim_start().starts_with(backend));
        assert!(line.contains("available"), "{line}");
    }
    assert!(text.contains("wgpu adapters ("), "{text}");
}

#[test]
fn says_what_auto_picks_and_why() {
    let text = info();
    let line = line(&text, "auto", |l| l.trim_start().starts_with("auto"));
    let pick = optik::auto_choice();
    assert!(
        line.contains(&format!("picks {}: {}", pick.kind(), pick.reason)),
        "{line}"
    );
}

#[test]
fn says_whether_the_vulkan_drivers_triangles_passed_the_check() {
    if optik::open_backend(optik::BackendKind::Vulkan).is_err() {
        eprintln!("skipped: no Vulkan device here");
        return;
    }
    let text = info();
    let line = line(&text, "the driver's triangles", |l| {
        l.contains("TriangleTest::Driver")
    });
    assert!(
        line.contains(") passed: of ") || line.contains(") failed: of "),
        "{line}"
    );
    assert!(
        line.contains("rays through shared edges and vertices of closed meshes"),
        "{line}"
    );
    assert!(line.contains("met two triangles or more"), "{line}");
    // The decision follows the verdict.
    if line.contains(") passed: ") {
        assert!(
            line.contains("uses the driver's triangles where they can serve"),
            "{line}"
        );
        assert!(line.contains(" 0 leaked and 0 met"), "{line}");
    } else {
        assert!(
            line.contains("uses optik's triangle stage for every triangle"),
            "{line}"
        );
    }
}
