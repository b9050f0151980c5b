//! `optik bench-report`: one process, one run, every figure as a ratio against its neighbours
//! (DESIGN.md §8).
//!
//! 1. Backends side by side on the test scenes: build time, camera and incoherent rays, the CPU
//!    backend also on one thread, with Embree (through `embreex`, `benches/embree/peer.py`) on
//!    the same rays, on one thread and the same thread count. The CPU backend and Embree take
//!    turns in [`ReportOptions::rounds`] rounds, and each Embree row gives optik's throughput
//!    over Embree's at the same thread count, round by round.
//! 2. The accuracy options, each as (time, error): leaks through a closed mesh's shared edges and
//!    vertices, and camera rays whose primitive differs from the robust default's.
//! 3. Specialised pipelines against pipelines with features forced on: what each skipped
//!    feature saves.
//! 4. Build and trace cost as the triangle count grows.
//! 5. With `scale`: a scene of over 10 million triangles, flat and instanced, traced with
//!    2^24 incoherent rays (build time, structure memory, throughput, launches).
//!
//! Absolute times are only meaningful on the machine that made them; the ratios are the result.

use crate::mesh::{self, BenchMesh, Mesh};
use crate::rays;
use crate::rounds::{median, ratio_cell};
use optik::raycast::{Hits, RayCaster};
use optik::{
    Accuracy, BackendKind, Device, ExceptionFlags, IDENTITY_3X4, PipelineCompileOptions,
    PrimitiveTypeFlags, Result, Setting, TransformDesc, TraversableGraph,
};
use optik_io::array;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// What to measure.
#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// Folder holding `stanford-bunny/` and `breakfast-room/` (DESIGN.md §9's scenes).
    pub scenes: PathBuf,
    /// Backends to include (those that cannot open are listed as skipped).
    pub backends: Vec<BackendKind>,
    /// Camera resolution.
    pub width: u32,
    /// Camera resolution.
    pub height: u32,
    /// Incoherent rays per scene.
    pub incoherent: usize,
    /// Launches per measurement; the best is kept.
    pub repeat: usize,
    /// CPU threads (`None`: all cores); Embree gets the same.
    pub threads: Option<usize>,
    /// Run Embree through `benches/embree/peer.py` (with [`ReportOptions::python`]).
    pub embree: bool,
    /// Rounds of the CPU backend (all threads, one thread) and Embree, interleaved, per scene:
    /// a shared machine's load moves both sides by tens of percent from one minute to the
    /// next, so their ratios are taken within each round and the table gives medians. At
    /// least 1; 1 measures each once. Without Embree the CPU backend is measured once.
    pub rounds: usize,
    /// Where `benches/embree/peer.py` lives.
    pub peer_script: PathBuf,
    /// The Python that runs it (one that can import `embreex`).
    pub python: String,
    /// Also measure the large scenes (10 485 760 triangles, flat and instanced: minutes and
    /// gigabytes, off by default).
    pub scale: bool,
}

impl ReportOptions {
    /// The rounds the throughput section runs: [`ReportOptions::rounds`] where it measures
    /// the CPU backend and Embree (rounds interleave the two), else 1.
    pub fn interleaved_rounds(&self) -> usize {
        if self.rounds_ignored_because().is_none() {
            self.rounds
        } else {
            1
        }
    }

    /// Why more than one round would change nothing (the CPU backend or Embree is not
    /// measured), or `None` when rounds interleave them.
    pub fn rounds_ignored_because(&self) -> Option<&'static str> {
        if !self.backends.contains(&BackendKind::Cpu) {
            Some("the CPU backend is not measured")
        } else if !self.embree {
            Some("Embree is left out")
        } else {
            None
        }
    }
}

/// Prints a markdown table.
fn table(title: &str, header: &[&str], rows: &[Vec<String>]) {
    println!("\n### {title}\n");
    println!("| {} |", header.join(" | "));
    println!(
        "|{}|",
        header.iter().map(|_| "---").collect::<Vec<_>>().join("|")
    );
    for r in rows {
        println!("| {} |", r.join(" | "));
    }
}

fn mrays(n: usize, seconds: f64) -> f64 {
    if seconds > 0.0 {
        n as f64 / seconds / 1e6
    } else {
        0.0
    }
}

fn open(kind: BackendKind, threads: Option<usize>) -> std::result::Result<Box<dyn Device>, String> {
    let choice = optik::BackendChoice::Named(kind);
    optik::open_with(choice, &optik::OpenOptions { threads }).map_err(|e| e.message().to_string())
}

/// A scene to measure: a mesh and its rays.
struct Scene {
    name: String,
    mesh: Mesh,
    camera: Vec<f32>,
    incoherent: Vec<f32>,
}

/// The benchmark scenes (`crate::scenes::ALL`) found in `opts.scenes`, each with the camera
/// `bench-cpu` uses (at `opts`' size) and `opts.incoherent` incoherent rays made as
/// `bench-cpu` makes its own: at the default size, the same rays.
fn scenes(opts: &ReportOptions) -> Vec<Scene> {
    let mut out = Vec::new();
    for bench in crate::scenes::ALL {
        // Table and JSON names without spaces, as earlier reports wrote them.
        let name = bench.name.replace(' ', "-");
        let path = opts.scenes.join(bench.file);
        match mesh::load(&path) {
            Ok(mesh) => {
                let camera = crate::scenes::camera_rays(&bench, &mesh, opts.width, opts.height);
                let incoherent = rays::incoherent(&mesh, opts.incoherent, 7);
                out.push(Scene {
                    name,
                    mesh,
                    camera,
                    incoherent,
                });
            }
            Err(e) => println!(
                "skipping scene {name}: {} (set --scenes to the folder of DESIGN.md §9's scenes)",
                e.message()
            ),
        }
    }
    if out.is_empty() {
        println!("no scene files found; measuring a generated sphere of 327 680 triangles instead");
        let mesh = Mesh::icosphere(7);
        let camera = rays::camera(&mesh, opts.width, opts.height, [-0.3, -0.25, -1.0]);
        let incoherent = rays::incoherent(&mesh, opts.incoherent, 7);
        out.push(Scene {
            name: "icosphere-7".into(),
            mesh,
            camera,
            incoherent,
        });
    }
    out
}

/// Embree's figures for one scene and ray set: (build s, trace s one thread, trace s all threads, hits).
fn embree(
    opts: &ReportOptions,
    mesh: &Mesh,
    rays: &[f32],
    threads: usize,
) -> std::result::Result<(f64, f64, f64, Hits), String> {
    let dir = std::env::temp_dir().join(format!("optik-report-{}", std::process::id()));
    let result = std::fs::create_dir_all(&dir)
        .map_err(|e| e.to_string())
        .and_then(|()| embree_in(&dir, opts, mesh, rays, threads));
    // On every outcome: a failing peer must not leave its inputs behind.
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// [`embree`] with its inputs and output in `dir`.
fn embree_in(
    dir: &Path,
    opts: &ReportOptions,
    mesh: &Mesh,
    rays: &[f32],
    threads: usize,
) -> std::result::Result<(f64, f64, f64, Hits), String> {
    let flat_v: Vec<f32> = mesh.positions.iter().flatten().copied().collect();
    let flat_t: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let (v, t, r) = (dir.join("v.npy"), dir.join("t.npy"), dir.join("r.npy"));
    array::write_npy(&v, &[mesh.positions.len(), 3], &flat_v)
        .and_then(|()| array::write_npy(&t, &[mesh.triangles.len(), 3], &flat_t))
        .and_then(|()| array::write_npy(&r, &[rays.len() / 8, 8], rays))
        .map_err(|e| e.to_string())?;
    let out = dir.join("hits.npz");
    let output = std::process::Command::new(&opts.python)
        .arg(&opts.peer_script)
        .args([&v, &t, &r, &out])
        .args([
            "--threads",
            &threads.to_string(),
            "--repeat",
            &opts.repeat.to_string(),
        ])
        .output()
        .map_err(|e| format!("cannot run {}: {e}", opts.python))?;
    let text = String::from_utf8_lossy(&output.stdout);
    let line = text.lines().last().unwrap_or("");
    let j: Value = serde_json::from_str(line).map_err(|_| {
        format!(
            "peer.py printed no result: {}{}",
            text.trim(),
            String::from_utf8_lossy(&output.stderr).trim()
        )
    })?;
    if let Some(e) = j.get("error") {
        return Err(e.to_string());
    }
    let f = |k: &str| {
        j.get(k)
            .and_then(Value::as_f64)
            .ok_or_else(|| format!("peer.py's result has no number {k:?}: {line}"))
    };
    let figures = (f("build_s")?, f("trace_s_1")?, f("trace_s_n")?);
    let hits = read_npz_hits(&out)?;
    Ok((figures.0, figures.1, figures.2, hits))
}

/// Reads `t` and `prim` back from the peer's `.npz` (through optik-io, which reads the zip64
/// entries numpy writes).
fn read_npz_hits(path: &Path) -> std::result::Result<Hits, String> {
    let mut npz = array::read_npz(path).map_err(|e| e.to_string())?;
    Ok(Hits {
        t: npz.array::<f32>("t").map_err(|e| e.to_string())?.data,
        prim: npz.array::<u32>("prim").map_err(|e| e.to_string())?.data,
        ..Hits::default()
    })
}

fn disagreements(a: &Hits, b: &Hits) -> usize {
    a.prim.iter().zip(&b.prim).filter(|(x, y)| x != y).count()
}

/// Seconds of one launch (the best of `repeat`) on a scene's camera rays, then on its
/// incoherent rays.
type SetSeconds = [f64; 2];

/// One round of Embree on a scene.
#[derive(Clone, Copy, Debug)]
struct EmbreeRound {
    /// Build seconds (of the camera rays' run).
    build: f64,
    /// Trace seconds on all threads, then on one: the order of [`CpuRounds::optik`].
    trace: [SetSeconds; 2],
}

/// The CPU backend and Embree on one scene, round by round.
#[derive(Clone, Debug, Default)]
struct CpuRounds {
    /// Build seconds on all threads, then on one (each structure is built once).
    build: [f64; 2],
    /// optik's seconds on all threads, then on one: one entry per round.
    optik: [Vec<SetSeconds>; 2],
    /// Embree's figures, one entry per round; `None` where it did not run.
    embree: Vec<Option<EmbreeRound>>,
}

impl CpuRounds {
    /// Mrays/s of optik's `side` (0: all threads, 1: one) on `set` (0: camera, 1: incoherent)
    /// per round, for `rays` rays per set.
    fn optik_rates(&self, side: usize, set: usize, rays: [usize; 2]) -> Vec<f64> {
        self.optik[side]
            .iter()
            .map(|s| mrays(rays[set], s[set]))
            .collect()
    }

    /// The median over the rounds of [`CpuRounds::optik_rates`], camera then incoherent.
    fn optik_medians(&self, side: usize, rays: [usize; 2]) -> [f64; 2] {
        [0, 1].map(|set| median(&self.optik_rates(side, set, rays)).unwrap_or(0.0))
    }
}

/// A row of the throughput table and its JSON record.
struct ThroughputRow {
    cells: Vec<String>,
    json: Value,
}

/// The throughput rows of the CPU backend (all threads, then one) and of Embree (one thread,
/// then `threads`) on `scene` from `m`'s rounds: `devices` names the two CPU devices, `rays`
/// counts the camera and incoherent rays, `differ` the camera rays whose triangle Embree's
/// hits and optik's disagree on. Throughputs are medians over the rounds. An Embree row
/// compares like with like, optik over Embree at the same thread count, within each round
/// (a shared machine's load moves both sides far more between rounds than within one), as
/// [`ratio_cell`]. No Embree rows when it ran in no round.
fn cpu_rows(
    scene: &str,
    devices: [&str; 2],
    threads: usize,
    rays: [usize; 2],
    m: &CpuRounds,
    differ: Option<usize>,
) -> (Vec<ThroughputRow>, Vec<ThroughputRow>) {
    let all = m.optik_medians(0, rays);
    let optik = [
        (devices[0].to_string(), "cpu", threads),
        ("optik CPU, 1 thread".to_string(), "cpu, 1 thread", 1),
    ]
    .into_iter()
    .enumerate()
    .map(|(side, (label, backend, n))| {
        let [cam, inc] = m.optik_medians(side, rays);
        ThroughputRow {
            cells: vec![
                scene.into(),
                label,
                format!("{:.1}", m.build[side] * 1e3),
                format!("{cam:.2}"),
                format!("{inc:.2}"),
                format!("{:.2}x / {:.2}x", cam / all[0], inc / all[1]),
            ],
            json: json!({"section": "throughput", "scene": scene, "backend": backend,
                "device": devices[side], "threads": n, "build_s": m.build[side],
                "camera_mrays_per_s": cam, "incoherent_mrays_per_s": inc,
                "camera_mrays_per_s_rounds": m.optik_rates(side, 0, rays),
                "incoherent_mrays_per_s_rounds": m.optik_rates(side, 1, rays)}),
        }
    })
    .collect();
    if m.embree.iter().all(Option::is_none) {
        return (optik, Vec::new());
    }
    let builds: Vec<f64> = m.embree.iter().flatten().map(|e| e.build).collect();
    let build = median(&builds).unwrap_or(f64::NAN);
    let note = differ.map_or(String::new(), |d| format!("; {d} camera prims differ"));
    let embree = [
        ("Embree robust, 1 thread".to_string(), 1, 1),
        (format!("Embree robust, {threads} threads"), threads, 0),
    ]
    .into_iter()
    .map(|(label, n, side)| {
        // Per round, Embree's throughput at this thread count and optik's over it (the
        // inverse ratio of the times); `None` where Embree did not run.
        let per_round = |set: usize| -> (Vec<Option<f64>>, Vec<Option<f64>>) {
            m.optik[side]
                .iter()
                .zip(&m.embree)
                .map(|(o, e)| {
                    let e = e.map(|e| e.trace[side][set]);
                    (e.map(|e| mrays(rays[set], e)), e.map(|e| e / o[set]))
                })
                .unzip()
        };
        let [(cam_rates, cam_ratios), (inc_rates, inc_ratios)] = [0, 1].map(per_round);
        let present = |v: &[Option<f64>]| v.iter().flatten().copied().collect::<Vec<f64>>();
        let (cam, inc) = (median(&present(&cam_rates)), median(&present(&inc_rates)));
        let rate_cell = |r: Option<f64>| r.map_or("-".into(), |r| format!("{r:.2}"));
        ThroughputRow {
            cells: vec![
                scene.into(),
                label.clone(),
                format!("{:.1}", build * 1e3),
                rate_cell(cam),
                rate_cell(inc),
                format!(
                    "{} / {}{note}",
                    ratio_cell(&present(&cam_ratios)),
                    ratio_cell(&present(&inc_ratios))
                ),
            ],
            json: json!({"section": "throughput", "scene": scene, "backend": label, "threads": n,
                "build_s": build, "camera_mrays_per_s": cam, "incoherent_mrays_per_s": inc,
                "build_s_rounds": m.embree.iter().map(|e| e.map(|e| e.build)).collect::<Vec<_>>(),
                "camera_mrays_per_s_rounds": cam_rates, "incoherent_mrays_per_s_rounds": inc_rates,
                "camera_optik_over_embree_rounds": cam_ratios,
                "incoherent_optik_over_embree_rounds": inc_ratios}),
        }
    })
    .collect();
    (optik, embree)
}

/// What [`measure_cpu`] measured on one scene.
struct CpuMeasured {
    /// The devices' names: all threads, then one.
    devices: [String; 2],
    rounds: CpuRounds,
    /// Camera rays whose triangle Embree's hits and optik's disagree on.
    differ: Option<usize>,
    /// Why Embree was left out, if it was.
    embree_error: Option<String>,
}

/// Times the CPU backend on `opts.threads` threads and on one, and Embree on one and
/// `threads` threads (with `opts.embree`), on `scene` in `rounds` interleaved rounds: each
/// round launches the camera and the incoherent rays on all threads, then on one, then runs
/// Embree's peer on the camera rays and on the incoherent rays. Each device's structure is
/// built once; rounds only launch. `Err`: the table cell that says why there are no figures.
fn measure_cpu(
    opts: &ReportOptions,
    scene: &Scene,
    threads: usize,
    rounds: usize,
) -> std::result::Result<CpuMeasured, String> {
    let error = |e: optik::Error| format!("error: {}", e.message());
    let mut devices = Vec::new();
    for t in [opts.threads, Some(1)] {
        devices.push(open(BackendKind::Cpu, t).map_err(|why| format!("skipped: {why}"))?);
    }
    let mut casters = Vec::new();
    for device in &devices {
        device.set_accuracy(Accuracy::ROBUST).map_err(error)?;
        casters.push(
            RayCaster::new(
                device.as_ref(),
                &scene.mesh.positions,
                &scene.mesh.triangles,
            )
            .map_err(error)?,
        );
    }
    let mut m = CpuRounds {
        build: [casters[0].build_seconds, casters[1].build_seconds],
        ..CpuRounds::default()
    };
    let (mut camera_hits, mut embree_hits, mut embree_error) = (None, None, None);
    for round in 0..rounds {
        for (side, caster) in casters.iter_mut().enumerate() {
            let (hits, cam) = caster.cast(&scene.camera, opts.repeat).map_err(error)?;
            let (_, inc) = caster.cast(&scene.incoherent, opts.repeat).map_err(error)?;
            // Hits do not depend on the thread count or the round: the first are kept.
            camera_hits.get_or_insert(hits);
            m.optik[side].push([cam, inc]);
        }
        let peer = (opts.embree && embree_error.is_none()).then(|| {
            embree(opts, &scene.mesh, &scene.camera, threads).and_then(|camera| {
                embree(opts, &scene.mesh, &scene.incoherent, threads).map(|inc| (camera, inc))
            })
        });
        m.embree.push(match peer {
            Some(Ok(((build, cam1, camn, hits), (_, inc1, incn, _)))) => {
                embree_hits.get_or_insert(hits);
                Some(EmbreeRound {
                    build,
                    trace: [[camn, incn], [cam1, inc1]],
                })
            }
            Some(Err(e)) => {
                if round > 0 {
                    println!(
                        "{}: Embree left out after {round} of {rounds} rounds: {e}",
                        scene.name
                    );
                }
                embree_error = Some(e);
                None
            }
            None => None,
        });
    }
    let differ = camera_hits
        .zip(embree_hits)
        .map(|(optik, embree)| disagreements(&optik, &embree));
    let names: Vec<String> = devices
        .iter()
        .map(|d| d.properties().device_name.clone())
        .collect();
    Ok(CpuMeasured {
        devices: [names[0].clone(), names[1].clone()],
        rounds: m,
        differ,
        embree_error,
    })
}

fn throughput(opts: &ReportOptions, scenes: &[Scene], report: &mut Vec<Value>) {
    let threads = opts.threads.unwrap_or_else(optik::available_cores);
    // Rounds only interleave the CPU backend with Embree; alone, one measurement will do.
    let rounds = opts.interleaved_rounds();
    let mut rows = Vec::new();
    for scene in scenes {
        let counts = [scene.camera.len() / 8, scene.incoherent.len() / 8];
        let mut cpu_rates: Option<(f64, f64)> = None;
        // After the scene's other rows, as a peer rather than a backend.
        let mut embree_rows = Vec::new();
        for &kind in &opts.backends {
            if kind == BackendKind::Cpu {
                match measure_cpu(opts, scene, threads, rounds) {
                    Ok(measured) => {
                        let (optik, embree) = cpu_rows(
                            &scene.name,
                            measured.devices.each_ref().map(String::as_str),
                            threads,
                            counts,
                            &measured.rounds,
                            measured.differ,
                        );
                        let [c, i] = measured.rounds.optik_medians(0, counts);
                        cpu_rates = Some((c, i));
                        for row in optik {
                            rows.push(row.cells);
                            report.push(row.json);
                        }
                        for row in embree {
                            embree_rows.push(row.cells);
                            report.push(row.json);
                        }
                        if let Some(e) = measured.embree_error
                            && measured.rounds.embree.iter().all(Option::is_none)
                        {
                            embree_rows.push(padded(
                                vec![scene.name.clone(), "Embree".into(), format!("skipped: {e}")],
                                6,
                            ));
                        }
                    }
                    Err(note) => rows.push(padded(
                        vec![scene.name.clone(), kind.name().into(), note],
                        6,
                    )),
                }
                continue;
            }
            let device = match open(kind, opts.threads) {
                Ok(d) => d,
                Err(why) => {
                    rows.push(padded(
                        vec![
                            scene.name.clone(),
                            kind.name().into(),
                            format!("skipped: {why}"),
                        ],
                        6,
                    ));
                    continue;
                }
            };
            // Vulkan also with the driver's own triangle test (not watertight, DESIGN.md §5):
            // what hardware triangles give against optik's emulated watertight ones.
            let variants: &[(Accuracy, &str)] = if kind == BackendKind::Vulkan {
                &[
                    (Accuracy::ROBUST, ""),
                    (
                        Accuracy {
                            triangle: optik::TriangleTest::Driver,
                            ..Accuracy::ROBUST
                        },
                        " (driver triangles)",
                    ),
                ]
            } else {
                &[(Accuracy::ROBUST, "")]
            };
            for &(accuracy, label) in variants {
                if let Err(e) = device.set_accuracy(accuracy) {
                    rows.push(vec![
                        scene.name.clone(),
                        format!("{}{label}", kind.name()),
                        format!("not offered: {}", e.message()),
                        "".into(),
                        "".into(),
                        "".into(),
                    ]);
                    continue;
                }
                let result = (|| -> Result<(f64, f64, f64)> {
                    let mut caster = RayCaster::new(
                        device.as_ref(),
                        &scene.mesh.positions,
                        &scene.mesh.triangles,
                    )?;
                    let (_, cam_s) = caster.cast(&scene.camera, opts.repeat)?;
                    let (_, inc_s) = caster.cast(&scene.incoherent, opts.repeat)?;
                    Ok((caster.build_seconds, cam_s, inc_s))
                })();
                match result {
                    Ok((build, cam, inc)) => {
                        let cam_rate = mrays(counts[0], cam);
                        let inc_rate = mrays(counts[1], inc);
                        let vs_cpu = cpu_rates.map_or("".into(), |(c, i)| {
                            format!("{:.2}x / {:.2}x", cam_rate / c, inc_rate / i)
                        });
                        rows.push(vec![
                            scene.name.clone(),
                            format!("{}{label}", device.properties().device_name),
                            format!("{:.1}", build * 1e3),
                            format!("{cam_rate:.2}"),
                            format!("{inc_rate:.2}"),
                            vs_cpu,
                        ]);
                        report.push(
                            json!({"section": "throughput", "scene": scene.name, "backend": format!("{}{label}", kind.name()),
                            "device": device.properties().device_name, "build_s": build,
                            "camera_mrays_per_s": cam_rate, "incoherent_mrays_per_s": inc_rate}),
                        );
                    }
                    Err(e) => rows.push(vec![
                        scene.name.clone(),
                        kind.name().into(),
                        format!("error: {}", e.message()),
                        "".into(),
                        "".into(),
                        "".into(),
                    ]),
                }
            }
        }
        rows.extend(embree_rows);
    }
    let rounds_note = if rounds > 1 {
        format!(
            "; the CPU backend and Embree in {rounds} interleaved rounds: median Mrays/s, median (range) of the rounds' ratios"
        )
    } else {
        String::new()
    };
    table(
        &format!(
            "Throughput ({}x{} camera rays, {} incoherent rays, best of {}{rounds_note})",
            opts.width, opts.height, opts.incoherent, opts.repeat
        ),
        &[
            "scene",
            "backend",
            "build ms",
            "camera Mrays/s",
            "incoherent Mrays/s",
            "vs CPU (camera / incoherent; Embree rows: optik / Embree, same threads)",
        ],
        &rows,
    );
}

/// Fraction of rays aimed at a closed mesh's vertices and edge midpoints from inside that escape.
fn leak_rate(device: &dyn Device, scale: f64, offset: [f64; 3]) -> Result<f64> {
    let mesh = Mesh::icosphere(4).transformed(scale, offset);
    let inside: [f32; 3] =
        std::array::from_fn(|k| (offset[k] + scale * [0.0123, -0.0311, 0.0217][k]) as f32);
    let aimed = rays::aimed_at_vertices_and_edges(&mesh, inside);
    let mut caster = RayCaster::new(device, &mesh.positions, &mesh.triangles)?;
    let (hits, _) = caster.cast(&aimed, 1)?;
    Ok(hits.prim.iter().filter(|&&p| p == u32::MAX).count() as f64 / hits.prim.len().max(1) as f64)
}

/// `cells` padded with empty cells to a table's `width`: a row that says why it has no
/// figures.
fn padded(mut cells: Vec<String>, width: usize) -> Vec<String> {
    cells.resize(width.max(cells.len()), String::new());
    cells
}

/// A row of the accuracy table with a note (why an option has no figures) instead of figures.
fn accuracy_note(kind: BackendKind, option: &str, note: String) -> Vec<String> {
    padded(vec![kind.name().into(), option.into(), note], 6)
}

fn accuracy(opts: &ReportOptions, scene: &Scene, report: &mut Vec<Value>) {
    let mut rows = Vec::new();
    let choices = [
        ("watertight + conservative (default)", Accuracy::ROBUST),
        (
            "watertight + plain",
            Accuracy {
                box_test: optik::BoxTest::Plain,
                ..Accuracy::ROBUST
            },
        ),
        (
            "moller-trumbore + conservative",
            Accuracy {
                triangle: optik::TriangleTest::MollerTrumbore,
                ..Accuracy::ROBUST
            },
        ),
        ("moller-trumbore + plain (fast)", Accuracy::FAST),
        (
            "driver triangles + conservative",
            Accuracy {
                triangle: optik::TriangleTest::Driver,
                ..Accuracy::ROBUST
            },
        ),
    ];
    for &kind in &opts.backends {
        let Ok(device) = open(kind, opts.threads) else {
            continue;
        };
        // Each option's incoherent time is its best over two passes through the options:
        // a slow moment of the (possibly shared) machine then spoils one pass of one option
        // rather than its figure (one pass made single rows read 2-4x on the H200).
        let hits_and_time = |acc: Accuracy| -> Result<(Hits, f64)> {
            device.set_accuracy(acc)?;
            let mut caster = RayCaster::new(
                device.as_ref(),
                &scene.mesh.positions,
                &scene.mesh.triangles,
            )?;
            let (hits, _) = caster.cast(&scene.camera, 1)?;
            Ok((hits, caster.cast(&scene.incoherent, opts.repeat)?.1))
        };
        let mut first: Vec<Result<(f64, Hits, f64, f64)>> = Vec::new();
        for (_, acc) in choices {
            first.push(hits_and_time(acc).and_then(|(hits, inc)| {
                Ok((
                    inc,
                    hits,
                    leak_rate(device.as_ref(), 1.0, [0.0; 3])?,
                    leak_rate(device.as_ref(), 1.0, [1e5, -1e5, 1e5])?,
                ))
            }));
        }
        for ((_, acc), measured) in choices.iter().zip(first.iter_mut()) {
            if let Ok((inc, ..)) = measured
                && let Ok((_, again)) = hits_and_time(*acc)
            {
                *inc = inc.min(again);
            }
        }
        let mut baseline: Option<(f64, Hits)> = None;
        for ((name, acc), measured) in choices.into_iter().zip(first) {
            if let Err(e) = device.set_accuracy(acc) {
                rows.push(accuracy_note(
                    kind,
                    name,
                    format!("not offered: {}", e.message()),
                ));
                continue;
            }
            match measured {
                Ok((inc, hits, leak0, leak_far)) => {
                    let (time_ratio, diff) = match &baseline {
                        None => (1.0, 0),
                        Some((t, h)) => (inc / t, disagreements(h, &hits)),
                    };
                    if baseline.is_none() {
                        baseline = Some((inc, hits));
                    }
                    rows.push(vec![
                        kind.name().into(),
                        name.into(),
                        format!("{time_ratio:.3}"),
                        format!("{:.4} %", leak0 * 100.0),
                        format!("{:.4} %", leak_far * 100.0),
                        format!("{diff}"),
                    ]);
                    report.push(json!({"section": "accuracy", "backend": kind.name(), "option": name,
                        "time_vs_default": time_ratio, "leak_origin": leak0, "leak_far": leak_far, "camera_prims_differing": diff}));
                }
                Err(e) => rows.push(accuracy_note(kind, name, format!("error: {}", e.message()))),
            }
        }
        let _ = device.set_accuracy(Accuracy::ROBUST);
        if kind == BackendKind::Vulkan {
            // The driver's own triangles against optik's watertightness check (cached per
            // driver build): what decides whether they could serve the default.
            let name = "driver triangle check";
            match optik::triangle_check::check_driver_triangles(device.as_ref()) {
                Ok(check) => {
                    rows.push(vec![
                        kind.name().into(),
                        name.into(),
                        if check.passed { "passed" } else { "failed" }.into(),
                        format!(
                            "of {} rays, {} leaked and {} met two triangles or more",
                            check.rays, check.leaks, check.doubles
                        ),
                        "".into(),
                        "".into(),
                    ]);
                    report.push(json!({"section": "accuracy", "backend": kind.name(), "option": name,
                        "passed": check.passed, "rays": check.rays, "leaks": check.leaks, "doubles": check.doubles, "cached": check.cached}));
                }
                Err(e) => rows.push(accuracy_note(kind, name, format!("error: {}", e.message()))),
            }
        }
    }
    table(
        &format!(
            "Accuracy options: time on {}'s incoherent rays vs the default, and error",
            scene.name
        ),
        &[
            "backend",
            "option",
            "time vs default",
            "leaks (closed mesh at origin)",
            "leaks (at 1e5)",
            "camera prims differing from default",
        ],
        &rows,
    );
}

fn specialisation(opts: &ReportOptions, scene: &Scene, report: &mut Vec<Value>) {
    let forced: [(&str, PipelineCompileOptions); 6] = [
        ("specialised (Auto)", PipelineCompileOptions::default()),
        (
            "+ motion",
            PipelineCompileOptions {
                uses_motion_blur: Setting::Value(true),
                ..Default::default()
            },
        ),
        (
            "+ any graph (instancing)",
            PipelineCompileOptions {
                traversable_graph: Setting::Value(TraversableGraph::Any),
                ..Default::default()
            },
        ),
        (
            "+ every primitive type",
            PipelineCompileOptions {
                primitive_types: Setting::Value(PrimitiveTypeFlags::ALL),
                ..Default::default()
            },
        ),
        (
            "+ every exception check",
            PipelineCompileOptions {
                exception_flags: Setting::Value(ExceptionFlags::ALL),
                ..Default::default()
            },
        ),
        (
            "+ 32 payload registers",
            PipelineCompileOptions {
                num_payload_values: Setting::Value(32),
                ..Default::default()
            },
        ),
    ];
    let everything = PipelineCompileOptions {
        uses_motion_blur: Setting::Value(true),
        traversable_graph: Setting::Value(TraversableGraph::Any),
        primitive_types: Setting::Value(PrimitiveTypeFlags::ALL),
        exception_flags: Setting::Value(ExceptionFlags::ALL),
        num_payload_values: Setting::Value(32),
        num_attribute_values: Setting::Value(8),
        allow_opacity_micromaps: Setting::Value(true),
    };
    let mut rows = Vec::new();
    for &kind in &opts.backends {
        let Ok(device) = open(kind, opts.threads) else {
            continue;
        };
        let measure = |options: &PipelineCompileOptions| -> Result<(f64, String)> {
            let mut caster = RayCaster::with_options(
                device.as_ref(),
                &scene.mesh.positions,
                &scene.mesh.triangles,
                options,
            )?;
            let features = caster.features()?.names().join(" ");
            let (_, s) = caster.cast(&scene.incoherent, opts.repeat)?;
            Ok((s, features))
        };
        let pipelines: Vec<(&str, PipelineCompileOptions)> = forced
            .iter()
            .copied()
            .chain([("everything on", everything)])
            .collect();
        // Each pipeline's best over two passes through the list, as the accuracy rows.
        let mut measured: Vec<Result<(f64, String)>> =
            pipelines.iter().map(|(_, o)| measure(o)).collect();
        for ((_, options), m) in pipelines.iter().zip(measured.iter_mut()) {
            if let Ok((s, _)) = m
                && let Ok((again, _)) = measure(options)
            {
                *s = s.min(again);
            }
        }
        // The forced pipelines again with instances or a transform alive elsewhere on the
        // device: a launch's kernel keeps only the features some live structure has
        // (`FeatureSet::narrowed_to`), so only now do these compile the instance code (one
        // level with an instance structure, any graph with a transform), what that code
        // costs rays of a flat structure where a scene has instances.
        let mut general: Vec<(String, Result<(f64, String)>)> = Vec::new();
        for (alive, rows) in [
            (
                Alive::Instance,
                &[(2, "+ any graph, an instance alive")][..],
            ),
            (
                Alive::Transform,
                &[
                    (2, "+ any graph, a transform alive"),
                    (6, "everything on, a transform alive"),
                ][..],
            ),
        ] {
            let measured = with_alive(device.as_ref(), alive, || {
                rows.iter()
                    .map(|&(i, name)| {
                        let options = &pipelines[i].1;
                        let best = measure(options).and_then(|(s, f)| {
                            measure(options).map(|(again, _)| (s.min(again), f))
                        });
                        (name.to_string(), best)
                    })
                    .collect::<Vec<_>>()
            });
            match measured {
                Ok(rows) => general.extend(rows),
                Err(e) => general.push((format!("{alive:?} alive"), Err(e))),
            }
        }
        let mut base = None;
        let named = pipelines.iter().map(|(n, _)| n.to_string());
        for (name, measured) in named.zip(measured).chain(general) {
            match measured {
                Ok((s, features)) => {
                    let b = *base.get_or_insert(s);
                    rows.push(vec![
                        kind.name().into(),
                        name.clone(),
                        format!("{:.3}", s / b),
                        features.clone(),
                    ]);
                    report.push(json!({"section": "specialisation", "backend": kind.name(), "pipeline": name,
                        "time_vs_specialised": s / b, "features": features}));
                }
                Err(e) => rows.push(vec![
                    kind.name().into(),
                    name.clone(),
                    format!("error: {}", e.message()),
                    "".into(),
                ]),
            }
        }
    }
    table(
        &format!(
            "Specialisation: time on {}'s incoherent rays vs the specialised pipeline",
            scene.name
        ),
        &[
            "backend",
            "pipeline",
            "time vs specialised",
            "pipeline features (a launch's kernel leaves out those no live structure has)",
        ],
        &rows,
    );
}

/// What [`with_alive`] keeps alive.
#[derive(Clone, Copy, Debug)]
enum Alive {
    /// An instance structure over a one-triangle structure.
    Instance,
    /// A static transform over a one-triangle structure.
    Transform,
}

/// Runs `f` while `alive` is alive on `device`, so that pipelines forced to any graph
/// compile its code (wgpu narrows a launch's kernel to the live structures).
fn with_alive<T>(device: &dyn Device, alive: Alive, f: impl FnOnce() -> T) -> Result<T> {
    let triangle = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let other = match alive {
        Alive::Instance => RayCaster::instanced(device, &triangle, &[[0, 1, 2]], &[IDENTITY_3X4])?,
        Alive::Transform => RayCaster::new(device, &triangle, &[[0, 1, 2]])?,
    };
    let transform = match alive {
        Alive::Instance => None,
        Alive::Transform => Some(device.create_transform(&TransformDesc::Static {
            child: other.handle(),
            object_to_world: IDENTITY_3X4,
            world_to_object: IDENTITY_3X4,
        })?),
    };
    let out = f();
    if let Some(t) = transform {
        device.destroy_accel(t)?;
    }
    Ok(out)
}

fn scaling(opts: &ReportOptions, report: &mut Vec<Value>) {
    let mut rows = Vec::new();
    for subdivisions in [3u32, 5, 7] {
        let mesh = Mesh::icosphere(subdivisions);
        let incoherent = rays::incoherent(&mesh, opts.incoherent.min(100_000), 11);
        for &kind in &opts.backends {
            let Ok(device) = open(kind, opts.threads) else {
                continue;
            };
            let measured = (|| -> Result<(f64, f64)> {
                let mut caster = RayCaster::new(device.as_ref(), &mesh.positions, &mesh.triangles)?;
                let (_, s) = caster.cast(&incoherent, opts.repeat)?;
                Ok((caster.build_seconds, s))
            })();
            if let Ok((build, s)) = measured {
                let rate = mrays(incoherent.len() / 8, s);
                rows.push(vec![
                    mesh.triangles.len().to_string(),
                    kind.name().into(),
                    format!("{:.2}", build * 1e3),
                    format!("{rate:.2}"),
                ]);
                report.push(json!({"section": "scaling", "triangles": mesh.triangles.len(), "backend": kind.name(),
                    "build_s": build, "incoherent_mrays_per_s": rate}));
            }
        }
    }
    table(
        "Build and trace as the triangle count grows (icospheres)",
        &["triangles", "backend", "build ms", "incoherent Mrays/s"],
        &rows,
    );
}

/// The large scene: copies of an icosphere on a grid, as one flat mesh and as one mesh with
/// an instance per copy (`grid` copies per axis; `subdivisions` of each sphere).
pub struct GridScene {
    /// One sphere.
    pub sphere: Mesh,
    /// Each copy's object-to-world matrix (a translation), 3×4 row-major.
    pub transforms: Vec<[f32; 12]>,
    /// All copies in one mesh, copy `i`'s triangles at `i * sphere.triangles.len()`.
    pub flat: Mesh,
}

impl GridScene {
    /// Spheres of radius 1, centres 2.5 apart.
    pub fn new(subdivisions: u32, grid: [u32; 3]) -> GridScene {
        let sphere = Mesh::icosphere(subdivisions);
        let mut transforms = Vec::new();
        for z in 0..grid[2] {
            for y in 0..grid[1] {
                for x in 0..grid[0] {
                    let [tx, ty, tz] = [x, y, z].map(|c| c as f32 * 2.5);
                    transforms.push([1.0, 0.0, 0.0, tx, 0.0, 1.0, 0.0, ty, 0.0, 0.0, 1.0, tz]);
                }
            }
        }
        let mut flat = Mesh::default();
        for m in &transforms {
            let base = flat.positions.len() as u32;
            flat.positions.extend(
                sphere
                    .positions
                    .iter()
                    .map(|p| [p[0] + m[3], p[1] + m[7], p[2] + m[11]]),
            );
            flat.triangles
                .extend(sphere.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        GridScene {
            sphere,
            transforms,
            flat,
        }
    }
}

/// Section 5: 32 spheres of 327 680 triangles (10 485 760), flat and instanced, 2^24 rays.
fn scale(opts: &ReportOptions, report: &mut Vec<Value>) {
    let scene = GridScene::new(7, [4, 4, 2]);
    let rays = rays::incoherent(&scene.flat, 1 << 24, 17);
    let mut rows = Vec::new();
    for &kind in &opts.backends {
        let device = match open(kind, opts.threads) {
            Ok(d) => d,
            Err(why) => {
                rows.push(padded(
                    vec![
                        "".into(),
                        "".into(),
                        kind.name().into(),
                        format!("skipped: {why}"),
                    ],
                    7,
                ));
                continue;
            }
        };
        for instanced in [false, true] {
            let layout = if instanced {
                "instanced (32 × 327 680)"
            } else {
                "flat"
            };
            let measured = (|| -> Result<(f64, u64, f64, usize, usize)> {
                let mut caster = if instanced {
                    RayCaster::instanced(
                        device.as_ref(),
                        &scene.sphere.positions,
                        &scene.sphere.triangles,
                        &scene.transforms,
                    )?
                } else {
                    RayCaster::new(
                        device.as_ref(),
                        &scene.flat.positions,
                        &scene.flat.triangles,
                    )?
                };
                let launches = (rays.len() / 8).div_ceil(caster.batch_rays());
                let (hits, s) = caster.cast(&rays, opts.repeat.min(2))?;
                Ok((
                    caster.build_seconds,
                    caster.accel_bytes()?,
                    s,
                    launches,
                    hits.hit_count(),
                ))
            })();
            match measured {
                Ok((build, bytes, s, launches, hit_count)) => {
                    let rate = mrays(rays.len() / 8, s);
                    rows.push(vec![
                        layout.into(),
                        scene.flat.triangles.len().to_string(),
                        kind.name().into(),
                        format!("{build:.2}"),
                        format!("{:.0}", bytes as f64 / (1 << 20) as f64),
                        format!("{rate:.2}"),
                        format!("{launches} ({hit_count} hits)"),
                    ]);
                    report.push(json!({"section": "scale", "layout": if instanced { "instanced" } else { "flat" },
                        "triangles": scene.flat.triangles.len(), "rays": rays.len() / 8, "backend": kind.name(),
                        "build_s": build, "accel_bytes": bytes, "incoherent_mrays_per_s": rate,
                        "launches": launches, "hits": hit_count}));
                }
                Err(e) => rows.push(padded(
                    vec![
                        layout.into(),
                        scene.flat.triangles.len().to_string(),
                        kind.name().into(),
                        format!("failed: {e}"),
                    ],
                    7,
                )),
            }
        }
    }
    table(
        "Scale: 10 485 760 triangles, 16 777 216 incoherent rays",
        &[
            "scene",
            "triangles",
            "backend",
            "build s",
            "structures MiB",
            "Mrays/s",
            "launches",
        ],
        &rows,
    );
}

/// Runs the whole report; returns its figures as JSON.
pub fn run(opts: &ReportOptions) -> Value {
    println!("# optik benchmark report\n");
    for s in optik::backend_statuses() {
        match &s.availability {
            Ok(d) => println!("- {}: {d}", s.kind),
            Err(why) => println!("- {}: not available ({why})", s.kind),
        }
    }
    let mut report = Vec::new();
    let scenes = scenes(opts);
    throughput(opts, &scenes, &mut report);
    if let Some(scene) = scenes.last() {
        accuracy(opts, scene, &mut report);
        specialisation(opts, scene, &mut report);
    }
    scaling(opts, &mut report);
    if opts.scale {
        scale(opts, &mut report);
    }
    json!({ "width": opts.width, "height": opts.height, "incoherent": opts.incoherent, "repeat": opts.repeat, "rows": report })
}

/// The Embree peer script in this source tree.
pub fn default_peer_script() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/embree/peer.py"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three rounds, Embree missing from the second: medians over the rounds, and Embree's
    /// rows paired with optik's at the same thread count, round by round.
    #[test]
    fn cpu_rows_pair_each_thread_count_with_embree_round_by_round() {
        // A million camera rays and two million incoherent ones: Mrays/s = 1/s and 2/s.
        let rays = [1_000_000, 2_000_000];
        let round = |build, all, one| {
            Some(EmbreeRound {
                build,
                trace: [all, one],
            })
        };
        let m = CpuRounds {
            build: [0.010, 0.020],
            optik: [
                vec![[0.5, 0.5], [0.25, 1.0], [1.0, 0.4]],
                vec![[1.0, 2.0], [1.0, 2.0], [2.0, 1.0]],
            ],
            embree: vec![
                round(0.03, [0.5, 1.0], [2.0, 2.0]),
                None,
                round(0.05, [0.2, 0.8], [1.0, 4.0]),
            ],
        };
        let (optik, embree) = cpu_rows("s", ["cpu-4", "cpu-1"], 4, rays, &m, Some(7));
        let cells: Vec<Vec<String>> = optik
            .iter()
            .chain(&embree)
            .map(|r| r.cells.clone())
            .collect();
        assert_eq!(
            cells,
            [
                ["s", "cpu-4", "10.0", "2.00", "4.00", "1.00x / 1.00x"],
                [
                    "s",
                    "optik CPU, 1 thread",
                    "20.0",
                    "1.00",
                    "1.00",
                    "0.50x / 0.25x"
                ],
                [
                    "s",
                    "Embree robust, 1 thread",
                    "40.0",
                    "0.75",
                    "0.75",
                    "1.25 (0.50–2.00) / 2.50 (1.00–4.00); 7 camera prims differ"
                ],
                [
                    "s",
                    "Embree robust, 4 threads",
                    "40.0",
                    "3.50",
                    "2.25",
                    "0.60 (0.20–1.00) / 2.00 (2.00–2.00); 7 camera prims differ"
                ],
            ]
            .map(|row| row.map(String::from).to_vec())
        );
        assert_eq!(optik[1].json["device"], "cpu-1");
        assert_eq!(optik[1].json["threads"], 1);
        assert_eq!(optik[0].json["camera_mrays_per_s"], 2.0);
        assert_eq!(
            optik[0].json["camera_mrays_per_s_rounds"],
            json!([2.0, 4.0, 1.0])
        );
        assert_eq!(
            embree[0].json["camera_mrays_per_s_rounds"],
            json!([0.5, null, 1.0])
        );
        assert_eq!(
            embree[0].json["camera_optik_over_embree_rounds"],
            json!([2.0, null, 0.5])
        );
        let rate = embree[1].json["incoherent_mrays_per_s"].as_f64();
        assert!(rate.is_some_and(|r| (r - 2.25).abs() < 1e-9), "{rate:?}");
    }

    /// One round gives plain ratios; without Embree there are no Embree rows.
    #[test]
    fn cpu_rows_of_one_round_and_without_embree() {
        let mut m = CpuRounds {
            build: [0.001, 0.002],
            optik: [vec![[0.5, 1.0]], vec![[1.0, 2.0]]],
            embree: vec![Some(EmbreeRound {
                build: 0.004,
                trace: [[0.25, 2.0], [0.5, 4.0]],
            })],
        };
        let (_, embree) = cpu_rows("s", ["a", "b"], 2, [1_000_000; 2], &m, None);
        assert_eq!(embree[0].cells[5], "0.50 / 2.00");
        assert_eq!(embree[1].cells[5], "0.50 / 2.00");
        m.embree = vec![None];
        let (optik, embree) = cpu_rows("s", ["a", "b"], 2, [1_000_000; 2], &m, None);
        assert_eq!(optik.len(), 2);
        assert!(embree.is_empty());
    }

    /// The flat and the instanced layout of the scale scene are the same scene: a ray hits
    /// copy `i`'s triangle `p` in one exactly where it hits triangle `p` of instance `i` in the
    /// other (distances equal up to the rounding of the translated vertices).
    #[test]
    fn flat_and_instanced_grid_scenes_agree() {
        let scene = GridScene::new(2, [2, 2, 2]);
        let per_copy = scene.sphere.triangles.len() as u32;
        assert_eq!(scene.flat.triangles.len() as u32, 8 * per_copy);
        let device = optik::open_backend(BackendKind::Cpu).expect("the CPU backend");
        let rays = rays::incoherent(&scene.flat, 4000, 3);
        let mut flat = RayCaster::new(
            device.as_ref(),
            &scene.flat.positions,
            &scene.flat.triangles,
        )
        .expect("flat caster");
        let mut instanced = RayCaster::instanced(
            device.as_ref(),
            &scene.sphere.positions,
            &scene.sphere.triangles,
            &scene.transforms,
        )
        .expect("instanced caster");
        let (a, _) = flat.cast(&rays, 1).expect("flat cast");
        let (b, _) = instanced.cast(&rays, 1).expect("instanced cast");
        let mut same = 0;
        for i in 0..a.prim.len() {
            let flat_hit = (a.prim[i] != optik::raycast::NO_HIT)
                .then(|| (a.prim[i] / per_copy, a.prim[i] % per_copy));
            let inst_hit = (b.prim[i] != optik::raycast::NO_HIT).then(|| (b.inst[i], b.prim[i]));
            if flat_hit == inst_hit
                && (flat_hit.is_none() || (a.t[i] - b.t[i]).abs() <= 1e-4 * a.t[i].abs())
            {
                same += 1;
            }
        }
        assert!(a.hit_count() > 1000, "{} hits", a.hit_count());
        assert!(same >= a.prim.len() - 4, "{same} of {} agree", a.prim.len());
        assert!(instanced.accel_bytes().unwrap() < flat.accel_bytes().unwrap());
    }

    /// Rounds interleave the CPU backend with Embree: with either left out, one round runs
    /// and the reason is named (the CLI's warning prints it).
    #[test]
    fn rounds_apply_only_to_the_cpu_backend_beside_embree() {
        let opts = |backends: Vec<BackendKind>, embree: bool| ReportOptions {
            scenes: PathBuf::new(),
            backends,
            width: 1,
            height: 1,
            incoherent: 1,
            repeat: 1,
            threads: None,
            embree,
            rounds: 5,
            peer_script: PathBuf::new(),
            python: "python3".into(),
            scale: false,
        };
        let both = opts(vec![BackendKind::Wgpu, BackendKind::Cpu], true);
        assert_eq!(both.interleaved_rounds(), 5);
        assert_eq!(both.rounds_ignored_because(), None);
        let no_embree = opts(vec![BackendKind::Cpu], false);
        assert_eq!(no_embree.interleaved_rounds(), 1);
        assert_eq!(
            no_embree.rounds_ignored_because(),
            Some("Embree is left out")
        );
        let no_cpu = opts(vec![BackendKind::Wgpu], true);
        assert_eq!(no_cpu.interleaved_rounds(), 1);
        assert_eq!(
            no_cpu.rounds_ignored_because(),
            Some("the CPU backend is not measured")
        );
    }

    /// The Embree peer's failures are errors that say what went wrong, and leave no
    /// temporary files: a Python that cannot start, a peer that prints nothing, and a result
    /// without one of its figures (which once read as NaN).
    #[test]
    fn embree_peer_failures_are_errors_and_leave_no_files() {
        let folder = tempfile_folder();
        let peer = folder.join("peer.sh");
        std::fs::write(&peer, "echo '{\"build_s\": 0.5, \"trace_s_1\": 1.0}'\n").unwrap();
        let opts = |python: &str, peer_script: &Path| ReportOptions {
            scenes: PathBuf::new(),
            backends: vec![BackendKind::Cpu],
            width: 1,
            height: 1,
            incoherent: 1,
            repeat: 1,
            threads: Some(1),
            embree: true,
            rounds: 1,
            peer_script: peer_script.to_path_buf(),
            python: python.into(),
            scale: false,
        };
        let mesh = Mesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
            ..Mesh::default()
        };
        let rays = [0.0f32; 8];
        let inputs = std::env::temp_dir().join(format!("optik-report-{}", std::process::id()));
        let cases = [
            (
                opts("/nonexistent/python", &peer),
                "cannot run /nonexistent/python",
            ),
            (opts("/bin/false", &peer), "peer.py printed no result"),
            (opts("sh", &peer), "no number \"trace_s_n\""),
        ];
        for (o, expected) in cases {
            let err = embree(&o, &mesh, &rays, 1).expect_err(expected);
            assert!(err.contains(expected), "{err:?} should say {expected:?}");
            assert!(!inputs.exists(), "{} left behind", inputs.display());
        }
        let _ = std::fs::remove_dir_all(&folder);
    }

    /// A fresh folder for one test.
    fn tempfile_folder() -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "optik-report-test-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// `bench-report` traces the rays `bench-cpu` traces: each scene's own camera (the
    /// Breakfast Room's Mitsuba sensor, not a framing view) and the same incoherent rays.
    #[test]
    fn report_scenes_trace_bench_cpu_rays() {
        let dir = tempfile_folder();
        // One triangle per file is enough: the rays depend on the mesh only through its box.
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 1\nf 1 2 3\n";
        for scene in crate::scenes::ALL {
            let path = dir.join(scene.file);
            std::fs::create_dir_all(path.parent().expect("a scene file is in a folder"))
                .expect("temporary folder");
            std::fs::write(&path, obj).expect("temporary scene file");
        }
        let (width, height) = crate::scenes::CAMERA_SIZE;
        let opts = ReportOptions {
            scenes: dir.clone(),
            backends: vec![BackendKind::Cpu],
            width,
            height,
            incoherent: crate::scenes::INCOHERENT_RAYS,
            repeat: 1,
            threads: None,
            embree: false,
            rounds: 1,
            peer_script: PathBuf::new(),
            python: "python3".into(),
            scale: false,
        };
        let found = scenes(&opts);
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(found.len(), crate::scenes::ALL.len());
        for (scene, bench) in found.iter().zip(crate::scenes::ALL) {
            let [camera, incoherent] = crate::scenes::ray_sets(&bench, &scene.mesh);
            assert_eq!(scene.name, bench.name.replace(' ', "-"));
            assert!(scene.camera == camera.rays, "{}: camera rays", scene.name);
            assert!(
                scene.incoherent == incoherent.rays,
                "{}: incoherent",
                scene.name
            );
        }
    }
}
