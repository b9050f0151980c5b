//! The command line every step's program shares.

use crate::common::{Options, Result};
use clap::Parser;
use std::path::PathBuf;

/// Runs one step of the OptiX 7 course headless and writes its image.
#[derive(Parser, Debug)]
struct Args {
    /// Backend: cpu, wgpu or vulkan (auto picks the fastest available).
    #[arg(long, default_value = "auto")]
    backend: String,
    /// Image width.
    #[arg(long, default_value_t = 1200)]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 1024)]
    height: u32,
    /// Frames to accumulate (ex11 and ex12).
    #[arg(long, default_value_t = 16)]
    frames: u32,
    /// An OBJ model for ex07 and later (default: a Cornell box generated in code).
    #[arg(long)]
    obj: Option<PathBuf>,
    /// Output image: .exr (linear float) or .png (sRGB); default `<step>.png`.
    #[arg(long, short)]
    out: Option<PathBuf>,
}

/// Parses the command line, renders the step `name` with `run` and writes the image.
pub fn main(name: &str, run: fn(&dyn optik::Device, &Options) -> Result<crate::common::Image>) {
    if let Err(e) = try_main(name, run) {
        eprintln!("{name}: {e}");
        std::process::exit(1);
    }
}

fn try_main(
    name: &str,
    run: fn(&dyn optik::Device, &Options) -> Result<crate::common::Image>,
) -> Result<()> {
    let args = Args::parse();
    let choice = optik::BackendChoice::parse(&args.backend).ok_or_else(|| {
        format!(
            "unknown backend `{}`: expected cpu, wgpu, vulkan or auto",
            args.backend
        )
    })?;
    if args.width == 0 || args.height == 0 {
        return Err(format!(
            "the image must be at least 1x1 pixels, not {}x{}",
            args.width, args.height
        )
        .into());
    }
    if args.frames == 0 {
        return Err("--frames must be at least 1".into());
    }
    let device = optik::open(choice)?;
    let opts = Options {
        width: args.width,
        height: args.height,
        frames: args.frames,
        model: args.obj,
    };
    let start = std::time::Instant::now();
    let image = run(device.as_ref(), &opts)?;
    let out = args
        .out
        .unwrap_or_else(|| PathBuf::from(format!("{name}.png")));
    image.write(&out)?;
    println!(
        "{name}: {}x{} on {} in {:.2} s -> {}",
        opts.width,
        opts.height,
        device.backend(),
        start.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}
