//! `optik compile FILE.wgsl`: the front end's verdict on a module.

use optik::frontend::{self, DeviceFunction};
use optik::{ProgramKind, ProgramSource};
use std::path::PathBuf;

/// Arguments of `optik compile`.
#[derive(clap::Args)]
pub struct CompileArgs {
    /// The WGSL file.
    file: PathBuf,
    /// Payload registers `RtPayload` holds (0..=32).
    #[arg(long, default_value_t = 32)]
    payload_values: u32,
}

/// Runs the command; returns the exit status.
pub fn run(args: &CompileArgs) -> u8 {
    let name = args.file.display().to_string();
    let text = match std::fs::read_to_string(&args.file) {
        Ok(t) => t,
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
    match frontend::compile(&ProgramSource::new(&name, text), args.payload_values) {
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
    let width = m.programs.iter().map(|p| p.name.len()).max().unwrap_or(0);
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
