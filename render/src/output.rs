//! Writing frames: linear float32 OpenEXR (R, G, B, and AOVs as `layer.channel`) and 8-bit
//! sRGB PNG.

use crate::{Frame, RenderError};
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, SmallVec,
    WritableImage,
};
use std::path::Path;

/// The image formats the renderer writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Linear float32 OpenEXR.
    Exr,
    /// 8-bit sRGB PNG.
    Png,
}

impl Format {
    /// The format named by `path`'s extension (`.exr` or `.png`, any case).
    pub fn of_path(path: &Path) -> Result<Format, RenderError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("exr") => Ok(Format::Exr),
            Some("png") => Ok(Format::Png),
            _ => Err(RenderError::Output(format!(
                "{}: unknown image extension (expected .exr or .png)",
                path.display()
            ))),
        }
    }
}

/// Writes `frame` to `path` in the format its extension names.
pub fn write(frame: &Frame, path: &Path) -> Result<(), RenderError> {
    let bytes = match Format::of_path(path)? {
        Format::Exr => exr_bytes(frame)?,
        Format::Png => png_bytes(frame)?,
    };
    std::fs::write(path, bytes).map_err(|e| RenderError::Output(format!("{}: {e}", path.display())))
}

/// The frame as an OpenEXR file: one part, float32 `R`, `G`, `B` and `<aov>.<channel>`.
pub fn exr_bytes(frame: &Frame) -> Result<Vec<u8>, RenderError> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let v = frame.mean.iter().map(|p| p[c]).collect();
        channels.push(AnyChannel::new(*name, FlatSamples::F32(v)));
    }
    for aov in &frame.aovs {
        let n = aov.channels.len();
        for (c, name) in aov.channels.iter().enumerate() {
            let v = aov.data.iter().skip(c).step_by(n).copied().collect();
            channels.push(AnyChannel::new(
                format!("{}.{name}", aov.name).as_str(),
                FlatSamples::F32(v),
            ));
        }
    }
    let layer = Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut out)
        .map_err(|e| RenderError::Output(format!("encoding EXR: {e}")))?;
    Ok(out.into_inner())
}

/// The sRGB transfer function of a linear value, clamped to [0, 1], as an 8-bit code.
pub fn srgb8(linear: f32) -> u8 {
    let v = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    let s = if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// The frame's mean as an 8-bit sRGB PNG.
pub fn png_bytes(frame: &Frame) -> Result<Vec<u8>, RenderError> {
    let mut out = Vec::new();
    let err = |e: png::EncodingError| RenderError::Output(format!("encoding PNG: {e}"));
    {
        let mut enc = png::Encoder::new(&mut out, frame.width, frame.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = enc.write_header().map_err(err)?;
        let data: Vec<u8> = frame.mean.iter().flat_map(|p| p.map(srgb8)).collect();
        writer.write_image_data(&data).map_err(err)?;
    }
    Ok(out)
}
