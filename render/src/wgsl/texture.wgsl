// Bitmap textures (compiled in only when a scene has one): the texel table starts with a
// directory of four floats per image (first texel, width, height, spare), then RGBA texels,
// row 0 at the top (Mitsuba looks up v = 0 in the first row).

@group(0) @binding(8) var<storage, read> texels: array<f32>;

// A texel index along an axis of `res` texels under Mitsuba's (Dr.Jit's) wrap modes:
// 0 repeat, 1 mirror, 2 clamp.
fn tex_wrap(i: i32, res: i32, mode: u32) -> i32 {
    if mode == 2u {
        return clamp(i, 0, res - 1);
    }
    if mode == 1u {
        let m = ((i % (2 * res)) + 2 * res) % (2 * res);
        return select(m, 2 * res - m - 1, m >= res);
    }
    return ((i % res) + res) % res;
}

fn tex_texel(base: u32, w: i32, x: i32, y: i32) -> vec4<f32> {
    let o = (base + u32(y * w + x)) * 4u;
    return vec4<f32>(texels[o], texels[o + 1u], texels[o + 2u], texels[o + 3u]);
}

// Image `image` at uv (already through to_uv): bilinear as Mitsuba's bitmap (texel centres
// at half-integers) or nearest.
fn tex_bitmap(image: u32, uv: vec2<f32>, bilinear: bool, wrap: u32) -> vec4<f32> {
    let d = image * 4u;
    let base = u32(texels[d]);
    let w = i32(texels[d + 1u]);
    let h = i32(texels[d + 2u]);
    let res = vec2<f32>(f32(w), f32(h));
    if !bilinear {
        let p = vec2<i32>(floor(uv * res));
        return tex_texel(base, w, tex_wrap(p.x, w, wrap), tex_wrap(p.y, h, wrap));
    }
    let pos = uv * res - 0.5;
    let p0 = floor(pos);
    let f = pos - p0;
    let x0 = tex_wrap(i32(p0.x), w, wrap);
    let x1 = tex_wrap(i32(p0.x) + 1, w, wrap);
    let y0 = tex_wrap(i32(p0.y), h, wrap);
    let y1 = tex_wrap(i32(p0.y) + 1, h, wrap);
    let a = mix(tex_texel(base, w, x0, y0), tex_texel(base, w, x1, y0), f.x);
    let b = mix(tex_texel(base, w, x0, y1), tex_texel(base, w, x1, y1), f.x);
    return mix(a, b, f.y);
}
