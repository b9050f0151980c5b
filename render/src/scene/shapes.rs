//! Mitsuba's built-in shapes as triangle meshes in their local space, and placing meshes in the
//! world.
//!
//! The tessellations follow Mitsuba 3's definitions: `rectangle` is [-1, 1]² at z = 0 facing +z
//! with uv = ((x + 1) / 2, (y + 1) / 2); `cube` is [-1, 1]³ with 24 vertices (flat faces, the same
//! corner order, normals and uvs as Mitsuba's cube mesh); `disk` is the unit disk at z = 0 facing
//! +z, with uv = (r, φ / 2π). Mitsuba's disk (and sphere) are analytic surfaces; here the disk is
//! a fan of [`DISK_SEGMENTS`] triangles, whose area is 0.3 % below π's.

use super::Mesh;
use glam::{Mat3, Mat4, Vec2, Vec3};

/// Triangles around a tessellated disk.
pub const DISK_SEGMENTS: u32 = 128;

/// Mitsuba's `rectangle`: two triangles over [-1, 1]² at z = 0, normal +z.
pub fn rectangle() -> Mesh {
    let p = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)];
    Mesh {
        positions: p.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect(),
        normals: vec![Vec3::Z; 4],
        uvs: p
            .iter()
            .map(|&(x, y)| Vec2::new((x + 1.0) / 2.0, (y + 1.0) / 2.0))
            .collect(),
        indices: vec![[1, 2, 0], [1, 3, 2]],
        ..Mesh::default()
    }
}

/// Mitsuba's `cube`: [-1, 1]³, four vertices per face so that each face is flat.
pub fn cube() -> Mesh {
    // Corner c has x = ±1 by bit 0, y by bit 1, z by bit 2.
    let corner = |c: u32| {
        Vec3::new(
            if c & 1 != 0 { 1.0 } else { -1.0 },
            if c & 2 != 0 { 1.0 } else { -1.0 },
            if c & 4 != 0 { 1.0 } else { -1.0 },
        )
    };
    const FACE_CORNERS: [[u32; 4]; 6] = [
        [1, 5, 4, 0],
        [3, 2, 6, 7],
        [1, 3, 7, 5],
        [5, 7, 6, 4],
        [4, 6, 2, 0],
        [3, 1, 0, 2],
    ];
    const FACE_NORMALS: [Vec3; 6] = [
        Vec3::NEG_Y,
        Vec3::Y,
        Vec3::X,
        Vec3::Z,
        Vec3::NEG_X,
        Vec3::NEG_Z,
    ];
    const CORNER_UV: [Vec2; 4] = [
        Vec2::new(0.0, 1.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(0.0, 0.0),
    ];
    let mut mesh = Mesh::default();
    for (s, corners) in FACE_CORNERS.iter().enumerate() {
        let v = 4 * s as u32;
        for (k, &c) in corners.iter().enumerate() {
            mesh.positions.push(corner(c));
            mesh.normals.push(FACE_NORMALS[s]);
            mesh.uvs.push(CORNER_UV[k]);
        }
        mesh.indices.push([v, v + 1, v + 2]);
        mesh.indices.push([v + 3, v, v + 2]);
    }
    mesh
}

/// Mitsuba's `disk`: the unit disk at z = 0 facing +z, as a fan of [`DISK_SEGMENTS`] triangles.
pub fn disk() -> Mesh {
    let n = DISK_SEGMENTS;
    let mut mesh = Mesh::default();
    // One centre vertex per segment, so that each carries its segment's φ in uv.
    for i in 0..n {
        let v = (i as f32 + 0.5) / n as f32;
        mesh.positions.push(Vec3::ZERO);
        mesh.normals.push(Vec3::Z);
        mesh.uvs.push(Vec2::new(0.0, v));
    }
    for i in 0..=n {
        let v = i as f32 / n as f32;
        let phi = std::f32::consts::TAU * v;
        mesh.positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
        mesh.normals.push(Vec3::Z);
        mesh.uvs.push(Vec2::new(1.0, v));
    }
    for i in 0..n {
        mesh.indices.push([i, n + i, n + i + 1]);
    }
    mesh
}

/// A unit sphere at the origin as a latitude-longitude mesh (for spheres under a non-uniform
/// scale, which optik's built-in sphere cannot express); uv as Mitsuba's sphere (φ / 2π, θ / π).
pub fn uv_sphere(rings: u32, segments: u32) -> Mesh {
    let mut mesh = Mesh::default();
    for r in 0..=rings {
        let v = r as f32 / rings as f32;
        let theta = std::f32::consts::PI * v;
        for s in 0..=segments {
            let u = s as f32 / segments as f32;
            let phi = std::f32::consts::TAU * u;
            let p = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            mesh.positions.push(p);
            mesh.normals.push(p);
            mesh.uvs.push(Vec2::new(u, v));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let a = r * row + s;
            let b = a + row;
            // Outward-facing (counter-clockwise seen from outside).
            if r > 0 {
                mesh.indices.push([a, b, a + 1]);
            }
            if r + 1 < rings {
                mesh.indices.push([a + 1, b, b + 1]);
            }
        }
    }
    mesh
}

/// Places a mesh: positions by `to_world`, normals by its inverse transpose (renormalised).
/// Triangle order is kept, as Mitsuba keeps it (a mirroring transform turns the geometric
/// normal, which follows the winding, around).
pub fn transform_mesh(mesh: &mut Mesh, to_world: &Mat4) {
    if *to_world == Mat4::IDENTITY {
        return;
    }
    for p in &mut mesh.positions {
        *p = to_world.transform_point3(*p);
    }
    let normal_matrix = Mat3::from_mat4(*to_world).inverse().transpose();
    for n in &mut mesh.normals {
        *n = (normal_matrix * *n).normalize_or_zero();
    }
}

/// The axis-aligned bounds of a set of points: (min, max).
pub fn bounds<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> (Vec3, Vec3) {
    points.into_iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn face_normal(m: &Mesh, t: [u32; 3]) -> Vec3 {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        (b - a).cross(c - a)
    }

    /// Every triangle's winding agrees with the authored normals (front side = normal side).
    fn winding_matches_normals(m: &Mesh) {
        for &t in &m.indices {
            let n = face_normal(m, t);
            let shading = m.normals[t[0] as usize];
            assert!(
                n.dot(shading) > 0.0,
                "triangle {t:?} winds against its normal"
            );
        }
    }

    #[test]
    fn rectangle_spans_the_unit_square_facing_z() {
        let r = rectangle();
        assert_eq!(r.indices.len(), 2);
        winding_matches_normals(&r);
        let (lo, hi) = bounds(&r.positions);
        assert_eq!(
            (lo, hi),
            (Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0))
        );
        let area: f32 = r
            .indices
            .iter()
            .map(|&t| face_normal(&r, t).length() / 2.0)
            .sum();
        assert!((area - 4.0).abs() < 1e-6);
        assert_eq!(r.uvs[3], Vec2::new(1.0, 1.0));
    }

    #[test]
    fn cube_has_six_flat_outward_faces() {
        let c = cube();
        assert_eq!((c.positions.len(), c.indices.len()), (24, 12));
        winding_matches_normals(&c);
        for (i, p) in c.positions.iter().enumerate() {
            // Every vertex lies on its face's plane, one unit out along the normal.
            assert_eq!(p.dot(c.normals[i]), 1.0);
        }
        let area: f32 = c
            .indices
            .iter()
            .map(|&t| face_normal(&c, t).length() / 2.0)
            .sum();
        assert!((area - 24.0).abs() < 1e-5);
    }

    #[test]
    fn disk_is_a_fine_fan_facing_z() {
        let d = disk();
        assert_eq!(d.indices.len() as u32, DISK_SEGMENTS);
        winding_matches_normals(&d);
        let area: f32 = d
            .indices
            .iter()
            .map(|&t| face_normal(&d, t).length() / 2.0)
            .sum();
        assert!(
            (area - std::f32::consts::PI).abs() / std::f32::consts::PI < 0.005,
            "area {area}"
        );
    }

    #[test]
    fn uv_sphere_faces_outwards() {
        let s = uv_sphere(16, 32);
        for &t in &s.indices {
            let centre = (s.positions[t[0] as usize]
                + s.positions[t[1] as usize]
                + s.positions[t[2] as usize])
                / 3.0;
            assert!(face_normal(&s, t).dot(centre) > 0.0);
        }
    }

    #[test]
    fn transform_moves_points_and_keeps_normals_perpendicular() {
        let mut r = rectangle();
        let m = Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0))
            * Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0))
            * Mat4::from_rotation_x(0.5);
        transform_mesh(&mut r, &m);
        let e = r.positions[1] - r.positions[0];
        assert!(e.dot(r.normals[0]).abs() < 1e-5);
        assert!((r.normals[0].length() - 1.0).abs() < 1e-6);
    }
}
