//! Reading and writing [`RecordImage`]s as OpenEXR files with the `exr` crate: integer
//! channels as `UINT`, float channels as `FLOAT`, one part, ZIP compression, so that
//! OpenImageIO (`idiff`, `oiiotool`) reads them as they are.

use crate::image::{Channel, ChannelKind, RecordImage};
use exr::prelude::*;
use std::path::Path;

/// Writes `image` to `path` atomically (optik_io::output), creating parent folders.
pub fn write(path: &Path, image: &RecordImage) -> std::result::Result<(), String> {
    if image.width == 0 || image.height == 0 {
        return Err(format!(
            "{}: an EXR image needs at least one pixel, this one is {}×{}",
            path.display(),
            image.width,
            image.height
        ));
    }
    if image.channels.is_empty() {
        return Err(format!(
            "{}: an EXR image needs at least one channel",
            path.display()
        ));
    }
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
    }
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = image
        .channels
        .iter()
        .map(|c| {
            let samples = match c.kind {
                ChannelKind::Uint => FlatSamples::U32(c.values.clone()),
                ChannelKind::Float => {
                    FlatSamples::F32(c.values.iter().map(|b| f32::from_bits(*b)).collect())
                }
            };
            AnyChannel::new(c.name.as_str(), samples)
        })
        .collect();
    let layer = Layer::new(
        (image.width, image.height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    // Encoded in memory, then written beside `path` and renamed over it: a failed write
    // leaves the previous file (a blessed reference) intact.
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    optik_io::output::write_bytes(path, &bytes.into_inner()).map_err(|e| e.to_string())
}

/// Reads an image written by [`fn@write`] (or any single-part EXR): `UINT` channels as
/// integers, `FLOAT` and `HALF` channels as floats; channels in the file's (sorted) order.
pub fn read(path: &Path) -> std::result::Result<RecordImage, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    read_bytes(&bytes, &path.display().to_string())
}

/// Most samples (pixels × channels) [`read_bytes`] reads: 2^26, 256 MiB of 32-bit samples,
/// far above any record or image of the suite.
const MAX_SAMPLES: u128 = 1 << 26;

/// Reads an EXR file held in memory (an embedded reference); `name` names it in errors.
pub fn read_bytes(bytes: &[u8], name: &str) -> std::result::Result<RecordImage, String> {
    // The header is read first: a few damaged bytes can declare an image of billions of
    // pixels, and the full read would allocate for it before finding the data missing
    // (an abort, found by fuzzing: fuzz/regressions/exr/).
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| format!("cannot read {name}: {e}"))?;
    for header in &meta.headers {
        let samples = (header.layer_size.width() as u128)
            * (header.layer_size.height() as u128)
            * (header.channels.list.len() as u128);
        if samples > MAX_SAMPLES {
            return Err(format!(
                "cannot read {name}: it declares {} x {} pixels of {} channels, more than the {MAX_SAMPLES} samples optik reads",
                header.layer_size.width(),
                header.layer_size.height(),
                header.channels.list.len()
            ));
        }
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| format!("cannot read {name}: {e}"))?;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| format!("{name}: the file has no image part"))?;
    let size = layer.size;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let name = c.name.to_string();
            match &c.sample_data {
                FlatSamples::U32(v) => Channel {
                    name,
                    kind: ChannelKind::Uint,
                    values: v.clone(),
                },
                FlatSamples::F32(v) => Channel {
                    name,
                    kind: ChannelKind::Float,
                    values: v.iter().map(|f| f.to_bits()).collect(),
                },
                FlatSamples::F16(v) => Channel {
                    name,
                    kind: ChannelKind::Float,
                    values: v.iter().map(|h| h.to_f32().to_bits()).collect(),
                },
            }
        })
        .collect();
    Ok(RecordImage {
        width: size.0,
        height: size.1,
        channels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_integers_and_float_bits() {
        let dir = std::env::temp_dir().join(format!("optik-conf-exr-{}", std::process::id()));
        let path = dir.join("rt.exr");
        let image = RecordImage {
            width: 3,
            height: 2,
            channels: vec![
                Channel {
                    name: "prim".into(),
                    kind: ChannelKind::Uint,
                    values: vec![0, 1, u32::MAX, 7, 0xFFFF_FFFE, 42],
                },
                Channel {
                    name: "t".into(),
                    kind: ChannelKind::Float,
                    values: [0.0f32, -0.0, 1.5, 1e-40, f32::MAX, 3.25]
                        .iter()
                        .map(|f| f.to_bits())
                        .collect(),
                },
            ],
        };
        write(&path, &image).unwrap();
        let back = read(&path).unwrap();
        assert!(back.same_layout(&image), "{}", back.layout_text());
        assert_eq!(back.channel("prim"), image.channel("prim"));
        assert_eq!(back.channel("t"), image.channel("t"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn truncated_bytes_are_an_error_naming_the_file() {
        let e = read_bytes(b"v/1\x01\x02\x00\x00", "refs/x.exr").unwrap_err();
        assert!(e.starts_with("cannot read refs/x.exr: "), "{e}");
    }

    #[test]
    fn empty_images_are_refused_with_a_reason() {
        let e = write(
            Path::new("/tmp/never.exr"),
            &RecordImage {
                width: 0,
                height: 1,
                channels: vec![],
            },
        )
        .unwrap_err();
        assert!(e.contains("at least one pixel"), "{e}");
    }
}
