//! Closed test meshes shared by the conformance suite, the benchmarks and the backends' tests,
//! so that a watertightness result on one means the same mesh on the others.

use std::collections::HashMap;

/// A closed unit icosphere at the origin: an icosahedron subdivided `subdivisions` times
/// (20 · 4^subdivisions triangles), every new vertex pushed out to the sphere as it is made
/// (in f64, rounded to f32 once at the end). Vertices are shared between faces, so every edge
/// is shared exactly; triangles are counter-clockwise seen from outside (the front).
pub fn icosphere(subdivisions: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let corners: [[f64; 3]; 12] = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let unit = |p: [f64; 3]| {
        let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        p.map(|c| c / len)
    };
    let mut positions: Vec<[f64; 3]> = corners.into_iter().map(unit).collect();
    for _ in 0..subdivisions {
        let mut midpoints = HashMap::new();
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let mut mid = |x: u32, y: u32| -> u32 {
                *midpoints.entry((x.min(y), x.max(y))).or_insert_with(|| {
                    let (p, q) = (positions[x as usize], positions[y as usize]);
                    positions.push(unit(std::array::from_fn(|k| (p[k] + q[k]) / 2.0)));
                    (positions.len() - 1) as u32
                })
            };
            let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    let vertices = positions.iter().map(|p| p.map(|c| c as f32)).collect();
    (vertices, triangles)
}

/// Rays from `inside` aimed exactly at every vertex and at the midpoint of every edge of a
/// mesh (8 floats each: origin, tmin 0, direction, tmax ∞; directions not normalised, so the
/// aimed point is at t = 1): the hardest rays for a closed mesh's watertightness, which no
/// watertight test lets out. Targets equal to `inside` are skipped.
pub fn rays_at_vertices_and_edges(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    inside: [f32; 3],
) -> Vec<f32> {
    let mut targets: Vec<[f32; 3]> = positions.to_vec();
    for t in triangles {
        for e in 0..3 {
            let a = positions[t[e] as usize];
            let b = positions[t[(e + 1) % 3] as usize];
            targets.push(std::array::from_fn(|k| 0.5 * (a[k] + b[k])));
        }
    }
    let mut rays = Vec::with_capacity(targets.len() * 8);
    for p in targets {
        let d: [f32; 3] = std::array::from_fn(|k| p[k] - inside[k]);
        if d.iter().any(|c| *c != 0.0) {
            rays.extend_from_slice(&[
                inside[0],
                inside[1],
                inside[2],
                0.0,
                d[0],
                d[1],
                d[2],
                f32::INFINITY,
            ]);
        }
    }
    rays
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_is_closed_and_on_the_unit_sphere() {
        for level in 0..4 {
            let (v, t) = icosphere(level);
            assert_eq!(t.len(), 20 * 4usize.pow(level));
            // Euler: V - E + F = 2 with E = 3F/2.
            assert_eq!(v.len() + t.len() - 3 * t.len() / 2, 2);
            let mut edges = HashMap::new();
            for tri in &t {
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                }
            }
            assert!(
                edges.values().all(|&n| n == 2),
                "every edge shared by two faces"
            );
            for p in &v {
                let r = (p.iter().map(|c| (*c as f64).powi(2)).sum::<f64>()).sqrt();
                assert!((r - 1.0).abs() < 1e-6);
            }
        }
    }
}
