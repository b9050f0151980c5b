//! ex11 (the course's `example11_denoiseColorOnly`, whose new idea besides the denoiser is
//! accumulation): the image converges over frames. Each launch is one frame of one sample per
//! pixel with four light samples, seeded by its frame number; the raygen program keeps the
//! running mean `(c + frame · old) / (frame + 1)` in the image buffer, which persists between
//! launches (see `raygen__render_frame` in `ex10_soft_shadows.wgsl`).

use crate::common::{Image, Options, Result, download_image};
use crate::ex10_soft_shadows::{SoftShadows, WGSL};
use optik::Device;

/// Renders `opts.frames` frames into one converging image.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    let mut step = SoftShadows::new(device, opts, ("ex10_soft_shadows.wgsl", WGSL), 4, &[])?;
    for frame in 0..opts.frames.max(1) {
        step.launch(device, frame, 1, 4)?;
    }
    download_image(device, step.image, opts.width, opts.height)
}
