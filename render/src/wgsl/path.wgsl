// The ray generation program: pixel filter, camera rays and accumulation; the integrator's
// trace_camera (integrator_*.wgsl) follows each camera ray.

const ACC_SUM: u32 = 0u;
const ACC_SUMSQ: u32 = 3u;
const ACC_RAYS: u32 = 6u;
const ACC_ALBEDO: u32 = 7u;
const ACC_NORMAL: u32 = 10u;
const ACC_DEPTH: u32 = 13u;

// Any-hit programs run only where masks exist (shadow rays respect masks too).
fn anyhit_off() -> u32 {
    if MASKS {
        return 0u;
    }
    return RT_RAY_FLAG_DISABLE_ANYHIT;
}

fn visible(origin: vec3<f32>, v: vec3<f32>) -> bool {
    var p: RtPayload;
    p[0] = 0u;
    // The segment ends just short of the light point (both ends offset robustly): t in [0, 1].
    rt_trace(params.scene, origin, v, 0.0, 1.0, 0.0, 0xFFu,
             RT_RAY_FLAG_TERMINATE_ON_FIRST_HIT | RT_RAY_FLAG_DISABLE_CLOSESTHIT | anyhit_off(),
             0u, 1u, 1u, &p);
    return p[0] == 1u;
}

struct PathResult {
    radiance: vec3<f32>,
    rays: f32,
    albedo: vec3<f32>,
    normal: vec3<f32>,
    depth: f32,
}

// A 1D offset from the pixel centre distributed as the reconstruction filter (box, tent or
// truncated Gaussian as Mitsuba defines them), so each sample's weight is one.
fn filter_offset(rng: ptr<function, u32>) -> f32 {
    let u = rng_next(rng);
    if params.filter_kind == 0u {
        return u - 0.5;
    }
    let r = params.filter_param;
    if params.filter_kind == 1u {
        if u < 0.5 {
            return r * (sqrt(2.0 * u) - 1.0);
        }
        return r * (1.0 - sqrt(2.0 - 2.0 * u));
    }
    // Gaussian of stddev filter_param, radius 4 stddev, minus its value at the radius.
    let s = r;
    let radius = 4.0 * s;
    let floor_v = exp(-radius * radius / (2.0 * s * s));
    for (var i = 0u; i < 64u; i++) {
        let x = (2.0 * rng_next(rng) - 1.0) * radius;
        let f = (exp(-x * x / (2.0 * s * s)) - floor_v) / (1.0 - floor_v);
        if rng_next(rng) < f {
            return x;
        }
    }
    return 0.0;
}

fn raygen__path() {
    let idx = rt_launch_index().xy;
    let size = params.size;
    if idx.x >= size.x || idx.y >= size.y {
        return;
    }
    let pixel = idx.y * size.x + idx.x;
    let cam_t = vec3<f32>(params.cam0.w, params.cam1.w, params.cam2.w);
    var sum = vec3<f32>(0.0);
    var sumsq = vec3<f32>(0.0);
    var rays = 0.0;
    var albedo = vec3<f32>(0.0);
    var normal = vec3<f32>(0.0);
    var depth = 0.0;
    for (var s = 0u; s < params.sample_count; s++) {
        var rng = rng_init(pixel, params.sample_base + s, params.seed);
        let ox = filter_offset(&rng);
        let oy = filter_offset(&rng);
        let pos = (vec2<f32>(idx) + vec2<f32>(0.5 + ox, 0.5 + oy)) / vec2<f32>(size);
        // Mitsuba's perspective camera: image x grows towards camera -x, y towards -y.
        let local = normalize(vec3<f32>((1.0 - 2.0 * pos.x) * params.tan_x,
                                        (1.0 - 2.0 * pos.y) * params.tan_y, 1.0));
        let world = vec3<f32>(dot(params.cam0.xyz, local), dot(params.cam1.xyz, local),
                              dot(params.cam2.xyz, local));
        let dir = normalize(world);
        let scale = length(world);
        let tmin = params.near_clip / local.z * scale;
        let tmax = params.far_clip / local.z * scale;
        let rng_path = rng_init(pixel ^ 0x9E3779B9u, params.sample_base + s, params.seed ^ 0x85EBCA6Bu);
        // The scene's integrator (programs.rs compiles in only its code).
        let r = trace_camera(cam_t, dir, tmin, tmax, rng_path);
        sum += r.radiance;
        sumsq += r.radiance * r.radiance;
        rays += r.rays;
        albedo += r.albedo;
        normal += r.normal;
        depth += r.depth;
    }
    let b = pixel * params.accum_stride;
    accum[b + 0u] += sum.x;
    accum[b + 1u] += sum.y;
    accum[b + 2u] += sum.z;
    accum[b + 3u] += sumsq.x;
    accum[b + 4u] += sumsq.y;
    accum[b + 5u] += sumsq.z;
    accum[b + 6u] += rays;
    if (params.flags & FLAG_AOVS) != 0u {
        accum[b + 7u] += albedo.x;
        accum[b + 8u] += albedo.y;
        accum[b + 9u] += albedo.z;
        accum[b + 10u] += normal.x;
        accum[b + 11u] += normal.y;
        accum[b + 12u] += normal.z;
    }
    if params.integrator == 2u {
        accum[b + ACC_DEPTH] += depth;
    }
}
