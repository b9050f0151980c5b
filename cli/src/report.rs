//! `optik bench-report`: the benchmark report of DESIGN.md §8, in one process.

use optik::BackendKind;
use optik_benches::report::{self, ReportOptions};
use std::path::PathBuf;

/// Arguments of `optik bench-report`.
#[derive(clap::Args)]
pub struct ReportArgs {
    /// Folder with the test scenes (stanford-bunny/, breakfast-room/); default $OPTIK_SCENES or ../shared/scenes.
    #[arg(long)]
    scenes: Option<PathBuf>,
    /// Backends to measure: cpu, wgpu, vulkan (default: all).
    #[arg(long, value_delimiter = ',')]
    backend: Vec<String>,
    /// 1920x1080 camera rays and 2M incoherent rays (default: 640x360 and 230 400).
    #[arg(long)]
    full: bool,
    /// Launches per measurement (the best is kept).
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// CPU threads; Embree gets the same (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Leave Embree out.
    #[arg(long)]
    no_embree: bool,
    /// Also write the figures as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// Runs the command; returns the exit status.
pub fn run(args: &ReportArgs) -> u8 {
    // Before the measurements: a bad --json path must not cost a whole report.
    if let Some(path) = &args.json
        && let Err(e) = optik_io::output::check_writable(path)
    {
        eprintln!("optik bench-report: --json {e}");
        return 2;
    }
    let mut backends = Vec::new();
    for name in &args.backend {
        match BackendKind::from_name(name) {
            Some(k) => backends.push(k),
            None => {
                eprintln!("--backend {name:?}: expected cpu, wgpu or vulkan");
                return 2;
            }
        }
    }
    if backends.is_empty() {
        backends = BackendKind::ALL.to_vec();
    }
    let scenes = args
        .scenes
        .clone()
        .or_else(|| std::env::var_os("OPTIK_SCENES").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("../shared/scenes"));
    let (width, height, incoherent) = if args.full {
        (1920, 1080, 2_000_000)
    } else {
        (640, 360, 230_400)
    };
    let opts = ReportOptions {
        scenes,
        backends,
        width,
        height,
        incoherent,
        repeat: args.repeat.max(1),
        threads: args.threads,
        embree: !args.no_embree,
        peer_script: report::default_peer_script(),
    };
    let figures = report::run(&opts);
    if let Some(path) = &args.json
        && let Err(e) = optik_io::output::write_bytes(
            path,
            serde_json::to_string_pretty(&figures)
                .unwrap_or_default()
                .as_bytes(),
        )
    {
        eprintln!("optik bench-report: {e}");
        return 1;
    }
    0
}
