// Mitsuba 3's `roughplastic`: a diffuse base (texture A) under a rough dielectric coating
// (isotropic Beckmann or GGX) weighted by specular_reflectance (texture B). The transmittance
// through the coating per cosine is a 64-entry table (mat_extra, computed by roughplastic.rs as
// Mitsuba computes it). Scalars: eta, 1/eta², specular sampling weight, nonlinear, internal
// reflectance, where the table starts (a record holds two tables when a twosided material has
// a different BSDF on each side); microfacet at MP_MICROFACET.

// Mitsuba's lerp_gather over the transmittance table.
fn roughplastic_transmittance(m: MatParams, cos_theta: f32) -> f32 {
    let x = cos_theta * 63.0;
    let i = min(u32(x), 62u);
    let table = u32(m[MP_SCALARS + 5u]);
    let v0 = mat_extra(table + i);
    let v1 = mat_extra(table + i + 1u);
    return mix(v0, v1, x - f32(i));
}

fn roughplastic_prob_specular(m: MatParams, t_i: f32) -> f32 {
    let w = m[MP_SCALARS + 2u];
    let ps = (1.0 - t_i) * w;
    let pd = t_i * (1.0 - w);
    return ps / (ps + pd);
}

fn bsdf_roughplastic_eval(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    let ci = wi.z;
    let co = wo.z;
    if ci <= 0.0 || co <= 0.0 {
        return vec4<f32>(0.0);
    }
    let s = MP_SCALARS;
    let eta = m[s];
    let d = mf_from(m, MP_MICROFACET);
    let h = normalize(wo + wi);
    let dv = mf_eval(d, h);
    let f = fresnel_dielectric(dot(wi, h), eta).r;
    let g1_wi = mf_smith_g1(d, wi, h);
    let g = g1_wi * mf_smith_g1(d, wo, h);
    var value = tex_rgb(m, MP_TEX_B, uv) * (f * dv * g / (4.0 * ci));
    let t_i = roughplastic_transmittance(m, ci);
    let t_o = roughplastic_transmittance(m, co);
    var diff = tex_rgb(m, MP_TEX_A, uv);
    let internal = m[s + 4u];
    if m[s + 3u] != 0.0 {
        diff = diff / (vec3<f32>(1.0) - diff * internal);
    } else {
        diff = diff / (1.0 - internal);
    }
    value += diff * (INV_PI * m[s + 1u] * co * t_i * t_o);
    let prob_specular = roughplastic_prob_specular(m, t_i);
    var spec_pdf: f32;
    if d.visible {
        spec_pdf = dv * g1_wi / (4.0 * ci);
    } else {
        spec_pdf = mf_pdf(d, wi, h) / (4.0 * dot(wo, h));
    }
    let pdf = spec_pdf * prob_specular + (1.0 - prob_specular) * cosine_hemisphere_pdf(wo);
    return vec4<f32>(value, pdf);
}

fn bsdf_roughplastic_sample(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    if wi.z <= 0.0 {
        return bsdf_sample_none();
    }
    let t_i = roughplastic_transmittance(m, wi.z);
    var wo: vec3<f32>;
    if u1 < roughplastic_prob_specular(m, t_i) {
        let d = mf_from(m, MP_MICROFACET);
        wo = reflect_m(wi, mf_sample(d, wi, u2).xyz);
    } else {
        wo = square_to_cosine_hemisphere(u2);
    }
    let ev = bsdf_roughplastic_eval(m, wi, wo, uv);
    if ev.w <= 0.0 {
        return bsdf_sample_none();
    }
    return BsdfSample(wo, ev.xyz / ev.w, ev.w, 1.0, 0u);
}

fn bsdf_roughplastic_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return tex_rgb(m, MP_TEX_A, uv);
}
