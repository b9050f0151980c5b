//! `optik info` names every backend with its availability, and the wgpu adapters found.

use std::process::Command;

#[test]
fn lists_every_backend() {
    let out = Command::new(env!("CARGO_BIN_EXE_optik"))
        .arg("info")
        .output()
        .expect("run optik");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for backend in ["cpu", "wgpu", "vulkan"] {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(backend))
            .unwrap_or_else(|| panic!("no line for {backend}:\n{text}"));
        assert!(line.contains("available"), "{line}");
    }
    assert!(text.contains("wgpu adapters ("), "{text}");
}

#[test]
fn says_what_auto_picks_and_why() {
    let out = Command::new(env!("CARGO_BIN_EXE_optik"))
        .arg("info")
        .output()
        .expect("run optik");
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("auto"))
        .unwrap_or_else(|| panic!("no line for auto:\n{text}"));
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
    let out = Command::new(env!("CARGO_BIN_EXE_optik"))
        .arg("info")
        .output()
        .expect("run optik");
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.contains("TriangleTest::Driver"))
        .unwrap_or_else(|| panic!("no line for the driver's triangles:\n{text}"));
    assert!(
        line.contains(") passed: 0 of ") || line.contains(") failed: "),
        "{line}"
    );
    assert!(line.contains("rays leaked through closed meshes"), "{line}");
}
