//! Which triangles can ever be hit (DESIGN.md §4): a triangle with a NaN or infinite vertex
//! never hits, nor does one of zero area. Backends leave such triangles out of their
//! structures at build time rather than trusting a floating-point test on the device to
//! reject them: a zero-area sliver along a shared edge rounds to a tiny non-zero area in f32
//! (more so where the shader compiler fuses multiply-adds) and would be hit a second time.

/// Whether every coordinate of the point is finite.
pub fn finite_point(p: &[f32; 3]) -> bool {
    p.iter().all(|v| v.is_finite())
}

/// Whether a triangle has zero area: its edge cross product is exactly zero in f64.
///
/// For vertices of similar magnitude the f32 differences and their products are exact in
/// f64, so the answer is exact; only coordinates many orders of magnitude apart round.
pub fn zero_area(t: &[[f32; 3]; 3]) -> bool {
    let e = |a: usize, k: usize| t[a][k] as f64 - t[0][k] as f64;
    let (e1, e2) = ([e(1, 0), e(1, 1), e(1, 2)], [e(2, 0), e(2, 1), e(2, 2)]);
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    n == [0.0; 3]
}

/// Whether a triangle can be hit in one motion key: finite vertices and a non-zero area.
pub fn triangle_hittable(t: &[[f32; 3]; 3]) -> bool {
    t.iter().all(finite_point) && !zero_area(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slivers_and_nan_triangles_are_not_hittable() {
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(triangle_hittable(&tri));
        // Collinear: a midpoint sliver along the diagonal, and a repeated vertex.
        assert!(!triangle_hittable(&[
            [-1.0, -1.0, 1.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0]
        ]));
        assert!(!triangle_hittable(&[
            [1.0, 2.0, 3.0],
            [1.0, 2.0, 3.0],
            [0.0, 1.0, 0.0]
        ]));
        // A thin but real triangle keeps its area.
        assert!(triangle_hittable(&[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1e-30, 0.0]
        ]));
        let mut nan = tri;
        nan[1][2] = f32::NAN;
        assert!(!triangle_hittable(&nan));
        nan[1][2] = f32::INFINITY;
        assert!(!triangle_hittable(&nan));
    }
}
