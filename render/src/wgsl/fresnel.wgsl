// Mitsuba 3's Fresnel equations (include/mitsuba/render/fresnel.h), shared by every BSDF kind
// with a specular interface. Assembled once by programs.rs when such a kind is present.

// fresnel(cos_theta_i, eta): unpolarised reflectance, the signed cosine of the refracted
// direction, and the relative indices eta_it and eta_ti.
struct Fresnel {
    r: f32,
    cos_t: f32,
    eta_it: f32,
    eta_ti: f32,
}

fn fresnel_dielectric(cos_i: f32, eta: f32) -> Fresnel {
    let outside = cos_i >= 0.0;
    let rcp_eta = 1.0 / eta;
    let eta_it = select(rcp_eta, eta, outside);
    let eta_ti = select(eta, rcp_eta, outside);
    let cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * (eta_ti * eta_ti);
    let ci = abs(cos_i);
    let ct = sqrt(max(cos_t_sqr, 0.0));
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    var r = 0.5 * (a_s * a_s + a_p * a_p);
    if eta == 1.0 {
        r = 0.0;
    } else if ci == 0.0 {
        r = 1.0;
    }
    // mulsign_neg: the refracted direction lies on the other side.
    let cos_t = select(ct, -ct, cos_i >= 0.0);
    return Fresnel(r, cos_t, eta_it, eta_ti);
}

// fresnel_conductor(cos_theta_i, eta + i k) per channel.
fn fresnel_conductor(cos_i: f32, eta_r: vec3<f32>, eta_i: vec3<f32>) -> vec3<f32> {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let temp_1 = eta_r * eta_r - eta_i * eta_i - vec3<f32>(s2);
    let a_2_pb_2 = sqrt(max(temp_1 * temp_1 + 4.0 * eta_i * eta_i * eta_r * eta_r, vec3<f32>(0.0)));
    let a = sqrt(max(0.5 * (a_2_pb_2 + temp_1), vec3<f32>(0.0)));
    let term_1 = a_2_pb_2 + vec3<f32>(c2);
    let term_2 = 2.0 * cos_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2);
    let term_3 = a_2_pb_2 * c2 + vec3<f32>(s4);
    let term_4 = term_2 * s2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);
    return 0.5 * (r_s + r_p);
}

// Mirror reflection about the normal (0, 0, 1).
fn reflect_z(wi: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(-wi.x, -wi.y, wi.z);
}

// Mirror reflection about the microfacet normal m.
fn reflect_m(wi: vec3<f32>, m: vec3<f32>) -> vec3<f32> {
    return m * (2.0 * dot(wi, m)) - wi;
}

// Refraction about the normal (0, 0, 1), given fresnel()'s cos_t and eta_ti.
fn refract_z(wi: vec3<f32>, cos_t: f32, eta_ti: f32) -> vec3<f32> {
    return vec3<f32>(-eta_ti * wi.x, -eta_ti * wi.y, cos_t);
}

// Refraction about the microfacet normal m.
fn refract_m(wi: vec3<f32>, m: vec3<f32>, cos_t: f32, eta_ti: f32) -> vec3<f32> {
    return m * (dot(wi, m) * eta_ti + cos_t) - wi * eta_ti;
}
