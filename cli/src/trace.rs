//! `optik trace`: casts rays from a NumPy file against a mesh through the public API
//! ([`optik::raycast`]) and writes the hits to a `.npz` file, printing one JSON line.

use optik::raycast::{self, RAY_FLOATS};
use optik::{Accuracy, BackendChoice, BackendKind};
use optik_io::array::{self, Member};
use std::path::{Path, PathBuf};

/// What `optik trace --help` adds below the options: the file formats, the miss encoding and
/// the exit codes.
const AFTER_HELP: &str = "\
Input:
  --mesh   a triangle mesh: Wavefront .obj (or gzip-compressed .obj.gz; all objects merged) or
           .ply (ASCII or binary, either endianness). Triangles are numbered in file order;
           a face of n > 3 vertices becomes n - 2 triangles (v0, vi, vi+1). A mesh with no
           triangles, or a face index that names no vertex, is an error.
  --rays   a .npy array of dtype float32 and shape (N, 8), C order: per ray origin x, y, z,
           tmin, direction x, y, z, tmax. N may be 0. t is measured in units of the
           direction's length; hits are accepted for tmin < t < tmax (tmax may be inf).

Output (--out, a .npz as np.savez writes; np.load(path)['t'] etc., each of shape (N,)):
  t     float32  distance to the closest hit (+inf on a miss)
  prim  uint32   index of the triangle hit (0xFFFFFFFF on a miss)
  inst  uint32   instance id, 0 for the mesh (0xFFFFFFFF on a miss)
  u, v  float32  barycentric weights of the triangle's second and third vertices: the hit
                 point is (1 - u - v) * v0 + u * v1 + v * v2 (both 0 on a miss)
  An invalid ray (NaN or infinite origin or direction, tmin < 0 or NaN, tmax NaN, or
  tmin > tmax) is a miss. The file is written to a temporary file beside --out and renamed
  over it, so a failed run leaves an existing --out untouched.

stdout: one JSON line: backend, rays, triangles, hits, misses (invalid rays included),
  invalid_rays, threads (CPU only), build_s, trace_s (best of --repeat), mrays_per_s.

Exit status: 0 success; 1 the work failed (an unreadable or invalid mesh or ray file, a
  device error, a failed write); 2 a usage error (an unknown option or a bad option value,
  --out in a missing or unwritable folder, --out naming an input file).";

/// Arguments of `optik trace`.
#[derive(clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct TraceArgs {
    /// The mesh: .obj, .obj.gz or .ply.
    #[arg(long)]
    mesh: PathBuf,
    /// float32 .npy array of shape (N, 8): origin xyz, tmin, direction xyz, tmax.
    #[arg(long)]
    rays: PathBuf,
    /// Output .npz with arrays t, prim, inst, u, v (see below).
    #[arg(long)]
    out: PathBuf,
    /// cpu, wgpu, vulkan or auto (the first that runs of vulkan, wgpu, cpu).
    #[arg(long, default_value = "auto")]
    backend: String,
    /// CPU worker threads (default: all cores); results do not depend on it.
    #[arg(long, value_parser = crate::args::threads)]
    threads: Option<usize>,
    /// robust (default), fast, or TRIANGLE+BOX: TRIANGLE watertight, mt or driver (Vulkan only); BOX conservative or plain.
    #[arg(long, default_value = "robust")]
    accuracy: String,
    /// Launches to time (at least 1); the best is reported.
    #[arg(long, default_value_t = 1, value_parser = crate::args::repeat)]
    repeat: usize,
}

/// Why the command failed, which decides the exit status.
enum Failure {
    /// Bad arguments: exit status 2.
    Usage(String),
    /// The work failed: exit status 1.
    Work(String),
}

impl From<optik::Error> for Failure {
    fn from(e: optik::Error) -> Self {
        Failure::Work(e.to_string())
    }
}

impl From<optik_io::IoError> for Failure {
    fn from(e: optik_io::IoError) -> Self {
        Failure::Work(e.to_string())
    }
}

/// Runs the command; returns the exit status.
pub fn run(args: &TraceArgs) -> u8 {
    match trace(args) {
        Ok(json) => {
            outln!("{json}");
            0
        }
        Err(Failure::Usage(e)) => {
            eprintln!("optik trace: {e}");
            2
        }
        Err(Failure::Work(e)) => {
            eprintln!("optik trace: {e}");
            1
        }
    }
}

/// Whether `a` and `b` name the same existing file.
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

fn trace(args: &TraceArgs) -> Result<serde_json::Value, Failure> {
    let choice = BackendChoice::parse(&args.backend).ok_or_else(|| {
        Failure::Usage(format!(
            "--backend {:?}: expected cpu, wgpu, vulkan or auto",
            args.backend
        ))
    })?;
    let accuracy = Accuracy::parse(&args.accuracy).ok_or_else(|| {
        Failure::Usage(format!(
            "--accuracy {:?}: expected robust, fast, or TRIANGLE+BOX with TRIANGLE watertight|mt|driver (driver: Vulkan only) and BOX conservative|plain (e.g. mt+conservative)",
            args.accuracy
        ))
    })?;
    for (flag, input) in [("--mesh", &args.mesh), ("--rays", &args.rays)] {
        if same_file(&args.out, input) {
            return Err(Failure::Usage(format!(
                "--out {} is the {flag} input; choose another output path",
                args.out.display()
            )));
        }
    }
    // Before any work: a bad output path must not cost a whole trace.
    optik_io::output::check_writable(&args.out)
        .map_err(|e| Failure::Usage(format!("--out {e}")))?;

    let mesh = optik_io::mesh::read_mesh(&args.mesh)?;
    let rays = array::read_npy::<f32>(&args.rays)?;
    if rays.shape.len() != 2 || rays.shape[1] != RAY_FLOATS {
        return Err(Failure::Work(format!(
            "{}: shape is {:?}; expected (N, 8): origin xyz, tmin, direction xyz, tmax",
            args.rays.display(),
            rays.shape
        )));
    }
    let options = optik::OpenOptions {
        threads: args.threads,
    };
    let device = optik::open_with(choice, &options)?;
    for warning in options.ignored_by(device.backend()) {
        eprintln!("optik trace: warning: {warning}");
    }
    if accuracy != device.accuracy() {
        device.set_accuracy(accuracy)?;
    }
    let mut caster = raycast::RayCaster::new(device.as_ref(), &mesh.positions, &mesh.triangles)?;
    let (hits, trace_s) = caster.cast(&rays.data, args.repeat)?;
    let n = rays.shape[0];
    let members = [
        Member::new("t", &[n], &hits.t),
        Member::new("prim", &[n], &hits.prim),
        Member::new("inst", &[n], &hits.inst),
        Member::new("u", &[n], &hits.u),
        Member::new("v", &[n], &hits.v),
    ]
    .into_iter()
    .collect::<Result<Vec<_>, String>>()
    .map_err(|e| Failure::Work(format!("{}: {e}", args.out.display())))?;
    array::write_npz(&args.out, &members)?;
    let hit_count = hits.hit_count();
    let backend = device.backend();
    let threads = match backend {
        BackendKind::Cpu => serde_json::json!(args.threads.unwrap_or_else(optik::available_cores)),
        _ => serde_json::Value::Null,
    };
    Ok(serde_json::json!({
        "backend": backend.name(),
        "rays": n,
        "triangles": mesh.triangles.len(),
        "hits": hit_count,
        "misses": n - hit_count,
        "invalid_rays": raycast::invalid_ray_count(&rays.data),
        "threads": threads,
        "build_s": caster.build_seconds,
        "trace_s": trace_s,
        "mrays_per_s": if trace_s > 0.0 { n as f64 / trace_s / 1e6 } else { 0.0 },
    }))
}
