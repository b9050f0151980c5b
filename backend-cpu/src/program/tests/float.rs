//! Float arithmetic, comparisons, min/max/clamp/select and conversions against Rust, bit
//! for bit, with NaN, infinities, -0.0, huge and subnormal values among the inputs.

use super::*;

const FLOATS: &str = r#"
@group(0) @binding(1) var<storage, read> a: array<f32>;
@group(0) @binding(2) var<storage, read> b: array<f32>;
@group(0) @binding(3) var<storage, read_write> out: array<u32>;
const K: u32 = 24u;

fn raygen__floats() {
    let n = arrayLength(&a);
    for (var i = 0u; i < n; i++) {
        let x = a[i];
        let y = b[i];
        let o = i * K;
        out[o + 0u] = bitcast<u32>(x + y);
        out[o + 1u] = bitcast<u32>(x - y);
        out[o + 2u] = bitcast<u32>(x * y);
        out[o + 3u] = bitcast<u32>(x / y);
        out[o + 4u] = bitcast<u32>(x % y);
        out[o + 5u] = bitcast<u32>(min(x, y));
        out[o + 6u] = bitcast<u32>(max(x, y));
        out[o + 7u] = bitcast<u32>(clamp(x, -1.0, y));
        out[o + 8u] = bitcast<u32>(select(x, y, x < y));
        out[o + 9u] = bitcast<u32>(i32(x));
        out[o + 10u] = u32(x);
        out[o + 11u] = bitcast<u32>(f32(bitcast<i32>(y)) + f32(bitcast<u32>(x)));
        out[o + 12u] = select(0u, 1u, x < y) | select(0u, 2u, x <= y) | select(0u, 4u, x > y)
            | select(0u, 8u, x >= y) | select(0u, 16u, x == y) | select(0u, 32u, x != y)
            | select(0u, 64u, bool(x)) | select(0u, 128u, !(x < y));
        out[o + 13u] = bitcast<u32>(-x);
        out[o + 14u] = bitcast<u32>(abs(x) + saturate(y));
        out[o + 15u] = bitcast<u32>(floor(x)) ^ bitcast<u32>(ceil(y));
        out[o + 16u] = bitcast<u32>(round(x)) ^ bitcast<u32>(trunc(y));
        out[o + 17u] = bitcast<u32>(fract(x));
        out[o + 18u] = bitcast<u32>(sign(x));
        out[o + 19u] = bitcast<u32>(sqrt(x)) ^ bitcast<u32>(inverseSqrt(y));
        out[o + 20u] = bitcast<u32>(step(x, y)) ^ bitcast<u32>(f32(x < y));
        out[o + 21u] = bitcast<u32>(mix(x, y, 0.25));
        out[o + 22u] = bitcast<u32>(fma(x, y, 1.5));
        out[o + 23u] = bitcast<u32>(smoothstep(-2.0, 3.0, x));
    }
}
"#;

/// WGSL `min` as compiled: `a < b ? a : b`.
pub fn fmin(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// WGSL `max` as compiled: `a > b ? a : b`.
pub fn fmax(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn reference(x: f32, y: f32) -> [u32; 24] {
    let clamp = |e: f32, lo: f32, hi: f32| fmin(fmax(e, lo), hi);
    let t = clamp((x - -2.0) / (3.0 - -2.0), 0.0, 1.0);
    [
        (x + y).to_bits(),
        (x - y).to_bits(),
        (x * y).to_bits(),
        (x / y).to_bits(),
        (x - y * (x / y).trunc()).to_bits(),
        fmin(x, y).to_bits(),
        fmax(x, y).to_bits(),
        clamp(x, -1.0, y).to_bits(),
        (if x < y { y } else { x }).to_bits(),
        x as i32 as u32,
        x as u32,
        ((y.to_bits() as i32) as f32 + x.to_bits() as f32).to_bits(),
        (x < y) as u32
            | ((x <= y) as u32) << 1
            | ((x > y) as u32) << 2
            | ((x >= y) as u32) << 3
            | ((x == y) as u32) << 4
            | ((x != y) as u32) << 5
            | ((x != 0.0) as u32) << 6
            | ((x >= y || x.is_nan() || y.is_nan()) as u32) << 7,
        (-x).to_bits(),
        (x.abs() + clamp(y, 0.0, 1.0)).to_bits(),
        x.floor().to_bits() ^ y.ceil().to_bits(),
        x.round_ties_even().to_bits() ^ y.trunc().to_bits(),
        (x - x.floor()).to_bits(),
        sign(x).to_bits(),
        x.sqrt().to_bits() ^ (1.0 / y.sqrt()).to_bits(),
        (if x <= y { 1.0f32 } else { 0.0 }).to_bits()
            ^ (if x < y { 1.0f32 } else { 0.0 }).to_bits(),
        (x * (1.0 - 0.25) + y * 0.25).to_bits(),
        x.mul_add(y, 1.5).to_bits(),
        (t * t * (3.0 - 2.0 * t)).to_bits(),
    ]
}

/// Same bits, or both NaN (NaN payloads and signs are not specified by WGSL).
pub fn same(a: u32, b: u32) -> bool {
    a == b || (f32::from_bits(a).is_nan() && f32::from_bits(b).is_nan())
}

#[test]
fn float_operations_match_rust_bit_for_bit() {
    let module = jit(FLOATS);
    let mut rng = Rng(99);
    let n = 4000;
    let (a, b): (Vec<f32>, Vec<f32>) = (0..n).map(|_| (rng.float(), rng.float())).unzip();
    let words = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
    let out = run(
        &module,
        "raygen__floats",
        vec![words(&a), words(&b), vec![0; n * 24]],
    );
    let mut mismatches = 0;
    for i in 0..n {
        for (j, &w) in reference(a[i], b[i]).iter().enumerate() {
            let got = out[2][i * 24 + j];
            // Results 9..=12 are integers and flags: compared exactly.
            let ok = if (9..=12).contains(&j) {
                got == w
            } else {
                same(got, w)
            };
            if !ok {
                if mismatches < 10 {
                    eprintln!(
                        "x={:e} y={:e} result {j}: jit {got:#x}, rust {w:#x}",
                        a[i], b[i]
                    );
                }
                mismatches += 1;
            }
        }
    }
    assert_eq!(mismatches, 0);
}

#[test]
fn min_max_and_casts_on_special_values() {
    let module = jit(FLOATS);
    let cases = [
        (f32::NAN, 1.0),
        (1.0, f32::NAN),
        (-0.0, 0.0),
        (0.0, -0.0),
        (3e9, -3e9),
        (f32::INFINITY, f32::NEG_INFINITY),
    ];
    let a = cases.iter().map(|c| c.0.to_bits()).collect();
    let b = cases.iter().map(|c| c.1.to_bits()).collect();
    let out = run(
        &module,
        "raygen__floats",
        vec![a, b, vec![0; cases.len() * 24]],
    );
    let at = |i: usize, j: usize| out[2][i * 24 + j];
    // min(NaN, 1) = 1 and min(1, NaN) = NaN: the compare-and-pick order, as in Rust.
    assert_eq!(f32::from_bits(at(0, 5)), 1.0);
    assert!(f32::from_bits(at(1, 5)).is_nan());
    // min(-0, 0) picks the second operand (no ordering between zeros).
    assert_eq!(at(2, 5), 0.0f32.to_bits());
    assert_eq!(at(3, 5), (-0.0f32).to_bits());
    // Saturating conversions: NaN to 0, out of range to the limits.
    assert_eq!((at(0, 9), at(0, 10)), (0, 0));
    assert_eq!((at(4, 9) as i32, at(4, 10)), (i32::MAX, 3_000_000_000));
    assert_eq!((at(5, 9) as i32, at(5, 10)), (i32::MAX, u32::MAX));
}
