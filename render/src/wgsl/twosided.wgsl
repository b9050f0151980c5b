// Mitsuba 3's `twosided` with one nested BSDF, instantiated per kind (KIND): where the material's
// two-sided flag is set, directions below the surface are mirrored to the front side (wi.z made
// positive, wo.z given wi's sign), so both sides shade alike. The closest-hit and probe programs
// call these.

fn bsdf_KIND_eval_sided(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    if m[MP_TWOSIDED] != 0.0 {
        return bsdf_KIND_eval(m, vec3<f32>(wi.xy, abs(wi.z)), vec3<f32>(wo.xy, mulsign(wo.z, wi.z)), uv);
    }
    return bsdf_KIND_eval(m, wi, wo, uv);
}

fn bsdf_KIND_sample_sided(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    if m[MP_TWOSIDED] != 0.0 {
        var s = bsdf_KIND_sample(m, vec3<f32>(wi.xy, abs(wi.z)), uv, u1, u2);
        s.wo.z = mulsign(s.wo.z, wi.z);
        return s;
    }
    return bsdf_KIND_sample(m, wi, uv, u1, u2);
}
