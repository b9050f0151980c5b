//! `bench-cpu`: optik's CPU backend against Embree, in one run.
//!
//! For the Stanford bunny and the Breakfast Room, camera and incoherent rays, one thread and
//! all threads, it times `optik trace`'s launch (a raygen reads rays, the closest-hit writes
//! the record: the public API) and Embree through `benches/embree/peer.py` (embreex, robust
//! mode, `rtcIntersect1` loops) on the same rays, and prints Mrays/s, the ratios, the build
//! time ratio and how many rays the two disagree on (different triangle, or hit against
//! miss). Both sides run robust: optik's default accuracy (watertight triangles,
//! conservative boxes) and Embree's robust flag. Rays start at `tmin = 0`, since embreex
//! cannot set tnear.
//!
//! ```text
//! cargo run --release -p optik-benches --bin bench-cpu -- [--repeat K] [--threads N]
//!     [--rounds R] [--python PYTHON] [--no-embree] [--save-rays DIR]
//! ```
//!
//! `--rounds R` interleaves the two sides: each ray set is timed in R rounds, each round
//! optik (all threads, then one) and then Embree, and the table gives each side's median
//! throughput, the median of the rounds' ratios and their range. A shared or throttled
//! machine moves both sides' absolute figures by tens of percent from one minute to the
//! next; a ratio taken within one round compares them under the same conditions, which one
//! run of each side cannot.
//!
//! A third table splits each one-thread row: optik's walk alone (`optik_benches::walk`: the
//! same structure and rays handed straight to the traversal, without the launch) against
//! Embree's one thread, and the launch path (the one-thread launch's time less the walk
//! alone's, a ray: the launch loop, the compiled programs, the trace entry and the closest
//! hit around the walk). Its rows also check that the walk alone finds what the launch finds.
//! The walk alone runs on the calling thread and the one-thread launch on the device's worker:
//! on a machine with more cores than that, pin the run (`taskset -c N bench-cpu --threads 1`)
//! so that both run on one core, or the table compares two cores' conditions.
//!
//! `--save-rays DIR` also writes each ray set as `DIR/<scene>-<rays>.npy` (making `DIR` if it
//! is missing), the input of `optik trace --rays`, e.g. to count instructions with
//! `valgrind --tool=callgrind`.
//!
//! Scenes come from `$OPTIK_SCENES` (default `../shared/scenes` next to the repository
//! root); a missing scene is skipped with a message. Without embreex (or with `--no-embree`)
//! only optik's figures are printed.

use optik::raycast::{RAY_FLOATS, RayCaster};
use optik::{BackendChoice, BackendKind, Device, OpenOptions};
use optik_benches::mesh::{self, Mesh};
use optik_benches::rounds::{median, round_cells};
use optik_benches::scenes::{self, RaySet, Scene};
use optik_benches::walk::Walk;
use optik_io::array;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// Command-line options.
struct Options {
    repeat: usize,
    threads: usize,
    rounds: usize,
    python: String,
    embree: bool,
    save_rays: Option<PathBuf>,
}

fn parse_options() -> Result<Options, String> {
    let mut o = Options {
        repeat: 5,
        threads: optik::available_cores(),
        rounds: 1,
        python: "python3".into(),
        embree: true,
        save_rays: None,
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = |name: &str| args.next().ok_or_else(|| format!("{name} needs a value"));
        match a.as_str() {
            "--repeat" => o.repeat = parse_count(&value("--repeat")?, "--repeat")?,
            "--threads" => o.threads = parse_count(&value("--threads")?, "--threads")?,
            "--rounds" => o.rounds = parse_count(&value("--rounds")?, "--rounds")?,
            "--python" => o.python = value("--python")?,
            "--no-embree" => o.embree = false,
            "--save-rays" => o.save_rays = Some(PathBuf::from(value("--save-rays")?)),
            "-h" | "--help" => {
                return Err(
                    "usage: bench-cpu [--repeat K] [--threads N] [--rounds R] [--python PYTHON] [--no-embree] [--save-rays DIR]"
                        .into(),
                );
            }
            other => return Err(format!("unknown argument {other:?}; see --help")),
        }
    }
    Ok(o)
}

fn parse_count(s: &str, name: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!("{name} {s:?}: expected a count of at least 1")),
    }
}

/// One row of the table.
struct Row {
    scene: &'static str,
    rays: &'static str,
    count: usize,
    threads: usize,
    /// Per round, optik's best launch time and Embree's (if it ran).
    rounds: Vec<(f64, Option<f64>)>,
    mismatches: Option<Mismatches>,
    /// One-thread rows: per round, the best pass of the walk alone (`optik_benches::walk`).
    walk: Vec<f64>,
    /// One-thread rows: rays on which the walk alone and the launch disagree (triangle or
    /// distance bits); always 0 unless the walk alone no longer walks what launches walk.
    walk_mismatches: usize,
}

/// Rays optik and Embree disagree on.
#[derive(Clone, Copy)]
struct Mismatches {
    /// A different triangle, or a hit against a miss.
    total: usize,
    /// Of those, a hit against a miss.
    hit_miss: usize,
    /// Largest relative difference of the hit distances where both hit.
    max_relative_t: f64,
}

impl Mismatches {
    fn of(prim: &[u32], t: &[f32], peer: &Peer) -> Mismatches {
        let mut m = Mismatches {
            total: 0,
            hit_miss: 0,
            max_relative_t: 0.0,
        };
        for i in 0..prim.len().min(peer.prim.len()) {
            if prim[i] == peer.prim[i] {
                continue;
            }
            m.total += 1;
            if (prim[i] == u32::MAX) != (peer.prim[i] == u32::MAX) {
                m.hit_miss += 1;
            } else {
                let (a, b) = (t[i] as f64, peer.t[i] as f64);
                m.max_relative_t = m.max_relative_t.max((a - b).abs() / b.abs().max(1e-30));
            }
        }
        m
    }
}

/// Build times of one scene, per round: optik's best (both thread counts, every ray set)
/// and Embree's best (every ray set), if it ran.
struct Build {
    scene: &'static str,
    rounds: Vec<(f64, Option<f64>)>,
}

/// What the Embree peer reported for one ray set.
struct Peer {
    build_s: f64,
    trace_s_1: f64,
    trace_s_n: f64,
    prim: Vec<u32>,
    t: Vec<f32>,
}

/// Makes `dir` and any missing folders above it; the error names it.
fn make_folder(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("{}: cannot make the folder: {e}", dir.display()))
}

fn main() -> ExitCode {
    let options = match parse_options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("bench-cpu: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(dir) = &options.save_rays
        && let Err(e) = make_folder(dir)
    {
        eprintln!("bench-cpu: --save-rays {e}");
        return ExitCode::FAILURE;
    }
    let work = std::env::temp_dir().join(format!("optik-bench-cpu-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&work) {
        eprintln!("bench-cpu: cannot make {}: {e}", work.display());
        return ExitCode::FAILURE;
    }
    let mut rows = Vec::new();
    let mut builds = Vec::new();
    let mut embree = options.embree;
    for scene in scenes::ALL {
        match run_scene(&scene, &options, &mut embree, &work, &mut rows) {
            Ok(Some(b)) => builds.push(b),
            Ok(None) => {}
            Err(e) => {
                eprintln!("bench-cpu: {}: {e}", scene.name);
                let _ = std::fs::remove_dir_all(&work);
                return ExitCode::FAILURE;
            }
        }
    }
    let _ = std::fs::remove_dir_all(&work);
    print_tables(&rows, &builds, &options);
    ExitCode::SUCCESS
}

/// Benchmarks one scene; `None` when its file is missing.
fn run_scene(
    scene: &Scene,
    options: &Options,
    embree: &mut bool,
    work: &Path,
    rows: &mut Vec<Row>,
) -> optik::Result<Option<Build>> {
    let path = match scenes::find(scene) {
        Ok(p) => p,
        Err(message) => {
            eprintln!("bench-cpu: skipping: {message}");
            return Ok(None);
        }
    };
    let mesh = mesh::load(&path)?;
    eprintln!(
        "bench-cpu: {} ({} triangles)",
        scene.name,
        mesh.triangles.len()
    );
    let files = MeshFiles::write(&mesh, work)?;
    let walk = Walk::new(&mesh)?;
    let mut build = Build {
        scene: scene.name,
        rounds: vec![(f64::INFINITY, None); options.rounds],
    };
    for set in scenes::ray_sets(scene, &mesh) {
        let count = set.rays.len() / RAY_FLOATS;
        if let Some(dir) = &options.save_rays {
            let name = format!("{}-{}.npy", scene.name.replace(' ', "-"), set.name);
            write(&dir.join(name), &[count, RAY_FLOATS], &set.rays)?;
        }
        // The table's two rows of this set: all threads, then one.
        let mut set_rows = [options.threads, 1].map(|threads| Row {
            scene: scene.name,
            rays: set.name,
            count,
            threads,
            rounds: Vec::new(),
            mismatches: None,
            walk: Vec::new(),
            walk_mismatches: 0,
        });
        for round in 0..options.rounds {
            // optik: all threads first, then one; each on its own device.
            let mut optik_s = [0.0; 2];
            let mut one_thread = (Vec::new(), Vec::new());
            for (i, threads) in [options.threads, 1].into_iter().enumerate() {
                let device = optik::open_with(
                    BackendChoice::Named(BackendKind::Cpu),
                    &OpenOptions {
                        threads: Some(threads),
                    },
                )?;
                let (seconds, build_s, hits) =
                    trace_optik(device.as_ref(), &mesh, &set, options.repeat)?;
                let b = &mut build.rounds[round].0;
                *b = b.min(build_s);
                optik_s[i] = seconds;
                one_thread = hits;
            }
            // The walk alone on this thread, beside the one-thread launch.
            let (walk_s, walk_hits) = walk.time(&set.rays, options.repeat);
            set_rows[1].walk.push(walk_s);
            if round == 0 {
                set_rows[1].walk_mismatches = disagreements(&walk_hits, &one_thread);
            }
            let peer = if *embree {
                match run_peer(&files, &set, options, work) {
                    Ok(p) => Some(p),
                    Err(e) => {
                        eprintln!("bench-cpu: Embree left out: {e}");
                        *embree = false;
                        None
                    }
                }
            } else {
                None
            };
            if let Some(p) = &peer {
                let b = &mut build.rounds[round].1;
                *b = Some(b.map_or(p.build_s, |b: f64| b.min(p.build_s)));
            }
            if round == 0 {
                // The same in every round: both sides' results do not depend on timing.
                let mismatches = peer
                    .as_ref()
                    .map(|p| Mismatches::of(&one_thread.0, &one_thread.1, p));
                for row in &mut set_rows {
                    row.mismatches = mismatches;
                }
            }
            for (i, row) in set_rows.iter_mut().enumerate() {
                let embree_s = peer.as_ref().map(|p| {
                    if row.threads == 1 {
                        p.trace_s_1
                    } else {
                        p.trace_s_n
                    }
                });
                row.rounds.push((optik_s[i], embree_s));
            }
        }
        let [all, one] = set_rows;
        rows.extend([one, all]);
    }
    Ok(Some(build))
}

/// What one optik run gives: the best launch time, the build time, the hit triangles and
/// distances.
type OptikRun = (f64, f64, (Vec<u32>, Vec<f32>));

/// Builds, traces `repeat` times and returns what the run gives.
fn trace_optik(
    device: &dyn Device,
    mesh: &Mesh,
    set: &RaySet,
    repeat: usize,
) -> optik::Result<OptikRun> {
    let mut caster = RayCaster::new(device, &mesh.positions, &mesh.triangles)?;
    let (hits, seconds) = caster.cast(&set.rays, repeat)?;
    Ok((seconds, caster.build_seconds, (hits.prim, hits.t)))
}

/// Rays on which two runs' hits differ: the triangle, or the distance's bits.
fn disagreements(a: &(Vec<u32>, Vec<f32>), b: &(Vec<u32>, Vec<f32>)) -> usize {
    let rays = a.0.len().max(b.0.len());
    let same = (0..rays)
        .filter(|&i| {
            a.0.get(i) == b.0.get(i)
                && a.1.get(i).map(|t| t.to_bits()) == b.1.get(i).map(|t| t.to_bits())
        })
        .count();
    rays - same
}

/// The mesh as the peer reads it.
struct MeshFiles {
    vertices: PathBuf,
    triangles: PathBuf,
}

impl MeshFiles {
    fn write(mesh: &Mesh, work: &Path) -> optik::Result<MeshFiles> {
        let vertices = work.join("vertices.npy");
        let triangles = work.join("triangles.npy");
        let flat_v: Vec<f32> = mesh.positions.iter().flatten().copied().collect();
        let flat_t: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        write(&vertices, &[mesh.positions.len(), 3], &flat_v)?;
        write(&triangles, &[mesh.triangles.len(), 3], &flat_t)?;
        Ok(MeshFiles {
            vertices,
            triangles,
        })
    }
}

fn write<T: array::Element>(path: &Path, shape: &[usize], data: &[T]) -> optik::Result<()> {
    array::write_npy(path, shape, data).map_err(|e| optik::Error::invalid(e.to_string()))
}

/// Runs `peer.py` on the rays with one and `options.threads` threads.
fn run_peer(
    files: &MeshFiles,
    set: &RaySet,
    options: &Options,
    work: &Path,
) -> Result<Peer, String> {
    let rays = work.join("rays.npy");
    let out = work.join("embree.npz");
    let prim = work.join("embree_prim.npy");
    let t = work.join("embree_t.npy");
    let count = set.rays.len() / RAY_FLOATS;
    write(&rays, &[count, RAY_FLOATS], &set.rays).map_err(|e| e.to_string())?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("embree/peer.py");
    let output = Command::new(&options.python)
        .arg(&script)
        .args([&files.vertices, &files.triangles, &rays, &out])
        .args(["--threads", &options.threads.to_string()])
        .args(["--repeat", &options.repeat.to_string()])
        .arg("--prim-npy")
        .arg(&prim)
        .arg("--t-npy")
        .arg(&t)
        .output()
        .map_err(|e| format!("cannot run {} {}: {e}", options.python, script.display()))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout.lines().last().unwrap_or("");
    let json: serde_json::Value = serde_json::from_str(line).map_err(|_| {
        format!(
            "peer.py printed no JSON (status {}): {}{}",
            output.status,
            stdout,
            String::from_utf8_lossy(&output.stderr)
        )
    })?;
    if let Some(e) = json.get("error") {
        return Err(format!("peer.py: {e}"));
    }
    let number = |key: &str| {
        json.get(key)
            .and_then(|v| v.as_f64())
            .ok_or_else(|| format!("peer.py's JSON lacks {key}: {line}"))
    };
    let prim_data = array::read_npy::<u32>(&prim)
        .map_err(|e| e.to_string())?
        .data;
    let t_data = array::read_npy::<f32>(&t).map_err(|e| e.to_string())?.data;
    Ok(Peer {
        build_s: number("build_s")?,
        trace_s_1: number("trace_s_1")?,
        trace_s_n: number("trace_s_n")?,
        prim: prim_data,
        t: t_data,
    })
}

fn print_tables(rows: &[Row], builds: &[Build], options: &Options) {
    let cpu = optik::backends::cpu::cpu_name();
    let rounds = match options.rounds {
        1 => String::new(),
        r => format!(
            "; {r} interleaved rounds: median throughputs, median (range) of the rounds' ratios"
        ),
    };
    println!(
        "optik CPU (watertight + conservative) vs Embree (robust), best of {} launches; {} threads available; {cpu}{rounds}",
        options.repeat, options.threads
    );
    println!();
    println!(
        "| scene | rays | count | threads | optik Mrays/s | Embree Mrays/s | optik / Embree | prim mismatches (hit/miss) |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    let rate = |count: usize, s: f64| count as f64 / s / 1e6;
    for r in rows {
        // Throughput: optik's over Embree's, the inverse ratio of the times.
        let [optik, embree, ratio] = round_cells(&r.rounds, |s| rate(r.count, s), |o, e| e / o, 2);
        let mismatches = r
            .mismatches
            .map_or("-".into(), |m| format!("{} ({})", m.total, m.hit_miss));
        println!(
            "| {} | {} | {} | {} | {optik} | {embree} | {ratio} | {mismatches} |",
            r.scene, r.rays, r.count, r.threads
        );
    }
    let worst = rows
        .iter()
        .filter_map(|r| r.mismatches)
        .map(|m| m.max_relative_t)
        .fold(0.0f64, f64::max);
    if rows.iter().any(|r| r.mismatches.is_some()) {
        println!();
        println!(
            "Mismatches are per ray set (the one-thread run); where both hit a different triangle the distances differ by at most {worst:.1e} (relative)."
        );
    }
    print_walk_table(rows, options);
    println!();
    println!("| scene | optik build s | Embree build s | optik / Embree time |");
    println!("|---|---:|---:|---:|");
    for b in builds {
        // Build time: optik's over Embree's (lower is better).
        let [optik, embree, ratio] = round_cells(&b.rounds, |s| s, |o, e| o / e, 3);
        println!("| {} | {optik} | {embree} | {ratio} |", b.scene);
    }
}

/// The one-thread rows split: the walk alone's throughput against Embree's one thread, and
/// what the launch spends around the walk (its time less the walk alone's, a ray; the
/// rounds' median).
fn print_walk_table(rows: &[Row], options: &Options) {
    println!();
    println!(
        "optik's walk alone (one thread: the same structure and rays handed straight to the walk, without a launch; best of {} passes) against Embree's one thread, and the launch path (optik's one-thread launch less the walk alone):",
        options.repeat
    );
    println!();
    println!(
        "| scene | rays | walk alone Mrays/s | walk alone / Embree | launch path ns a ray | launch path / launch |"
    );
    println!("|---|---|---:|---:|---:|---:|");
    let rate = |count: usize, s: f64| count as f64 / s / 1e6;
    for r in rows.iter().filter(|r| r.threads == 1 && !r.walk.is_empty()) {
        let pairs: Vec<(f64, Option<f64>)> = r
            .walk
            .iter()
            .zip(&r.rounds)
            .map(|(&w, &(_, e))| (w, e))
            .collect();
        let [walk, _, ratio] = round_cells(&pairs, |s| rate(r.count, s), |w, e| e / w, 2);
        let path: Vec<f64> = r
            .walk
            .iter()
            .zip(&r.rounds)
            .map(|(&w, &(o, _))| o - w)
            .collect();
        let share: Vec<f64> = path
            .iter()
            .zip(&r.rounds)
            .map(|(&p, &(o, _))| p / o)
            .collect();
        let ns = median(&path).map_or("-".into(), |p| format!("{:.1}", p / r.count as f64 * 1e9));
        let share = median(&share).map_or("-".into(), |s| format!("{:.0} %", s * 100.0));
        println!(
            "| {} | {} | {walk} | {ratio} | {ns} | {share} |",
            r.scene, r.rays
        );
    }
    let disagreeing: usize = rows.iter().map(|r| r.walk_mismatches).sum();
    if disagreeing > 0 {
        println!();
        println!(
            "The walk alone and the launch disagree on {disagreeing} rays: the walk alone no longer walks what launches walk, and its figures are not comparable."
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disagreements_count_rays_with_another_triangle_or_distance() {
        let a = (vec![1, 2, 3, u32::MAX], vec![1.0, 2.0, 3.0, f32::INFINITY]);
        assert_eq!(disagreements(&a, &a.clone()), 0);
        let other_triangle = (vec![1, 5, 3, u32::MAX], a.1.clone());
        assert_eq!(disagreements(&a, &other_triangle), 1);
        let other_distance = (a.0.clone(), vec![1.0, 2.0, 3.0000002, f32::INFINITY]);
        assert_eq!(disagreements(&a, &other_distance), 1);
        let shorter = (vec![1, 2], vec![1.0, 2.0]);
        assert_eq!(disagreements(&a, &shorter), 2);
    }

    #[test]
    fn the_rays_folder_is_made_where_missing() {
        let root = std::env::temp_dir().join(format!("bench-cpu-rays-{}", std::process::id()));
        let nested = root.join("a/b");
        assert_eq!(make_folder(&nested), Ok(()));
        assert!(nested.is_dir());
        assert_eq!(make_folder(&nested), Ok(()), "an existing folder is fine");
        let file = root.join("file");
        std::fs::write(&file, b"x").unwrap();
        let e = make_folder(&file.join("c")).unwrap_err();
        assert!(e.contains("file/c") && e.contains("cannot make"), "{e}");
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn rounds_are_parsed_as_a_count() {
        assert_eq!(parse_count("3", "--rounds"), Ok(3));
        assert!(parse_count("0", "--rounds").is_err());
        assert!(parse_count("x", "--rounds").is_err());
    }
}
