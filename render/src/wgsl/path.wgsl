// Mitsuba 3's `path` integrator as a ray generation program: emission with MIS against the
// previous BSDF sample, next-event estimation (the closest-hit program samples the light, this
// program traces the shadow ray), BSDF sampling and Russian roulette.

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

fn trace_path(origin0: vec3<f32>, dir0: vec3<f32>, tmin0: f32, tmax0: f32, rng_in: u32) -> PathResult {
    var rng = rng_in;
    var res = PathResult(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), vec3<f32>(0.0), 0.0);
    var origin = origin0;
    var dir = dir0;
    var tmin = tmin0;
    var tmax = tmax0;
    var throughput = vec3<f32>(1.0);
    var eta = 1.0;
    var depth = 0u;
    var prev_pdf = 1.0;
    var prev_delta = true;
    if params.max_depth == 0u {
        return res;
    }
    loop {
        var p: RtPayload;
        p[P_RNG] = rng;
        let scatter = depth + 1u < params.max_depth;
        p[P_FLAGS] = select(0u, IN_SCATTER, scatter);
        rt_trace(params.scene, origin, dir, tmin, tmax, 0.0, 0xFFu, anyhit_off(),
                 0u, 1u, 0u, &p);
        res.rays += 1.0;
        let flags = p[P_FLAGS];
        if (flags & OUT_HIT) != 0u {
            rng = p[P_RNG];
        }
        if depth == 0u && (params.flags & FLAG_AOVS) != 0u && (flags & OUT_HIT) != 0u {
            res.albedo = get_v3(&p, P_ALBEDO);
            res.normal = get_v3(&p, P_NORMAL);
        }
        // Direct emission, weighted against next-event estimation at the previous vertex.
        let le = get_v3(&p, P_LE);
        let hidden = depth == 0u && (params.flags & FLAG_HIDE_EMITTERS) != 0u;
        if any(le > vec3<f32>(0.0)) && !hidden {
            var em_pdf = 0.0;
            if !prev_delta {
                em_pdf = get_f(&p, P_EMPDF);
            }
            res.radiance += throughput * le * mis_weight(prev_pdf, em_pdf);
        }
        if (flags & OUT_HIT) == 0u || !scatter {
            break;
        }
        if (flags & OUT_NEE) != 0u {
            res.rays += 1.0;
            if visible(get_v3(&p, P_SORIGIN), get_v3(&p, P_SVEC)) {
                res.radiance += throughput * get_v3(&p, P_NEE);
            }
        }
        if (flags & OUT_CONTINUE) == 0u {
            break;
        }
        throughput *= get_v3(&p, P_WEIGHT);
        eta *= get_f(&p, P_ETA);
        prev_pdf = get_f(&p, P_PDF);
        prev_delta = (flags & OUT_DELTA) != 0u;
        origin = get_v3(&p, P_ORIGIN);
        dir = get_v3(&p, P_WO);
        tmin = 0.0;
        tmax = 3.0e38;
        depth += 1u;
        // Russian roulette as Mitsuba's path: from rr_depth, survive with
        // min(max throughput component · eta², 0.95).
        let tp_max = max(throughput.x, max(throughput.y, throughput.z));
        if tp_max <= 0.0 {
            break;
        }
        if depth >= params.rr_depth {
            let q = min(tp_max * eta * eta, 0.95);
            if rng_next(&rng) >= q {
                break;
            }
            throughput /= q;
        }
    }
    return res;
}

// Mitsuba's `direct`: the emission seen by the camera ray, then emitter_samples light samples
// and bsdf_samples BSDF samples at its hit, each strategy weighted by the power heuristic of
// its pdf times its share of the samples. The camera ray is traced again for each further
// sample (the hit program draws one light and one BSDF sample per call).
fn trace_direct(origin: vec3<f32>, dir: vec3<f32>, tmin: f32, tmax: f32, rng_in: u32) -> PathResult {
    var rng = rng_in;
    var res = PathResult(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), vec3<f32>(0.0), 0.0);
    let ne = params.emitter_samples;
    let nb = params.bsdf_samples;
    let rounds = max(max(ne, nb), 1u);
    for (var k = 0u; k < rounds; k++) {
        var p: RtPayload;
        p[P_RNG] = rng;
        var inflags = IN_SCATTER;
        if k >= ne {
            inflags |= IN_NO_NEE;
        }
        if k >= nb {
            inflags |= IN_NO_BSDF;
        }
        p[P_FLAGS] = inflags;
        rt_trace(params.scene, origin, dir, tmin, tmax, 0.0, 0xFFu, anyhit_off(), 0u, 1u, 0u, &p);
        res.rays += 1.0;
        let flags = p[P_FLAGS];
        if k == 0u {
            if (params.flags & FLAG_HIDE_EMITTERS) == 0u {
                res.radiance += get_v3(&p, P_LE);
            }
            if (params.flags & FLAG_AOVS) != 0u && (flags & OUT_HIT) != 0u {
                res.albedo = get_v3(&p, P_ALBEDO);
                res.normal = get_v3(&p, P_NORMAL);
            }
        }
        if (flags & OUT_HIT) == 0u {
            break;
        }
        rng = p[P_RNG];
        if (flags & OUT_NEE) != 0u {
            res.rays += 1.0;
            if visible(get_v3(&p, P_SORIGIN), get_v3(&p, P_SVEC)) {
                res.radiance += get_v3(&p, P_NEE);
            }
        }
        if (flags & OUT_CONTINUE) != 0u {
            let weight = get_v3(&p, P_WEIGHT);
            let pdf = get_f(&p, P_PDF);
            let delta = (flags & OUT_DELTA) != 0u;
            var q: RtPayload;
            q[P_RNG] = rng;
            q[P_FLAGS] = 0u;
            rt_trace(params.scene, get_v3(&p, P_ORIGIN), get_v3(&p, P_WO), 0.0, 3.0e38, 0.0, 0xFFu,
                     anyhit_off(), 0u, 1u, 0u, &q);
            res.rays += 1.0;
            let le = get_v3(&q, P_LE);
            if any(le > vec3<f32>(0.0)) {
                var em_pdf = 0.0;
                if !delta {
                    em_pdf = get_f(&q, P_EMPDF);
                }
                res.radiance += weight * le * mis_weight(pdf * params.frac_bsdf, em_pdf * params.frac_lum)
                    / f32(nb);
            }
        }
    }
    return res;
}

// Mitsuba's `aov`: the first hit's albedo, shading normal and distance (0 on a miss).
fn trace_aov(origin: vec3<f32>, dir: vec3<f32>, tmin: f32, tmax: f32) -> PathResult {
    var res = PathResult(vec3<f32>(0.0), 1.0, vec3<f32>(0.0), vec3<f32>(0.0), 0.0);
    var p: RtPayload;
    p[P_RNG] = 0u;
    p[P_FLAGS] = 0u;
    rt_trace(params.scene, origin, dir, tmin, tmax, 0.0, 0xFFu, anyhit_off(), 0u, 1u, 0u, &p);
    if (p[P_FLAGS] & OUT_HIT) != 0u {
        res.albedo = get_v3(&p, P_ALBEDO);
        res.normal = get_v3(&p, P_NORMAL);
        res.depth = get_f(&p, P_PDF);
    }
    return res;
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
        var r: PathResult;
        if params.integrator == 1u {
            r = trace_direct(cam_t, dir, tmin, tmax, rng_path);
        } else if params.integrator == 2u {
            r = trace_aov(cam_t, dir, tmin, tmax);
        } else {
            r = trace_path(cam_t, dir, tmin, tmax, rng_path);
        }
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
