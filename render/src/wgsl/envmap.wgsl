// Mitsuba's `envmap` (compiled in only when a scene has one): radiance by Mitsuba 3.9.1's
// lookup (texel-centred and periodic in φ, align-corners in θ, bilinear), times `scale`;
// directions sampled from the cell distribution geometry.rs builds (cells between texel
// centres, weighted by luminance · sin θ), with the matching solid-angle pdf.
// Light entry: kind 6, cdf, scale rgb, selection, world-to-map rows (6..15), image id and
// table base as u32 bits (15, 16), far (17), map-to-world rows (18..27).

fn env_dir_to_map(b: u32, d: vec3<f32>) -> vec3<f32> {
    return normalize(vec3<f32>(dot(lv3(b + 6u), d), dot(lv3(b + 9u), d), dot(lv3(b + 12u), d)));
}

fn env_uv(v: vec3<f32>) -> vec2<f32> {
    var u = atan2(v.x, -v.z) * (0.5 * INV_PI);
    u = u - floor(u);
    return vec2<f32>(u, acos(clamp(v.y, -1.0, 1.0)) * INV_PI);
}

fn env_eval(b: u32, d: vec3<f32>) -> vec3<f32> {
    let uv = env_uv(env_dir_to_map(b, d));
    let image = bitcast<u32>(lights[b + 15u]);
    let di = image * 4u;
    let base = u32(texels[di]);
    let w = i32(texels[di + 1u]);
    let h = i32(texels[di + 2u]);
    let cx = uv.x * f32(w) - 0.5;
    let ry = clamp(uv.y, 0.0, 1.0) * f32(h - 1);
    let x0 = floor(cx);
    let y0 = min(floor(ry), f32(h - 1));
    let fx = cx - x0;
    let fy = ry - y0;
    let xa = tex_wrap(i32(x0), w, 0u);
    let xb = tex_wrap(i32(x0) + 1, w, 0u);
    let ya = i32(y0);
    let yb = min(ya + 1, h - 1);
    let a = mix(tex_texel(base, w, xa, ya), tex_texel(base, w, xb, ya), fx);
    let c = mix(tex_texel(base, w, xa, yb), tex_texel(base, w, xb, yb), fx);
    return mix(a, c, fy).xyz * lv3(b + 2u);
}

// The largest k in [0, n) with table[at + k] <= u (a CDF of n + 1 entries from 0 to 1).
fn env_find(at: u32, n: u32, u: f32) -> u32 {
    var lo = 0u;
    var hi = n - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if texels[at + mid] <= u {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    return lo;
}

fn env_dims(b: u32) -> vec2<u32> {
    let di = bitcast<u32>(lights[b + 15u]) * 4u;
    return vec2<u32>(u32(texels[di + 1u]), u32(texels[di + 2u]));
}

// The solid-angle pdf of sampling direction d (selection included).
fn env_pdf(b: u32, d: vec3<f32>) -> f32 {
    let v = env_dir_to_map(b, d);
    let uv = env_uv(v);
    let dims = env_dims(b);
    let w = dims.x;
    let rows = dims.y - 1u;
    let sin_t = sqrt(max(0.0, 1.0 - v.y * v.y));
    if sin_t <= 0.0 {
        return 0.0;
    }
    let i = u32(tex_wrap(i32(floor(uv.x * f32(w) - 0.5)), i32(w), 0u));
    let j = min(u32(uv.y * f32(rows)), rows - 1u);
    let t = bitcast<u32>(lights[b + 16u]);
    let cells = t + rows + 1u + rows * (w + 1u);
    let p = texels[cells + j * w + i];
    return lights[b + 5u] * p * f32(w * rows) / (2.0 * PI * PI * sin_t);
}

fn sample_env(b: u32, x: vec3<f32>, u: vec2<f32>) -> LightSample {
    let dims = env_dims(b);
    let w = dims.x;
    let rows = dims.y - 1u;
    let t = bitcast<u32>(lights[b + 16u]);
    let j = env_find(t, rows, u.x);
    let r0 = texels[t + j];
    let r1 = texels[t + j + 1u];
    let fv = clamp((u.x - r0) / max(r1 - r0, 1e-30), 0.0, 1.0);
    let ct = t + rows + 1u + j * (w + 1u);
    let i = env_find(ct, w, u.y);
    let c0 = texels[ct + i];
    let c1 = texels[ct + i + 1u];
    let fu = clamp((u.y - c0) / max(c1 - c0, 1e-30), 0.0, 1.0);
    var uu = (f32(i) + 0.5 + fu) / f32(w);
    uu = uu - floor(uu);
    let vv = (f32(j) + fv) / f32(rows);
    let theta = vv * PI;
    let phi = uu * 2.0 * PI;
    let sin_t = sin(theta);
    let dm = vec3<f32>(sin(phi) * sin_t, cos(theta), -cos(phi) * sin_t);
    let dir = normalize(vec3<f32>(dot(lv3(b + 18u), dm), dot(lv3(b + 21u), dm), dot(lv3(b + 24u), dm)));
    let pdf = env_pdf(b, dir);
    if !(pdf > 0.0) {
        return light_none();
    }
    let far = lights[b + 17u];
    return LightSample(dir, env_eval(b, dir) / pdf, pdf, x + dir * far, false);
}
