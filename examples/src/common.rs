//! What every step shares and no step is about: images and their files, uploading arrays,
//! packing shader binding table records, the course's camera and colours.

use optik::{
    Buffer, Device, ProgramGroup, SBT_RECORD_ALIGNMENT, SBT_RECORD_HEADER_SIZE, SbtRecord,
    SbtRegion,
};
use std::path::{Path, PathBuf};

/// The error type of the examples: a message that names what went wrong.
pub type Error = Box<dyn std::error::Error + Send + Sync>;
/// The examples' result type.
pub type Result<T> = std::result::Result<T, Error>;

/// A linear RGB image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels.
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// An image from RGBA pixels as the programs write them (alpha dropped).
    pub fn from_rgba(width: u32, height: u32, rgba: &[[f32; 4]]) -> Image {
        Image {
            width,
            height,
            pixels: rgba.iter().map(|p| [p[0], p[1], p[2]]).collect(),
        }
    }

    /// Writes the image: OpenEXR (32-bit float, linear) for `.exr`, 8-bit sRGB PNG for `.png`.
    pub fn write(&self, path: &Path) -> Result<()> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("exr") => {
                let w = self.width as usize;
                exr::prelude::write_rgb_file(path, w, self.height as usize, |x, y| {
                    let p = self.pixels[y * w + x];
                    (p[0], p[1], p[2])
                })
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            }
            Some("png") => {
                let file = std::fs::File::create(path)
                    .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
                let mut enc =
                    png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
                enc.set_color(png::ColorType::Rgb);
                enc.set_depth(png::BitDepth::Eight);
                let bytes: Vec<u8> = self
                    .pixels
                    .iter()
                    .flat_map(|p| p.map(|v| (srgb_encode(v) * 255.0 + 0.5) as u8))
                    .collect();
                enc.write_header()
                    .and_then(|mut w| w.write_image_data(&bytes))
                    .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            }
            _ => {
                return Err(format!(
                    "cannot write {}: the output must end in .exr or .png",
                    path.display()
                )
                .into());
            }
        }
        Ok(())
    }

    /// Reads an RGB(A) OpenEXR file written by [`Image::write`] (or any with R, G, B channels).
    pub fn read_exr(path: &Path) -> Result<Image> {
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| Image {
                width: res.width() as u32,
                height: res.height() as u32,
                pixels: vec![[0.0; 3]; res.width() * res.height()],
            },
            |img: &mut Image,
             pos: exr::prelude::Vec2<usize>,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                img.pixels[pos.y() * img.width as usize + pos.x()] = [r, g, b];
            },
        )
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        Ok(image.layer_data.channel_data.pixels)
    }
}

/// Linear to sRGB-encoded, clamped to [0, 1].
pub fn srgb_encode(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// What a step renders: the image size and, for the steps that take them, the number of
/// accumulated frames and the OBJ model.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Launches accumulated (ex11, ex12).
    pub frames: u32,
    /// The OBJ model of ex07 and later; `None` renders the generated Cornell box.
    pub model: Option<PathBuf>,
}

impl Options {
    /// A `width × height` image of the generated scenes, with 4 frames where frames count.
    pub fn new(width: u32, height: u32) -> Options {
        Options {
            width,
            height,
            frames: 4,
            model: None,
        }
    }
}

/// Creates a buffer holding `data` (at least 4 bytes: empty arrays still need a binding).
pub fn upload<T: bytemuck::Pod>(device: &dyn Device, data: &[T]) -> Result<Buffer> {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    let buffer = device.create_buffer(bytes.len().max(4) as u64)?;
    device.write_buffer(buffer, 0, bytes)?;
    Ok(buffer)
}

/// Reads a `width × height` image of `vec4<f32>` pixels written by a raygen program.
pub fn download_image(
    device: &dyn Device,
    buffer: Buffer,
    width: u32,
    height: u32,
) -> Result<Image> {
    let mut rgba = vec![[0.0f32; 4]; width as usize * height as usize];
    device.read_buffer(buffer, 0, bytemuck::cast_slice_mut(&mut rgba))?;
    Ok(Image::from_rgba(width, height, &rgba))
}

/// A shader binding table laid out in one buffer, as OptiX programs usually lay it out:
/// the raygen record, then the miss records, then the hit group records, each region with
/// the stride of its largest record.
pub struct SbtLayout {
    /// The buffer holding every record.
    pub buffer: Buffer,
    /// The table to launch with.
    pub table: optik::ShaderBindingTable,
}

fn align(n: u32) -> u32 {
    n.div_ceil(SBT_RECORD_ALIGNMENT) * SBT_RECORD_ALIGNMENT
}

/// Packs `raygen`, `miss` and `hitgroup` records (header from `sbt_record_pack_header`, then the
/// data words) into one buffer.
pub fn build_sbt(
    device: &dyn Device,
    raygen: (ProgramGroup, Vec<u32>),
    miss: Vec<(ProgramGroup, Vec<u32>)>,
    hitgroup: Vec<(ProgramGroup, Vec<u32>)>,
) -> Result<SbtLayout> {
    let mut bytes: Vec<u8> = Vec::new();
    let mut region = |records: &[(ProgramGroup, Vec<u32>)]| -> Result<(u64, u32, u32)> {
        let longest = records.iter().map(|r| r.1.len() as u32).max().unwrap_or(0);
        let stride = align(SBT_RECORD_HEADER_SIZE + 4 * longest);
        let offset = bytes.len() as u64;
        for (group, data) in records {
            let mut record = device.sbt_record_pack_header(*group)?.to_vec();
            record.extend_from_slice(bytemuck::cast_slice(data));
            record.resize(stride as usize, 0);
            bytes.extend_from_slice(&record);
        }
        Ok((offset, stride, records.len() as u32))
    };
    let (raygen_offset, _, _) = region(std::slice::from_ref(&raygen))?;
    let (miss_offset, miss_stride, miss_count) = region(&miss)?;
    let (hit_offset, hit_stride, hit_count) = region(&hitgroup)?;
    let buffer = upload(device, &bytes)?;
    let regioned = |offset, stride, count| {
        (count > 0).then_some(SbtRegion {
            buffer,
            offset,
            stride,
            count,
        })
    };
    let table = optik::ShaderBindingTable {
        raygen: SbtRecord {
            buffer,
            offset: raygen_offset,
        },
        exception: None,
        miss: regioned(miss_offset, miss_stride, miss_count),
        hitgroup: regioned(hit_offset, hit_stride, hit_count),
        callables: None,
    };
    Ok(SbtLayout { buffer, table })
}

/// The course's camera (`SampleRenderer::setCamera`): a position, the direction to the centre
/// of the screen and the screen's half-extent vectors, as `vec4<f32>`s for a uniform.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CameraParams {
    /// Eye position (w unused).
    pub position: [f32; 4],
    /// Unit direction to the centre of the screen.
    pub direction: [f32; 4],
    /// The screen's full width, as a vector.
    pub horizontal: [f32; 4],
    /// The screen's full height, as a vector.
    pub vertical: [f32; 4],
}

impl CameraParams {
    /// Looks from `from` at `at` with `up` up, for an image of aspect `width / height`.
    /// The course's `cosFovy = 0.66` gives a vertical field of view of 2·atan(0.33) = 36.5°.
    pub fn look_at(from: [f32; 3], at: [f32; 3], up: [f32; 3], width: u32, height: u32) -> Self {
        use glam::Vec3;
        let (from, at, up) = (Vec3::from(from), Vec3::from(at), Vec3::from(up));
        let cos_fovy = 0.66;
        let aspect = width as f32 / height.max(1) as f32;
        let direction = (at - from).normalize();
        let horizontal = cos_fovy * aspect * direction.cross(up).normalize();
        let vertical = cos_fovy * horizontal.cross(direction).normalize();
        let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
        CameraParams {
            position: v4(from),
            direction: v4(direction),
            horizontal: v4(horizontal),
            vertical: v4(vertical),
        }
    }
}

/// The course's `randomColor(i)`: a fixed, well-spread colour per index.
pub fn random_color(i: u32) -> [f32; 3] {
    let r = i.wrapping_mul(13 * 17).wrapping_add(0x234235);
    let g = i.wrapping_mul(7 * 3 * 5).wrapping_add(0x773477);
    let b = i.wrapping_mul(11 * 19).wrapping_add(0x223766);
    [r, g, b].map(|c| (c & 255) as f32 / 255.0)
}
