//! `optik-fuzz TARGET`: runs a fuzz target and prints one JSON line of figures; exits 1
//! when an input panicked (the inputs are written to `--save`), 3 on a hang. With
//! `OPTIK_FUZZ_VERBOSE` set, panics print where they happened and targets say why they
//! rejected an input.

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Fuzzes one optik target with mutated seeds (stable Rust, no coverage feedback).
#[derive(Parser)]
#[command(name = "optik-fuzz")]
struct Args {
    /// The target: wgsl, exr, accel, obj, ply, npy or mitsuba (`--list` shows them).
    target: Option<String>,
    /// Lists the targets.
    #[arg(long)]
    list: bool,
    /// Inputs to run.
    #[arg(long, default_value_t = 1_000_000)]
    inputs: u64,
    /// Stop after this many seconds even if inputs remain.
    #[arg(long)]
    seconds: Option<f64>,
    /// The run's seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The first input index (to regenerate an input: `--start I --inputs 1 --save DIR`).
    #[arg(long, default_value_t = 0)]
    start: u64,
    /// Seconds one input may take before it counts as a hang.
    #[arg(long, default_value_t = 10.0)]
    per_input: f64,
    /// Folder for crashing inputs.
    #[arg(long, default_value = "target/fuzz-findings")]
    save: PathBuf,
    /// Write every input to `<save>/<target>-current.bin` before running it (finds the
    /// input of an abort).
    #[arg(long)]
    save_each: bool,
    /// Print progress every this many inputs.
    #[arg(long, default_value_t = 100_000)]
    progress: u64,
}

fn main() -> ExitCode {
    let args = Args::parse();
    if args.list {
        for t in optik_fuzz::targets::ALL {
            println!("{}", t.name);
        }
        return ExitCode::SUCCESS;
    }
    let Some(name) = args.target.as_deref() else {
        eprintln!("optik-fuzz: name a target (--list shows them)");
        return ExitCode::from(2);
    };
    let Some(target) = optik_fuzz::target(name) else {
        eprintln!("optik-fuzz: no target {name:?} (--list shows them)");
        return ExitCode::from(2);
    };
    let settings = optik_fuzz::Settings {
        seed: args.seed,
        start: args.start,
        inputs: args.inputs,
        time: args.seconds.map(Duration::from_secs_f64),
        per_input: Duration::from_secs_f64(args.per_input),
        save: Some(args.save),
        save_each: args.save_each,
        progress: args.progress,
    };
    // Panics are findings, reported once each below; the default hook's backtraces for
    // each would flood a long run. OPTIK_FUZZ_VERBOSE keeps the hook, so replaying one
    // input shows where it panicked.
    if std::env::var_os("OPTIK_FUZZ_VERBOSE").is_none() {
        std::panic::set_hook(Box::new(|_| {}));
    }
    let report = optik_fuzz::run(target, &settings);
    for c in &report.crashes {
        eprintln!("optik-fuzz: {name}: input {}: {}", c.index, c.message);
    }
    println!("{}", report.json(name));
    if report.crashes.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
