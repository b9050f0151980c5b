//! The `optik` command.

/// Prints a line on stdout; when stdout is closed (`optik info | head`) the program ends quietly
/// instead of panicking.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if writeln!(std::io::stdout(), $($arg)*).is_err() {
            std::process::exit(0);
        }
    }};
}

mod compile;
mod conformance;
mod info;
mod render;
mod report;
mod trace;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// optik: an OptiX-7-style ray tracing API for Rust, on CPU, wgpu and Vulkan.
#[derive(Parser)]
#[command(name = "optik", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Compiles a WGSL module and lists its programs, or prints each error as FILE:LINE:COLUMN.
    Compile(compile::CompileArgs),
    /// Lists each backend, whether it can run here, and the devices and adapters found.
    Info,
    /// Casts rays (a float32 .npy of shape (N, 8)) against a mesh and writes hits to a .npz.
    Trace(trace::TraceArgs),
    /// Renders a Mitsuba 3 XML scene or an OBJ model with optik's path tracer to an EXR or PNG.
    Render(render::RenderArgs),
    /// Runs the conformance suite on the chosen backends and prints the case × backend table;
    /// `--list` shows the catalog, `--out DIR` writes EXRs and an HTML report, `bless` writes
    /// references where the oracle and every available backend agree.
    Conformance(conformance::ConformanceArgs),
    /// Measures backends, accuracy options, specialisation and scaling side by side (DESIGN.md §8).
    BenchReport(report::ReportArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let code = match cli.command {
        Command::Compile(args) => compile::run(&args),
        Command::Info => info::run(),
        Command::Trace(args) => trace::run(&args),
        Command::Render(args) => render::run(&args),
        Command::Conformance(args) => conformance::run(&args),
        Command::BenchReport(args) => report::run(&args),
    };
    ExitCode::from(code)
}
