// Mitsuba 3's `thindielectric`: a thin sheet reflecting with the Fresnel reflectance summed over
// internal bounces, r' = 2r / (1 + r), and transmitting the rest without bending (a null lobe,
// which Mitsuba's Delta flag includes: no MIS at the next emitter hit). Texture A:
// specular_reflectance, B: specular_transmittance. Scalar: eta.

fn bsdf_thindielectric_eval(m: MatParams, wi: vec3<f32>, wo: vec3<f32>, uv: vec2<f32>) -> vec4<f32> {
    return vec4<f32>(0.0);
}

fn bsdf_thindielectric_sample(m: MatParams, wi: vec3<f32>, uv: vec2<f32>, u1: f32, u2: vec2<f32>) -> BsdfSample {
    var r = fresnel_dielectric(abs(wi.z), m[MP_SCALARS]).r;
    r *= 2.0 / (1.0 + r);
    if u1 <= r {
        return BsdfSample(reflect_z(wi), tex_rgb(m, MP_TEX_A, uv), r, 1.0, 1u);
    }
    return BsdfSample(-wi, tex_rgb(m, MP_TEX_B, uv), 1.0 - r, 1.0, 2u);
}

fn bsdf_thindielectric_albedo(m: MatParams, uv: vec2<f32>) -> vec3<f32> {
    return tex_rgb(m, MP_TEX_B, uv);
}
