//! The software sampler behind `textureSampleLevel`, `textureLoad` and
//! `textureDimensions` for `texture_2d<f32>`.
//!
//! Textures have one mip level, so the level of `textureSampleLevel` selects nothing (WGSL
//! clamps it to the levels present). Texel centres are at half-integer coordinates, as in
//! every GPU API: nearest picks `floor(u * width)`, linear blends the four texels around
//! `u * width - 0.5` with weights `a * (1 - f) + b * f`. Addressing applies per texel index
//! (repeat wraps, clamp-to-edge clamps). `R32Float` reads as `(r, 0, 0, 1)`, as GPUs
//! expand one-channel formats. `textureLoad` out of range (or at a level above 0) gives
//! zeros, naga's `ReadZeroSkipWrite` policy for images.

use super::abi::{BoundTexture, TextureFormat};
use optik_api::{AddressMode, FilterMode, SamplerDesc};

/// The texel at `(x, y)`, which must be inside the texture.
///
/// # Safety
/// `t.ptr` is valid for `width * height` texels of `t.format`.
unsafe fn texel(t: &BoundTexture, x: u32, y: u32) -> [f32; 4] {
    let index = y as usize * t.width as usize + x as usize;
    let at = unsafe { t.ptr.add(index * t.format.texel_size() as usize) };
    match t.format {
        TextureFormat::Rgba8Unorm => {
            let b: [u8; 4] = unsafe { at.cast::<[u8; 4]>().read_unaligned() };
            b.map(|c| c as f32 / 255.0)
        }
        TextureFormat::Rgba32Float => unsafe { at.cast::<[f32; 4]>().read_unaligned() },
        TextureFormat::R32Float => [unsafe { at.cast::<f32>().read_unaligned() }, 0.0, 0.0, 1.0],
    }
}

/// A texel index along an axis of `size` texels, addressed by `mode`.
fn address(i: i64, size: u32, mode: AddressMode) -> u32 {
    match mode {
        AddressMode::ClampToEdge => i.clamp(0, size as i64 - 1) as u32,
        AddressMode::Repeat => i.rem_euclid(size as i64) as u32,
    }
}

fn lerp(a: [f32; 4], b: [f32; 4], f: f32) -> [f32; 4] {
    std::array::from_fn(|i| a[i] * (1.0 - f) + b[i] * f)
}

/// `textureSampleLevel(t, s, uv, level, offset)`.
///
/// # Safety
/// `t.ptr` is valid for `width * height` texels of `t.format`.
pub unsafe fn sample_level(
    t: &BoundTexture,
    s: &SamplerDesc,
    uv: [f32; 2],
    _level: f32,
    offset: [i32; 2],
) -> [f32; 4] {
    if t.width == 0 || t.height == 0 || t.ptr.is_null() {
        return [0.0; 4];
    }
    let size = [t.width, t.height];
    let mode = s.address_mode;
    match s.filter {
        FilterMode::Nearest => {
            let [x, y] = std::array::from_fn(|a| {
                address(
                    (uv[a] * size[a] as f32).floor() as i64 + offset[a] as i64,
                    size[a],
                    mode,
                )
            });
            unsafe { texel(t, x, y) }
        }
        FilterMode::Linear => {
            let pos: [f32; 2] = std::array::from_fn(|a| uv[a] * size[a] as f32 - 0.5);
            let base: [f32; 2] = pos.map(f32::floor);
            let frac: [f32; 2] = std::array::from_fn(|a| pos[a] - base[a]);
            let i0: [i64; 2] = std::array::from_fn(|a| base[a] as i64 + offset[a] as i64);
            let [x0, y0] = std::array::from_fn(|a| address(i0[a], size[a], mode));
            let [x1, y1] = std::array::from_fn(|a| address(i0[a] + 1, size[a], mode));
            let (t00, t10, t01, t11) = unsafe {
                (
                    texel(t, x0, y0),
                    texel(t, x1, y0),
                    texel(t, x0, y1),
                    texel(t, x1, y1),
                )
            };
            lerp(lerp(t00, t10, frac[0]), lerp(t01, t11, frac[0]), frac[1])
        }
    }
}

/// `textureLoad(t, coords, level)`.
///
/// # Safety
/// `t.ptr` is valid for `width * height` texels of `t.format`.
pub unsafe fn load(t: &BoundTexture, coords: [i32; 2], level: i32) -> [f32; 4] {
    let inside = level == 0
        && !t.ptr.is_null()
        && (0..t.width as i64).contains(&(coords[0] as i64))
        && (0..t.height as i64).contains(&(coords[1] as i64));
    if !inside {
        return [0.0; 4];
    }
    unsafe { texel(t, coords[0] as u32, coords[1] as u32) }
}

/// `textureDimensions(t, level)`.
pub fn size(t: &BoundTexture, level: u32) -> [u32; 2] {
    let shift = level.min(31);
    [(t.width >> shift).max(1), (t.height >> shift).max(1)]
}
