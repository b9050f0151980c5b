//! Curve bases as Bézier control points.
//!
//! Every round curve segment is stored with its control points in the input's basis. Both
//! the bounds (here) and the CPU intersector (backend-cpu/src/traversal/curve.rs) first convert a segment to
//! Bézier form, whose control polygon holds the curve (the convex hull property): centre
//! and radius alike, since OptiX interpolates the radius with the same basis as the centre.

use super::aabb::Aabb;
use optik_api::CurveType;

/// A segment in Bézier form: `degree + 1` control points `(x, y, z, radius)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BezierSegment {
    /// 1 (linear), 2 (quadratic) or 3 (cubic).
    pub degree: usize,
    /// Control points; the first `degree + 1` count.
    pub points: [[f32; 4]; 4],
}

fn combine(p: &[[f32; 4]; 4], w: [f32; 4]) -> [f32; 4] {
    std::array::from_fn(|k| w[0] * p[0][k] + w[1] * p[1][k] + w[2] * p[2][k] + w[3] * p[3][k])
}

impl BezierSegment {
    /// The Bézier form of a segment's control points in `basis`.
    pub fn from_basis(basis: CurveType, p: &[[f32; 4]; 4]) -> BezierSegment {
        let (degree, weights): (usize, [[f32; 4]; 4]) = match basis {
            CurveType::RoundLinear => (
                1,
                [
                    [1.0, 0.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0, 0.0],
                    [0.0; 4],
                    [0.0; 4],
                ],
            ),
            // Uniform quadratic B-spline: b0 = (p0 + p1) / 2, b1 = p1, b2 = (p1 + p2) / 2.
            CurveType::RoundQuadraticBSpline => (
                2,
                [
                    [0.5, 0.5, 0.0, 0.0],
                    [0.0, 1.0, 0.0, 0.0],
                    [0.0, 0.5, 0.5, 0.0],
                    [0.0; 4],
                ],
            ),
            // Uniform cubic B-spline.
            CurveType::RoundCubicBSpline => (
                3,
                [
                    [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0, 0.0],
                    [0.0, 2.0 / 3.0, 1.0 / 3.0, 0.0],
                    [0.0, 1.0 / 3.0, 2.0 / 3.0, 0.0],
                    [0.0, 1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0],
                ],
            ),
            // Catmull-Rom between p1 and p2: tangents (p2 - p0) / 2 and (p3 - p1) / 2.
            CurveType::RoundCatmullRom => (
                3,
                [
                    [0.0, 1.0, 0.0, 0.0],
                    [-1.0 / 6.0, 1.0, 1.0 / 6.0, 0.0],
                    [0.0, 1.0 / 6.0, 1.0, -1.0 / 6.0],
                    [0.0, 0.0, 1.0, 0.0],
                ],
            ),
        };
        let mut points = [[0.0f32; 4]; 4];
        for (i, w) in weights.iter().enumerate().take(degree + 1) {
            points[i] = combine(p, *w);
        }
        BezierSegment { degree, points }
    }

    /// The point (centre and radius) at parameter `u` in [0, 1] (de Casteljau).
    pub fn eval(&self, u: f32) -> [f32; 4] {
        let mut q = self.points;
        for level in (1..=self.degree).rev() {
            for i in 0..level {
                let next = q[i + 1];
                for (a, b) in q[i].iter_mut().zip(next) {
                    *a += (b - *a) * u;
                }
            }
        }
        q[0]
    }

    /// The two halves at `u = 1/2` (de Casteljau subdivision).
    pub fn split(&self) -> (BezierSegment, BezierSegment) {
        let n = self.degree;
        let mut left = [[0.0f32; 4]; 4];
        let mut right = [[0.0f32; 4]; 4];
        let mut q = self.points;
        left[0] = q[0];
        right[n] = q[n];
        for level in 1..=n {
            for i in 0..=(n - level) {
                let next = q[i + 1];
                for (a, b) in q[i].iter_mut().zip(next) {
                    *a = 0.5 * (*a + b);
                }
            }
            left[level] = q[0];
            right[n - level] = q[n - level];
        }
        (
            BezierSegment {
                degree: n,
                points: left,
            },
            BezierSegment {
                degree: n,
                points: right,
            },
        )
    }

    /// A box holding the swept tube: the control points' box grown by the largest control
    /// radius magnitude (radii along the curve are convex combinations of the control
    /// radii). Every backend bounds curves with this.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        let mut r = 0.0f32;
        for p in &self.points[..=self.degree] {
            b.grow([p[0], p[1], p[2]]);
            r = r.max(p[3].abs());
        }
        b.padded(r).rounded_out()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bspline3(p: &[[f32; 4]; 4], u: f32) -> [f32; 4] {
        let w = [
            (1.0 - u).powi(3) / 6.0,
            (3.0 * u.powi(3) - 6.0 * u * u + 4.0) / 6.0,
            (-3.0 * u.powi(3) + 3.0 * u * u + 3.0 * u + 1.0) / 6.0,
            u.powi(3) / 6.0,
        ];
        combine(p, w)
    }

    fn catmull_rom(p: &[[f32; 4]; 4], u: f32) -> [f32; 4] {
        let w = [
            0.5 * (-u.powi(3) + 2.0 * u * u - u),
            0.5 * (3.0 * u.powi(3) - 5.0 * u * u + 2.0),
            0.5 * (-3.0 * u.powi(3) + 4.0 * u * u + u),
            0.5 * (u.powi(3) - u * u),
        ];
        combine(p, w)
    }

    fn bspline2(p: &[[f32; 4]; 4], u: f32) -> [f32; 4] {
        let w = [0.5 * (1.0 - u).powi(2), 0.5 + u - u * u, 0.5 * u * u, 0.0];
        combine(p, w)
    }

    #[test]
    fn bezier_forms_match_the_bases() {
        let p = [
            [0.0, 0.0, 0.0, 0.1],
            [1.0, 2.0, 0.0, 0.2],
            [3.0, 1.0, 1.0, 0.05],
            [4.0, -1.0, 2.0, 0.3],
        ];
        for (basis, reference) in [
            (
                CurveType::RoundCubicBSpline,
                bspline3 as fn(&[[f32; 4]; 4], f32) -> [f32; 4],
            ),
            (CurveType::RoundCatmullRom, catmull_rom),
            (CurveType::RoundQuadraticBSpline, bspline2),
        ] {
            let b = BezierSegment::from_basis(basis, &p);
            for i in 0..=10 {
                let u = i as f32 / 10.0;
                let (got, want) = (b.eval(u), reference(&p, u));
                for k in 0..4 {
                    assert!(
                        (got[k] - want[k]).abs() < 1e-5,
                        "{basis:?} u={u}: {got:?} vs {want:?}"
                    );
                }
                let bb = b.bounds();
                for k in 0..3 {
                    assert!(bb.min[k] <= want[k] - want[3] && want[k] + want[3] <= bb.max[k]);
                }
            }
            let (l, r) = b.split();
            for i in 0..=4 {
                let u = i as f32 / 4.0;
                let (a, c) = (l.eval(u), b.eval(u * 0.5));
                let (d, e) = (r.eval(u), b.eval(0.5 + u * 0.5));
                for k in 0..4 {
                    assert!((a[k] - c[k]).abs() < 1e-5 && (d[k] - e[k]).abs() < 1e-5);
                }
            }
        }
    }
}
