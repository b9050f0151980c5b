// Mitsuba 3's `diffuse`: Lambertian reflection on the front side only (wi.z > 0).

fn bsdf_diffuse_eval(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let r = tex_rgb(m, MP_TEX_A, uv);
    return vec4<f32>(r * (INV_PI * wo.z), cosine_hemisphere_pdf(wo));
}

fn bsdf_diffuse_sample(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    if wi.z <= 0.0 {
        return bsdf_sample_none();
    }
    let wo = square_to_cosine_hemisphere(u2);
    let pdf = cosine_hemisphere_pdf(wo);
    if pdf <= 0.0 {
        return bsdf_sample_none();
    }
    return BsdfSample(wo, tex_rgb(m, MP_TEX_A, uv), pdf, 1.0, 0u);
}

fn bsdf_diffuse_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return tex_rgb(m, MP_TEX_A, uv);
}
