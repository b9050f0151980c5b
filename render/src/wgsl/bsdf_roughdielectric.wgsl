// Mitsuba 3's `roughdielectric` (Walter et al. 2007): microfacet reflection and refraction.
// Texture A: specular_reflectance, B: specular_transmittance. Scalar: eta = int_ior / ext_ior;
// microfacet at MP_MICROFACET. Without visible-normal sampling, the sampling distribution's
// roughness is scaled by 1.2 - 0.2 sqrt(|cos θi|) (Walter's trick), as Mitsuba does.

fn roughdielectric_sampling(d: Microfacet, cos_i: f32) -> Microfacet {
    if d.visible {
        return d;
    }
    return mf_scaled(d, 1.2 - 0.2 * sqrt(abs(cos_i)));
}

fn bsdf_roughdielectric_eval(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    let ci = wi.z;
    let co = wo.z;
    if ci == 0.0 {
        return vec4<f32>(0.0);
    }
    let m_eta = m[MP_SCALARS];
    let is_reflect = ci * co > 0.0;
    let eta = select(1.0 / m_eta, m_eta, ci > 0.0);
    let inv_eta = select(m_eta, 1.0 / m_eta, ci > 0.0);
    var h = normalize(wi + wo * select(eta, 1.0, is_reflect));
    h = h * mulsign(1.0, h.z);
    let d = mf_from(m, MP_MICROFACET);
    let dv = mf_eval(d, h);
    let f = fresnel_dielectric(dot(wi, h), m_eta).r;
    let g = mf_g(d, wi, wo, h);
    let wi_h = dot(wi, h);
    let wo_h = dot(wo, h);
    var value: vec3<f32>;
    if is_reflect {
        value = tex_rgb(m, MP_TEX_A, uv) * (f * dv * g / (4.0 * abs(ci)));
    } else {
        let scale = inv_eta * inv_eta;
        let denom = wi_h + eta * wo_h;
        value = tex_rgb(m, MP_TEX_B, uv)
            * abs((scale * (1.0 - f) * dv * g * eta * eta * wi_h * wo_h) / (ci * denom * denom));
    }
    // The pdf, with the side filter of Mitsuba's pdf().
    var pdf = 0.0;
    if wi_h * ci > 0.0 && wo_h * co > 0.0 {
        var dwh_dwo: f32;
        if is_reflect {
            dwh_dwo = 1.0 / (4.0 * wo_h);
        } else {
            let denom = wi_h + eta * wo_h;
            dwh_dwo = (eta * eta * wo_h) / (denom * denom);
        }
        let sd = roughdielectric_sampling(d, ci);
        var prob = mf_pdf(sd, wi * mulsign(1.0, ci), h);
        prob *= select(1.0 - f, f, is_reflect);
        pdf = prob * abs(dwh_dwo);
    }
    return vec4<f32>(value, pdf);
}

fn bsdf_roughdielectric_sample(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    let ci = wi.z;
    if ci == 0.0 {
        return bsdf_sample_none();
    }
    let m_eta = m[MP_SCALARS];
    let d = mf_from(m, MP_MICROFACET);
    let ms = mf_sample(roughdielectric_sampling(d, ci), wi * mulsign(1.0, ci), u2);
    if ms.w == 0.0 {
        return bsdf_sample_none();
    }
    let n = ms.xyz;
    let fr = fresnel_dielectric(dot(wi, n), m_eta);
    let f = fr.r;
    let selected_r = u1 <= f;
    var pdf = ms.w * select(1.0 - f, f, selected_r);
    var wo: vec3<f32>;
    var weight: vec3<f32>;
    var eta_out = 1.0;
    var dwh_dwo: f32;
    if selected_r {
        wo = reflect_m(wi, n);
        weight = tex_rgb(m, MP_TEX_A, uv);
        dwh_dwo = 1.0 / (4.0 * dot(wo, n));
    } else {
        eta_out = fr.eta_it;
        wo = refract_m(wi, n, fr.cos_t, fr.eta_ti);
        weight = tex_rgb(m, MP_TEX_B, uv) * (fr.eta_ti * fr.eta_ti);
        let denom = dot(wi, n) + eta_out * dot(wo, n);
        dwh_dwo = (eta_out * eta_out * dot(wo, n)) / (denom * denom);
    }
    if d.visible {
        weight *= mf_smith_g1(d, wo, n);
    } else {
        weight *= mf_g(d, wi, wo, n) * dot(wi, n) / (ci * n.z);
    }
    pdf *= abs(dwh_dwo);
    return BsdfSample(wo, weight, pdf, eta_out, 0u);
}

fn bsdf_roughdielectric_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return tex_rgb(m, MP_TEX_B, uv);
}
