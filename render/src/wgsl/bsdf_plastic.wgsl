// Mitsuba 3's `plastic`: a diffuse base (texture A) under a smooth dielectric coating whose
// delta reflection is weighted by specular_reflectance (texture B); internal scattering by
// Mitsuba's diffuse Fresnel reflectance fit, optionally `nonlinear`. Front side only.
// Scalars: eta, 1/eta², specular sampling weight, nonlinear, fdr_int.

fn plastic_diffuse(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    let s = MP_SCALARS;
    let diff = tex_rgb(m, MP_TEX_A, uv);
    let fdr_int = m[s + 4u];
    if m[s + 3u] != 0.0 {
        return diff / (vec3<f32>(1.0) - diff * fdr_int);
    }
    return diff / (1.0 - fdr_int);
}

// The probability of sampling the diffuse lobe, given the Fresnel reflectance at wi.
fn plastic_prob_diffuse(m: MatParams, f_i: f32) -> f32 {
    let w = m[MP_SCALARS + 2u];
    let prob_specular = f_i * w;
    let prob_diffuse = (1.0 - f_i) * (1.0 - w);
    return prob_diffuse / (prob_specular + prob_diffuse);
}

fn bsdf_plastic_eval(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let eta = m[MP_SCALARS];
    let f_i = fresnel_dielectric(wi.z, eta).r;
    let f_o = fresnel_dielectric(wo.z, eta).r;
    let hemi = cosine_hemisphere_pdf(wo);
    let value = plastic_diffuse(m, uv) * (hemi * m[MP_SCALARS + 1u] * (1.0 - f_i) * (1.0 - f_o));
    return vec4<f32>(value, hemi * plastic_prob_diffuse(m, f_i));
}

fn bsdf_plastic_sample(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    if wi.z <= 0.0 {
        return bsdf_sample_none();
    }
    let eta = m[MP_SCALARS];
    let f_i = fresnel_dielectric(wi.z, eta).r;
    let prob_diffuse = plastic_prob_diffuse(m, f_i);
    let prob_specular = 1.0 - prob_diffuse;
    if u1 < prob_specular {
        let w = tex_rgb(m, MP_TEX_B, uv) * (f_i / prob_specular);
        return BsdfSample(reflect_z(wi), w, prob_specular, 1.0, 1u);
    }
    let wo = square_to_cosine_hemisphere(u2);
    let pdf = prob_diffuse * cosine_hemisphere_pdf(wo);
    let f_o = fresnel_dielectric(wo.z, eta).r;
    let w = plastic_diffuse(m, uv) * (m[MP_SCALARS + 1u] * (1.0 - f_i) * (1.0 - f_o) / prob_diffuse);
    return BsdfSample(wo, w, pdf, 1.0, 0u);
}

fn bsdf_plastic_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return tex_rgb(m, MP_TEX_A, uv);
}
