// Mitsuba 3's `path` integrator: emission with MIS against the previous BSDF sample,
// next-event estimation (the closest-hit program samples the light, this program traces the
// shadow ray), BSDF sampling and Russian roulette.

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

fn trace_camera(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, rng: u32) -> PathResult {
    return trace_path(o, d, tmin, tmax, rng);
}
