//! Ray sets for benchmarks and robustness checks, deterministic for a seed.
//!
//! Each ray is `RAY_FLOATS` floats: origin xyz, tmin, direction xyz, tmax.

use crate::mesh::Mesh;

/// A small deterministic generator (xorshift64*), so ray sets are reproducible everywhere.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (v >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> [f32; 3] {
        let z = 1.0 - 2.0 * self.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * self.next_f32();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

fn push(rays: &mut Vec<f32>, o: [f32; 3], d: [f32; 3], tmin: f32, tmax: f32) {
    rays.extend_from_slice(&[o[0], o[1], o[2], tmin, d[0], d[1], d[2], tmax]);
}

/// Pinhole camera rays, `width × height`, looking at the mesh's bounding box from outside it
/// along `view` (a direction), framing the whole box.
pub fn camera(mesh: &Mesh, width: u32, height: u32, view: [f32; 3]) -> Vec<f32> {
    let (lo, hi) = mesh.bounds();
    let center: [f32; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let radius = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f32>().sqrt() * 0.5;
    let w = normalize(view);
    let up = if w[1].abs() > 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let fov_tan = 0.5f32;
    let dist = radius / fov_tan * 1.1;
    let eye: [f32; 3] = std::array::from_fn(|k| center[k] - w[k] * dist);
    let aspect = width as f32 / height as f32;
    camera_at(eye, w, up, 2.0 * (fov_tan * aspect).atan(), width, height)
}

/// Pinhole camera rays, `width × height`, from `eye` along `view` with `up` roughly up, over
/// `horizontal_fov` radians across the width (a scene's own camera, e.g. one inside a room).
pub fn camera_at(
    eye: [f32; 3],
    view: [f32; 3],
    up: [f32; 3],
    horizontal_fov: f32,
    width: u32,
    height: u32,
) -> Vec<f32> {
    let w = normalize(view);
    let u = normalize(cross(w, up));
    let v = cross(u, w);
    let half_x = (0.5 * horizontal_fov).tan();
    let half_y = half_x * height as f32 / width as f32;
    let mut rays = Vec::with_capacity((width * height) as usize * 8);
    for y in 0..height {
        for x in 0..width {
            let sx = ((x as f32 + 0.5) / width as f32 * 2.0 - 1.0) * half_x;
            let sy = (1.0 - (y as f32 + 0.5) / height as f32 * 2.0) * half_y;
            let d = normalize(std::array::from_fn(|k| w[k] + sx * u[k] + sy * v[k]));
            push(&mut rays, eye, d, 0.0, f32::INFINITY);
        }
    }
    rays
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f32; 3]) -> [f32; 3] {
    let l = a.iter().map(|v| v * v).sum::<f32>().sqrt();
    a.map(|v| v / l)
}

/// Incoherent rays: origins uniform in the mesh's bounding box, directions uniform on the sphere.
pub fn incoherent(mesh: &Mesh, count: usize, seed: u64) -> Vec<f32> {
    let (lo, hi) = mesh.bounds();
    let mut rng = Rng::new(seed);
    let mut rays = Vec::with_capacity(count * 8);
    for _ in 0..count {
        let o: [f32; 3] = std::array::from_fn(|k| lo[k] + (hi[k] - lo[k]) * rng.next_f32());
        push(&mut rays, o, rng.unit_vector(), 0.0, f32::INFINITY);
    }
    rays
}

/// Rays from `inside` aimed exactly at every vertex and at the midpoint of every edge of the
/// mesh: the hardest rays for a closed mesh's watertightness
/// (`optik::shapes::rays_at_vertices_and_edges`).
pub fn aimed_at_vertices_and_edges(mesh: &Mesh, inside: [f32; 3]) -> Vec<f32> {
    optik::shapes::rays_at_vertices_and_edges(&mesh.positions, &mesh.triangles, inside)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_well_formed() {
        let m = Mesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 1.0]],
            triangles: vec![[0, 1, 2]],
            ..Mesh::default()
        };
        assert_eq!(incoherent(&m, 10, 7), incoherent(&m, 10, 7));
        assert_ne!(incoherent(&m, 10, 7), incoherent(&m, 10, 8));
        let cam = camera(&m, 4, 3, [0.0, 0.0, -1.0]);
        assert_eq!(cam.len(), 4 * 3 * 8);
        for r in cam.chunks_exact(8) {
            let len: f32 = r[4..7].iter().map(|v| v * v).sum::<f32>().sqrt();
            assert!((len - 1.0).abs() < 1e-5);
        }
        // A 90° camera along -z: the corner rays lean out by 45° across the width.
        let at = camera_at(
            [1.0, 2.0, 3.0],
            [0.0, 0.0, -2.0],
            [0.0, 1.0, 0.0],
            90f32.to_radians(),
            2,
            2,
        );
        let first = &at[..8];
        assert_eq!(first[..4], [1.0, 2.0, 3.0, 0.0]);
        assert!(
            first[4] < 0.0 && first[5] > 0.0 && first[6] < 0.0,
            "{first:?}"
        );
        assert!((first[4] / first[6] - 0.5).abs() < 1e-6, "{first:?}");
        let aimed = aimed_at_vertices_and_edges(&m, [0.2, 0.2, 0.2]);
        assert_eq!(aimed.len(), (3 + 3) * 8);
        let mut rng = Rng::new(1);
        for _ in 0..1000 {
            let x = rng.next_f32();
            assert!((0.0..1.0).contains(&x));
        }
    }
}
