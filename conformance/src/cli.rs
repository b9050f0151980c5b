//! The command line of the conformance suite (README.md, "Rules"), as a library for the `optik` CLI:
//! `optik conformance [--backend cpu|wgpu|vulkan|all] [--filter GLOB] [--json] [--list]
//! [--out DIR]` and `optik conformance bless`.

use crate::case::Case;
use crate::catalog;
use crate::compare;
use crate::exrio;
use crate::judge;
use crate::report;
use crate::runner::{self, Devices, References, Status};
use optik::BackendKind;
use std::path::PathBuf;

/// `optik conformance` options.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ConformanceArgs {
    /// Backends to run: cpu, wgpu, vulkan or all (comma-separated lists work too).
    #[arg(long, default_value = "all")]
    pub backend: String,
    /// Only cases whose name matches this glob (`*`, `?`; a bare group name means `group.*`;
    /// several patterns separated by commas).
    #[arg(long, value_name = "GLOB")]
    pub filter: Option<String>,
    /// Print one JSON document instead of the table.
    #[arg(long)]
    pub json: bool,
    /// List the catalog instead of running it.
    #[arg(long)]
    pub list: bool,
    /// List, for each rule of DESIGN.md §4–§5, the cases that guard it.
    #[arg(long)]
    pub rules: bool,
    /// Print the oracle's view of the selected cases: every ambiguous record, why, and what
    /// is admissible (no backend runs).
    #[arg(long)]
    pub explain: bool,
    /// Write outputs, references, differences and index.html here.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Read references from this folder instead of the ones built into the binary; with
    /// `bless`, write them here (default there: the source tree's conformance/references).
    #[arg(long, value_name = "DIR")]
    pub references: Option<PathBuf>,
    /// `bless`: write references where the oracle and every available backend agree.
    #[command(subcommand)]
    pub command: Option<ConformanceCommand>,
}

/// Subcommands of `optik conformance`.
#[derive(clap::Subcommand, Debug, Clone)]
pub enum ConformanceCommand {
    /// Write references for the selected cases where the oracle and every available backend
    /// agree within the case's tolerance; print the disagreements and write nothing else.
    Bless,
}

/// Writes `text` to stdout. When stdout is closed (`optik conformance --list | head`) the
/// process ends quietly instead of panicking, as the `optik` command's other output does.
fn out(text: &str) {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    if stdout
        .write_all(text.as_bytes())
        .and_then(|_| stdout.flush())
        .is_err()
    {
        std::process::exit(0);
    }
}

/// Parses `--backend`.
pub fn parse_backends(s: &str) -> Result<Vec<BackendKind>, String> {
    if s == "all" {
        return Ok(BackendKind::ALL.to_vec());
    }
    s.split(',')
        .map(|n| {
            BackendKind::from_name(n.trim())
                .ok_or_else(|| format!("unknown backend `{n}`: expected cpu, wgpu, vulkan or all"))
        })
        .collect()
}

/// The selected cases.
pub fn selected(args: &ConformanceArgs) -> Vec<Case> {
    catalog::all()
        .into_iter()
        .filter(|c| {
            args.filter
                .as_deref()
                .is_none_or(|f| runner::filter_matches(f, &c.name))
        })
        .collect()
}

/// Runs `optik conformance` with these arguments; returns the exit status (0: nothing failed).
pub fn run(args: &ConformanceArgs) -> i32 {
    if let Some(ConformanceCommand::Bless) = args.command {
        return bless(args);
    }
    let backends = match parse_backends(&args.backend) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("optik conformance: {e}");
            return 2;
        }
    };
    let cases = selected(args);
    if args.explain {
        for c in &cases {
            out(&report::explain(c));
        }
        return 0;
    }
    if args.list || args.rules {
        if args.rules {
            out(&report::rules_text(&cases));
        } else if args.json {
            out(&format!(
                "{}\n",
                serde_json::to_string_pretty(&report::list_json(&cases)).unwrap_or_default()
            ));
        } else {
            out(&report::list_text(&cases));
        }
        return 0;
    }
    if cases.is_empty() {
        eprintln!("optik conformance: no case matches the filter");
        return 2;
    }
    if let Some(dir) = &args.out
        && let Err(e) = report::prepare_out_dir(dir)
    {
        eprintln!("optik conformance: --out {e}");
        return 2;
    }
    let references = match &args.references {
        Some(dir) if !dir.is_dir() => {
            eprintln!(
                "optik conformance: --references {}: not a folder",
                dir.display()
            );
            return 2;
        }
        Some(dir) => References::Dir(dir.clone()),
        None => References::Embedded,
    };
    let devices = Devices::open(&backends);
    let quiet = args.json;
    // Progress on stderr, one line per case and backend (stdout holds the table or JSON).
    let total = cases.len() * backends.len();
    let mut done = 0;
    let mut last = std::time::Instant::now();
    let results = runner::run_all(&cases, &devices, Some(&references), |r| {
        done += 1;
        let secs = last.elapsed().as_secs_f64();
        last = std::time::Instant::now();
        let status = match r.status {
            Status::Fail => "FAIL",
            s => s.name(),
        };
        eprintln!(
            "[{done}/{total}] {} on {}: {status} ({secs:.1} s)",
            r.name, r.backend
        );
        if !quiet && r.status == Status::Fail {
            eprintln!("    {}", r.detail);
        }
    });
    if args.json {
        out(&format!(
            "{}\n",
            serde_json::to_string_pretty(&report::json(&results)).unwrap_or_default()
        ));
    } else {
        out(&report::table(&results, &backends));
    }
    if let Some(dir) = &args.out {
        if let Err(e) = report::write_out_dir(dir, &results, &backends) {
            eprintln!("optik conformance: {e}");
            return 2;
        }
        if !args.json {
            out(&format!("report: {}\n", dir.join("index.html").display()));
        }
    }
    let (_, failed, _) = report::counts(&results);
    i32::from(failed > 0)
}

/// `optik conformance bless`: for each selected case, runs the oracle and every available
/// backend; where all that run it agree (a backend that skips the case as unsupported has no
/// say; at least one must run it), writes the oracle's canonical records as the reference (and
/// a backend's own output as `<case>.<backend>.exr` where the case allows one). Returns 0
/// when every selected case was blessed.
pub fn bless(args: &ConformanceArgs) -> i32 {
    let backends = match parse_backends(&args.backend) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("optik conformance bless: {e}");
            return 2;
        }
    };
    let dir = match &args.references {
        Some(dir) => dir.clone(),
        // The embedded references cannot be rewritten; the source tree they came from can,
        // when this binary runs where it was built.
        None if runner::default_references_dir().is_dir() => runner::default_references_dir(),
        None => {
            eprintln!(
                "optik conformance bless: the source tree this binary was built from ({}) is not here; give --references DIR to say where to write",
                runner::default_references_dir().display()
            );
            return 2;
        }
    };
    let devices = Devices::open(&backends);
    let available = devices.available();
    if available.is_empty() {
        eprintln!(
            "optik conformance bless: no backend can run here, so nothing can agree with the oracle; nothing written"
        );
        for (k, d) in devices.iter() {
            if let Err(reason) = d {
                eprintln!("  {k}: {reason}");
            }
        }
        return 1;
    }
    let mut failures = 0;
    for case in selected(args) {
        let expected = runner::expectations(&case);
        let Ok(es) = &expected else {
            eprintln!(
                "{}: not blessed: the oracle cannot evaluate it: {}",
                case.name,
                expected.err().unwrap_or_default()
            );
            failures += 1;
            continue;
        };
        let mut agree = true;
        let mut ran = 0;
        let mut own: Vec<(BackendKind, Vec<crate::image::RecordImage>)> = Vec::new();
        for (kind, device) in devices.iter() {
            let Ok(device) = device else { continue };
            // Judged against the oracle only: the old reference is what is being replaced.
            let r = runner::run_on(&case, &expected, kind, device, None);
            match r.status {
                Status::Pass => {
                    ran += 1;
                    if case.backend_specific.iter().any(|(k, _)| *k == kind) {
                        own.push((
                            kind,
                            r.launches.iter().filter_map(|l| l.output.clone()).collect(),
                        ));
                    }
                }
                Status::Skip => {
                    // A backend that does not support what the case needs has no say in it.
                    eprintln!("{}: {kind} skips it ({})", case.name, r.detail);
                }
                Status::Fail => {
                    eprintln!(
                        "{}: not blessed: {kind} disagrees with the oracle: {}",
                        case.name, r.detail
                    );
                    agree = false;
                }
            }
        }
        if ran == 0 && agree {
            eprintln!("{}: not blessed: no backend ran it", case.name);
            agree = false;
        }
        if !agree {
            failures += 1;
            continue;
        }
        let mut written = Vec::new();
        for (k, e) in es.iter().enumerate() {
            let image = judge::canonical_image(&case, e);
            if let Err(g) = compare::nan_inf_gate(&image) {
                eprintln!("{}: not blessed: the reference would hold {g}", case.name);
                failures += 1;
                written.clear();
                break;
            }
            written.push((dir.join(format!("{}.exr", case.launch_stem(k))), image));
        }
        for (kind, images) in own {
            for (k, image) in images.into_iter().enumerate() {
                written.push((
                    dir.join(format!("{}.{}.exr", case.launch_stem(k), kind.name())),
                    image,
                ));
            }
        }
        for (path, image) in written {
            match exrio::write(&path, &image) {
                Ok(()) => out(&format!("blessed {}\n", path.display())),
                Err(e) => {
                    eprintln!("{e}");
                    failures += 1;
                }
            }
        }
    }
    i32::from(failures > 0)
}
