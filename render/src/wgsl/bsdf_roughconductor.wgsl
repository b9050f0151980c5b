// Mitsuba 3's `roughconductor`: a microfacet reflection (Beckmann or GGX, anisotropic) with the
// conductor Fresnel reflectance, front side only. Texture A: specular_reflectance. Scalars:
// eta rgb, k rgb; microfacet at MP_MICROFACET.

fn roughconductor_f(m: MatParams, cos_i: f32, uv: vec2<f32>) -> vec3<f32> {
    let s = MP_SCALARS;
    let eta = vec3<f32>(m[s], m[s + 1u], m[s + 2u]);
    let k = vec3<f32>(m[s + 3u], m[s + 4u], m[s + 5u]);
    return fresnel_conductor(cos_i, eta, k) * tex_rgb(m, MP_TEX_A, uv);
}

fn bsdf_roughconductor_eval(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let d = mf_from(m, MP_MICROFACET);
    let h = normalize(wo + wi);
    var value = vec3<f32>(0.0);
    let dv = mf_eval(d, h);
    if dv != 0.0 {
        let g = mf_g(d, wi, wo, h);
        value = roughconductor_f(m, dot(wi, h), uv) * (dv * g / (4.0 * wi.z));
    }
    var pdf = 0.0;
    if dot(wi, h) > 0.0 && dot(wo, h) > 0.0 {
        if d.visible {
            pdf = dv * mf_smith_g1(d, wi, h) / (4.0 * wi.z);
        } else {
            pdf = mf_pdf(d, wi, h) / (4.0 * dot(wo, h));
        }
    }
    return vec4<f32>(value, pdf);
}

fn bsdf_roughconductor_sample(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    if wi.z <= 0.0 {
        return bsdf_sample_none();
    }
    let d = mf_from(m, MP_MICROFACET);
    let ms = mf_sample(d, wi, u2);
    let n = ms.xyz;
    let wo = reflect_m(wi, n);
    if ms.w == 0.0 || wo.z <= 0.0 {
        return bsdf_sample_none();
    }
    var weight: f32;
    if d.visible {
        weight = mf_smith_g1(d, wo, n);
    } else {
        weight = mf_g(d, wi, wo, n) * dot(wi, n) / (wi.z * n.z);
    }
    let pdf = ms.w / (4.0 * dot(wo, n));
    return BsdfSample(wo, roughconductor_f(m, dot(wi, n), uv) * weight, pdf, 1.0, 0u);
}

fn bsdf_roughconductor_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return tex_rgb(m, MP_TEX_A, uv);
}
