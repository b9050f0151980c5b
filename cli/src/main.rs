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

mod args;
mod cancel;
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
#[command(name = "optik", version, after_help = EXIT_STATUS)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// The exit status scheme every command follows, shown under every help page.
const EXIT_STATUS: &str = "Exit status: 0 success; 1 the work failed (a compile error, a failed case, an input that cannot be used); 2 a usage error (a bad argument or option).";

#[derive(Subcommand)]
enum Command {
    /// Compiles a WGSL module and lists its programs (kind, name, line, device functions
    /// called), bindings and registers used, or prints each error as FILE:LINE:COLUMN with the
    /// source line; a module without programs is an error.
    Compile(compile::CompileArgs),
    /// Lists each backend and whether it can run here, what `--backend auto` picks and why,
    /// and the Vulkan devices and wgpu adapters found.
    Info,
    /// Casts rays (a float32 .npy of shape (N, 8)) against a mesh and writes hits to a .npz.
    Trace(trace::TraceArgs),
    /// Renders a Mitsuba 3 XML scene or an OBJ model with optik's path tracer to an EXR or PNG.
    Render(render::RenderArgs),
    /// Runs the conformance suite on the chosen backends and prints the case × backend table;
    /// each case is judged against the f64 oracle and its reference (built into this binary; a
    /// missing or unreadable one fails the case). `--list` shows the catalog, `--out DIR`
    /// writes EXRs and an HTML report, `bless` writes references where the oracle and every
    /// available backend agree.
    Conformance(conformance::ConformanceArgs),
    /// Measures backends, accuracy options, specialisation and scaling side by side on the
    /// test scenes, with Embree as a CPU peer (against the CPU backend on all threads and on
    /// one, taking turns with it in `--rounds` rounds), and prints the report.
    BenchReport(report::ReportArgs),
}

fn main() -> ExitCode {
    let cli = parse();
    cancel::install();
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

/// Parses the command line with [`EXIT_STATUS`] under every command's help, including
/// commands added later; a usage error exits with status 2.
fn parse() -> Cli {
    use clap::{CommandFactory, FromArgMatches};
    // A command with help text of its own below the options keeps it: where that text already
    // details the exit status, as it is; otherwise with the scheme after it.
    let command = Cli::command().mut_subcommands(|c| {
        let text = match c.get_after_help().map(|own| own.to_string()) {
            Some(own) if own.contains("Exit status:") => own,
            Some(own) => format!("{own}\n\n{EXIT_STATUS}"),
            None => EXIT_STATUS.to_string(),
        };
        c.after_help(text)
    });
    Cli::from_arg_matches(&command.get_matches()).unwrap_or_else(|e| e.exit())
}
