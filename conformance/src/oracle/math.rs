//! `f64` vectors and 3×4 affine matrices for the oracle (its own code: the oracle shares no
//! arithmetic with the backends).

/// A 3-vector.
pub type V3 = [f64; 3];

/// `a + b`.
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a − b`.
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a · s`.
pub fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a · b`.
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`.
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean length.
pub fn length(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// Largest absolute component.
pub fn max_abs(a: V3) -> f64 {
    a[0].abs().max(a[1].abs()).max(a[2].abs())
}

/// `a` scaled to unit length (`a` itself when zero).
pub fn normalize(a: V3) -> V3 {
    let l = length(a);
    if l > 0.0 { scale(a, 1.0 / l) } else { a }
}

/// An `f32` vector as `f64`.
pub fn from_f32(a: [f32; 3]) -> V3 {
    [a[0] as f64, a[1] as f64, a[2] as f64]
}

/// A 3×4 row-major affine matrix in `f64`.
pub type M34 = [f64; 12];

/// The identity.
pub const IDENTITY: M34 = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// An `f32` matrix as `f64`.
pub fn m_from_f32(m: &[f32; 12]) -> M34 {
    std::array::from_fn(|i| m[i] as f64)
}

/// `a · b` (apply `b` first).
pub fn m_mul(a: &M34, b: &M34) -> M34 {
    let mut r = [0.0; 12];
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

/// The inverse; `None` when singular or not finite.
pub fn m_inverse(m: &M34) -> Option<M34> {
    let a = |r: usize, c: usize| m[r * 4 + c];
    let c00 = a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1);
    let c01 = a(1, 2) * a(2, 0) - a(1, 0) * a(2, 2);
    let c02 = a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0);
    let det = a(0, 0) * c00 + a(0, 1) * c01 + a(0, 2) * c02;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let l = [
        [
            c00 * inv,
            (a(0, 2) * a(2, 1) - a(0, 1) * a(2, 2)) * inv,
            (a(0, 1) * a(1, 2) - a(0, 2) * a(1, 1)) * inv,
        ],
        [
            c01 * inv,
            (a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0)) * inv,
            (a(0, 2) * a(1, 0) - a(0, 0) * a(1, 2)) * inv,
        ],
        [
            c02 * inv,
            (a(0, 1) * a(2, 0) - a(0, 0) * a(2, 1)) * inv,
            (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0)) * inv,
        ],
    ];
    let t = [a(0, 3), a(1, 3), a(2, 3)];
    let mut r = [0.0; 12];
    for row in 0..3 {
        for col in 0..3 {
            r[row * 4 + col] = l[row][col];
        }
        r[row * 4 + 3] = -(l[row][0] * t[0] + l[row][1] * t[1] + l[row][2] * t[2]);
    }
    Some(r)
}

/// `m · p` for a point.
pub fn m_point(m: &M34, p: V3) -> V3 {
    std::array::from_fn(|r| {
        m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3]
    })
}

/// `m · v` for a vector (no translation).
pub fn m_vector(m: &M34, v: V3) -> V3 {
    std::array::from_fn(|r| m[r * 4] * v[0] + m[r * 4 + 1] * v[1] + m[r * 4 + 2] * v[2])
}

/// Largest absolute row sum of the linear part (the ∞-norm).
pub fn m_norm(m: &M34) -> f64 {
    (0..3)
        .map(|r| m[r * 4].abs() + m[r * 4 + 1].abs() + m[r * 4 + 2].abs())
        .fold(0.0, f64::max)
}

/// Largest absolute translation component.
pub fn m_translation_norm(m: &M34) -> f64 {
    m[3].abs().max(m[7].abs()).max(m[11].abs())
}

/// The determinant of the linear part.
pub fn m_det(m: &M34) -> f64 {
    let a = |r: usize, c: usize| m[r * 4 + c];
    a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
        - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_round_trips() {
        let m: M34 = [0.0, -2.0, 0.5, 5.0, 2.0, 0.0, 0.0, -3.0, 0.0, 0.3, 0.5, 1.0];
        let inv = m_inverse(&m).unwrap();
        let p = [1.0, -2.0, 3.5];
        let q = m_point(&inv, m_point(&m, p));
        assert!(max_abs(sub(p, q)) < 1e-12);
        let id = m_mul(&m, &inv);
        for (a, b) in id.iter().zip(IDENTITY.iter()) {
            assert!((a - b).abs() < 1e-12);
        }
        assert!(m_inverse(&[0.0; 12]).is_none());
    }
}
