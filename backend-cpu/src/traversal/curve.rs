//! The built-in round-curve test.
//!
//! A round curve is the volume swept by a sphere whose centre and radius follow the
//! segment's basis. The test converts the segment to Bézier form and subdivides it (de
//! Casteljau, halving the parameter range) until each piece is within the tolerance of the
//! straight *round cone* between its end spheres (the convex hull of two spheres), culling
//! pieces whose control boxes the ray misses. The first entry into a round cone is solved
//! exactly, in f64.
//!
//! **Tolerance.** A piece is accepted when its interior control points (centre and radius)
//! lie within `tol = CURVE_TOLERANCE_RADIUS · rmax + CURVE_TOLERANCE_SIZE · size` of the
//! chord, where `rmax` is the segment's largest control radius and `size` its control box's
//! diagonal; the piece's swept surface then lies within `tol` of the true one, so reported
//! hit points are within `tol` of the exact surface and `rt_curve_parameter` is accurate to
//! the same degree (at most [`MAX_DEPTH`] halvings, 65 536 pieces). Rays report only entries
//! (front faces): a ray starting inside the tube hits nothing of that piece, as OptiX's
//! built-in curves do (best effort). Open strand ends (the default for quadratic and cubic
//! curves) cut the tube flat at the end point: rays entering through the cut hit nothing.

use super::ray::PreparedRay;
use super::slab;
use crate::accel::curve_basis::BezierSegment;
use crate::accel::curve_caps;

/// Tolerance relative to the segment's largest radius.
pub const CURVE_TOLERANCE_RADIUS: f64 = 1.0 / 1024.0;
/// Tolerance relative to the segment's size (matters only where radii vanish).
pub const CURVE_TOLERANCE_SIZE: f64 = 1.0 / 65536.0;
/// Deepest subdivision.
pub const MAX_DEPTH: u32 = 16;

/// A curve hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveHit {
    /// Distance along the (unnormalised) direction.
    pub t: f32,
    /// The curve parameter in [0, 1] (`rt_curve_parameter`).
    pub u: f32,
}

type V = [f64; 3];
fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn scale(a: V, s: f64) -> V {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn p3(p: &[f32; 4]) -> V {
    [p[0] as f64, p[1] as f64, p[2] as f64]
}

/// How far a Bézier piece's interior control points (centre plus radius) stray from the
/// straight piece between its ends.
fn deviation(seg: &BezierSegment) -> f64 {
    let n = seg.degree;
    let (a, b) = (p3(&seg.points[0]), p3(&seg.points[n]));
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let mut worst = 0.0f64;
    for i in 1..n {
        let p = sub(p3(&seg.points[i]), a);
        let along = if len2 > 0.0 { dot(p, ab) / len2 } else { 0.0 };
        let off = sub(p, scale(ab, along));
        let f = i as f64 / n as f64;
        let r_lerp = seg.points[0][3] as f64 * (1.0 - f) + seg.points[n][3] as f64 * f;
        worst = worst.max(dot(off, off).sqrt() + (seg.points[i][3] as f64 - r_lerp).abs());
    }
    worst
}

/// Roots of `A t² + 2B t + C = 0`, ascending (Numerical Recipes form).
fn quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    if a == 0.0 {
        return (b != 0.0).then(|| {
            let t = -c / (2.0 * b);
            (t, t)
        });
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (x, y) = (c / q, q / a);
    Some(if x <= y { (x, y) } else { (y, x) })
}

/// Entry distances of a ray (unit `d`, origin `o`) into a sphere, ascending.
fn sphere_roots(o: V, d: V, centre: V, r: f64) -> Option<(f64, f64)> {
    let f = sub(o, centre);
    let b = dot(f, d);
    let v = sub(f, scale(d, b));
    let disc = r * r - dot(v, v);
    if disc < 0.0 {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    let c = dot(f, f) - r * r;
    if q == 0.0 {
        return Some((-b, -b));
    }
    let (x, y) = (c / q, q);
    Some(if x <= y { (x, y) } else { (y, x) })
}

/// A round cone: the convex hull of the spheres `(a, ra)` and `(b, rb)`, optionally cut flat
/// at `a` or `b` (open strand ends).
struct RoundCone {
    a: V,
    b: V,
    ra: f64,
    rb: f64,
    open_a: bool,
    open_b: bool,
    /// Unit axis and length (axis undefined when the ends coincide).
    w: V,
    len: f64,
    /// sin and cos of the cone's half angle; `None` when one sphere holds the other.
    cone: Option<(f64, f64)>,
}

impl RoundCone {
    fn new(a: V, b: V, ra: f64, rb: f64, open_a: bool, open_b: bool) -> RoundCone {
        let ab = sub(b, a);
        let len = dot(ab, ab).sqrt();
        let w = if len > 0.0 {
            scale(ab, 1.0 / len)
        } else {
            [0.0, 0.0, 1.0]
        };
        let cone = (len > (ra - rb).abs()).then(|| {
            let s = (ra - rb) / len;
            (s, (1.0 - s * s).sqrt())
        });
        RoundCone {
            a,
            b,
            ra,
            rb,
            open_a,
            open_b,
            w,
            len,
            cone,
        }
    }

    /// Axial coordinate of `p`.
    fn axial(&self, p: V) -> f64 {
        dot(sub(p, self.a), self.w)
    }

    /// Whether `p` lies inside the (cut) solid.
    fn contains(&self, p: V) -> bool {
        let y = self.axial(p);
        if (self.open_a && y < 0.0) || (self.open_b && y > self.len) {
            return false;
        }
        let in_a = dot(sub(p, self.a), sub(p, self.a)) <= self.ra * self.ra;
        let in_b = dot(sub(p, self.b), sub(p, self.b)) <= self.rb * self.rb;
        match self.cone {
            None => in_a || in_b,
            Some((sin, cos)) => {
                if y < self.ra * sin {
                    in_a
                } else if y > self.len + self.rb * sin {
                    in_b
                } else {
                    let radial = sub(sub(p, self.a), scale(self.w, y));
                    dot(radial, radial).sqrt() * cos + y * sin <= self.ra
                }
            }
        }
    }

    /// The first point where a ray from outside (unit `d`) enters the solid within
    /// `(tmin, tmax)`: `(t, axial fraction in [0, 1])`. Entries through a cut end are not
    /// hits and hide what lies behind them.
    fn entry(&self, o: V, d: V, tmin: f64, tmax: f64) -> Option<(f64, f64)> {
        let start = tmin.max(0.0);
        if self.contains([
            o[0] + start * d[0],
            o[1] + start * d[1],
            o[2] + start * d[2],
        ]) {
            return None;
        }
        let y_ok = |y: f64| !((self.open_a && y < 0.0) || (self.open_b && y > self.len));
        let mut best: Option<f64> = None;
        let mut consider = |t: f64, valid: bool| {
            if valid && t > tmin && t < tmax && best.is_none_or(|b| t < b) {
                best = Some(t);
            }
        };
        let at = |t: f64| [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
        match self.cone {
            None => {
                let (c, r) = if self.ra >= self.rb {
                    (self.a, self.ra)
                } else {
                    (self.b, self.rb)
                };
                if let Some((t0, _)) = sphere_roots(o, d, c, r) {
                    consider(t0, y_ok(self.axial(at(t0))));
                }
            }
            Some((sin, cos)) => {
                // Each sphere contributes the cap beyond its tangent circle.
                if let Some((t0, _)) = sphere_roots(o, d, self.a, self.ra) {
                    let y = self.axial(at(t0));
                    consider(t0, y <= self.ra * sin && y_ok(y));
                }
                if let Some((t0, _)) = sphere_roots(o, d, self.b, self.rb) {
                    let y = self.axial(at(t0));
                    consider(t0, y >= self.len + self.rb * sin && y_ok(y));
                }
                // The lateral surface: ρ·cos α + y·sin α = ra between the tangent circles.
                let oa = sub(o, self.a);
                let (y0, dy, od) = (dot(oa, self.w), dot(d, self.w), dot(oa, d));
                let c2 = cos * cos;
                let k = self.ra - sin * y0;
                let qa = c2 - dy * dy;
                let qb = c2 * (od - y0 * dy) + sin * dy * k;
                let qc = c2 * (dot(oa, oa) - y0 * y0) - k * k;
                if let Some((t0, t1)) = quadratic(qa, qb, qc) {
                    for t in [t0, t1] {
                        let y = y0 + t * dy;
                        let on_nappe = self.ra - sin * y >= 0.0;
                        let between = y >= self.ra * sin && y <= self.len + self.rb * sin;
                        consider(t, on_nappe && between && y_ok(y));
                    }
                }
            }
        }
        let t = best?;
        // A ray that came in through a cut end was already inside when it met `t`.
        for (open, plane_y, inward) in [(self.open_a, 0.0, 1.0), (self.open_b, self.len, -1.0)] {
            let dy = dot(d, self.w);
            if !open || dy * inward <= 0.0 {
                continue;
            }
            let tp = (plane_y - self.axial(o)) / dy;
            if tp > tmin && tp < t {
                let p = at(tp);
                let radial = sub(sub(p, self.a), scale(self.w, plane_y));
                let r = if plane_y == 0.0 { self.ra } else { self.rb };
                let cut_radius = match self.cone {
                    Some((sin, cos))
                        if (plane_y == 0.0 && sin <= 0.0) || (plane_y != 0.0 && sin >= 0.0) =>
                    {
                        r / cos
                    }
                    _ => r,
                };
                if dot(radial, radial) <= cut_radius * cut_radius {
                    return None;
                }
            }
        }
        let frac = if self.len > 0.0 {
            (self.axial(at(t)) / self.len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Some((t, frac))
    }
}

/// Intersects the ray `origin + t·dir` with a curve segment (Bézier form) in `(tmin, tmax)`;
/// `caps` holds [`curve_caps`] bits.
pub fn intersect(
    origin: [f32; 3],
    dir: [f32; 3],
    seg: &BezierSegment,
    caps: u8,
    tmin: f32,
    tmax: f32,
) -> Option<CurveHit> {
    let d = [dir[0] as f64, dir[1] as f64, dir[2] as f64];
    let dlen = dot(d, d).sqrt();
    if dlen == 0.0 || !dlen.is_finite() {
        return None;
    }
    let dn = scale(d, 1.0 / dlen);
    let o = [origin[0] as f64, origin[1] as f64, origin[2] as f64];
    let bounds = seg.bounds();
    let size = (0..3)
        .map(|k| (bounds.max[k] - bounds.min[k]) as f64)
        .map(|e| e * e)
        .sum::<f64>()
        .sqrt();
    let rmax = seg.points[..=seg.degree]
        .iter()
        .fold(0.0f64, |m, p| m.max(p[3] as f64));
    let tol = CURVE_TOLERANCE_RADIUS * rmax + CURVE_TOLERANCE_SIZE * size;
    let ray = PreparedRay::new(origin, dir, true);
    let mut best: Option<(f32, f32)> = None;
    let mut stack: Vec<(BezierSegment, f32, f32, u32)> = vec![(*seg, 0.0, 1.0, 0)];
    while let Some((piece, u0, u1, depth)) = stack.pop() {
        let t_end = best.map_or(tmax, |b| b.0);
        let b = piece.bounds();
        if slab::entry(&ray, &b.min, &b.max, tmin, t_end).is_none() {
            continue;
        }
        if depth < MAX_DEPTH && deviation(&piece) > tol {
            let (l, r) = piece.split();
            let um = 0.5 * (u0 + u1);
            stack.push((r, um, u1, depth + 1));
            stack.push((l, u0, um, depth + 1));
            continue;
        }
        let n = piece.degree;
        let cone = RoundCone::new(
            p3(&piece.points[0]),
            p3(&piece.points[n]),
            piece.points[0][3] as f64,
            piece.points[n][3] as f64,
            u0 == 0.0 && caps & curve_caps::OPEN_START != 0,
            u1 == 1.0 && caps & curve_caps::OPEN_END != 0,
        );
        if let Some((tn, frac)) = cone.entry(o, dn, tmin as f64 * dlen, t_end as f64 * dlen) {
            let t = (tn / dlen) as f32;
            if t > tmin && t < t_end {
                best = Some((t, u0 + (u1 - u0) * frac as f32));
            }
        }
    }
    best.map(|(t, u)| CurveHit { t, u })
}

#[cfg(test)]
mod tests {
    use super::*;
    use optik_api::CurveType;

    fn seg(basis: CurveType, p: [[f32; 4]; 4]) -> BezierSegment {
        BezierSegment::from_basis(basis, &p)
    }

    #[test]
    fn straight_capsule_hits_match_analytic() {
        // A capsule along x from 0 to 4, radius 0.5.
        let s = seg(
            CurveType::RoundLinear,
            [
                [0.0, 0.0, 0.0, 0.5],
                [4.0, 0.0, 0.0, 0.5],
                [0.0; 4],
                [0.0; 4],
            ],
        );
        let h = intersect([2.0, 0.0, -5.0], [0.0, 0.0, 2.0], &s, 0, 0.0, f32::INFINITY).unwrap();
        assert!(
            (h.t - 2.25).abs() < 1e-6 && (h.u - 0.5).abs() < 1e-6,
            "{h:?}"
        );
        // Round cap at the end: along the axis from beyond x = 4.
        let h = intersect([6.0, 0.0, 0.0], [-1.0, 0.0, 0.0], &s, 0, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 1.5).abs() < 1e-6 && h.u == 1.0, "{h:?}");
        // Grazing miss, hit just inside.
        assert!(
            intersect(
                [2.0, 0.5001, -5.0],
                [0.0, 0.0, 1.0],
                &s,
                0,
                0.0,
                f32::INFINITY
            )
            .is_none()
        );
        assert!(
            intersect(
                [2.0, 0.4999, -5.0],
                [0.0, 0.0, 1.0],
                &s,
                0,
                0.0,
                f32::INFINITY
            )
            .is_some()
        );
        // From inside: nothing.
        assert!(intersect([2.0, 0.0, 0.0], [0.0, 0.0, 1.0], &s, 0, 0.0, f32::INFINITY).is_none());
        // Open start: a ray along the axis from before x = 0 enters through the cut.
        assert!(
            intersect(
                [-3.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                &s,
                curve_caps::OPEN_START,
                0.0,
                f32::INFINITY
            )
            .is_none()
        );
        let h = intersect([-3.0, 0.0, 0.0], [1.0, 0.0, 0.0], &s, 0, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 2.5).abs() < 1e-6);
    }

    #[test]
    fn tapered_cone_against_distance_field() {
        // Compare with ray marching of the exact distance to the swept union of spheres.
        let (a, b, ra, rb) = ([0.0f64, 0.0, 0.0], [3.0f64, 1.0, 0.0], 0.8f64, 0.2f64);
        let s = seg(
            CurveType::RoundLinear,
            [
                [0.0, 0.0, 0.0, 0.8],
                [3.0, 1.0, 0.0, 0.2],
                [0.0; 4],
                [0.0; 4],
            ],
        );
        // Distance to the union of spheres along the segment: convex in the parameter, so a
        // ternary search finds its minimum; sphere tracing then finds the first contact.
        let sdf = |p: V| {
            let f = |s: f64| {
                let c = [a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, 0.0];
                dot(sub(p, c), sub(p, c)).sqrt() - (ra + (rb - ra) * s)
            };
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            for _ in 0..100 {
                let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
                if f(m1) < f(m2) { hi = m2 } else { lo = m1 }
            }
            f(0.5 * (lo + hi))
        };
        for i in 0..40 {
            let x = -1.0 + i as f32 * 0.11;
            let o = [x, 0.3, -4.0];
            let d = [0.05, 0.0, 1.0];
            let got = intersect(o, d, &s, 0, 0.0, f32::INFINITY).map(|h| h.t as f64);
            let dl = dot(p3(&[d[0], d[1], d[2], 0.0]), p3(&[d[0], d[1], d[2], 0.0])).sqrt();
            let mut want = None;
            let mut t = 0.0f64;
            while t < 10.0 {
                let p = [
                    o[0] as f64 + t * d[0] as f64,
                    o[1] as f64,
                    o[2] as f64 + t * d[2] as f64,
                ];
                let dist = sdf(p);
                if dist < 1e-9 {
                    want = Some(t);
                    break;
                }
                t += dist / dl;
            }
            match (got, want) {
                (Some(g), Some(w)) => assert!((g - w).abs() < 2e-3, "x={x}: {g} vs {w}"),
                (None, None) => {}
                (g, w) => panic!("x={x}: {g:?} vs {w:?}"),
            }
        }
    }

    #[test]
    fn cubic_curve_hits_lie_within_tolerance() {
        let p = [
            [-1.0, 0.0, 0.0, 0.1],
            [0.0, 1.5, 0.0, 0.1],
            [1.5, -1.0, 0.0, 0.1],
            [3.0, 0.5, 0.0, 0.1],
        ];
        for basis in [
            CurveType::RoundCubicBSpline,
            CurveType::RoundCatmullRom,
            CurveType::RoundQuadraticBSpline,
        ] {
            let s = seg(basis, p);
            let mut hits = 0;
            for i in 0..200 {
                let u = i as f32 / 199.0;
                let c = s.eval(u);
                // Aim straight down -z at the curve's centre line.
                if let Some(h) = intersect(
                    [c[0], c[1], 5.0],
                    [0.0, 0.0, -1.0],
                    &s,
                    0,
                    0.0,
                    f32::INFINITY,
                ) {
                    hits += 1;
                    let q = s.eval(h.u);
                    let hit = [c[0] as f64, c[1] as f64, 5.0 - h.t as f64];
                    let dist = dot(sub(hit, p3(&q)), sub(hit, p3(&q))).sqrt();
                    // The reported point lies on the sphere of the reported parameter.
                    assert!(
                        (dist - q[3] as f64).abs() < 0.1 * 0.01 + 1e-4,
                        "{basis:?} u={u}: {dist} vs {}",
                        q[3]
                    );
                    assert!(
                        (h.t - (5.0 - 0.1)).abs() < 0.02,
                        "{basis:?} u={u}: t={}",
                        h.t
                    );
                }
            }
            assert!(hits >= 195, "{basis:?}: {hits}");
        }
    }
}
