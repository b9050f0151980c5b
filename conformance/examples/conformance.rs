//! `optik conformance` without the `optik` binary: `cargo run -p optik-conformance --example
//! conformance -- --list`. The `optik` CLI embeds the same `ConformanceArgs`.

use clap::Parser;
use optik_conformance::cli::{ConformanceArgs, run};

/// optik conformance suite.
#[derive(Parser)]
#[command(name = "optik-conformance")]
struct Cli {
    #[command(flatten)]
    args: ConformanceArgs,
}

fn main() {
    std::process::exit(run(&Cli::parse().args));
}
