//! Decoding texture and environment images into linear RGB [`Image`]s.
//!
//! 8- and 16-bit PNG and JPEG files are sRGB-encoded: they are decoded to linear values unless
//! the texture asks for the raw values (Mitsuba's `raw`). Radiance HDR and OpenEXR files hold
//! linear floats and are kept as they are.

use super::{Image, Rgb};
use std::path::Path;

/// Reads an image file; `raw` keeps 8/16-bit values as stored (no sRGB decoding).
/// The error text says what was wrong and what was expected.
pub fn load_image(path: &Path, raw: bool) -> Result<Image, String> {
    if !path.exists() {
        return Err(format!("the image {} does not exist", path.display()));
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "exr" {
        return load_exr(path);
    }
    let reader = image::ImageReader::open(path)
        .map_err(|e| format!("cannot open the image {}: {e}", path.display()))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read the image {}: {e}", path.display()))?;
    let decoded = reader.decode().map_err(|e| {
        format!(
            "cannot decode the image {}: {e}; expected a PNG, JPEG, Radiance HDR or OpenEXR file",
            path.display()
        )
    })?;
    let float_file = matches!(
        decoded,
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)
    );
    let has_alpha = decoded.color().has_alpha();
    let rgba = decoded.to_rgba32f();
    let (width, height) = rgba.dimensions();
    let decode = !float_file && !raw;
    let mut texels = Vec::with_capacity((width * height) as usize);
    let mut alpha = Vec::new();
    for p in rgba.pixels() {
        let c = Rgb::new(p[0], p[1], p[2]);
        texels.push(if decode { c.map(srgb_to_linear) } else { c });
        if has_alpha {
            alpha.push(p[3]);
        }
    }
    Ok(Image {
        path: path.to_path_buf(),
        width,
        height,
        texels,
        alpha: has_alpha.then_some(alpha),
    })
}

/// The sRGB transfer function's inverse.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

fn load_exr(path: &Path) -> Result<Image, String> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            let (w, h) = (resolution.width(), resolution.height());
            (w, vec![[0f32; 4]; w * h])
        },
        |(w, px), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b, a];
        },
    )
    .map_err(|e| format!("cannot read the OpenEXR image {}: {e}", path.display()))?;
    let layer = &image.layer_data;
    let size = layer.size;
    let (_, pixels) = &layer.channel_data.pixels;
    let has_alpha = layer.channel_data.channels.3.is_some();
    Ok(Image {
        path: path.to_path_buf(),
        width: size.width() as u32,
        height: size.height() as u32,
        texels: pixels.iter().map(|p| Rgb::new(p[0], p[1], p[2])).collect(),
        alpha: has_alpha.then(|| pixels.iter().map(|p| p[3]).collect()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_matches_the_standard_curve() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }

    #[test]
    fn png_is_decoded_to_linear_unless_raw() {
        let dir = std::env::temp_dir().join(format!("optik-scene-img-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.png");
        let img = image::RgbaImage::from_raw(2, 1, vec![128, 0, 255, 255, 0, 64, 0, 128]).unwrap();
        img.save(&path).unwrap();
        let lin = load_image(&path, false).unwrap();
        assert_eq!((lin.width, lin.height), (2, 1));
        assert!((lin.texels[0].x - srgb_to_linear(128.0 / 255.0)).abs() < 1e-6);
        assert_eq!(lin.alpha.as_deref(), Some(&[1.0, 128.0 / 255.0][..]));
        let raw = load_image(&path, true).unwrap();
        assert!((raw.texels[0].x - 128.0 / 255.0).abs() < 1e-6);
        assert!(
            load_image(&dir.join("missing.png"), false)
                .unwrap_err()
                .contains("does not exist")
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
