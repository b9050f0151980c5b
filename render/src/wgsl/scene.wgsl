// The scene's buffers: accumulation, mesh data and the light table (rust side: upload.rs).

@group(0) @binding(1) var<storage, read_write> accum: array<f32>;
@group(0) @binding(2) var<storage, read> positions: array<f32>;
@group(0) @binding(3) var<storage, read> normals: array<f32>;
@group(0) @binding(4) var<storage, read> uvs: array<f32>;
@group(0) @binding(5) var<storage, read> indices: array<u32>;
@group(0) @binding(6) var<storage, read> lights: array<f32>;
// Spheres, SPHERE_WORDS floats each: centre, radius (object space of their GAS), then the
// rows of the rotation from world (or group) space to the sphere's own frame.
@group(0) @binding(7) var<storage, read> spheres: array<f32>;
const SPHERE_WORDS: u32 = 16u;

// Payload registers of a radiance ray (in: rng, flags; out: the rest).
const P_RNG: u32 = 0u;
const P_FLAGS: u32 = 1u;
const P_LE: u32 = 2u;
const P_EMPDF: u32 = 5u;
const P_NEE: u32 = 6u;
const P_WO: u32 = 9u;
const P_WEIGHT: u32 = 12u;
const P_PDF: u32 = 15u;
const P_ETA: u32 = 16u;
const P_ORIGIN: u32 = 17u;
const P_SORIGIN: u32 = 20u;
const P_SVEC: u32 = 23u;
const P_ALBEDO: u32 = 26u;
const P_NORMAL: u32 = 29u;

// P_FLAGS in: the hit point should scatter (sample lights and the BSDF), and the direct
// integrator's requests to leave out one of the two.
const IN_SCATTER: u32 = 1u;
const IN_NO_NEE: u32 = 2u;
const IN_NO_BSDF: u32 = 4u;
// P_FLAGS out.
const OUT_HIT: u32 = 1u;
const OUT_CONTINUE: u32 = 2u;
const OUT_DELTA: u32 = 4u;
const OUT_NEE: u32 = 8u;

fn set_f(i: u32, v: f32) {
    rt_set_payload(i, bitcast<u32>(v));
}

fn set_v3(i: u32, v: vec3<f32>) {
    set_f(i, v.x);
    set_f(i + 1u, v.y);
    set_f(i + 2u, v.z);
}

fn get_f(p: ptr<function, RtPayload>, i: u32) -> f32 {
    return bitcast<f32>((*p)[i]);
}

fn get_v3(p: ptr<function, RtPayload>, i: u32) -> vec3<f32> {
    return vec3<f32>(get_f(p, i), get_f(p, i + 1u), get_f(p, i + 2u));
}

// The side of a surface with geometric normal ng that direction d leaves from.
fn side(ng: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    return select(-ng, ng, dot(ng, d) >= 0.0);
}

// ---- Lights ----
// Entries of LIGHT_WORDS floats: kind, cdf (inclusive upper end), radiance or intensity rgb,
// pdf (area pdf for triangles, selection probability otherwise), then kind-specific data.
const LIGHT_TRIANGLE: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;
const LIGHT_CONSTANT: u32 = 3u;
const LIGHT_SPHERE: u32 = 4u;
const LIGHT_SPOT: u32 = 5u;
const LIGHT_ENVMAP: u32 = 6u;

struct LightSample {
    dir: vec3<f32>,
    // Emitted radiance / pdf (solid angle, selection included).
    weight: vec3<f32>,
    pdf: f32,
    target_p: vec3<f32>,
    delta: bool,
}

fn light_none() -> LightSample {
    return LightSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, vec3<f32>(0.0), false);
}

fn lv3(base: u32) -> vec3<f32> {
    return vec3<f32>(lights[base], lights[base + 1u], lights[base + 2u]);
}

// One light from the table by its power CDF, then a point or direction on it. Only the kinds
// the scene has are compiled (the SAMPLE_* constants, programs.rs).
fn sample_light(x: vec3<f32>, u_sel: f32, u: vec2<f32>) -> LightSample {
    var lo = 0u;
    var hi = params.light_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if lights[mid * LIGHT_WORDS + 1u] <= u_sel {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let b = lo * LIGHT_WORDS;
    let kind = u32(lights[b]);
    let le = lv3(b + 2u);
    let pdf0 = lights[b + 5u];
    if SAMPLE_TRIANGLE && kind == LIGHT_TRIANGLE {
        let p0 = lv3(b + 6u);
        let e1 = lv3(b + 9u);
        let e2 = lv3(b + 12u);
        let st = sqrt(1.0 - u.x);
        let y = p0 + e1 * (1.0 - st) + e2 * (st * u.y);
        let n = normalize(cross(e1, e2)) * lights[b + 15u];
        let v = y - x;
        let dist2 = dot(v, v);
        let dir = v * inverseSqrt(dist2);
        let cos_l = dot(n, -dir);
        if cos_l <= 0.0 || dist2 <= 0.0 {
            return light_none();
        }
        let pdf = pdf0 * dist2 / cos_l;
        return LightSample(dir, le / pdf, pdf, rt_offset_ray(y, n), false);
    }
    if SAMPLE_POINT && kind == LIGHT_POINT {
        let p = lv3(b + 6u);
        let v = p - x;
        let dist2 = dot(v, v);
        if dist2 <= 0.0 {
            return light_none();
        }
        return LightSample(v * inverseSqrt(dist2), le / (dist2 * pdf0), pdf0, p, true);
    }
    if SAMPLE_DIRECTIONAL && kind == LIGHT_DIRECTIONAL {
        // Towards the light; the target lies beyond the scene's bounding sphere.
        let dir = -lv3(b + 6u);
        let far = lights[b + 9u];
        return LightSample(dir, le / pdf0, pdf0, x + dir * far, true);
    }
    if SAMPLE_SPHERE && kind == LIGHT_SPHERE {
        return sample_sphere_light(b, x, le, pdf0, u);
    }
    if SAMPLE_SPOT && kind == LIGHT_SPOT {
        // Mitsuba's spot: intensity times its falloff (1 inside beam_width, linear in the
        // angle down to 0 at cutoff_angle) in the light's frame.
        let p = lv3(b + 6u);
        let v = p - x;
        let dist2 = dot(v, v);
        if dist2 <= 0.0 {
            return light_none();
        }
        let dir = v * inverseSqrt(dist2);
        let l = normalize(vec3<f32>(dot(lv3(b + 9u), -dir), dot(lv3(b + 12u), -dir), dot(lv3(b + 15u), -dir)));
        let cos_t = l.z;
        var falloff = 0.0;
        if cos_t > lights[b + 18u] {
            falloff = 1.0;
            if cos_t < lights[b + 19u] {
                falloff = (lights[b + 20u] - acos(cos_t)) * lights[b + 21u];
            }
        }
        if falloff <= 0.0 {
            return light_none();
        }
        return LightSample(dir, le * falloff / (dist2 * pdf0), pdf0, p, true);
    }
    if ENVMAP && kind == LIGHT_ENVMAP {
        return sample_env(b, x, u);
    }
    if !SAMPLE_CONSTANT {
        return light_none();
    }
    // Constant: uniform directions over the sphere (Mitsuba's constant emitter).
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = 2.0 * PI * u.y;
    let dir = vec3<f32>(r * cos(phi), r * sin(phi), z);
    let pdf = pdf0 / (4.0 * PI);
    let far = lights[b + 9u];
    return LightSample(dir, le / pdf, pdf, x + dir * far, false);
}

// Mitsuba's sphere sample_direction: from outside, a direction uniform in the cone of the
// visible cap (Taylor expansion for tiny cones, as Mitsuba); from inside, a point uniform
// over the surface. Emission leaves the outward (or, flipped, inward) side only.
fn sample_sphere_light(b: u32, x: vec3<f32>, le: vec3<f32>, sel: f32, u: vec2<f32>) -> LightSample {
    let c = lv3(b + 6u);
    let r = lights[b + 9u];
    let flip = lights[b + 10u];
    let dc_v = c - x;
    let dc2 = dot(dc_v, dc_v);
    var y: vec3<f32>;
    var n: vec3<f32>;
    var pdf: f32;
    if dc2 > r * r {
        let inv_dc = inverseSqrt(dc2);
        let sin_max = r * inv_dc;
        let sin_max2 = sin_max * sin_max;
        let inv_sin_max = 1.0 / sin_max;
        let cos_max = sqrt(max(0.0, 1.0 - sin_max2));
        var sin2 = sin_max2 * u.x;
        if sin_max2 > 0.00068523 {
            let t = (cos_max - 1.0) * u.x + 1.0;
            sin2 = 1.0 - t * t;
        }
        let cos_t = sqrt(max(0.0, 1.0 - sin2));
        let cos_a = sin2 * inv_sin_max + cos_t * sqrt(max(0.0, 1.0 - sin2 * inv_sin_max * inv_sin_max));
        let sin_a = sqrt(max(0.0, 1.0 - cos_a * cos_a));
        let phi = u.y * 2.0 * PI;
        let f = frame_new(-dc_v * inv_dc);
        let d = to_world(f, vec3<f32>(cos(phi) * sin_a, sin(phi) * sin_a, cos_a));
        y = c + d * r;
        n = d;
        pdf = sel / (2.0 * PI * (1.0 - cos_max));
    } else {
        let z = 1.0 - 2.0 * u.x;
        let rr = sqrt(max(0.0, 1.0 - z * z));
        let phi = 2.0 * PI * u.y;
        let d = vec3<f32>(rr * cos(phi), rr * sin(phi), z);
        y = c + d * r;
        n = d;
        let v = y - x;
        let dist2 = dot(v, v);
        let cos_l = abs(dot(normalize(v), d));
        if cos_l <= 0.0 || dist2 <= 0.0 {
            return light_none();
        }
        pdf = sel * dist2 / (cos_l * 4.0 * PI * r * r);
    }
    n = n * flip;
    let v = y - x;
    let dist2 = dot(v, v);
    if dist2 <= 0.0 || !(pdf > 0.0) {
        return light_none();
    }
    let dir = v * inverseSqrt(dist2);
    if dot(n, -dir) <= 0.0 {
        return light_none();
    }
    return LightSample(dir, le / pdf, pdf, rt_offset_ray(y, n), false);
}

// ---- Mesh hits ----
// SBT record data words: vertex base (a sphere: its index), triangle base, normal base, uv
// base (NONE: absent), flip, emitter pdf (meshes: selection / area; spheres: selection),
// emitted radiance rgb, pad, a mask's opacity texture (13 floats), then the material's
// parameters and its precomputed table, then those of the back side's BSDF when a twosided
// material has two (geometry.rs's layout).
const SBT_OPACITY: u32 = 10u;
const SBT_MATERIAL: u32 = 23u;

struct Hit {
    p: vec3<f32>,
    ng: vec3<f32>,
    ns: vec3<f32>,
    uv: vec2<f32>,
    t: f32,
}

fn vtx3(buf_base: u32, i: u32) -> vec3<f32> {
    let b = (buf_base + i) * 3u;
    return vec3<f32>(positions[b], positions[b + 1u], positions[b + 2u]);
}

fn nrm3(buf_base: u32, i: u32) -> vec3<f32> {
    let b = (buf_base + i) * 3u;
    return vec3<f32>(normals[b], normals[b + 1u], normals[b + 2u]);
}

fn uv2(buf_base: u32, i: u32) -> vec2<f32> {
    let b = (buf_base + i) * 2u;
    return vec2<f32>(uvs[b], uvs[b + 1u]);
}

// A normal from object to world space (the transpose of world-to-object's linear part).
fn normal_to_world(n: vec3<f32>) -> vec3<f32> {
    let w = rt_world_to_object();
    return normalize(vec3<f32>(dot(w[0], n), dot(w[1], n), dot(w[2], n)));
}

fn mesh_hit() -> Hit {
    let prim = rt_primitive_index();
    let vbase = rt_sbt_data_u32(0u);
    let tbase = rt_sbt_data_u32(1u);
    let nbase = rt_sbt_data_u32(2u);
    let uvbase = rt_sbt_data_u32(3u);
    let flip = rt_sbt_data_u32(4u);
    let ti = (tbase + prim) * 3u;
    let i0 = indices[ti];
    let i1 = indices[ti + 1u];
    let i2 = indices[ti + 2u];
    let p0 = vtx3(vbase, i0);
    let p1 = vtx3(vbase, i1);
    let p2 = vtx3(vbase, i2);
    let b = rt_triangle_barycentrics();
    let w0 = 1.0 - b.x - b.y;
    var p = p0 * w0 + p1 * b.x + p2 * b.y;
    var ng = normalize(cross(p1 - p0, p2 - p0));
    var ns = ng;
    if nbase != NONE {
        ns = normalize(nrm3(nbase, i0) * w0 + nrm3(nbase, i1) * b.x + nrm3(nbase, i2) * b.y);
    }
    if INSTANCED {
        // Object to world; normals by the inverse transpose, as Mitsuba's instance.
        p = rt_object_to_world() * vec4<f32>(p, 1.0);
        ng = normal_to_world(ng);
        ns = normal_to_world(ns);
    }
    if flip != 0u {
        ng = -ng;
        ns = -ns;
    }
    // Without texture coordinates Mitsuba uses the barycentrics.
    var uv = b;
    if uvbase != NONE {
        uv = uv2(uvbase, i0) * w0 + uv2(uvbase, i1) * b.x + uv2(uvbase, i2) * b.y;
    }
    return Hit(p, ng, ns, uv, rt_ray_tmax());
}

// Mitsuba's sphere: the hit point projected back onto the surface, the normal from the
// centre, uv = (φ / 2π, θ / π) in the sphere's own frame.
fn sphere_hit() -> Hit {
    let sb = rt_sbt_data_u32(0u) * SPHERE_WORDS;
    let flip = rt_sbt_data_u32(4u);
    let c = vec3<f32>(spheres[sb], spheres[sb + 1u], spheres[sb + 2u]);
    let r = spheres[sb + 3u];
    let t = rt_ray_tmax();
    var p = rt_world_ray_origin() + rt_world_ray_direction() * t;
    var local = p - c;
    if INSTANCED {
        local = rt_world_to_object() * vec4<f32>(p, 1.0) - c;
    }
    local = normalize(local);
    p = c + local * r;
    var n = local;
    if INSTANCED {
        p = rt_object_to_world() * vec4<f32>(p, 1.0);
        n = normal_to_world(local);
    }
    let q = vec3<f32>(
        dot(vec3<f32>(spheres[sb + 4u], spheres[sb + 5u], spheres[sb + 6u]), local),
        dot(vec3<f32>(spheres[sb + 7u], spheres[sb + 8u], spheres[sb + 9u]), local),
        dot(vec3<f32>(spheres[sb + 10u], spheres[sb + 11u], spheres[sb + 12u]), local));
    var phi = atan2(q.y, q.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let theta = acos(clamp(q.z, -1.0, 1.0));
    let uv = vec2<f32>(phi * (0.5 * INV_PI), theta * INV_PI);
    if flip != 0u {
        n = -n;
    }
    return Hit(p, n, n, uv, t);
}

// Emission of a sphere hit and the pdf with which next-event estimation would have chosen it
// from the ray's origin: Mitsuba's sphere pdf_direction (the visible cap's cone from outside).
// Emitting spheres are never instanced, so their table entry is in world space.
fn sphere_emission(h: Hit, d: vec3<f32>) {
    let le = vec3<f32>(rt_sbt_data_f32(6u), rt_sbt_data_f32(7u), rt_sbt_data_f32(8u));
    let sel = rt_sbt_data_f32(5u);
    var out_le = vec3<f32>(0.0);
    if dot(h.ns, d) < 0.0 {
        out_le = le;
    }
    let sb = rt_sbt_data_u32(0u) * SPHERE_WORDS;
    let c = vec3<f32>(spheres[sb], spheres[sb + 1u], spheres[sb + 2u]);
    let r = spheres[sb + 3u];
    let sin_a = r / length(c - rt_world_ray_origin());
    var pdf = 0.0;
    if sin_a < 0.99999994 {
        let cos_a = sqrt(max(0.0, 1.0 - sin_a * sin_a));
        pdf = sel / (2.0 * PI * (1.0 - cos_a));
    } else {
        let cos_l = abs(dot(h.ng, d));
        if cos_l > 0.0 {
            pdf = sel * h.t * h.t / (cos_l * 4.0 * PI * r * r);
        }
    }
    set_v3(P_LE, out_le);
    set_f(P_EMPDF, pdf);
}

fn sbt_material() -> MatParams {
    var m: MatParams;
    for (var i = 0u; i < MAT_PARAMS_LEN; i++) {
        m[i] = rt_sbt_data_f32(SBT_MATERIAL + i);
    }
    return m;
}

// The back side's material of a twosided material with two different BSDFs: parameters and
// table after the front's.
fn back_material() -> MatParams {
    var m: MatParams;
    for (var i = 0u; i < MAT_PARAMS_LEN; i++) {
        m[i] = rt_sbt_data_f32(SBT_MATERIAL + MATERIAL_WORDS + i);
    }
    return m;
}

// Word `i` of the record's data: the materials' precomputed tables (roughplastic's
// transmittance, which names where its table starts), read where needed rather than copied
// with the parameters.
fn mat_extra(i: u32) -> f32 {
    return rt_sbt_data_f32(i);
}

// Emission seen along d at the hit (Mitsuba's area emitter: front side only) and the
// solid-angle pdf with which next-event estimation would have chosen this point.
fn mesh_emission(h: Hit, d: vec3<f32>) {
    let le = vec3<f32>(rt_sbt_data_f32(6u), rt_sbt_data_f32(7u), rt_sbt_data_f32(8u));
    let pdf_area = rt_sbt_data_f32(5u);
    var out_le = vec3<f32>(0.0);
    if dot(h.ns, d) < 0.0 {
        out_le = le;
    }
    let cos_l = abs(dot(h.ng, d));
    var pdf = 0.0;
    if cos_l > 0.0 {
        pdf = pdf_area * h.t * h.t / cos_l;
    }
    set_v3(P_LE, out_le);
    set_f(P_EMPDF, pdf);
}

fn miss__radiance() {
    rt_set_payload(P_FLAGS, 0u);
    if ENVMAP && params.env_light != NONE {
        let b = params.env_light * LIGHT_WORDS;
        let d = rt_world_ray_direction();
        set_v3(P_LE, env_eval(b, d));
        set_f(P_EMPDF, env_pdf(b, d));
        return;
    }
    set_v3(P_LE, params.env_radiance);
    set_f(P_EMPDF, params.env_pdf);
}

fn miss__shadow() {
    rt_set_payload(0u, 1u);
}
