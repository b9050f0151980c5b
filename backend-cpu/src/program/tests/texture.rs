//! Textures: `textureSampleLevel` (nearest and linear, repeat and clamp-to-edge, at the
//! edges and outside [0, 1]), `textureLoad` in and out of range, `textureDimensions`, and
//! every texel format.

use super::*;
use crate::program::abi::BoundTexture;
use optik_api::{AddressMode, FilterMode, SamplerDesc, TextureFormat};

const TEXTURES: &str = r#"
@group(0) @binding(1) var<storage, read> uv: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> out: array<vec4<f32>>;
@group(0) @binding(3) var tex: texture_2d<f32>;
@group(0) @binding(4) var smp: sampler;

fn fetch(t: texture_2d<f32>, s: sampler, at: vec2<f32>) -> vec4<f32> {
    return textureSampleLevel(t, s, at, 0.0);
}

fn raygen__sample() {
    let n = arrayLength(&uv);
    for (var i = 0u; i < n; i++) {
        out[i] = fetch(tex, smp, uv[i]);
    }
}

fn raygen__offset() {
    out[0] = textureSampleLevel(tex, smp, uv[0], 2.0, vec2<i32>(1, -1));
}

fn raygen__load() {
    let n = arrayLength(&uv);
    for (var i = 0u; i < n; i++) {
        out[i] = textureLoad(tex, vec2<i32>(uv[i]), 0);
    }
    let d = textureDimensions(tex);
    let d1 = textureDimensions(tex, 1u);
    out[n] = vec4<f32>(f32(d.x), f32(d.y), f32(d1.x), f32(textureNumLevels(tex)));
    out[n + 1u] = textureLoad(tex, vec2<u32>(0u, 0u), 1);
}
"#;

/// A 4×2 RGBA8 texture whose texel (x, y) is (x, y, x + y, 1) × 40 / 255.
fn rgba8() -> Vec<u8> {
    (0..2)
        .flat_map(|y| (0..4).flat_map(move |x| [x * 40, y * 40, (x + y) * 40, 255]))
        .collect()
}

fn texel(x: i64, y: i64) -> [f32; 4] {
    let t = rgba8();
    let i = ((y * 4 + x) * 4) as usize;
    std::array::from_fn(|c| t[i + c] as f32 / 255.0)
}

fn sample(
    texels: &[u8],
    format: TextureFormat,
    sampler: SamplerDesc,
    program: &str,
    uv: &[[f32; 2]],
) -> Vec<[f32; 4]> {
    let module = jit(TEXTURES);
    let f = module.program(program).unwrap();
    let mut uv_words: Vec<u32> = uv.iter().flat_map(|p| p.map(f32::to_bits)).collect();
    let mut out = vec![0u32; (uv.len() + 2) * 4];
    let mut params: Vec<u32> = Vec::new();
    let resources = [
        BoundResource::Buffer(BoundBuffer {
            ptr: params.as_mut_ptr().cast(),
            len: 0,
        }),
        BoundResource::Buffer(BoundBuffer {
            ptr: uv_words.as_mut_ptr().cast(),
            len: uv_words.len() * 4,
        }),
        BoundResource::Buffer(BoundBuffer {
            ptr: out.as_mut_ptr().cast(),
            len: out.len() * 4,
        }),
        BoundResource::Texture(BoundTexture {
            ptr: texels.as_ptr(),
            width: 4,
            height: 2,
            format,
        }),
        BoundResource::Sampler(sampler),
    ];
    f.call(
        &Bindings {
            resources: &resources,
        },
        &mut Mock::default(),
    );
    out.chunks(4)
        .map(|c| std::array::from_fn(|i| f32::from_bits(c[i])))
        .collect()
}

fn sampler(filter: FilterMode, address_mode: AddressMode) -> SamplerDesc {
    SamplerDesc {
        filter,
        address_mode,
    }
}

fn close(a: [f32; 4], b: [f32; 4]) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-6)
}

#[test]
fn nearest_sampling_picks_the_texel_under_the_coordinate() {
    let uv = [
        [0.0, 0.0],
        [0.99, 0.99],
        [0.3, 0.6],
        [1.1, 0.2],
        [-0.1, 0.2],
        [2.6, -1.3],
    ];
    let clamp = sample(
        &rgba8(),
        TextureFormat::Rgba8Unorm,
        sampler(FilterMode::Nearest, AddressMode::ClampToEdge),
        "raygen__sample",
        &uv,
    );
    let want_clamp = [
        texel(0, 0),
        texel(3, 1),
        texel(1, 1),
        texel(3, 0),
        texel(0, 0),
        texel(3, 0),
    ];
    let repeat = sample(
        &rgba8(),
        TextureFormat::Rgba8Unorm,
        sampler(FilterMode::Nearest, AddressMode::Repeat),
        "raygen__sample",
        &uv,
    );
    // 1.1 * 4 = 4.4 -> texel 4 -> wraps to 0; -0.1 * 4 -> -1 -> 3; 2.6 * 4 = 10.4 -> 10 -> 2; -1.3 * 2 = -2.6 -> -3 -> 1.
    let want_repeat = [
        texel(0, 0),
        texel(3, 1),
        texel(1, 1),
        texel(0, 0),
        texel(3, 0),
        texel(2, 1),
    ];
    for i in 0..uv.len() {
        assert!(
            close(clamp[i], want_clamp[i]),
            "clamp {:?}: {:?} vs {:?}",
            uv[i],
            clamp[i],
            want_clamp[i]
        );
        assert!(
            close(repeat[i], want_repeat[i]),
            "repeat {:?}: {:?} vs {:?}",
            uv[i],
            repeat[i],
            want_repeat[i]
        );
    }
}

#[test]
fn linear_sampling_blends_four_texels() {
    let lerp = |a: [f32; 4], b: [f32; 4], t: f32| -> [f32; 4] {
        std::array::from_fn(|i| a[i] * (1.0 - t) + b[i] * t)
    };
    // Texel centres: u = (x + 0.5) / 4, v = (y + 0.5) / 2.
    let uv = [[0.125, 0.25], [0.25, 0.5], [0.0, 0.0], [1.0, 1.0]];
    let clamp = sample(
        &rgba8(),
        TextureFormat::Rgba8Unorm,
        sampler(FilterMode::Linear, AddressMode::ClampToEdge),
        "raygen__sample",
        &uv,
    );
    let repeat = sample(
        &rgba8(),
        TextureFormat::Rgba8Unorm,
        sampler(FilterMode::Linear, AddressMode::Repeat),
        "raygen__sample",
        &uv,
    );
    assert!(close(clamp[0], texel(0, 0)), "a texel centre is that texel");
    let middle = lerp(
        lerp(texel(0, 0), texel(1, 0), 0.5),
        lerp(texel(0, 1), texel(1, 1), 0.5),
        0.5,
    );
    assert!(close(clamp[1], middle), "between four centres: their mean");
    assert!(
        close(clamp[2], texel(0, 0)),
        "the corner clamps to the corner texel"
    );
    assert!(close(clamp[3], texel(3, 1)));
    // Repeat at the corner blends with the opposite edges.
    let wrapped = lerp(
        lerp(texel(3, 1), texel(0, 1), 0.5),
        lerp(texel(3, 0), texel(0, 0), 0.5),
        0.5,
    );
    assert!(close(repeat[2], wrapped), "{:?} vs {wrapped:?}", repeat[2]);
}

#[test]
fn sampling_offsets_and_float_formats() {
    // Offset (1, -1) from texel (0, 1): texel (1, 0); the level selects nothing.
    let got = sample(
        &rgba8(),
        TextureFormat::Rgba8Unorm,
        sampler(FilterMode::Nearest, AddressMode::ClampToEdge),
        "raygen__offset",
        &[[0.1, 0.9]],
    );
    assert!(close(got[0], texel(1, 0)));
    let floats: Vec<u8> = (0..8)
        .flat_map(|i| (0..4).flat_map(move |c| (i as f32 * 10.0 + c as f32).to_le_bytes()))
        .collect();
    let got = sample(
        &floats,
        TextureFormat::Rgba32Float,
        sampler(FilterMode::Nearest, AddressMode::ClampToEdge),
        "raygen__sample",
        &[[0.6, 0.6]],
    );
    assert_eq!(got[0], [60.0, 61.0, 62.0, 63.0]);
    let single: Vec<u8> = (0..8).flat_map(|i| (i as f32).to_le_bytes()).collect();
    let got = sample(
        &single,
        TextureFormat::R32Float,
        sampler(FilterMode::Nearest, AddressMode::ClampToEdge),
        "raygen__sample",
        &[[0.6, 0.6]],
    );
    assert_eq!(
        got[0],
        [6.0, 0.0, 0.0, 1.0],
        "one channel expands to (r, 0, 0, 1)"
    );
}

#[test]
fn texture_load_and_dimensions() {
    let coords = [[0.0, 0.0], [3.0, 1.0], [4.0, 0.0], [-1.0, 0.0], [2.0, 2.0]];
    let got = sample(
        &rgba8(),
        TextureFormat::Rgba8Unorm,
        SamplerDesc::default(),
        "raygen__load",
        &coords,
    );
    assert!(close(got[0], texel(0, 0)));
    assert!(close(got[1], texel(3, 1)));
    for (i, g) in got.iter().enumerate().take(5).skip(2) {
        assert_eq!(*g, [0.0; 4], "out of range load {i} reads zero");
    }
    assert_eq!(
        got[5],
        [4.0, 2.0, 2.0, 1.0],
        "dimensions, at level 1, and one level"
    );
    assert_eq!(
        got[6], [0.0; 4],
        "a load at a level the texture lacks reads zero"
    );
}

#[test]
fn an_unbound_texture_samples_zero() {
    let module = jit(TEXTURES);
    let mut buffers = Buffers::new(vec![vec![0, 0], vec![1; 12]]);
    buffers.run(&module, "raygen__sample", &mut Mock::default());
    assert_eq!(buffers.words[1][..4], [0, 0, 0, 0]);
}
