//! 3×4 row-major affine matrices, the form OptiX's transforms and instances use.

use crate::accel::Matrix3x4;

/// `a · b` (apply `b` first).
pub fn mul(a: &Matrix3x4, b: &Matrix3x4) -> Matrix3x4 {
    let mut r = [0.0f32; 12];
    for row in 0..3 {
        for col in 0..4 {
            let mut v =
                a[row * 4] * b[col] + a[row * 4 + 1] * b[4 + col] + a[row * 4 + 2] * b[8 + col];
            if col == 3 {
                v += a[row * 4 + 3];
            }
            r[row * 4 + col] = v;
        }
    }
    r
}

/// The inverse, computed in f64; `None` when the linear part is singular or not finite.
pub fn inverse(m: &Matrix3x4) -> Option<Matrix3x4> {
    let a = |r: usize, c: usize| m[r * 4 + c] as f64;
    let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
        - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let mut l = [[0.0f64; 3]; 3];
    l[0][0] = (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) * inv_det;
    l[0][1] = (a(0, 2) * a(2, 1) - a(0, 1) * a(2, 2)) * inv_det;
    l[0][2] = (a(0, 1) * a(1, 2) - a(0, 2) * a(1, 1)) * inv_det;
    l[1][0] = (a(1, 2) * a(2, 0) - a(1, 0) * a(2, 2)) * inv_det;
    l[1][1] = (a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0)) * inv_det;
    l[1][2] = (a(0, 2) * a(1, 0) - a(0, 0) * a(1, 2)) * inv_det;
    l[2][0] = (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0)) * inv_det;
    l[2][1] = (a(0, 1) * a(2, 0) - a(0, 0) * a(2, 1)) * inv_det;
    l[2][2] = (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0)) * inv_det;
    let t = [a(0, 3), a(1, 3), a(2, 3)];
    let mut r = [0.0f32; 12];
    for row in 0..3 {
        for col in 0..3 {
            r[row * 4 + col] = l[row][col] as f32;
        }
        r[row * 4 + 3] = -(l[row][0] * t[0] + l[row][1] * t[1] + l[row][2] * t[2]) as f32;
    }
    Some(r)
}

/// Applies `m` to a point.
pub fn transform_point(m: &Matrix3x4, p: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|r| {
        m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3]
    })
}

/// Applies the linear part of `m` to a vector.
pub fn transform_vector(m: &Matrix3x4, v: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|r| m[r * 4] * v[0] + m[r * 4 + 1] * v[1] + m[r * 4 + 2] * v[2])
}

/// Whether every element is finite.
pub fn is_finite(m: &Matrix3x4) -> bool {
    m.iter().all(|v| v.is_finite())
}

/// The determinant of the linear part (negative for mirroring transforms).
pub fn determinant(m: &Matrix3x4) -> f64 {
    let a = |r: usize, c: usize| m[r * 4 + c] as f64;
    a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
        - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::IDENTITY_3X4;

    #[test]
    fn inverse_of_scale_rotate_translate() {
        let m: Matrix3x4 = [0.0, -2.0, 0.0, 5.0, 2.0, 0.0, 0.0, -3.0, 0.0, 0.0, 0.5, 1.0];
        let inv = inverse(&m).unwrap();
        let id = mul(&m, &inv);
        for (a, b) in id.iter().zip(IDENTITY_3X4.iter()) {
            assert!((a - b).abs() < 1e-6, "{id:?}");
        }
        let p = [1.0, 2.0, 3.0];
        let q = transform_point(&inv, transform_point(&m, p));
        for i in 0..3 {
            assert!((p[i] - q[i]).abs() < 1e-5);
        }
        assert!(inverse(&[0.0; 12]).is_none());
        assert!(determinant(&[-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]) < 0.0);
    }
}
