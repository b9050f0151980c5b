//! `optik compile FILE.wgsl`: the front end's verdict on a module.

use optik::ProgramKind;
use optik::frontend::{self, DeviceFunction};
use std::path::PathBuf;

/// Arguments of `optik compile`.
#[derive(clap::Args)]
pub struct CompileArgs {
    /// The WGSL file (UTF-8; a byte order mark is fine).
    file: PathBuf,
    /// Payload registers the prelude's `RtPayload` holds (0..=32).
    #[arg(long, default_value_t = 32)]
    payload_values: u32,
}

/// The widest program-name column of a listing: longer names overflow it rather than
/// pad every line (and a width past 65 535 would make Rust's formatter panic).
const NAME_COLUMN_MAX: usize = 48;

/// Runs the command; returns the exit status (0: it compiles and holds programs, 1: it does
/// not, 2: a bad argument or an unreadable file).
pub fn run(args: &CompileArgs) -> u8 {
    let name = args.file.display().to_string();
    let bytes = match std::fs::read(&args.file) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{name}: cannot read: {e}");
            return 2;
        }
    };
    if args.payload_values > 32 {
        eprintln!(
            "--payload-values is {}; at most 32 payload registers exist",
            args.payload_values
        );
        return 2;
    }
    let compiled = frontend::source_from_bytes(&name, &bytes)
        .and_then(|source| frontend::compile(&source, args.payload_values));
    match compiled {
        Ok(module) if module.programs.is_empty() => {
            eprintln!(
                "{name}: no programs found: a program is a function without parameters or result whose name starts with {}",
                ProgramKind::ALL
                    .iter()
                    .map(|k| format!("`{}`", k.prefix()))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            1
        }
        Ok(module) => {
            print_module(&module);
            0
        }
        Err(e) => {
            if e.diagnostics().is_empty() {
                eprintln!("{name}: {e}");
            }
            for d in e.diagnostics() {
                eprintln!("{d}");
            }
            1
        }
    }
}

fn print_module(m: &frontend::CompiledModule) {
    outln!("{}: {} programs", m.file_name, m.programs.len());
    let width = m
        .programs
        .iter()
        .map(|p| p.name.len())
        .max()
        .unwrap_or(0)
        .min(NAME_COLUMN_MAX);
    for kind in ProgramKind::ALL {
        for p in frontend::programs_of_kind(m, kind) {
            let calls: Vec<&str> = p
                .device_functions
                .iter()
                .copied()
                .map(DeviceFunction::name)
                .collect();
            outln!(
                "  {:<22} {:<width$}  line {:>4}  calls: {}",
                kind.name(),
                p.name,
                p.line,
                if calls.is_empty() {
                    "-".to_string()
                } else {
                    calls.join(", ")
                },
            );
        }
    }
    if !m.bindings.is_empty() {
        outln!("bindings:");
        for b in &m.bindings {
            outln!("  @binding({}) {}: {:?}", b.binding, b.name, b.kind);
        }
    }
    outln!("payload registers used: {}", m.payload_values_used);
    outln!("attribute registers used: {}", m.attribute_values_used);
}
