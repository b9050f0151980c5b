// Mitsuba 3's `conductor`: a perfect specular reflection weighted by the conductor Fresnel
// reflectance (eta + i k per channel) and specular_reflectance (texture A), front side only.
// Scalars: eta rgb, k rgb.

fn bsdf_conductor_eval(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    return vec4<f32>(0.0);
}

fn bsdf_conductor_sample(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    if wi.z <= 0.0 {
        return bsdf_sample_none();
    }
    let s = MP_SCALARS;
    let eta = vec3<f32>(m[s], m[s + 1u], m[s + 2u]);
    let k = vec3<f32>(m[s + 3u], m[s + 4u], m[s + 5u]);
    let f = fresnel_conductor(wi.z, eta, k);
    return BsdfSample(reflect_z(wi), tex_rgb(m, MP_TEX_A, uv) * f, 1.0, 1.0, 1u);
}

fn bsdf_conductor_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return tex_rgb(m, MP_TEX_A, uv);
}
