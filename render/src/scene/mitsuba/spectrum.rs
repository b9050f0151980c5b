//! `<spectrum>` values reduced to linear sRGB as Mitsuba 3's RGB variants do.
//!
//! A uniform value stays a grey except inside an emitter, where Mitsuba uses
//! `value · xyz_to_srgb(1, 1, 1)` (a flat spectrum is not white under sRGB's D65 white point).
//! Wavelength:value lists are integrated against the CIE 1931 curves at 1000 evenly spaced
//! wavelengths from 360 to 830 nm, weighted by D65 except inside emitters, converted from XYZ to
//! linear sRGB and clamped to [0, 1] (or only at 0 for emitters and unbounded parameters).

use super::data::{CIE_D65, CIE_X, CIE_Y, CIE_Z};
use crate::scene::{Location, Rgb, SceneError};
use glam::DVec3;
use std::path::Path;

/// Mitsuba's `MI_CIE_Y_NORMALIZATION`: 1 / ∫ȳ.
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;

/// A spectrum as written: one value for every wavelength, or wavelength:value pairs.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength.
    Uniform(f64),
    /// Wavelengths in nm (increasing) and values, linearly interpolated between them.
    Samples(Vec<f64>, Vec<f64>),
}

impl Spectrum {
    /// Parses `value="0.5"` or `value="400:0.1, 500:0.4"`.
    pub fn parse(s: &str, at: &Location) -> Result<Spectrum, SceneError> {
        let tokens: Vec<&str> = s
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .collect();
        if tokens.len() == 1 && !tokens[0].contains(':') {
            return Ok(Spectrum::Uniform(super::xml::parse_f64(tokens[0], at)?));
        }
        let mut wl = Vec::new();
        let mut vals = Vec::new();
        for t in tokens {
            let (w, v) = t.split_once(':').ok_or_else(|| SceneError {
                at: at.clone(),
                message: format!(
                    "spectrum entry \"{t}\" is not wavelength:value; expected e.g. \"400:0.5\""
                ),
            })?;
            wl.push(super::xml::parse_f64(w, at)?);
            vals.push(super::xml::parse_f64(v, at)?);
        }
        Self::samples(wl, vals, at)
    }

    /// Reads a `.spd` file: lines of `wavelength value`, `#` comments.
    pub fn from_file(path: &Path, at: &Location) -> Result<Spectrum, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|e| SceneError {
            at: at.clone(),
            message: format!("cannot read the spectrum file {}: {e}", path.display()),
        })?;
        let mut wl = Vec::new();
        let mut vals = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let mut it = line.split_whitespace();
            let here = Location {
                file: path.to_path_buf(),
                line: i as u32 + 1,
            };
            let (Some(w), Some(v)) = (it.next(), it.next()) else {
                return Err(SceneError {
                    at: here,
                    message: "expected \"wavelength value\"".into(),
                });
            };
            wl.push(super::xml::parse_f64(w, &here)?);
            vals.push(super::xml::parse_f64(v, &here)?);
        }
        Self::samples(wl, vals, at)
    }

    fn samples(wl: Vec<f64>, vals: Vec<f64>, at: &Location) -> Result<Spectrum, SceneError> {
        if wl.len() < 2 {
            return Err(SceneError {
                at: at.clone(),
                message:
                    "a spectrum needs at least two wavelength:value pairs (or one plain value)"
                        .into(),
            });
        }
        if wl.windows(2).any(|w| w[1] <= w[0]) {
            return Err(SceneError {
                at: at.clone(),
                message: "spectrum wavelengths must increase from one pair to the next".into(),
            });
        }
        Ok(Spectrum::Samples(wl, vals))
    }

    /// Linear sRGB as Mitsuba's RGB variants see this spectrum: in an emitter (`emitter`) or
    /// an unbounded parameter such as a conductor's `eta` (`unbounded`), or a reflectance.
    pub fn to_rgb(&self, emitter: bool, unbounded: bool) -> Rgb {
        match self {
            Spectrum::Uniform(v) if emitter => (xyz_to_srgb(DVec3::ONE) * *v).as_vec3(),
            Spectrum::Uniform(v) => Rgb::splat(*v as f32),
            Spectrum::Samples(wl, vals) => {
                list_to_srgb(wl, vals, !(emitter || unbounded), !emitter).as_vec3()
            }
        }
    }
}

/// Mitsuba's XYZ → linear sRGB matrix.
pub fn xyz_to_srgb(xyz: DVec3) -> DVec3 {
    DVec3::new(
        3.240479 * xyz.x - 1.537150 * xyz.y - 0.498535 * xyz.z,
        -0.969256 * xyz.x + 1.875991 * xyz.y + 0.041556 * xyz.z,
        0.055648 * xyz.x - 0.204043 * xyz.y + 1.057311 * xyz.z,
    )
}

/// Linear interpolation in a 95-node table over [360, 830] nm.
fn table(t: &[f32; 95], w: f64) -> f64 {
    let x = (w - CIE_MIN) * (94.0 / (CIE_MAX - CIE_MIN));
    let i0 = (x.max(0.0) as usize).min(93);
    let f = x - i0 as f64;
    (1.0 - f) * t[i0] as f64 + f * t[i0 + 1] as f64
}

/// The reduction of a sampled spectrum to sRGB (1000 steps over the CIE range, as Mitsuba).
fn list_to_srgb(wl: &[f64], vals: &[f64], bounded: bool, d65: bool) -> DVec3 {
    const STEPS: usize = 1000;
    let (first, last) = (wl[0], wl[wl.len() - 1]);
    let mut xyz = DVec3::ZERO;
    for i in 0..STEPS {
        let w = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first || w > last {
            continue;
        }
        // The last interval whose start is at or below w (the end point belongs to it).
        let k = wl.partition_point(|&x| x <= w).clamp(1, wl.len() - 1) - 1;
        let (w0, w1, v0, v1) = (wl[k], wl[k + 1], vals[k], vals[k + 1]);
        let v = ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1);
        let weight = if d65 { table(&CIE_D65, w) } else { 1.0 };
        let cie =
            DVec3::new(table(&CIE_X, w), table(&CIE_Y, w), table(&CIE_Z, w)) * CIE_Y_NORMALIZATION;
        xyz += cie * v * weight;
    }
    xyz *= (CIE_MAX - CIE_MIN) / STEPS as f64;
    let rgb = xyz_to_srgb(xyz);
    if bounded {
        rgb.clamp(DVec3::ZERO, DVec3::ONE)
    } else {
        rgb.max(DVec3::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Rgb, b: [f32; 3], tol: f32) {
        let b = Rgb::from(b);
        assert!((a - b).abs().max_element() <= tol, "{a} vs Mitsuba's {b}");
    }

    /// Values printed by Mitsuba 3.9.1 (`mi.spectrum_list_to_srgb`, scalar_rgb).
    #[test]
    fn spectrum_lists_match_mitsuba() {
        let at = Location::default();
        let s = Spectrum::parse("400:0.1, 500:0.5, 600:0.8, 700:0.2", &at).unwrap();
        // bounded, with D65: a reflectance.
        close(s.to_rgb(false, false), [0.731215, 0.646851, 0.271934], 2e-4);
        let e = Spectrum::parse("400:1.0 500:3.5 600:8.0 700:2.0", &at).unwrap();
        // unbounded, without D65: an emitter.
        close(e.to_rgb(true, false), [8.94057, 5.31158, 1.63589], 2e-3);
        let flat = Spectrum::parse("360:1, 830:1", &at).unwrap();
        close(
            flat.to_rgb(false, false),
            [0.998983, 0.998872, 0.998802],
            2e-4,
        );
    }

    #[test]
    fn uniform_spectrum_is_grey_except_in_emitters() {
        let s = Spectrum::parse("2", &Location::default()).unwrap();
        close(s.to_rgb(false, false), [2.0, 2.0, 2.0], 0.0);
        // Mitsuba: value · xyz_to_srgb(1, 1, 1) = 2 · (1.20479, 0.948291, 0.908916).
        close(s.to_rgb(true, false), [2.40958, 1.896582, 1.817832], 1e-4);
    }

    #[test]
    fn bad_spectra_are_errors() {
        let at = Location::default();
        assert!(Spectrum::parse("400:0.5", &at).is_err());
        assert!(Spectrum::parse("500:0.5, 400:0.2", &at).is_err());
        assert!(Spectrum::parse("400-0.5, 500:1", &at).is_err());
        assert!(Spectrum::parse("abc", &at).is_err());
    }
}
