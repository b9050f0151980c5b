//! Denoising a rendered image with the albedo and normal of its first hits as guides.
//!
//! [`denoise`] runs Intel Open Image Denoise (OIDN) when its library can be loaded, and the
//! edge-aware à-trous filter of [`atrous`] otherwise; the result names the denoiser that ran
//! ([`Denoiser`]), with the reason when OIDN could not.
//!
//! Why OIDN is loaded at run time (`libloading`) rather than linked (the `oidn` crate): linking
//! needs the library when optik is *built*, and a fresh machine has none (Debian has no
//! package; OIDN's release archives come from GitHub, which a build cannot assume). Loading it
//! at run time keeps every build identical and lets a user add the library later: the PyPI
//! wheel `pyoidn` ships `libOpenImageDenoise.so` (`scripts/oidn-setup` installs it), and optik
//! finds it through `OPTIK_OIDN_LIB` or that script's folder ([`oidn::candidates`]).

pub mod atrous;
pub mod oidn;

use std::fmt;

/// Which denoiser produced an image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Denoiser {
    /// Intel Open Image Denoise's `RT` filter with albedo and normal guides.
    Oidn {
        /// The library's version, `major.minor.patch`.
        version: String,
        /// The file the library was loaded from.
        library: String,
    },
    /// optik's edge-aware à-trous filter ([`atrous`]), guided by the same albedo and normals.
    ATrous {
        /// Why OIDN did not run (not found, or the error it reported).
        reason: String,
    },
}

impl fmt::Display for Denoiser {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Denoiser::Oidn { version, library } => {
                write!(f, "Intel Open Image Denoise {version} ({library})")
            }
            Denoiser::ATrous { reason } => write!(
                f,
                "edge-aware à-trous filter with albedo and normal guides (OIDN not used: {reason})"
            ),
        }
    }
}

/// A request that cannot be denoised: buffers whose sizes disagree with the image size.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DenoiseError(pub String);

impl fmt::Display for DenoiseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for DenoiseError {}

/// Checks that `color`, `albedo` and `normal` each hold `width × height` pixels.
pub(crate) fn check_sizes(
    color: &[[f32; 3]],
    albedo: &[[f32; 3]],
    normal: &[[f32; 3]],
    width: u32,
    height: u32,
) -> Result<usize, DenoiseError> {
    let n = width as usize * height as usize;
    if n == 0 {
        return Err(DenoiseError(format!(
            "cannot denoise a {width}x{height} image: both sides must be at least 1"
        )));
    }
    for (name, len) in [
        ("colour", color.len()),
        ("albedo", albedo.len()),
        ("normal", normal.len()),
    ] {
        if len != n {
            return Err(DenoiseError(format!(
                "the {name} buffer has {len} pixels; a {width}x{height} image needs {n}"
            )));
        }
    }
    Ok(n)
}

/// Denoises `color` (linear HDR, rows top to bottom) guided by the first hit's `albedo` and
/// world-space `normal`: with OIDN when its library loads ([`oidn::Oidn::load`]), else with the
/// à-trous filter. Returns the image and which denoiser ran.
pub fn denoise(
    color: &[[f32; 3]],
    albedo: &[[f32; 3]],
    normal: &[[f32; 3]],
    width: u32,
    height: u32,
) -> Result<(Vec<[f32; 3]>, Denoiser), DenoiseError> {
    check_sizes(color, albedo, normal, width, height)?;
    let reason = match oidn::Oidn::load() {
        Ok(lib) => match lib.denoise(color, albedo, normal, width, height) {
            Ok(out) => {
                return Ok((
                    out,
                    Denoiser::Oidn {
                        version: lib.version().to_string(),
                        library: lib.path().display().to_string(),
                    },
                ));
            }
            Err(e) => format!("OIDN failed: {e}"),
        },
        Err(e) => e,
    };
    let out = atrous::atrous(color, albedo, normal, width, height)?;
    Ok((out, Denoiser::ATrous { reason }))
}

#[cfg(test)]
pub(crate) mod testimage;
