//! ex12 (the course's `example12_denoiseSeparateChannels`): denoising guided by albedo and
//! normals. The programs write the first hit's albedo and shading normal beside the colour;
//! after the frames are accumulated, [`optik_render::denoise`] runs Intel Open Image Denoise
//! when its library is installed (`scripts/oidn-setup`) and optik's edge-aware à-trous filter
//! otherwise, and says which ran. (The course's own ex12 passes the guides but leaves OptiX's
//! `guideAlbedo`/`guideNormal` off, so its denoiser ignores them; here they are used.)

use crate::common::{Image, Options, Result, download_image, upload};
use crate::ex10_soft_shadows::SoftShadows;
use optik::Device;
use optik_render::denoise::{self, Denoiser};

/// The programs: the step's own, then the shared surface code.
pub const WGSL: &str = concat!(
    include_str!("ex12_denoising.wgsl"),
    include_str!("surface.wgsl")
);

/// Which denoiser ex12 may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DenoiserChoice {
    /// OIDN when its library loads, else the à-trous filter.
    Auto,
    /// Always the à-trous filter (reproducible everywhere: the course test uses it).
    ATrous,
}

/// Everything ex12 produces.
pub struct Denoised {
    /// The accumulated, noisy colour.
    pub noisy: Image,
    /// The first hit's albedo.
    pub albedo: Image,
    /// The first hit's shading normal (zero on the background).
    pub normal: Image,
    /// The denoised colour.
    pub denoised: Image,
    /// Which denoiser ran, and why OIDN did not if it did not.
    pub denoiser: Denoiser,
}

/// Renders `opts.frames` frames of one sample per pixel with albedo and normal outputs, and
/// denoises the result with `choice`.
pub fn render(device: &dyn Device, opts: &Options, choice: DenoiserChoice) -> Result<Denoised> {
    let (w, h) = (opts.width, opts.height);
    let blank = vec![[0.0f32; 4]; (w * h) as usize];
    let (albedo, normal) = (upload(device, &blank)?, upload(device, &blank)?);
    let mut step = SoftShadows::new(
        device,
        opts,
        ("ex12_denoising.wgsl", WGSL),
        10,
        &[albedo, normal],
    )?;
    for frame in 0..opts.frames.max(1) {
        step.launch(device, frame, 1, 4)?;
    }
    let noisy = download_image(device, step.image, w, h)?;
    let albedo = download_image(device, albedo, w, h)?;
    let normal = download_image(device, normal, w, h)?;
    let (pixels, denoiser) = match choice {
        DenoiserChoice::Auto => {
            denoise::denoise(&noisy.pixels, &albedo.pixels, &normal.pixels, w, h)?
        }
        DenoiserChoice::ATrous => (
            denoise::atrous::atrous(&noisy.pixels, &albedo.pixels, &normal.pixels, w, h)?,
            Denoiser::ATrous {
                reason: "the à-trous filter was asked for".into(),
            },
        ),
    };
    Ok(Denoised {
        denoised: Image {
            width: w,
            height: h,
            pixels,
        },
        noisy,
        albedo,
        normal,
        denoiser,
    })
}

/// Renders and denoises with the best denoiser available, printing which ran.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    let out = render(device, opts, DenoiserChoice::Auto)?;
    eprintln!("ex12: denoised with {}", out.denoiser);
    Ok(out.denoised)
}
