//! A short run of every fuzz target (a few seconds each) and the replay of every input in
//! `fuzz/regressions/<target>/` (inputs that once crashed).

use std::time::Duration;

/// Seconds per target in `cargo test`; `scripts/fuzz` runs the long campaign.
const SHORT_RUN: Duration = Duration::from_secs(3);

fn short_run(name: &str) {
    let target = optik_fuzz::target(name).unwrap_or_else(|| panic!("no target {name}"));
    let report = optik_fuzz::run(
        target,
        &optik_fuzz::Settings {
            seed: 0x5eed,
            inputs: 200_000,
            time: Some(SHORT_RUN),
            per_input: Duration::from_secs(20),
            ..Default::default()
        },
    );
    assert!(report.inputs > 0, "{name}: no input ran");
    assert!(
        report.crashes.is_empty(),
        "{name}: {} inputs crashed; first, input {}: {}",
        report.crashes.len(),
        report.crashes[0].index,
        report.crashes[0].message
    );
    assert!(
        report.accepted > 0,
        "{name}: no input got through every stage"
    );
}

#[test]
fn wgsl_front_end_jit_and_spirv_short_run() {
    short_run("wgsl");
}

#[test]
fn exr_reader_short_run() {
    short_run("exr");
}

#[test]
fn accel_build_inputs_short_run() {
    short_run("accel");
}

#[test]
fn obj_reader_short_run() {
    short_run("obj");
}

#[test]
fn ply_reader_short_run() {
    short_run("ply");
}

#[test]
fn npy_reader_short_run() {
    short_run("npy");
}

#[test]
fn mitsuba_reader_short_run() {
    short_run("mitsuba");
}

#[test]
fn regressions_replay_without_crashing() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("regressions");
    let mut replayed = 0;
    for target in optik_fuzz::targets::ALL {
        let Ok(dir) = std::fs::read_dir(root.join(target.name)) else {
            continue;
        };
        for entry in dir.flatten() {
            let bytes = std::fs::read(entry.path()).unwrap();
            let outcome = std::panic::catch_unwind(|| (target.run)(&bytes));
            assert!(
                matches!(
                    outcome,
                    Ok(optik_fuzz::Outcome::Accepted | optik_fuzz::Outcome::Rejected)
                ),
                "{}: {:?}",
                entry.path().display(),
                outcome.map_err(|_| "panic")
            );
            replayed += 1;
        }
    }
    eprintln!("replayed {replayed} regression inputs");
}
