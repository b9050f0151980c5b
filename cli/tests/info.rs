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
