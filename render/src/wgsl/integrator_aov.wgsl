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

fn trace_camera(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, rng: u32) -> PathResult {
    return trace_aov(o, d, tmin, tmax);
}
