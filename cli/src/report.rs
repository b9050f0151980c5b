//! `optik bench-report`: the benchmark report of DESIGN.md §8, in one process.

use optik::BackendKind;
use optik_benches::report::{self, ReportOptions};
use std::path::PathBuf;

/// Arguments of `optik bench-report`.
#[derive(clap::Args)]
pub struct ReportArgs {
    /// Folder with the test scenes (stanford-bunny/, breakfast-room/); default $OPTIK_SCENES or
    /// ../shared/scenes. Without them a generated sphere is measured.
    #[arg(long, value_name = "DIR")]
    scenes: Option<PathBuf>,
    /// Backends to measure, comma-separated: cpu, wgpu, vulkan (default: all).
    #[arg(long, value_delimiter = ',')]
    backend: Vec<String>,
    /// 1920x1080 camera rays and 2M incoherent rays (default: 640x360 and 230 400).
    #[arg(long)]
    full: bool,
    /// Launches per measurement, at least 1 (the best is kept).
    #[arg(long, default_value_t = 3, value_parser = crate::args::repeat)]
    repeat: usize,
    /// CPU backend threads, 1 to 1024; Embree gets the same (default: all cores). Only the
    /// CPU backend and Embree use it.
    #[arg(long, value_parser = crate::args::threads)]
    threads: Option<usize>,
    /// Rounds, at least 1, in which the CPU backend (all threads, then one) and Embree take
    /// turns on each scene; the table gives median throughputs and the median (range) of the
    /// rounds' optik / Embree ratios, which a shared machine's changing load moves less than
    /// one run of each side. Without Embree or the CPU backend, each is measured once.
    #[arg(long, default_value_t = 1, value_parser = crate::args::rounds)]
    rounds: usize,
    /// Leave Embree out.
    #[arg(long)]
    no_embree: bool,
    /// The Python that runs the Embree peer (it must import `embreex`).
    #[arg(long, value_name = "PYTHON", default_value = "python3")]
    python: String,
    /// Also trace a scene of 10 485 760 triangles, flat and instanced, with 2^24 incoherent
    /// rays (minutes and several GiB of memory).
    #[arg(long)]
    scale: bool,
    /// Also write the figures as JSON here.
    #[arg(long, value_name = "FILE")]
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
    if let Some(dir) = args.scenes.as_ref().filter(|d| !d.is_dir()) {
        eprintln!("--scenes {}: not a folder", dir.display());
        return 2;
    }
    if let Some(n) = args.threads
        && args.no_embree
        && !backends.contains(&BackendKind::Cpu)
    {
        eprintln!(
            "warning: --threads {n} is ignored: only the CPU backend and Embree use threads, and neither is measured"
        );
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
        repeat: args.repeat,
        threads: args.threads,
        embree: !args.no_embree,
        rounds: args.rounds,
        peer_script: report::default_peer_script(),
        python: args.python.clone(),
        scale: args.scale,
    };
    if let Some(why) = opts.rounds_ignored_because().filter(|_| opts.rounds > 1) {
        eprintln!(
            "warning: --rounds {} is ignored: rounds interleave the CPU backend with Embree, and {why}",
            opts.rounds
        );
    }
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
