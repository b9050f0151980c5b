// Mitsuba 3's `twosided` with one nested BSDF, instantiated per kind (KIND): where the material's
// two-sided flag is set, directions below the surface are mirrored to the front side (wi.z made
// positive, wo.z given wi's sign), so both sides shade alike. The closest-hit and probe programs
// call these.
//
// Each calls the BSDF once, with directions chosen by `select`: drivers inline every call, and
// a call per side doubled the BSDF's code in every closest-hit program.

fn bsdf_KIND_eval_sided(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    let two = m[MP_TWOSIDED] != 0.0;
    let wi_s = select(wi, vec3<f32>(wi.xy, abs(wi.z)), two);
    let wo_s = select(wo, vec3<f32>(wo.xy, mulsign(wo.z, wi.z)), two);
    return bsdf_KIND_eval(m, wi_s, wo_s, uv);
}

fn bsdf_KIND_sample_sided(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    let two = m[MP_TWOSIDED] != 0.0;
    var s = bsdf_KIND_sample(m, select(wi, vec3<f32>(wi.xy, abs(wi.z)), two), uv, u1, u2);
    s.wo.z = select(s.wo.z, mulsign(s.wo.z, wi.z), two);
    return s;
}
