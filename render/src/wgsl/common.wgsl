// Shared by every program of the renderer: launch parameters, bindings, random numbers,
// frames, warps and the MIS heuristic. Assembled first by programs.rs.

struct Params {
    scene: vec2<u32>,
    size: vec2<u32>,
    sample_base: u32,
    sample_count: u32,
    seed: u32,
    max_depth: u32,
    rr_depth: u32,
    flags: u32,
    filter_kind: u32,
    light_count: u32,
    filter_param: f32,
    near_clip: f32,
    far_clip: f32,
    tan_x: f32,
    cam0: vec4<f32>,
    cam1: vec4<f32>,
    cam2: vec4<f32>,
    tan_y: f32,
    accum_stride: u32,
    probe_count: u32,
    // The envmap's light table entry (NONE: no envmap).
    env_light: u32,
    env_radiance: vec3<f32>,
    env_pdf: f32,
    // Mitsuba's direct integrator: next-event estimation weighs its MIS with the strategies'
    // sample fractions and 1 / emitter_samples (path: all 1).
    frac_lum: f32,
    frac_bsdf: f32,
    weight_lum: f32,
    // 0 path, 1 direct, 2 aov.
    integrator: u32,
    emitter_samples: u32,
    bsdf_samples: u32,
    pad2: u32,
    pad3: u32,
}

@group(0) @binding(0) var<uniform> params: Params;

const PI: f32 = 3.14159265358979323846;
const INV_PI: f32 = 0.31830988618379067154;
const FLAG_HIDE_EMITTERS: u32 = 1u;
const FLAG_AOVS: u32 = 2u;
const NONE: u32 = 0xFFFFFFFFu;
const LIGHT_WORDS: u32 = 32u;

// PCG (O'Neill), the RXS-M-XS output of a 32-bit LCG step: counter-based seeding below makes
// every pixel's stream depend only on (pixel, sample, seed).
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn rng_init(pixel: u32, sample: u32, seed: u32) -> u32 {
    return pcg_hash(pixel ^ pcg_hash(sample ^ pcg_hash(seed)));
}

fn rng_next(state: ptr<function, u32>) -> f32 {
    *state = pcg_hash(*state);
    // 24 bits: every value is exactly representable and strictly below 1.
    return f32(*state >> 8u) * (1.0 / 16777216.0);
}

fn rng_next2(state: ptr<function, u32>) -> vec2<f32> {
    let a = rng_next(state);
    let b = rng_next(state);
    return vec2<f32>(a, b);
}

// An orthonormal frame around n (Duff et al. 2017, as Mitsuba's coordinate_system).
struct Frame {
    s: vec3<f32>,
    t: vec3<f32>,
    n: vec3<f32>,
}

fn frame_new(n: vec3<f32>) -> Frame {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let s = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let t = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return Frame(s, t, n);
}

fn to_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, f.s), dot(v, f.t), dot(v, f.n));
}

fn to_world(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return f.s * v.x + f.t * v.y + f.n * v.z;
}

// Shirley and Chiu's concentric map, as Mitsuba's square_to_uniform_disk_concentric.
fn square_to_disk_concentric(u: vec2<f32>) -> vec2<f32> {
    let x = 2.0 * u.x - 1.0;
    let y = 2.0 * u.y - 1.0;
    if x == 0.0 && y == 0.0 {
        return vec2<f32>(0.0);
    }
    var r: f32;
    var phi: f32;
    if abs(x) > abs(y) {
        r = x;
        phi = (PI / 4.0) * (y / x);
    } else {
        r = y;
        phi = (PI / 2.0) - (PI / 4.0) * (x / y);
    }
    return r * vec2<f32>(cos(phi), sin(phi));
}

fn square_to_cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let p = square_to_disk_concentric(u);
    let z = sqrt(max(0.0, 1.0 - dot(p, p)));
    return vec3<f32>(p, z);
}

fn cosine_hemisphere_pdf(v: vec3<f32>) -> f32 {
    return INV_PI * max(v.z, 0.0);
}

// The power heuristic of Mitsuba's path integrator: 0 where the weight is not finite.
fn mis_weight(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    let w = a2 / (a2 + b2);
    // NaN and infinities fail this test.
    if w >= 0.0 && w <= 1.0 {
        return w;
    }
    return 0.0;
}

// dr::mulsign(a, b): a with the sign of b applied (b's sign bit, so -0 counts as negative).
fn mulsign(a: f32, b: f32) -> f32 {
    return select(a, -a, (bitcast<u32>(b) & 0x80000000u) != 0u);
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.212671, 0.715160, 0.072169));
}

// ---- Textures ----
// A texture is 13 floats of material parameters: kind (0 constant, 1 checkerboard, 2 bilinear
// bitmap, 3 nearest bitmap), colour 0 (a bitmap: image id, wrap mode), colour 1, then
// Mitsuba's to_uv as two rows of a 3x3 affine matrix. Bitmaps are read by tex_bitmap
// (texture.wgsl, compiled in only when a scene has one).
// Material parameters (material.rs): texture slots A and B, kind-specific scalars from
// MP_SCALARS, the microfacet distribution at MP_MICROFACET, the two-sided flag.
alias MatParams = array<f32, 40>;
const MAT_PARAMS_LEN: u32 = 40u;
const MP_TEX_A: u32 = 0u;
const MP_TEX_B: u32 = 13u;
const MP_SCALARS: u32 = 26u;
const MP_MICROFACET: u32 = 33u;
const MP_TWOSIDED: u32 = 39u;

fn tex_rgb(m: MatParams, at: u32, uv: vec2<f32>) -> vec3<f32> {
    let kind = u32(m[at]);
    let c0 = vec3<f32>(m[at + 1u], m[at + 2u], m[at + 3u]);
    if kind == 0u {
        return c0;
    }
    let tu = m[at + 7u] * uv.x + m[at + 8u] * uv.y + m[at + 9u];
    let tv = m[at + 10u] * uv.x + m[at + 11u] * uv.y + m[at + 12u];
    if kind >= 2u {
        return tex_bitmap(u32(c0.x), vec2<f32>(tu, tv), kind == 2u, u32(c0.y)).xyz;
    }
    let c1 = vec3<f32>(m[at + 4u], m[at + 5u], m[at + 6u]);
    // Mitsuba's checkerboard: colour 0 where the two halves agree.
    let even = (u32(floor(2.0 * fract(tu))) + u32(floor(2.0 * fract(tv)))) % 2u == 0u;
    return select(c1, c0, even);
}

// ---- BSDF interface ----
struct BsdfSample {
    wo: vec3<f32>,
    // BSDF · |cos θo| / pdf.
    weight: vec3<f32>,
    pdf: f32,
    eta: f32,
    // 0: a smooth lobe; 1: a Dirac (delta) lobe; 2: a null lobe (thindielectric's straight
    // transmission; Mitsuba's Delta flag includes Null).
    delta: u32,
}

fn bsdf_sample_none() -> BsdfSample {
    return BsdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 1.0, 0u);
}
