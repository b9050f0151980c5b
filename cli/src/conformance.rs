//! `optik conformance`: the conformance suite of conformance/README.md (the catalog, the runner and
//! `bless`), embedded from `optik_conformance::cli`, which owns the options and the output.

pub use optik_conformance::cli::ConformanceArgs;

/// Runs the command; returns the exit status (0: nothing failed, 1: a case failed or was not
/// blessed, 2: bad arguments or an output folder that cannot be written).
pub fn run(args: &ConformanceArgs) -> u8 {
    // The library answers 0, 1 or 2; anything else would be a bug, reported as a failure.
    u8::try_from(optik_conformance::cli::run(args)).unwrap_or(1)
}
