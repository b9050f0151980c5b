//! Help and docs: `optik --help` names only commands that exist, every command's help ends
//! with the one exit status scheme, usage errors exit with 2, and the README has a section
//! per command.

use std::process::Command;

fn optik(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_optik"))
        .args(args)
        .output()
        .expect("run optik");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The subcommands `optik --help` lists, and the text above its usage line.
fn commands() -> (Vec<String>, String) {
    let (code, help, err) = optik(&["--help"]);
    assert_eq!(code, Some(0), "{err}");
    let about = help.split("Usage:").next().unwrap_or_default().to_string();
    let names = help
        .split("Commands:")
        .nth(1)
        .expect("a Commands section")
        .lines()
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|n| *n != "help")
        .map(str::to_string)
        .collect();
    (names, about)
}

const SCHEME: &str = "Exit status: 0 success; 1 the work failed";

#[test]
fn top_level_help_names_only_real_commands() {
    let (names, about) = commands();
    for expected in ["compile", "info", "trace", "conformance", "bench-report"] {
        assert!(names.iter().any(|n| n == expected), "{expected}: {names:?}");
    }
    // The old text named `render` and `report`, which did not exist.
    for word in about.split(|c: char| !c.is_alphanumeric() && c != '-') {
        if ["render", "report", "bench", "trace", "compile"].contains(&word) {
            assert!(
                names.iter().any(|n| n == word),
                "help names `{word}`: {about}"
            );
        }
    }
}

#[test]
fn every_command_has_help_with_the_exit_status_scheme() {
    let (names, _) = commands();
    let (_, top, _) = optik(&["--help"]);
    assert!(top.contains(SCHEME), "{top}");
    for name in &names {
        let (code, help, err) = optik(&[name, "--help"]);
        assert_eq!(code, Some(0), "{name}: {err}");
        assert!(help.contains(SCHEME), "{name}:\n{help}");
        // Usage errors are status 2 on every command.
        let (code, _, err) = optik(&[name, "--no-such-option"]);
        assert_eq!(code, Some(2), "{name}: {err}");
    }
    assert_eq!(optik(&["no-such-command"]).0, Some(2));
}

#[test]
fn the_readme_has_a_section_per_command() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md"))
        .expect("README.md at the repository root");
    let (names, _) = commands();
    for name in &names {
        let heading = format!("### `optik {name}`");
        assert!(readme.contains(&heading), "README.md lacks `{heading}`");
    }
    assert!(
        readme.contains("Exit status"),
        "README.md does not give the exit status scheme"
    );
}

#[test]
fn bench_report_refuses_zero_and_unbounded_counts() {
    for (option, value, says) in [
        ("--repeat", "0", "expected a count of at least 1"),
        ("--rounds", "0", "expected a count of at least 1"),
        ("--rounds", "two", "expected a count of at least 1"),
        ("--threads", "0", "expected a thread count from 1 to"),
        ("--threads", "5000", "expected a thread count from 1 to"),
        (
            "--scenes",
            "/nonexistent/scenes",
            "--scenes /nonexistent/scenes: not a folder",
        ),
    ] {
        let (code, _, err) = optik(&["bench-report", option, value]);
        assert_eq!(code, Some(2), "{option} {value}: {err}");
        assert!(err.contains(says), "{option} {value}: {err}");
    }
}
