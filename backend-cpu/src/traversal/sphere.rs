//! The built-in sphere test (Haines, Günther and Akenine-Möller, "Precision Improvements
//! for Ray/Sphere Intersection", Ray Tracing Gems ch. 7).
//!
//! The discriminant comes from the squared distance between the centre and the ray
//! (Hearn and Baker's form), not from `b² − 4ac`, so small spheres far away keep their
//! silhouettes; the roots use the Numerical Recipes form (`q = −(b + sign(b)√Δ)`, `t₀ = c/q`,
//! `t₁ = q/a`), so the near root of a huge sphere near the origin does not cancel.
//!
//! A ray from outside reports its entry (front face); a ray starting inside reports its exit
//! (back face). Hits lie in the open interval `(tmin, tmax)`.

/// A sphere hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereHit {
    /// Distance along the (unnormalised) direction.
    pub t: f32,
    /// Entry (`true`) or exit.
    pub front: bool,
}

/// Intersects the ray `origin + t·dir` with the sphere `(centre.xyz, radius)`.
#[inline]
pub fn intersect(
    origin: [f32; 3],
    dir: [f32; 3],
    sphere: [f32; 4],
    tmin: f32,
    tmax: f32,
) -> Option<SphereHit> {
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let f = [
        origin[0] - sphere[0],
        origin[1] - sphere[1],
        origin[2] - sphere[2],
    ];
    let r = sphere[3];
    let a = dot(dir, dir);
    if a == 0.0 || !a.is_finite() {
        return None;
    }
    // The equation is a·t² + 2b·t + c = 0 with b = f·d.
    let b = dot(f, dir);
    let c = dot(f, f) - r * r;
    // Hearn–Baker: the point of the ray nearest the centre is f − (b/a)·d.
    let s = b / a;
    let v = [f[0] - s * dir[0], f[1] - s * dir[1], f[2] - s * dir[2]];
    let disc = a * (r * r - dot(v, v));
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    let (t0, t1) = if q == 0.0 {
        // Tangent ray through the centre's closest point at t = 0 (b = 0 and Δ = 0).
        (-s, -s)
    } else {
        let (x, y) = (c / q, q / a);
        if x <= y { (x, y) } else { (y, x) }
    };
    if t0 > tmin && t0 < tmax {
        Some(SphereHit { t: t0, front: true })
    } else if t1 > tmin && t1 < tmax {
        Some(SphereHit {
            t: t1,
            front: t0 > tmin,
        })
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference(o: [f64; 3], d: [f64; 3], s: [f64; 4]) -> Option<f64> {
        let f = [o[0] - s[0], o[1] - s[1], o[2] - s[2]];
        let a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let b = f[0] * d[0] + f[1] * d[1] + f[2] * d[2];
        let c = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] - s[3] * s[3];
        let disc = b * b - a * c;
        (disc >= 0.0).then(|| (-b - disc.sqrt()) / a)
    }

    #[test]
    fn entry_and_exit() {
        let s = [0.0, 0.0, 10.0, 2.0];
        assert_eq!(
            intersect([0.0; 3], [0.0, 0.0, 1.0], s, 0.0, f32::INFINITY),
            Some(SphereHit {
                t: 8.0,
                front: true
            })
        );
        assert_eq!(
            intersect([0.0, 0.0, 10.0], [0.0, 0.0, 1.0], s, 0.0, f32::INFINITY),
            Some(SphereHit {
                t: 2.0,
                front: false
            })
        );
        assert_eq!(
            intersect([0.0; 3], [0.0, 0.0, 1.0], s, 8.0, f32::INFINITY),
            Some(SphereHit {
                t: 12.0,
                front: false
            })
        );
        assert_eq!(
            intersect([0.0; 3], [0.0, 0.0, 1.0], s, 0.0, 8.0),
            None,
            "open interval"
        );
        assert_eq!(
            intersect([0.0; 3], [0.0, 2.0001, 1.0], s, 0.0, f32::INFINITY),
            None
        );
        assert_eq!(
            intersect([0.0; 3], [0.0, 0.0, -1.0], s, 0.0, f32::INFINITY),
            None,
            "behind"
        );
        assert_eq!(
            intersect([0.0; 3], [0.0; 3], s, 0.0, f32::INFINITY),
            None,
            "zero direction"
        );
    }

    #[test]
    fn tiny_sphere_far_away_keeps_its_silhouette() {
        // Radius 1, 1e5 away: the textbook discriminant has no correct bits left; count the
        // rays on a grid across the silhouette that agree with an f64 reference.
        let centre = [3.0e4, -2.0e4, 1.0e5];
        let s = [centre[0] as f32, centre[1] as f32, centre[2] as f32, 1.0];
        let mut disagree = 0;
        for i in -40..=40 {
            for j in -40..=40 {
                let target = [
                    centre[0] + i as f64 * 0.03,
                    centre[1] + j as f64 * 0.03,
                    centre[2],
                ];
                let d = [target[0] as f32, target[1] as f32, target[2] as f32];
                let got = intersect([0.0; 3], d, s, 0.0, f32::INFINITY).map(|h| h.t as f64);
                let want = reference(
                    [0.0; 3],
                    [d[0] as f64, d[1] as f64, d[2] as f64],
                    [centre[0], centre[1], centre[2], 1.0],
                );
                match (got, want) {
                    (Some(g), Some(w)) => assert!((g - w).abs() < 1e-4 * w, "{g} vs {w}"),
                    (None, None) => {}
                    _ => disagree += 1,
                }
            }
        }
        // Only rays within rounding of the silhouette may differ.
        assert!(disagree <= 8, "{disagree} silhouette disagreements");
    }

    #[test]
    fn huge_sphere_near_origin_has_accurate_near_root() {
        // A ground "plane" of radius 1e6 whose surface is 0.5 below the origin.
        let s = [0.0, -1.0e6 - 0.5, 0.0, 1.0e6];
        let h = intersect([0.0; 3], [0.0, -1.0, 0.0], s, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 0.5).abs() < 0.07, "{}", h.t);
        assert!(h.front);
        let h = intersect([0.0; 3], [0.3, -1.0, 0.2], s, 0.0, f32::INFINITY).unwrap();
        let w = reference([0.0; 3], [0.3, -1.0, 0.2], [0.0, -1.0e6 - 0.5, 0.0, 1.0e6]).unwrap();
        assert!((h.t as f64 - w).abs() < 0.07, "{} vs {w}", h.t);
    }
}
