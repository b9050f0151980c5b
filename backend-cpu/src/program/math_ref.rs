//! WGSL built-ins that compiled code calls out to Rust for, written from the WGSL
//! specification's formulas (§17.5 numeric, §17.9 data packing, §17.10 data unpacking).
//!
//! These are rarely on a hot path (colour packing, `pack4x8unorm`, is compiled inline), and
//! Rust is the clearest place to get their rounding right once.

use half::f16;

/// `ldexp(x, e)`: `x * 2^e`, rounded once (the product is exact in f64 for every `e` that
/// can change an f32 result).
pub fn ldexp(x: f32, e: i32) -> f32 {
    (x as f64 * 2f64.powi(e.clamp(-400, 400))) as f32
}

/// `frexp(x)`: `(fract, exp)` with `x = fract * 2^exp` and `|fract|` in [0.5, 1); zero,
/// infinities and NaN give `(x, 0)`.
pub fn frexp(x: f32) -> (f32, i32) {
    if x == 0.0 || !x.is_finite() {
        return (x, 0);
    }
    // Every f32, subnormals included, is a normal f64: read the exponent there.
    let bits = (x as f64).to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32 - 1022;
    let fract = f64::from_bits((bits & !(0x7ff << 52)) | (1022 << 52)) as f32;
    (fract, exp)
}

/// `quantizeToF16(x)`: `x` rounded to f16 and back.
pub fn quantize_f16(x: f32) -> f32 {
    f16::from_f32(x).to_f32()
}

fn snorm(x: f32, scale: f32) -> i32 {
    (0.5 + scale * x.clamp(-1.0, 1.0)).floor() as i32
}

fn unorm(x: f32, scale: f32) -> u32 {
    (0.5 + scale * x.clamp(0.0, 1.0)).floor() as u32
}

/// `pack4x8snorm`.
pub fn pack4x8snorm(v: [f32; 4]) -> u32 {
    v.iter().enumerate().fold(0, |acc, (i, &x)| {
        acc | ((snorm(x, 127.0) as u32 & 0xff) << (8 * i))
    })
}

/// `pack4x8unorm` (the compiled version is inline; this is the reference).
pub fn pack4x8unorm(v: [f32; 4]) -> u32 {
    v.iter().enumerate().fold(0, |acc, (i, &x)| {
        acc | ((unorm(x, 255.0) & 0xff) << (8 * i))
    })
}

/// `pack2x16snorm`.
pub fn pack2x16snorm(v: [f32; 2]) -> u32 {
    (snorm(v[0], 32767.0) as u32 & 0xffff) | ((snorm(v[1], 32767.0) as u32 & 0xffff) << 16)
}

/// `pack2x16unorm`.
pub fn pack2x16unorm(v: [f32; 2]) -> u32 {
    (unorm(v[0], 65535.0) & 0xffff) | ((unorm(v[1], 65535.0) & 0xffff) << 16)
}

/// `pack2x16float`.
pub fn pack2x16float(v: [f32; 2]) -> u32 {
    f16::from_f32(v[0]).to_bits() as u32 | ((f16::from_f32(v[1]).to_bits() as u32) << 16)
}

/// `pack4xI8`: the low 8 bits of each component.
pub fn pack4xi8(v: [i32; 4]) -> u32 {
    v.iter()
        .enumerate()
        .fold(0, |acc, (i, &x)| acc | ((x as u32 & 0xff) << (8 * i)))
}

/// `pack4xU8`.
pub fn pack4xu8(v: [u32; 4]) -> u32 {
    v.iter()
        .enumerate()
        .fold(0, |acc, (i, &x)| acc | ((x & 0xff) << (8 * i)))
}

/// `pack4xI8Clamp`: each component clamped to [-128, 127] first.
pub fn pack4xi8_clamp(v: [i32; 4]) -> u32 {
    pack4xi8(v.map(|x| x.clamp(-128, 127)))
}

/// `pack4xU8Clamp`: each component clamped to [0, 255] first.
pub fn pack4xu8_clamp(v: [u32; 4]) -> u32 {
    pack4xu8(v.map(|x| x.min(255)))
}

/// `unpack4x8snorm`.
pub fn unpack4x8snorm(x: u32) -> [f32; 4] {
    std::array::from_fn(|i| ((x >> (8 * i)) as u8 as i8 as f32 / 127.0).max(-1.0))
}

/// `unpack4x8unorm`.
pub fn unpack4x8unorm(x: u32) -> [f32; 4] {
    std::array::from_fn(|i| ((x >> (8 * i)) & 0xff) as f32 / 255.0)
}

/// `unpack2x16snorm`.
pub fn unpack2x16snorm(x: u32) -> [f32; 2] {
    std::array::from_fn(|i| ((x >> (16 * i)) as u16 as i16 as f32 / 32767.0).max(-1.0))
}

/// `unpack2x16unorm`.
pub fn unpack2x16unorm(x: u32) -> [f32; 2] {
    std::array::from_fn(|i| ((x >> (16 * i)) & 0xffff) as f32 / 65535.0)
}

/// `unpack2x16float`.
pub fn unpack2x16float(x: u32) -> [f32; 2] {
    std::array::from_fn(|i| f16::from_bits((x >> (16 * i)) as u16).to_f32())
}

/// `unpack4xI8`: each byte sign-extended.
pub fn unpack4xi8(x: u32) -> [i32; 4] {
    std::array::from_fn(|i| (x >> (8 * i)) as u8 as i8 as i32)
}

/// `unpack4xU8`.
pub fn unpack4xu8(x: u32) -> [u32; 4] {
    std::array::from_fn(|i| (x >> (8 * i)) & 0xff)
}

/// `dot4I8Packed`.
pub fn dot4i8packed(a: u32, b: u32) -> i32 {
    let (a, b) = (unpack4xi8(a), unpack4xi8(b));
    (0..4).map(|i| a[i] * b[i]).sum()
}

/// `dot4U8Packed`.
pub fn dot4u8packed(a: u32, b: u32) -> u32 {
    let (a, b) = (unpack4xu8(a), unpack4xu8(b));
    (0..4).map(|i| a[i] * b[i]).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frexp_and_ldexp_round_trip() {
        for x in [1.0f32, -3.5, 0.1, 1e-40, f32::MAX, f32::MIN_POSITIVE, -0.75] {
            let (f, e) = frexp(x);
            assert!((0.5..1.0).contains(&f.abs()), "{x}: fract {f}");
            assert_eq!(ldexp(f, e), x);
        }
        assert_eq!(frexp(0.0), (0.0, 0));
        assert_eq!(ldexp(1.0, 200), f32::INFINITY);
        assert_eq!(ldexp(1.0, -200), 0.0);
    }

    #[test]
    fn packing_follows_the_spec_examples() {
        assert_eq!(pack4x8unorm([1.0, 0.0, 0.5, 2.0]), 0xff80_00ff);
        assert_eq!(pack4x8snorm([-1.0, 1.0, 0.0, -2.0]), 0x8100_7f81);
        assert_eq!(unpack4x8snorm(0x80), [-1.0, 0.0, 0.0, 0.0]);
        assert_eq!(pack4xi8_clamp([300, -300, -1, 5]), 0x05ff_807f);
        assert_eq!(dot4i8packed(0xff, 0xff), 1);
        assert_eq!(dot4u8packed(0xff, 0xff), 65025);
    }
}
