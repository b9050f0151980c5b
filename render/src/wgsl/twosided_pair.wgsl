// Mitsuba 3's `twosided` with two nested BSDFs (FRONT, BACK), instantiated per pair present
// (PAIR): directions above the surface are shaded by FRONT with the record's material, those
// below by BACK with the back side's material, seen from its own front (wi and wo mirrored);
// at grazing wi neither side reflects. The closest-hit program calls these as it calls a
// kind's.

fn bsdf_PAIR_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return bsdf_FRONT_albedo(m, uv);
}

fn bsdf_PAIR_eval_sided(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    if wi.z > 0.0 {
        return bsdf_FRONT_eval(m, wi, wo, uv);
    }
    if wi.z < 0.0 {
        let flip = vec3<f32>(1.0, 1.0, -1.0);
        return bsdf_BACK_eval(back_material(), wi * flip, wo * flip, uv);
    }
    return vec4<f32>(0.0);
}

fn bsdf_PAIR_sample_sided(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    if wi.z > 0.0 {
        return bsdf_FRONT_sample(m, wi, uv, u1, u2);
    }
    if wi.z < 0.0 {
        var s = bsdf_BACK_sample(back_material(), wi * vec3<f32>(1.0, 1.0, -1.0), uv, u1, u2);
        s.wo.z = -s.wo.z;
        return s;
    }
    return bsdf_sample_none();
}
