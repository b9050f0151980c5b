// Mitsuba 3's microfacet distributions (include/mitsuba/render/microfacet.h): Beckmann and GGX,
// anisotropic, with visible-normal sampling (Heitz and d'Eon 2014) or sampling of D·cos θm.
// Assembled once by programs.rs when a rough BSDF kind is present.

struct Microfacet {
    // 0: Beckmann, 1: GGX.
    kind: u32,
    au: f32,
    av: f32,
    visible: bool,
}

// Four material parameters from `at`: distribution, alpha_u, alpha_v, sample_visible.
// Mitsuba clamps the roughness to 1e-4 when it builds a distribution.
fn mf_from(m: MatParams, at: u32) -> Microfacet {
    return Microfacet(u32(m[at]), max(m[at + 1u], 1e-4), max(m[at + 2u], 1e-4), m[at + 3u] != 0.0);
}

fn mf_scaled(d: Microfacet, s: f32) -> Microfacet {
    return Microfacet(d.kind, d.au * s, d.av * s, d.visible);
}

fn sqr(x: f32) -> f32 {
    return x * x;
}

// D(m).
fn mf_eval(d: Microfacet, m: vec3<f32>) -> f32 {
    let alpha_uv = d.au * d.av;
    let c = m.z;
    let c2 = c * c;
    var result: f32;
    if d.kind == 0u {
        result = exp(-(sqr(m.x / d.au) + sqr(m.y / d.av)) / c2) / (PI * alpha_uv * c2 * c2);
    } else {
        result = 1.0 / (PI * alpha_uv * sqr(sqr(m.x / d.au) + sqr(m.y / d.av) + sqr(m.z)));
    }
    // Also removes NaNs at grazing angles.
    if result * c > 1e-20 {
        return result;
    }
    return 0.0;
}

// Smith's shadowing-masking term for one direction.
fn mf_smith_g1(d: Microfacet, v: vec3<f32>, m: vec3<f32>) -> f32 {
    if dot(v, m) * v.z <= 0.0 {
        return 0.0;
    }
    let xy_alpha_2 = sqr(d.au * v.x) + sqr(d.av * v.y);
    if xy_alpha_2 == 0.0 {
        return 1.0;
    }
    let tan_theta_alpha_2 = xy_alpha_2 / sqr(v.z);
    if d.kind == 0u {
        let a = inverseSqrt(tan_theta_alpha_2);
        if a >= 1.6 {
            return 1.0;
        }
        let a_sqr = a * a;
        return (3.535 * a + 2.181 * a_sqr) / (1.0 + 2.276 * a + 2.577 * a_sqr);
    }
    return 2.0 / (1.0 + sqrt(1.0 + tan_theta_alpha_2));
}

fn mf_g(d: Microfacet, wi: vec3<f32>, wo: vec3<f32>, m: vec3<f32>) -> f32 {
    return mf_smith_g1(d, wi, m) * mf_smith_g1(d, wo, m);
}

// The density of sampling m (given wi) with mf_sample.
fn mf_pdf(d: Microfacet, wi: vec3<f32>, m: vec3<f32>) -> f32 {
    let result = mf_eval(d, m);
    if d.visible {
        return result * mf_smith_g1(d, wi, m) * abs(dot(wi, m)) / wi.z;
    }
    return result * m.z;
}

// erf by Abramowitz and Stegun 7.1.26 (absolute error below 1.5e-7).
fn erf_approx(x: f32) -> f32 {
    let ax = abs(x);
    let t = 1.0 / (1.0 + 0.3275911 * ax);
    let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    let y = 1.0 - poly * exp(-ax * ax);
    return select(-y, y, x >= 0.0);
}

// erfinv by Giles' single-precision approximation ("Approximating the erfinv function", 2010).
fn erfinv_approx(x: f32) -> f32 {
    var w = -log(max((1.0 - x) * (1.0 + x), 1e-30));
    var p: f32;
    if w < 5.0 {
        w = w - 2.5;
        p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
    } else {
        w = sqrt(w) - 3.0;
        p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
    }
    return p * x;
}

const INV_SQRT_PI: f32 = 0.56418958354775628695;

// Slopes of the visible normals of the unit-roughness distribution, seen from cos θi.
fn mf_sample_visible_11(kind: u32, cos_theta_i: f32, u_in: vec2<f32>) -> vec2<f32> {
    if kind == 0u {
        // Mitsuba's numerical inversion of the Beckmann visible-slope CDF.
        let tan_theta_i = sqrt(max(1.0 - cos_theta_i * cos_theta_i, 0.0)) / cos_theta_i;
        let cot_theta_i = 1.0 / max(tan_theta_i, 1e-7);
        let maxval = erf_approx(cot_theta_i);
        var u = clamp(u_in, vec2<f32>(1e-6), vec2<f32>(1.0 - 1e-6));
        var x = maxval - (maxval + 1.0) * erf_approx(sqrt(-log(u.x)));
        u.x *= 1.0 + maxval + INV_SQRT_PI * tan_theta_i * exp(-cot_theta_i * cot_theta_i);
        for (var i = 0; i < 3; i++) {
            let slope = erfinv_approx(x);
            let value = 1.0 + x + INV_SQRT_PI * tan_theta_i * exp(-slope * slope) - u.x;
            let derivative = 1.0 - slope * tan_theta_i;
            x -= value / derivative;
        }
        return vec2<f32>(erfinv_approx(x), erfinv_approx(2.0 * u.y - 1.0));
    }
    // GGX: Heitz's 2018 construction, as Mitsuba.
    var p = square_to_disk_concentric(u_in);
    let s = 0.5 * (1.0 + cos_theta_i);
    p.y = mix(sqrt(max(1.0 - p.x * p.x, 0.0)), p.y, s);
    let x = p.x;
    let y = p.y;
    let z = sqrt(max(1.0 - dot(p, p), 0.0));
    let sin_theta_i = sqrt(max(1.0 - cos_theta_i * cos_theta_i, 0.0));
    let norm = 1.0 / (sin_theta_i * y + cos_theta_i * z);
    return vec2<f32>(cos_theta_i * y - sin_theta_i * z, x) * norm;
}

// A microfacet normal for wi and its density (mf_pdf): xyz and w.
fn mf_sample(d: Microfacet, wi: vec3<f32>, u: vec2<f32>) -> vec4<f32> {
    if !d.visible {
        var sin_phi: f32;
        var cos_phi: f32;
        var alpha_2: f32;
        if d.au == d.av {
            sin_phi = sin(2.0 * PI * u.y);
            cos_phi = cos(2.0 * PI * u.y);
            alpha_2 = d.au * d.au;
        } else {
            let ratio = d.av / d.au;
            let tmp = ratio * tan(2.0 * PI * u.y);
            cos_phi = inverseSqrt(tmp * tmp + 1.0);
            cos_phi = mulsign(cos_phi, abs(u.y - 0.5) - 0.25);
            sin_phi = cos_phi * tmp;
            alpha_2 = 1.0 / (sqr(cos_phi / d.au) + sqr(sin_phi / d.av));
        }
        var cos_theta: f32;
        var pdf: f32;
        if d.kind == 0u {
            cos_theta = inverseSqrt(1.0 - alpha_2 * log(1.0 - u.x));
            let c2 = cos_theta * cos_theta;
            let c3 = max(c2 * cos_theta, 1e-20);
            pdf = (1.0 - u.x) / (PI * d.au * d.av * c3);
        } else {
            let tan_theta_m_2 = alpha_2 * u.x / (1.0 - u.x);
            cos_theta = inverseSqrt(1.0 + tan_theta_m_2);
            let c2 = cos_theta * cos_theta;
            let temp = 1.0 + tan_theta_m_2 / alpha_2;
            let c3 = max(c2 * cos_theta, 1e-20);
            pdf = 1.0 / (PI * d.au * d.av * c3 * temp * temp);
        }
        let sin_theta = sqrt(1.0 - cos_theta * cos_theta);
        return vec4<f32>(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta, pdf);
    }
    let wi_p = normalize(vec3<f32>(d.au * wi.x, d.av * wi.y, wi.z));
    // Frame3f::sincos_phi.
    let s2 = wi_p.x * wi_p.x + wi_p.y * wi_p.y;
    var cos_phi = 1.0;
    var sin_phi = 0.0;
    if s2 > 4.0 * 5.9604645e-8 {
        let inv = inverseSqrt(s2);
        cos_phi = clamp(wi_p.x * inv, -1.0, 1.0);
        sin_phi = clamp(wi_p.y * inv, -1.0, 1.0);
    }
    let slope0 = mf_sample_visible_11(d.kind, wi_p.z, u);
    let slope = vec2<f32>((cos_phi * slope0.x - sin_phi * slope0.y) * d.au,
                          (sin_phi * slope0.x + cos_phi * slope0.y) * d.av);
    let m = normalize(vec3<f32>(-slope.x, -slope.y, 1.0));
    let pdf = mf_eval(d, m) * mf_smith_g1(d, wi, m) * abs(dot(wi, m)) / wi.z;
    return vec4<f32>(m, pdf);
}
