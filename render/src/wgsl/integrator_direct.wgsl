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

fn trace_camera(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, rng: u32) -> PathResult {
    return trace_direct(o, d, tmin, tmax, rng);
}
