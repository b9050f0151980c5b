//! `optik render`: renders a Mitsuba 3 XML scene or an OBJ model with optik's path tracer
//! (`optik-render`) and writes a linear float32 EXR or an sRGB PNG.

use optik::{BackendChoice, OpenOptions};
use optik_render::{Frame, Progress, RenderFeatures, RenderOptions};
use std::io::IsTerminal;
use std::path::PathBuf;

/// What `optik render --help` adds below the options.
const AFTER_HELP: &str = "\
The scene: a Mitsuba 3 scene (.xml; -D name=value sets its $name parameters, as Mitsuba's -D)
  or an OBJ+MTL model (.obj). --spp overrides the scene's sample count, --seed its seed; the
  same seed gives the same image on every backend, thread count and launch batching.

Output: .exr is linear float32 R, G, B (with --aovs, also albedo.R/G/B and normal.X/Y/Z of the
  first hit); .png is 8-bit sRGB of the clamped image. A progress bar with samples/s and
  Mrays/s shows on a terminal.

--features prints what the scene calls for (BSDF kinds, textures, emitters, instancing, max
  depth, shadow rays, payload registers) and the programs compiled for it.

Exit status: 0 success; 1 the work failed (an invalid scene, a device error, a failed
  write); 2 a usage error.";

/// Arguments of `optik render`.
#[derive(clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct RenderArgs {
    /// The scene: .xml (Mitsuba 3) or .obj.
    scene: PathBuf,
    /// Output image: .exr or .png.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Samples per pixel (default: the scene's).
    #[arg(long)]
    spp: Option<u32>,
    /// Seed of the per-pixel random numbers (default: the scene's).
    #[arg(long)]
    seed: Option<u32>,
    /// cpu, wgpu, vulkan or auto (the first that runs of vulkan, wgpu, cpu).
    #[arg(long, default_value = "auto")]
    backend: String,
    /// CPU worker threads (default: all cores); the image does not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Sets a scene parameter: -D name=value (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    defines: Vec<String>,
    /// Prints the scene's features and the programs compiled for it.
    #[arg(long)]
    features: bool,
    /// Keeps the first hit's albedo and normal as extra EXR layers.
    #[arg(long)]
    aovs: bool,
}

/// Runs the command; returns the exit status.
pub fn run(args: &RenderArgs) -> u8 {
    let mut defines = Vec::new();
    for d in &args.defines {
        match d.split_once('=') {
            Some((k, v)) if !k.is_empty() => defines.push((k.to_string(), v.to_string())),
            _ => {
                eprintln!("optik render: -D {d}: expected NAME=VALUE");
                return 2;
            }
        }
    }
    let Some(choice) = BackendChoice::parse(&args.backend) else {
        eprintln!(
            "optik render: --backend {}: expected cpu, wgpu, vulkan or auto",
            args.backend
        );
        return 2;
    };
    if args.out.is_none() && !args.features {
        eprintln!("optik render: nothing to do: give --out FILE.exr|png (or --features)");
        return 2;
    }
    if let Some(out) = &args.out {
        if let Err(e) = optik_render::output::Format::of_path(out) {
            eprintln!("optik render: --out: {e}");
            return 2;
        }
        let folder = match out.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => std::path::Path::new("."),
        };
        if !folder.is_dir() {
            eprintln!(
                "optik render: --out {}: the folder {} does not exist",
                out.display(),
                folder.display()
            );
            return 2;
        }
    }
    let scene = match optik_render::scene::load(&args.scene, &defines) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("optik render: {e}");
            return 1;
        }
    };
    for w in &scene.warnings {
        eprintln!("optik render: warning: {}: {}", w.at, w.message);
    }
    if args.features {
        let f = RenderFeatures::of(&scene, args.aovs);
        outln!("{}", f.describe().trim_end());
        outln!("programs: {}", f.programs().join(", "));
    }
    let Some(out) = &args.out else { return 0 };
    let device = match optik::open_with(
        choice,
        &OpenOptions {
            threads: args.threads,
        },
    ) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("optik render: {e}");
            return 1;
        }
    };
    let options = RenderOptions {
        spp: args.spp,
        seed: args.seed,
        want_variance: false,
        want_aovs: args.aovs,
        samples_per_launch: None,
    };
    let pixels = scene.film.width as u64 * scene.film.height as u64;
    let frame = if std::io::stderr().is_terminal() {
        let mut bar = ProgressBar::new(pixels);
        optik_render::render_with_progress(device.as_ref(), &scene, &options, &mut |p| {
            bar.update(p)
        })
    } else {
        optik_render::render(device.as_ref(), &scene, &options)
    };
    let frame: Frame = match frame {
        Ok(f) => f,
        Err(e) => {
            eprintln!("optik render: {e}");
            return 1;
        }
    };
    if let Err(e) = optik_render::output::write(&frame, out) {
        eprintln!("optik render: {e}");
        return 1;
    }
    let s = &frame.stats;
    let samples = pixels as f64 * frame.spp as f64;
    outln!(
        "{}: {}x{} at {} spp on {} in {:.2} s ({:.2} Msamples/s, {:.2} Mrays/s; setup {:.2} s)",
        out.display(),
        frame.width,
        frame.height,
        frame.spp,
        device.backend(),
        s.render_seconds,
        samples / s.render_seconds.max(1e-9) / 1e6,
        s.rays / s.render_seconds.max(1e-9) / 1e6,
        s.setup_seconds
    );
    0
}

/// A one-line progress bar on stderr with samples/s.
struct ProgressBar {
    pixels: u64,
    start: std::time::Instant,
}

impl ProgressBar {
    fn new(pixels: u64) -> Self {
        ProgressBar {
            pixels,
            start: std::time::Instant::now(),
        }
    }

    fn update(&mut self, p: Progress) {
        let width = 30;
        let filled = (p.done as u64 * width / p.total.max(1) as u64) as usize;
        let secs = self.start.elapsed().as_secs_f64().max(1e-9);
        let rate = self.pixels as f64 * p.done as f64 / secs / 1e6;
        eprint!(
            "\r[{}{}] {}/{} spp, {:.2} Msamples/s",
            "#".repeat(filled),
            " ".repeat(width as usize - filled),
            p.done,
            p.total,
            rate
        );
        if p.done == p.total {
            eprintln!();
        }
    }
}
