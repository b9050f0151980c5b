//! Numeric built-ins: transcendentals, geometry, matrices, decomposition and data packing,
//! against Rust written with the same operation order.

use super::float::{fmax, fmin, same};
use super::*;
use crate::program::math_ref as m;

const BUILTINS: &str = r#"
@group(0) @binding(1) var<storage, read> a: array<f32>;
@group(0) @binding(2) var<storage, read> b: array<f32>;
@group(0) @binding(3) var<storage, read_write> out: array<u32>;
const K: u32 = 40u;

fn put(o: u32, x: f32) { out[o] = bitcast<u32>(x); }

fn raygen__builtins() {
    let n = arrayLength(&a);
    for (var i = 0u; i < n; i++) {
        let x = a[i];
        let y = b[i];
        let o = i * K;
        put(o + 0u, sin(x) + cos(y) * tan(x));
        put(o + 1u, asin(y) + acos(x) + atan(y) + atan2(x, y));
        put(o + 2u, sinh(x) + cosh(y) + tanh(x));
        put(o + 3u, asinh(y) + acosh(x) + atanh(y));
        put(o + 4u, exp(x) + exp2(y) + log(x) + log2(y));
        put(o + 5u, pow(x, y));
        put(o + 6u, radians(x) + degrees(y));
        let v = vec3<f32>(x, y, 1.5);
        let w = vec3<f32>(y, -0.5, x);
        put(o + 7u, dot(v, w));
        let c = cross(v, w);
        put(o + 8u, c.x); put(o + 9u, c.y); put(o + 10u, c.z);
        put(o + 11u, length(v) + distance(v, w));
        let nv = normalize(w);
        put(o + 12u, nv.x); put(o + 13u, nv.z);
        let r = reflect(v, nv);
        put(o + 14u, r.x); put(o + 15u, r.y);
        let f = faceForward(v, w, nv);
        put(o + 16u, f.z);
        let t = refract(nv, normalize(v), 0.75);
        put(o + 17u, t.x); put(o + 18u, t.y);
        let mf = modf(x);
        put(o + 19u, mf.fract); put(o + 20u, mf.whole);
        let fe = frexp(y);
        put(o + 21u, fe.fract); out[o + 22u] = bitcast<u32>(fe.exp);
        put(o + 23u, ldexp(x, i32(y) % 300));
        put(o + 24u, inverseSqrt(abs(x)));
        out[o + 25u] = pack4x8unorm(vec4<f32>(x, y, 0.5, x * y));
        out[o + 26u] = pack4x8snorm(vec4<f32>(x, y, -0.5, 2.0));
        out[o + 27u] = pack2x16snorm(vec2<f32>(x, y)) ^ pack2x16unorm(vec2<f32>(y, x));
        out[o + 28u] = bitcast<u32>(x) ^ bitcast<u32>(y);
        let bits = bitcast<u32>(x);
        let u4 = unpack4x8unorm(bits) + unpack4x8snorm(bits);
        put(o + 29u, u4.x + u4.y * 2.0 + u4.z * 3.0 + u4.w * 4.0);
        let u2 = unpack2x16unorm(bits) + unpack2x16snorm(bits);
        put(o + 30u, u2.x + u2.y * 2.0);
        let ybits = bitcast<u32>(y);
        out[o + 31u] = bitcast<u32>(dot4I8Packed(bits, ybits)) ^ dot4U8Packed(bits, ybits);
        out[o + 32u] = pack4xI8(vec4<i32>(i32(x), i32(y), -3, 300)) ^ pack4xU8(vec4<u32>(u32(x), u32(y), 3u, 300u));
        out[o + 33u] = pack4xI8Clamp(vec4<i32>(i32(x), i32(y), -3, 300)) ^ pack4xU8Clamp(vec4<u32>(u32(x), u32(y), 3u, 300u));
        let ui = unpack4xI8(bits);
        let uu = unpack4xU8(ybits);
        out[o + 34u] = bitcast<u32>(ui.x + ui.y * 3 + ui.z * 5 + ui.w * 7) ^ (uu.x + uu.y * 3u + uu.z * 5u + uu.w * 7u);
        let m3 = mat3x3<f32>(v, w, vec3<f32>(1.0, x, 2.0));
        put(o + 35u, determinant(m3));
        let m2 = mat2x2<f32>(x, y, 1.0, 2.0);
        let m4 = mat4x4<f32>(vec4<f32>(x, 1.0, 2.0, 3.0), vec4<f32>(y, x, 0.5, 1.0), vec4<f32>(1.0, 2.0, y, x), vec4<f32>(0.25, x, y, 4.0));
        put(o + 36u, determinant(m2) + determinant(m4));
        let tr = transpose(mat2x3<f32>(v, w));
        put(o + 37u, tr[1].y + tr[2].x * 3.0);
        let mv = m3 * w;
        let vm = v * m3;
        put(o + 38u, mv.x + mv.y * 2.0 + mv.z * 3.0 + vm.x * 4.0 + vm.y * 5.0 + vm.z * 6.0);
        let mm = m3 * transpose(m3);
        put(o + 39u, mm[0].x + mm[1].z * 2.0 + mm[2].y * 3.0);
    }
}
"#;

type V3 = [f32; 3];

fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn length(a: V3) -> f32 {
    dot(a, a).sqrt()
}
fn normalize(a: V3) -> V3 {
    let l = length(a);
    a.map(|x| x / l)
}
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// Column-major 3×3 times vector, rows summed left to right over columns.
fn mat_vec(m: [V3; 3], v: V3) -> V3 {
    std::array::from_fn(|r| m[0][r] * v[0] + m[1][r] * v[1] + m[2][r] * v[2])
}
fn det2(m: [[f32; 2]; 2]) -> f32 {
    m[0][0] * m[1][1] - m[1][0] * m[0][1]
}
fn det3(m: [V3; 3]) -> f32 {
    let minor = |c: usize| {
        let k: Vec<usize> = (0..3).filter(|&k| k != c).collect();
        det2([[m[k[0]][1], m[k[0]][2]], [m[k[1]][1], m[k[1]][2]]])
    };
    m[0][0] * minor(0) - m[1][0] * minor(1) + m[2][0] * minor(2)
}
fn det4(m: [[f32; 4]; 4]) -> f32 {
    let minor = |c: usize| {
        let k: Vec<usize> = (0..4).filter(|&k| k != c).collect();
        det3(std::array::from_fn(|i| {
            [m[k[i]][1], m[k[i]][2], m[k[i]][3]]
        }))
    };
    m[0][0] * minor(0) - m[1][0] * minor(1) + m[2][0] * minor(2) - m[3][0] * minor(3)
}
fn sat_i(x: f32) -> i32 {
    x as i32
}

fn reference(x: f32, y: f32) -> Vec<u32> {
    let f = |v: f32| v.to_bits();
    let v = [x, y, 1.5];
    let w = [y, -0.5, x];
    let c = [
        v[1] * w[2] - v[2] * w[1],
        v[2] * w[0] - v[0] * w[2],
        v[0] * w[1] - v[1] * w[0],
    ];
    let nv = normalize(w);
    let k = 2.0 * dot(nv, v);
    let r = [v[0] - k * nv[0], v[1] - k * nv[1], v[2] - k * nv[2]];
    let ff = if dot(w, nv) < 0.0 { v[2] } else { -v[2] };
    let nvv = normalize(v);
    let d = dot(nvv, nv);
    let kk = 1.0 - 0.75 * 0.75 * (1.0 - d * d);
    let refr = |i: usize| {
        if kk < 0.0 {
            0.0
        } else {
            0.75 * nv[i] - (0.75 * d + kk.sqrt()) * nvv[i]
        }
    };
    let whole = x.trunc();
    let (fr, ex) = m::frexp(y);
    let bits = x.to_bits();
    let ybits = y.to_bits();
    let (un, sn) = (m::unpack4x8unorm(bits), m::unpack4x8snorm(bits));
    let u4: [f32; 4] = std::array::from_fn(|i| un[i] + sn[i]);
    let (a2, b2) = (m::unpack2x16unorm(bits), m::unpack2x16snorm(bits));
    let u2: [f32; 2] = std::array::from_fn(|i| a2[i] + b2[i]);
    let ui = m::unpack4xi8(bits);
    let uu = m::unpack4xu8(ybits);
    let m3 = [v, w, [1.0, x, 2.0]];
    let m4 = [
        [x, 1.0, 2.0, 3.0],
        [y, x, 0.5, 1.0],
        [1.0, 2.0, y, x],
        [0.25, x, y, 4.0],
    ];
    // transpose(mat2x3(v, w)) is a mat3x2 whose column c is (v[c], w[c]).
    let mv = mat_vec(m3, w);
    let vm = [dot(v, m3[0]), dot(v, m3[1]), dot(v, m3[2])];
    let t3: [V3; 3] = std::array::from_fn(|c| std::array::from_fn(|r| m3[r][c]));
    let mm: [V3; 3] = std::array::from_fn(|c| mat_vec(m3, t3[c]));
    vec![
        f(x.sin() + y.cos() * x.tan()),
        f(y.asin() + x.acos() + y.atan() + x.atan2(y)),
        f(x.sinh() + y.cosh() + x.tanh()),
        f(y.asinh() + x.acosh() + y.atanh()),
        f(x.exp() + y.exp2() + x.ln() + y.log2()),
        f(x.powf(y)),
        f(x * 0.017_453_292 + y * 57.295_78),
        f(dot(v, w)),
        f(c[0]),
        f(c[1]),
        f(c[2]),
        f(length(v) + length(sub(v, w))),
        f(nv[0]),
        f(nv[2]),
        f(r[0]),
        f(r[1]),
        f(ff),
        f(refr(0)),
        f(refr(1)),
        f(x - whole),
        f(whole),
        f(fr),
        ex as u32,
        f(m::ldexp(x, sat_i(y).wrapping_rem(300))),
        f(1.0 / x.abs().sqrt()),
        m::pack4x8unorm([x, y, 0.5, x * y]),
        m::pack4x8snorm([x, y, -0.5, 2.0]),
        m::pack2x16snorm([x, y]) ^ m::pack2x16unorm([y, x]),
        x.to_bits() ^ y.to_bits(),
        f(u4[0] + u4[1] * 2.0 + u4[2] * 3.0 + u4[3] * 4.0),
        f(u2[0] + u2[1] * 2.0),
        (m::dot4i8packed(bits, ybits) as u32) ^ m::dot4u8packed(bits, ybits),
        m::pack4xi8([sat_i(x), sat_i(y), -3, 300]) ^ m::pack4xu8([x as u32, y as u32, 3, 300]),
        m::pack4xi8_clamp([sat_i(x), sat_i(y), -3, 300])
            ^ m::pack4xu8_clamp([x as u32, y as u32, 3, 300]),
        (ui[0]
            .wrapping_add(ui[1] * 3)
            .wrapping_add(ui[2] * 5)
            .wrapping_add(ui[3] * 7) as u32)
            ^ (uu[0] + uu[1] * 3 + uu[2] * 5 + uu[3] * 7),
        f(det3(m3)),
        f(det2([[x, y], [1.0, 2.0]]) + det4(m4)),
        f(w[1] + v[2] * 3.0),
        f(mv[0] + mv[1] * 2.0 + mv[2] * 3.0 + vm[0] * 4.0 + vm[1] * 5.0 + vm[2] * 6.0),
        f(mm[0][0] + mm[1][2] * 2.0 + mm[2][1] * 3.0),
    ]
}

#[test]
fn built_ins_match_rust_bit_for_bit() {
    let module = jit(BUILTINS);
    let mut rng = Rng(7);
    let n = 3000;
    let (a, b): (Vec<f32>, Vec<f32>) = (0..n).map(|_| (rng.float(), rng.float())).unzip();
    let words = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
    let out = run(
        &module,
        "raygen__builtins",
        vec![words(&a), words(&b), vec![0; n * 40]],
    );
    let mut mismatches = 0;
    for i in 0..n {
        for (j, &w) in reference(a[i], b[i]).iter().enumerate() {
            let got = out[2][i * 40 + j];
            if !same(got, w) {
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
    let _ = (fmin(0.0, 1.0), fmax(0.0, 1.0));
}
