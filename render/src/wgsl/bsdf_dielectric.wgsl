// Mitsuba 3's `dielectric`: a smooth interface between int_ior (inside, below the normal) and
// ext_ior; reflection or refraction chosen by the Fresnel reflectance. Texture A:
// specular_reflectance, B: specular_transmittance. Scalar: eta = int_ior / ext_ior.

fn bsdf_dielectric_eval(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    return vec4<f32>(0.0);
}

fn bsdf_dielectric_sample(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    let f = fresnel_dielectric(wi.z, m[MP_SCALARS]);
    let t_i = 1.0 - f.r;
    if u1 <= f.r {
        return BsdfSample(reflect_z(wi), tex_rgb(m, MP_TEX_A, uv), f.r, 1.0, 1u);
    }
    // Radiance is scaled by the solid angle compression of refraction.
    let w = tex_rgb(m, MP_TEX_B, uv) * (f.eta_ti * f.eta_ti);
    return BsdfSample(refract_z(wi, f.cos_t, f.eta_ti), w, t_i, f.eta_it, 1u);
}

fn bsdf_dielectric_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return tex_rgb(m, MP_TEX_B, uv);
}
