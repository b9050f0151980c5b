//! `optik render`: renders a Mitsuba 3 XML scene or an OBJ model with optik's path tracer
//! (`optik-render`) and writes a linear float32 EXR or an sRGB PNG; its modes print the
//! pipeline built (`--features`), time the specialised pipeline against the all-effects one
//! (`--benchmark`) and measure error against time per accuracy setting (`--convergence`).

use optik::{BackendChoice, Device, OpenOptions};
use optik_render::modes::benchmark::{BenchmarkOptions, benchmark};
use optik_render::modes::convergence::{accuracy_name, accuracy_settings, convergence};
use optik_render::modes::plot::plot_png;
use optik_render::scene::Scene;
use optik_render::{Effects, Frame, RenderOptions, Renderer, denoise};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// What `optik render --help` adds below the options.
const AFTER_HELP: &str = "\
The scene: a Mitsuba 3 scene (.xml; -D name=value sets its $name parameters, as Mitsuba's -D)
  or an OBJ+MTL model (.obj). --spp overrides the scene's sample count, --seed its seed; the
  same seed gives the same image on every backend, thread count and launch batching.

Output: .exr is linear float32 R, G, B (with --aovs, also albedo.R/G/B and normal.X/Y/Z of the
  first hit); .png is 8-bit sRGB of the clamped image. A progress bar with samples/s and
  Mrays/s shows when stderr is a terminal.

--features prints what the scene calls for (BSDF kinds, textures, emitters, instancing, max
  depth, shadow rays, payload registers), the programs and compile options of the pipeline
  built from it, and the traversal features the backend compiled. Without --out it only
  builds the pipeline.

--denoise denoises the image guided by the first hit's albedo and normal: with Intel Open
  Image Denoise when its library loads (scripts/oidn-setup installs it; OPTIK_OIDN_LIB names
  it), else with optik's edge-aware a-trous filter. It prints which denoiser ran.

--benchmark renders the scene with the specialised pipeline and with one compiling every
  effect (all BSDF kinds, shadow rays, environment, 32 payload registers, every traversal
  feature), in --rounds interleaved timed runs after a warm-up, and prints the all-effects /
  specialised time ratio per backend and a z-test that the two images agree. --backend takes
  a list here (cpu,wgpu,vulkan). No --out.

--convergence REF.exr renders at 1, 2, 4, ... up to --spp samples per pixel for each accuracy
  setting (triangle test x box test) the backend runs, prints relative MSE against REF.exr
  ((x-r)^2/(r^2+0.01), averaged) and render time, and plots them to --out PLOT.png (log-log,
  no text: the command prints the legend). --backend takes a list here.

Exit status: 0 success; 1 the work failed (an invalid scene, a device error, a failed
  write, images of the benchmark's two pipelines that disagree); 2 a usage error.";

/// Arguments of `optik render`.
#[derive(clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct RenderArgs {
    /// The scene: .xml (Mitsuba 3) or .obj.
    scene: PathBuf,
    /// Output image: .exr or .png (with --convergence: the plot, .png).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Samples per pixel (default: the scene's; with --convergence, the most).
    #[arg(long)]
    spp: Option<u32>,
    /// Seed of the per-pixel random numbers (default: the scene's).
    #[arg(long)]
    seed: Option<u32>,
    /// cpu, wgpu, vulkan or auto (the first that runs of vulkan, wgpu, cpu); a list such as
    /// cpu,wgpu,vulkan with --benchmark and --convergence.
    #[arg(long, default_value = "auto")]
    backend: String,
    /// CPU worker threads (default: all cores); the image does not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Sets a scene parameter: -D name=value (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    defines: Vec<String>,
    /// Prints the scene's features, the programs compiled for it and the pipeline options.
    #[arg(long)]
    features: bool,
    /// Keeps the first hit's albedo and normal as extra EXR layers.
    #[arg(long)]
    aovs: bool,
    /// Denoises the image (OIDN when installed, else the à-trous filter) and says which ran.
    #[arg(long, conflicts_with_all = ["benchmark", "convergence"])]
    denoise: bool,
    /// Times the specialised pipeline against the all-effects one and prints the ratio.
    #[arg(long, conflicts_with = "convergence")]
    benchmark: bool,
    /// Timed runs of each pipeline in --benchmark (at least 1).
    #[arg(long, default_value_t = 5, requires = "benchmark")]
    rounds: u32,
    /// Measures relative MSE against this EXR versus time, per accuracy setting.
    #[arg(long, value_name = "REF.exr")]
    convergence: Option<PathBuf>,
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
    let mut choices = Vec::new();
    for name in args.backend.split(',') {
        let Some(choice) = BackendChoice::parse(name.trim()) else {
            eprintln!(
                "optik render: --backend {}: expected cpu, wgpu, vulkan or auto{}",
                args.backend,
                if args.benchmark || args.convergence.is_some() {
                    ", or a comma-separated list of them"
                } else {
                    ""
                }
            );
            return 2;
        };
        choices.push(choice);
    }
    let modes = args.benchmark || args.convergence.is_some();
    if choices.len() > 1 && !modes {
        eprintln!(
            "optik render: --backend {}: one backend renders an image (lists are for \
             --benchmark and --convergence)",
            args.backend
        );
        return 2;
    }
    if args.spp == Some(0) {
        eprintln!("optik render: --spp 0: expected at least 1 sample per pixel");
        return 2;
    }
    if args.rounds == 0 {
        eprintln!("optik render: --rounds 0: expected at least 1");
        return 2;
    }
    if args.benchmark && args.out.is_some() {
        eprintln!("optik render: --benchmark writes no image: leave out --out");
        return 2;
    }
    if args.out.is_none() && !args.features && !modes {
        eprintln!(
            "optik render: nothing to do: give --out FILE.exr|png (or --features, --benchmark \
             or --convergence)"
        );
        return 2;
    }
    if let Some(out) = &args.out {
        if args.convergence.is_some() {
            if out.extension().and_then(|e| e.to_str()) != Some("png") {
                eprintln!(
                    "optik render: --out {}: with --convergence, expected the plot's .png",
                    out.display()
                );
                return 2;
            }
        } else if let Err(e) = optik_render::output::Format::of_path(out) {
            eprintln!("optik render: --out: {e}");
            return 2;
        }
        let folder = match out.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
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
    if let Some(reference) = args.convergence.as_ref().filter(|r| !r.is_file()) {
        eprintln!(
            "optik render: --convergence {}: no such file (expected the reference EXR)",
            reference.display()
        );
        return 2;
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
    let open = |choice: BackendChoice| match optik::open_with(
        choice,
        &OpenOptions {
            threads: args.threads,
        },
    ) {
        Ok(d) => Some(d),
        Err(e) => {
            eprintln!("optik render: {e}");
            None
        }
    };
    if args.benchmark {
        return run_benchmark(args, &scene, &choices, open);
    }
    if let Some(reference) = &args.convergence {
        return run_convergence(args, &scene, reference, &choices, open);
    }
    let Some(device) = open(choices[0]) else {
        return 1;
    };
    render_image(args, &scene, device.as_ref())
}

/// The normal mode: `--features` and/or one image.
fn render_image(args: &RenderArgs, scene: &Scene, device: &dyn Device) -> u8 {
    let options = RenderOptions {
        spp: args.spp,
        seed: args.seed,
        want_variance: false,
        want_aovs: args.aovs || args.denoise,
        samples_per_launch: None,
    };
    if args.features {
        // The plan first: it needs no device, so a scene the renderer refuses still shows it.
        let plan = optik_render::PipelinePlan::new(scene, options.want_aovs, Effects::Scene);
        outln!("{}", plan.describe().trim_end());
    }
    let mut renderer = match Renderer::new(device, scene, &options, Effects::Scene) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("optik render: {e}");
            return 1;
        }
    };
    if args.features {
        match renderer.compiled_features() {
            Ok(f) => outln!(
                "compiled on {}: {}",
                device.backend(),
                optik_render::plan::describe_compiled(&f)
            ),
            Err(e) => {
                eprintln!("optik render: {e}");
                return 1;
            }
        }
    }
    let Some(out) = &args.out else { return 0 };
    let pixels = scene.film.width as u64 * scene.film.height as u64;
    let result = if std::io::stderr().is_terminal() {
        accumulate_with_bar(&mut renderer, pixels)
    } else {
        let spp = renderer.spp();
        renderer.accumulate(spp, &mut |_| {})
    };
    let frame = result.and_then(|_| renderer.frame());
    let mut frame: Frame = match frame {
        Ok(f) => f,
        Err(e) => {
            eprintln!("optik render: {e}");
            return 1;
        }
    };
    if args.denoise {
        match denoise_frame(&mut frame) {
            Ok(which) => outln!("denoised with {which}"),
            Err(e) => {
                eprintln!("optik render: --denoise: {e}");
                return 1;
            }
        }
        if !args.aovs {
            frame.aovs.clear();
        }
    }
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

/// Replaces the frame's mean by its denoised version, guided by its albedo and normal AOVs;
/// returns which denoiser ran.
fn denoise_frame(frame: &mut Frame) -> Result<denoise::Denoiser, String> {
    let layer = |name: &str| -> Result<Vec<[f32; 3]>, String> {
        let aov = frame
            .aovs
            .iter()
            .find(|a| a.name == name)
            .ok_or_else(|| format!("the render has no {name} layer to guide the denoiser"))?;
        Ok(aov
            .data
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect())
    };
    let (albedo, normal) = (layer("albedo")?, layer("normal")?);
    let (out, which) = denoise::denoise(&frame.mean, &albedo, &normal, frame.width, frame.height)
        .map_err(|e| e.to_string())?;
    frame.mean = out;
    Ok(which)
}

/// Renders with an indicatif bar on stderr showing samples per pixel, samples/s and Mrays/s.
/// The rays per sample come from the first launch's count (read back once), so the bar costs
/// no further reads.
fn accumulate_with_bar(
    renderer: &mut Renderer,
    pixels: u64,
) -> Result<(), optik_render::RenderError> {
    let total = renderer.spp();
    let bar = indicatif::ProgressBar::new(total as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "[{bar:30}] {pos}/{len} spp, {msg} ({elapsed}, about {eta} left)",
    ) {
        bar.set_style(style.progress_chars("#>-"));
    }
    let start = std::time::Instant::now();
    let first = renderer.samples_per_launch().min(total);
    renderer.accumulate(first, &mut |_| {})?;
    let rays_per_sample = renderer.rays()? / (pixels as f64 * first as f64).max(1.0);
    let update = |done: u32| {
        let secs = start.elapsed().as_secs_f64().max(1e-9);
        let samples = pixels as f64 * done as f64 / secs;
        bar.set_position(done as u64);
        bar.set_message(format!(
            "{:.2} Msamples/s, {:.2} Mrays/s",
            samples / 1e6,
            samples * rays_per_sample / 1e6
        ));
    };
    update(first);
    renderer.accumulate(total - first, &mut |p| update(p.done))?;
    bar.finish();
    Ok(())
}

/// `--benchmark`: the two pipelines on each backend.
fn run_benchmark(
    args: &RenderArgs,
    scene: &Scene,
    choices: &[BackendChoice],
    open: impl Fn(BackendChoice) -> Option<Box<dyn Device>>,
) -> u8 {
    let options = BenchmarkOptions {
        spp: args.spp,
        seed: args.seed,
        rounds: args.rounds,
    };
    let mut status = 0;
    for &choice in choices {
        let Some(device) = open(choice) else {
            status = 1;
            continue;
        };
        let r = match benchmark(device.as_ref(), scene, &options) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("optik render: --benchmark on {}: {e}", device.backend());
                status = 1;
                continue;
            }
        };
        if args.features {
            outln!("{}", r.specialised.plan.describe().trim_end());
            outln!("--- all-effects pipeline:");
            outln!("{}", r.all_effects.plan.describe().trim_end());
        }
        for side in [&r.specialised, &r.all_effects] {
            outln!(
                "{} on {}: {}; compiled: {}",
                side.plan.effects.name(),
                r.backend,
                side.plan.programs.join(", "),
                optik_render::plan::describe_compiled(&side.compiled)
            );
        }
        outln!("{}", r.summary());
        if !r.agreement.passed {
            eprintln!(
                "optik render: --benchmark on {}: the two pipelines' images disagree",
                r.backend
            );
            status = 1;
        }
    }
    status
}

/// `--convergence REF.exr`: relative MSE against time per accuracy setting and backend.
fn run_convergence(
    args: &RenderArgs,
    scene: &Scene,
    reference: &Path,
    choices: &[BackendChoice],
    open: impl Fn(BackendChoice) -> Option<Box<dyn Device>>,
) -> u8 {
    let (w, h, rgb) = match optik_render::validate::files::read_rgb(reference) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("optik render: --convergence: {e}");
            return 1;
        }
    };
    if (w, h) != (scene.film.width, scene.film.height) {
        eprintln!(
            "optik render: --convergence {}: the reference is {w}x{h}, the scene's film {}x{}",
            reference.display(),
            scene.film.width,
            scene.film.height
        );
        return 1;
    }
    let reference: Vec<[f32; 3]> = rgb.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let max_spp = args.spp.unwrap_or(scene.sampler.sample_count);
    let mut curves = Vec::new();
    let mut status = 0;
    outln!("backend accuracy spp seconds rel_mse");
    for &choice in choices {
        let Some(device) = open(choice) else {
            status = 1;
            continue;
        };
        let c = match convergence(
            device.as_ref(),
            scene,
            &reference,
            max_spp,
            args.seed,
            &accuracy_settings(),
        ) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("optik render: --convergence on {}: {e}", device.backend());
                status = 1;
                continue;
            }
        };
        for (a, why) in &c.refused {
            eprintln!(
                "optik render: {} does not run {}: {why}",
                device.backend(),
                accuracy_name(*a)
            );
        }
        for curve in &c.curves {
            for p in &curve.points {
                outln!(
                    "{} {} {} {:.6} {:.6e}",
                    curve.backend,
                    accuracy_name(curve.accuracy),
                    p.spp,
                    p.seconds,
                    p.rel_mse
                );
            }
        }
        curves.extend(c.curves);
    }
    if let Some(out) = &args.out {
        match plot_png(&curves, out) {
            Ok(legend) => outln!("{}: {}", out.display(), legend.to_string().trim_end()),
            Err(e) => {
                eprintln!("optik render: {e}");
                return 1;
            }
        }
    }
    status
}
