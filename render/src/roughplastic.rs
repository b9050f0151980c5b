//! Precomputed terms of Mitsuba 3's `plastic` and `roughplastic`, computed on the host exactly as
//! Mitsuba computes them when a BSDF is created: the diffuse Fresnel reflectance fit
//! (`fresnel_diffuse_reflectance`) and, for the rough coating, the transmittance through the
//! rough interface per incident cosine (`eval_transmittance`, 64 entries) and the internal
//! reflectance (`eval_reflectance`), both by Gauss–Legendre quadrature over visible normals.

use crate::scene::Microfacet;

/// Entries of the transmittance table (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TABLE_RES: usize = 64;

/// Mitsuba's fit of the hemispherical average of the dielectric Fresnel reflectance.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv_eta = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv_eta + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        // Horner, lowest coefficient first.
        let c = [0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &k| acc * inv_eta + k)
    }
}

/// roughplastic's precomputed terms.
#[derive(Clone, Debug, PartialEq)]
pub struct Tables {
    /// Transmittance into the coating at `cos θ = i / 63` (the first at 1e-6).
    pub external_transmittance: [f32; TABLE_RES],
    /// The coating's reflectance seen from inside, averaged over the cosine-weighted hemisphere.
    pub internal_reflectance: f32,
}

impl Tables {
    /// The tables of a coating with relative index `eta` and isotropic roughness `alpha`.
    pub fn new(distribution: Microfacet, alpha: f32, eta: f32) -> Tables {
        let d = Distribution {
            ggx: distribution == Microfacet::Ggx,
            alpha: f64::from(alpha.max(1e-4)),
        };
        let eta = f64::from(eta);
        let mut external_transmittance = [0.0; TABLE_RES];
        let mut internal = 0.0;
        for (i, t) in external_transmittance.iter_mut().enumerate() {
            let mu = (i as f64 / (TABLE_RES - 1) as f64).max(1e-6);
            let wi = [(1.0 - mu * mu).sqrt(), 0.0, mu];
            *t = quadrature(&d, wi, eta, true) as f32;
            internal += quadrature(&d, wi, 1.0 / eta, false) * mu;
        }
        Tables {
            external_transmittance,
            internal_reflectance: (internal / TABLE_RES as f64 * 2.0) as f32,
        }
    }
}

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(v: V3) -> V3 {
    let l = dot(v, v).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

/// An isotropic microfacet distribution with visible-normal sampling (microfacet.wgsl's
/// functions for the case Mitsuba's tables use).
struct Distribution {
    ggx: bool,
    alpha: f64,
}

impl Distribution {
    fn smith_g1(&self, v: V3, m: V3) -> f64 {
        if dot(v, m) * v[2] <= 0.0 {
            return 0.0;
        }
        let xy = (self.alpha * v[0]).powi(2) + (self.alpha * v[1]).powi(2);
        if xy == 0.0 {
            return 1.0;
        }
        let t2 = xy / (v[2] * v[2]);
        if self.ggx {
            return 2.0 / (1.0 + (1.0 + t2).sqrt());
        }
        let a = 1.0 / t2.sqrt();
        if a >= 1.6 {
            return 1.0;
        }
        (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
    }

    /// A visible normal for `wi` (Mitsuba's `sample` with `sample_visible`).
    fn sample(&self, wi: V3, u: [f64; 2]) -> V3 {
        let wi_p = normalize([self.alpha * wi[0], self.alpha * wi[1], wi[2]]);
        let s2 = wi_p[0] * wi_p[0] + wi_p[1] * wi_p[1];
        let (sin_phi, cos_phi) = if s2 <= 4.0 * f64::from(f32::EPSILON / 2.0) {
            (0.0, 1.0)
        } else {
            let inv = 1.0 / s2.sqrt();
            (
                (wi_p[1] * inv).clamp(-1.0, 1.0),
                (wi_p[0] * inv).clamp(-1.0, 1.0),
            )
        };
        let s = self.sample_visible_11(wi_p[2], u);
        let slope = [
            (cos_phi * s[0] - sin_phi * s[1]) * self.alpha,
            (sin_phi * s[0] + cos_phi * s[1]) * self.alpha,
        ];
        normalize([-slope[0], -slope[1], 1.0])
    }

    fn sample_visible_11(&self, cos_theta_i: f64, u: [f64; 2]) -> [f64; 2] {
        if self.ggx {
            let mut p = square_to_disk_concentric(u);
            let s = 0.5 * (1.0 + cos_theta_i);
            let top = (1.0 - p[0] * p[0]).max(0.0).sqrt();
            p[1] = top + (p[1] - top) * s;
            let (x, y) = (p[0], p[1]);
            let z = (1.0 - x * x - y * y).max(0.0).sqrt();
            let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
            let norm = 1.0 / (sin_theta_i * y + cos_theta_i * z);
            return [(cos_theta_i * y - sin_theta_i * z) * norm, x * norm];
        }
        let tan_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt() / cos_theta_i;
        let cot_theta_i = 1.0 / tan_theta_i;
        let maxval = libm::erf(cot_theta_i);
        let mut u = u.map(|v| v.clamp(1e-6, 1.0 - 1e-6));
        let mut x = maxval - (maxval + 1.0) * libm::erf((-u[0].ln()).sqrt());
        let inv_sqrt_pi = 1.0 / std::f64::consts::PI.sqrt();
        u[0] *= 1.0 + maxval + inv_sqrt_pi * tan_theta_i * (-cot_theta_i * cot_theta_i).exp();
        for _ in 0..3 {
            let slope = erfinv(x);
            let value = 1.0 + x + inv_sqrt_pi * tan_theta_i * (-slope * slope).exp() - u[0];
            let derivative = 1.0 - slope * tan_theta_i;
            x -= value / derivative;
        }
        [erfinv(x), erfinv(2.0 * u[1] - 1.0)]
    }
}

/// Shirley and Chiu's concentric map.
fn square_to_disk_concentric(u: [f64; 2]) -> [f64; 2] {
    let (x, y) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if x == 0.0 && y == 0.0 {
        return [0.0, 0.0];
    }
    let q = std::f64::consts::FRAC_PI_4;
    let (r, phi) = if x.abs() > y.abs() {
        (x, q * (y / x))
    } else {
        (y, 2.0 * q - q * (x / y))
    };
    [r * phi.cos(), r * phi.sin()]
}

/// The inverse error function: Giles' approximation refined by Newton steps on `erf`.
fn erfinv(y: f64) -> f64 {
    if y <= -1.0 {
        return f64::NEG_INFINITY;
    }
    if y >= 1.0 {
        return f64::INFINITY;
    }
    let mut w = -((1.0 - y) * (1.0 + y)).ln();
    let mut x = if w < 5.0 {
        w -= 2.5;
        let c = [
            2.81022636e-08,
            3.43273939e-07,
            -3.5233877e-06,
            -4.39150654e-06,
            0.00021858087,
            -0.00125372503,
            -0.00417768164,
            0.246640727,
            1.50140941,
        ];
        c.iter().fold(0.0, |p, &k| k + p * w) * y
    } else {
        w = w.sqrt() - 3.0;
        let c = [
            -0.000200214257,
            0.000100950558,
            0.00134934322,
            -0.00367342844,
            0.00573950773,
            -0.0076224613,
            0.00943887047,
            1.00167406,
            2.83297682,
        ];
        c.iter().fold(0.0, |p, &k| k + p * w) * y
    };
    let two_over_sqrt_pi = 2.0 / std::f64::consts::PI.sqrt();
    for _ in 0..2 {
        let d = two_over_sqrt_pi * (-x * x).exp();
        if d > 0.0 {
            x -= (libm::erf(x) - y) / d;
        }
    }
    x
}

/// The dielectric Fresnel reflectance, cos θt and eta_ti (Mitsuba's `fresnel`).
fn fresnel(cos_i: f64, eta: f64) -> (f64, f64, f64) {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
    let ci = cos_i.abs();
    let ct = cos_t_sqr.max(0.0).sqrt();
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    let r = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        0.5 * (a_s * a_s + a_p * a_p)
    };
    (r, if outside { -ct } else { ct }, eta_ti)
}

/// Gauss–Legendre nodes and weights on [-1, 1] (Newton's method on the Legendre polynomial).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = -(std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / dp;
                x -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// Mitsuba's `eval_transmittance` (`transmit`) or `eval_reflectance` of a rough interface seen
/// from `wi`: the expected Fresnel-weighted, shadowed energy over visible normals.
fn quadrature(d: &Distribution, wi: V3, eta: f64, transmit: bool) -> f64 {
    let res = if eta > 1.0 { 32 } else { 128 };
    let gl = gauss_legendre(res);
    let mut sum = 0.0;
    for &(nx, wx) in &gl {
        for &(ny, wy) in &gl {
            let m = d.sample(wi, [nx * 0.5 + 0.5, ny * 0.5 + 0.5]);
            let (f, cos_t, eta_ti) = fresnel(dot(wi, m), eta);
            let value = if transmit {
                let c = dot(wi, m) * eta_ti + cos_t;
                let wo = [
                    m[0] * c - wi[0] * eta_ti,
                    m[1] * c - wi[1] * eta_ti,
                    m[2] * c - wi[2] * eta_ti,
                ];
                if wo[2] * wi[2] >= 0.0 {
                    0.0
                } else {
                    d.smith_g1(wo, m) * (1.0 - f)
                }
            } else {
                let c = 2.0 * dot(wi, m);
                let wo = [m[0] * c - wi[0], m[1] * c - wi[1], m[2] * c - wi[2]];
                if wo[2] <= 0.0 || wi[2] <= 0.0 {
                    0.0
                } else {
                    d.smith_g1(wo, m) * f
                }
            };
            sum += value * wx * wy * 0.25;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let gl = gauss_legendre(8);
        let total: f64 = gl.iter().map(|(_, w)| w).sum();
        assert!((total - 2.0).abs() < 1e-12);
        // x^14 integrates to 2/15 on [-1, 1]; 8 nodes are exact up to degree 15.
        let x14: f64 = gl.iter().map(|(x, w)| w * x.powi(14)).sum();
        assert!((x14 - 2.0 / 15.0).abs() < 1e-12, "{x14}");
    }

    #[test]
    fn erfinv_inverts_erf() {
        for y in [-0.999, -0.5, 0.0, 0.3, 0.9, 0.99999] {
            assert!((libm::erf(erfinv(y)) - y).abs() < 1e-12, "{y}");
        }
    }

    #[test]
    fn a_smooth_coating_transmits_one_minus_fresnel() {
        // Nearly smooth: the transmittance at normal incidence is 1 - ((eta-1)/(eta+1))^2.
        let t = Tables::new(Microfacet::Ggx, 1e-4, 1.5);
        let expected = 1.0 - (0.5f32 / 2.5).powi(2);
        assert!((t.external_transmittance[63] - expected).abs() < 1e-4);
        // Less is transmitted at grazing incidence.
        assert!(t.external_transmittance[1] < t.external_transmittance[40]);
    }
}
