//! `optik trace`: casts rays from a NumPy file against a mesh through the public API and writes
//! the hits to a `.npz` file, printing one JSON line of timings.

use optik::{Accuracy, BackendChoice, BackendKind};
use optik_benches::{mesh, npy, raycast};
use std::path::PathBuf;

/// Arguments of `optik trace`.
#[derive(clap::Args)]
pub struct TraceArgs {
    /// The mesh: .obj, .obj.gz or .ply.
    #[arg(long)]
    mesh: PathBuf,
    /// float32 array of shape (N, 8): origin xyz, tmin, direction xyz, tmax.
    #[arg(long)]
    rays: PathBuf,
    /// Output .npz with arrays t, prim, inst, u, v.
    #[arg(long)]
    out: PathBuf,
    /// cpu, wgpu, vulkan or auto.
    #[arg(long, default_value = "auto")]
    backend: String,
    /// CPU worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// robust (default), fast, or TRIANGLE+BOX: TRIANGLE watertight, mt or driver (Vulkan only); BOX conservative or plain.
    #[arg(long, default_value = "robust")]
    accuracy: String,
    /// Launches to time; the best is reported.
    #[arg(long, default_value_t = 1)]
    repeat: usize,
}

/// Runs the command; returns the exit status.
pub fn run(args: &TraceArgs) -> u8 {
    match trace(args) {
        Ok(json) => {
            outln!("{json}");
            0
        }
        Err(e) => {
            eprintln!("optik trace: {e}");
            1
        }
    }
}

fn trace(args: &TraceArgs) -> optik::Result<serde_json::Value> {
    let choice = BackendChoice::parse(&args.backend).ok_or_else(|| {
        optik::Error::invalid(format!(
            "--backend {:?}: expected cpu, wgpu, vulkan or auto",
            args.backend
        ))
    })?;
    let accuracy = Accuracy::parse(&args.accuracy).ok_or_else(|| {
        optik::Error::invalid(format!(
            "--accuracy {:?}: expected robust, fast, or TRIANGLE+BOX with TRIANGLE watertight|mt|driver (driver: Vulkan only) and BOX conservative|plain (e.g. mt+conservative)",
            args.accuracy
        ))
    })?;
    if args.threads == Some(0) {
        return Err(optik::Error::invalid(
            "--threads 0: give at least one thread",
        ));
    }
    let mesh = mesh::load(&args.mesh)?;
    let bytes = std::fs::read(&args.rays)
        .map_err(|e| optik::Error::from(e).context(args.rays.display()))?;
    let rays = npy::read_f32(&bytes, &args.rays.display().to_string())?;
    if rays.shape.len() != 2 || rays.shape[1] != raycast::RAY_FLOATS {
        return Err(optik::Error::invalid(format!(
            "{}: shape is {:?}; expected (N, 8): origin xyz, tmin, direction xyz, tmax",
            args.rays.display(),
            rays.shape
        )));
    }
    let device = optik::open_with(
        choice,
        &optik::OpenOptions {
            threads: args.threads,
        },
    )?;
    if accuracy != device.accuracy() {
        device.set_accuracy(accuracy)?;
    }
    let mut caster = raycast::RayCaster::new(device.as_ref(), &mesh)?;
    let (hits, trace_s) = caster.cast(&rays.data, args.repeat)?;
    let n = hits.t.len();
    npy::write_npz(
        &args.out,
        &[
            ("t", npy::encode(&[n], &hits.t)),
            ("prim", npy::encode(&[n], &hits.prim)),
            ("inst", npy::encode(&[n], &hits.inst)),
            ("u", npy::encode(&[n], &hits.u)),
            ("v", npy::encode(&[n], &hits.v)),
        ],
    )?;
    let backend = device.backend();
    let threads = match backend {
        BackendKind::Cpu => serde_json::json!(
            args.threads
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        ),
        _ => serde_json::Value::Null,
    };
    Ok(serde_json::json!({
        "backend": backend.name(),
        "rays": n,
        "threads": threads,
        "build_s": caster.build_seconds,
        "trace_s": trace_s,
        "mrays_per_s": if trace_s > 0.0 { n as f64 / trace_s / 1e6 } else { 0.0 },
    }))
}
