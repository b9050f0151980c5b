//! Integer arithmetic and bit built-ins against Rust, bit for bit, on thousands of inputs
//! a third of which are edge cases (0, ±1, MIN, MAX, shift amounts around 32).

use super::*;

const INTS: &str = r#"
@group(0) @binding(1) var<storage, read> a: array<i32>;
@group(0) @binding(2) var<storage, read> b: array<i32>;
@group(0) @binding(3) var<storage, read_write> out: array<u32>;
const K: u32 = 24u;

fn flags(x: i32, y: i32) -> u32 {
    let ux = bitcast<u32>(x);
    let uy = bitcast<u32>(y);
    return select(0u, 1u, x < y) | select(0u, 2u, ux < uy) | select(0u, 4u, x >= y)
        | select(0u, 8u, x == y) | select(0u, 16u, ux > uy) | select(0u, 32u, x != y)
        | select(0u, 64u, x <= y) | select(0u, 128u, ux >= uy);
}

fn raygen__ints() {
    let n = arrayLength(&a);
    for (var i = 0u; i < n; i++) {
        let x = a[i];
        let y = b[i];
        let ux = bitcast<u32>(x);
        let uy = bitcast<u32>(y);
        let o = i * K;
        out[o + 0u] = bitcast<u32>(x / y);
        out[o + 1u] = bitcast<u32>(x % y);
        out[o + 2u] = ux / uy;
        out[o + 3u] = ux % uy;
        out[o + 4u] = bitcast<u32>(x * y);
        out[o + 5u] = bitcast<u32>(x + y - (x ^ y));
        out[o + 6u] = bitcast<u32>(x << uy);
        out[o + 7u] = bitcast<u32>(x >> uy);
        out[o + 8u] = ux >> uy;
        out[o + 9u] = flags(x, y);
        out[o + 10u] = bitcast<u32>(-x) ^ ~uy;
        out[o + 11u] = bitcast<u32>(abs(x)) + bitcast<u32>(min(x, y)) * 3u + bitcast<u32>(max(x, y)) * 5u
            + min(ux, uy) * 7u + max(ux, uy) * 11u + bitcast<u32>(clamp(x, -100, 100)) * 13u;
        out[o + 12u] = countOneBits(ux) | (countLeadingZeros(ux) << 8u) | (countTrailingZeros(ux) << 16u);
        out[o + 13u] = reverseBits(ux);
        out[o + 14u] = firstLeadingBit(ux);
        out[o + 15u] = bitcast<u32>(firstLeadingBit(x));
        out[o + 16u] = firstTrailingBit(ux);
        out[o + 17u] = bitcast<u32>(extractBits(x, uy & 63u, (uy >> 8u) & 63u));
        out[o + 18u] = extractBits(ux, uy & 63u, (uy >> 8u) & 63u);
        out[o + 19u] = insertBits(ux, ~ux, uy & 63u, (uy >> 8u) & 63u);
        out[o + 20u] = bitcast<u32>(sign(x)) ^ (ux & uy) ^ (ux | (uy << 3u));
        out[o + 21u] = bitcast<u32>(countOneBits(x) + reverseBits(x) + countLeadingZeros(x));
        out[o + 22u] = bitcast<u32>(vec2<i32>(x, y) / vec2<i32>(y, x)).y;
        out[o + 23u] = dot(vec3<u32>(ux, uy, 3u), vec3<u32>(uy, ux, ux));
    }
}
"#;

fn div(x: i32, y: i32) -> i32 {
    if y == 0 || (x == i32::MIN && y == -1) {
        x
    } else {
        x / y
    }
}

fn rem(x: i32, y: i32) -> i32 {
    if y == 0 || (x == i32::MIN && y == -1) {
        0
    } else {
        x % y
    }
}

fn first_leading_u(x: u32) -> u32 {
    if x == 0 {
        u32::MAX
    } else {
        31 - x.leading_zeros()
    }
}

fn first_leading_i(x: i32) -> i32 {
    let v = if x < 0 { !x } else { x } as u32;
    if v == 0 {
        -1
    } else {
        31 - v.leading_zeros() as i32
    }
}

fn bit_range(offset: u32, count: u32) -> (u32, u32) {
    let o = offset.min(32);
    (o, count.min(32 - o))
}

fn extract_u(e: u32, offset: u32, count: u32) -> u32 {
    let (o, c) = bit_range(offset, count);
    if c == 0 {
        0
    } else {
        (e << (32 - o - c)) >> (32 - c)
    }
}

fn extract_i(e: i32, offset: u32, count: u32) -> i32 {
    let (o, c) = bit_range(offset, count);
    if c == 0 {
        0
    } else {
        (e << (32 - o - c)) >> (32 - c)
    }
}

fn insert(e: u32, new: u32, offset: u32, count: u32) -> u32 {
    let (o, c) = bit_range(offset, count);
    let mask = if c == 0 {
        0
    } else {
        (u32::MAX >> (32 - c)) << (o & 31)
    };
    (e & !mask) | (new.wrapping_shl(o) & mask)
}

fn flags(x: i32, y: i32) -> u32 {
    let (ux, uy) = (x as u32, y as u32);
    (x < y) as u32
        | ((ux < uy) as u32) << 1
        | ((x >= y) as u32) << 2
        | ((x == y) as u32) << 3
        | ((ux > uy) as u32) << 4
        | ((x != y) as u32) << 5
        | ((x <= y) as u32) << 6
        | ((ux >= uy) as u32) << 7
}

fn reference(x: i32, y: i32) -> [u32; 24] {
    let (ux, uy) = (x as u32, y as u32);
    let sign = x.signum();
    [
        div(x, y) as u32,
        rem(x, y) as u32,
        ux.checked_div(uy).unwrap_or(ux),
        ux.checked_rem(uy).unwrap_or(0),
        x.wrapping_mul(y) as u32,
        x.wrapping_add(y).wrapping_sub(x ^ y) as u32,
        x.wrapping_shl(uy) as u32,
        x.wrapping_shr(uy) as u32,
        ux.wrapping_shr(uy),
        flags(x, y),
        (x.wrapping_neg() as u32) ^ !uy,
        (x.wrapping_abs() as u32)
            .wrapping_add((x.min(y) as u32).wrapping_mul(3))
            .wrapping_add((x.max(y) as u32).wrapping_mul(5))
            .wrapping_add(ux.min(uy).wrapping_mul(7))
            .wrapping_add(ux.max(uy).wrapping_mul(11))
            .wrapping_add((x.clamp(-100, 100) as u32).wrapping_mul(13)),
        ux.count_ones() | (ux.leading_zeros() << 8) | (ux.trailing_zeros() << 16),
        ux.reverse_bits(),
        first_leading_u(ux),
        first_leading_i(x) as u32,
        if ux == 0 {
            u32::MAX
        } else {
            ux.trailing_zeros()
        },
        extract_i(x, uy & 63, (uy >> 8) & 63) as u32,
        extract_u(ux, uy & 63, (uy >> 8) & 63),
        insert(ux, !ux, uy & 63, (uy >> 8) & 63),
        (sign as u32) ^ (ux & uy) ^ (ux | uy.wrapping_shl(3)),
        (x.count_ones() as i32)
            .wrapping_add(x.reverse_bits())
            .wrapping_add(x.leading_zeros() as i32) as u32,
        div(y, x) as u32,
        ux.wrapping_mul(uy)
            .wrapping_add(uy.wrapping_mul(ux))
            .wrapping_add(3u32.wrapping_mul(ux)),
    ]
}

#[test]
fn integer_operations_match_rust_bit_for_bit() {
    let module = jit(INTS);
    let mut rng = Rng(0x1234_5678);
    let n = 4000;
    let (a, b): (Vec<u32>, Vec<u32>) = (0..n).map(|_| (rng.int(), rng.int())).unzip();
    let out = run(
        &module,
        "raygen__ints",
        vec![a.clone(), b.clone(), vec![0; n * 24]],
    );
    let mut mismatches = 0;
    for i in 0..n {
        let want = reference(a[i] as i32, b[i] as i32);
        for (j, &w) in want.iter().enumerate() {
            if out[2][i * 24 + j] != w {
                if mismatches < 10 {
                    eprintln!(
                        "x={} y={} result {j}: jit {:#x}, rust {w:#x}",
                        a[i] as i32,
                        b[i] as i32,
                        out[2][i * 24 + j]
                    );
                }
                mismatches += 1;
            }
        }
    }
    assert_eq!(mismatches, 0);
}

#[test]
fn the_traps_of_integer_division_are_defined() {
    // The cases Cranelift's sdiv/srem trap on, one by one.
    let module = jit(INTS);
    let cases = [
        (i32::MIN, -1),
        (5, 0),
        (i32::MIN, 0),
        (0, 0),
        (-7, 2),
        (7, -2),
    ];
    let a = cases.iter().map(|c| c.0 as u32).collect();
    let b = cases.iter().map(|c| c.1 as u32).collect();
    let out = run(
        &module,
        "raygen__ints",
        vec![a, b, vec![0; cases.len() * 24]],
    );
    let got: Vec<(i32, i32)> = (0..cases.len())
        .map(|i| (out[2][i * 24] as i32, out[2][i * 24 + 1] as i32))
        .collect();
    assert_eq!(
        got,
        vec![
            (i32::MIN, 0),
            (5, 0),
            (i32::MIN, 0),
            (0, 0),
            (-3, -1),
            (-3, 1)
        ]
    );
}

const FOLDING: &str = r#"
@group(0) @binding(1) var<storage, read> inp: array<u32>;
@group(0) @binding(2) var<storage, read_write> folded: array<u32>;
@group(0) @binding(3) var<storage, read_write> runtime: array<u32>;

const A = array<u32, 14>(0u, 1u, 4294967295u, 2147483648u, 2147483647u, 7u, 4294967289u, 31u, 32u, 33u, 5u, 1065353216u, 2143289344u, 2139095040u);
const B = array<u32, 14>(0u, 4294967295u, 4294967295u, 4294967295u, 0u, 2u, 3u, 32u, 33u, 7u, 0u, 3212836864u, 1065353216u, 4286578688u);
const K: u32 = 22u;

fn ops(x: u32, y: u32, o: u32, dst: ptr<function, array<u32, 22>>) {
    let sx = bitcast<i32>(x);
    let sy = bitcast<i32>(y);
    let fx = bitcast<f32>(x);
    let fy = bitcast<f32>(y);
    (*dst)[0] = bitcast<u32>(sx / sy);
    (*dst)[1] = bitcast<u32>(sx % sy);
    (*dst)[2] = x / y;
    (*dst)[3] = x % y;
    (*dst)[4] = bitcast<u32>(sx >> y) ^ (x >> y) ^ (x << y);
    (*dst)[5] = select(0u, 1u, sx < sy) | select(0u, 2u, x < y) | select(0u, 4u, fx < fy) | select(0u, 8u, fx == fy) | select(0u, 16u, fx != fy) | select(0u, 32u, fx >= fy);
    (*dst)[6] = bitcast<u32>(fx + fy);
    (*dst)[7] = bitcast<u32>(fx * fy);
    (*dst)[8] = bitcast<u32>(fx / fy);
    (*dst)[9] = bitcast<u32>(fx % fy);
    (*dst)[10] = bitcast<u32>(i32(fx));
    (*dst)[11] = u32(fx);
    (*dst)[12] = bitcast<u32>(f32(sx)) ^ bitcast<u32>(f32(y));
    (*dst)[13] = bitcast<u32>(-sx) ^ ~y;
    (*dst)[14] = bitcast<u32>(-fx);
    (*dst)[15] = select(0u, 1u, bool(x)) | select(0u, 2u, bool(fy)) | select(0u, 4u, !bool(y));
    (*dst)[16] = x * y + (x - y);
    (*dst)[17] = bitcast<u32>(sx * sy - sy);
    (*dst)[18] = u32(f32(x) > 1e9) + u32(x >= y) * 2u + u32(sx <= sy) * 4u + u32(sx > sy) * 8u;
    (*dst)[19] = (x & y) | ((x ^ y) << 1u);
    (*dst)[20] = bitcast<u32>(select(fx, fy, x > y));
    (*dst)[21] = bitcast<u32>(fx - fy);
}

fn raygen__fold() {
    // Unrolled: every operand is a constant and every operation folds while lowering.
    for (var i = 0u; i < 14u; i++) {
        var r: array<u32, 22>;
        ops(A[i], B[i], i * K, &r);
        for (var k = 0u; k < K; k++) { folded[i * K + k] = r[k]; }
    }
    // The same values from a buffer: every operation is an instruction.
    let n = arrayLength(&inp) / 2u;
    for (var i = 0u; i < n; i++) {
        var r: array<u32, 22>;
        ops(inp[2u * i], inp[2u * i + 1u], i * K, &r);
        for (var k = 0u; k < K; k++) { runtime[i * K + k] = r[k]; }
    }
}
"#;

#[test]
fn constant_folding_computes_what_the_instructions_do() {
    const A: [u32; 14] = [
        0,
        1,
        u32::MAX,
        0x8000_0000,
        0x7fff_ffff,
        7,
        (-7i32) as u32,
        31,
        32,
        33,
        5,
        0x3f80_0000,
        0x7fc0_0000,
        0x7f80_0000,
    ];
    const B: [u32; 14] = [
        0,
        u32::MAX,
        u32::MAX,
        u32::MAX,
        0,
        2,
        3,
        32,
        33,
        7,
        0,
        0xbf80_0000,
        0x3f80_0000,
        0xff80_0000,
    ];
    let module = jit(FOLDING);
    let inp: Vec<u32> = A.iter().zip(&B).flat_map(|(&a, &b)| [a, b]).collect();
    let out = run(
        &module,
        "raygen__fold",
        vec![inp, vec![0; 14 * 22], vec![0; 14 * 22]],
    );
    for i in 0..14 {
        for k in 0..22 {
            let (f, r) = (out[1][i * 22 + k], out[2][i * 22 + k]);
            assert!(
                super::float::same(f, r),
                "a={:#x} b={:#x} result {k}: folded {f:#x}, computed {r:#x}",
                A[i],
                B[i]
            );
        }
    }
}
