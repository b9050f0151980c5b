//! The benchmarks' meshes: files read by `optik_io::mesh` (the reader `optik trace` and the
//! renderer use), and generated test shapes.

use optik::{Error, Result};
use std::path::Path;

/// A triangle mesh (optik-io's mesh type).
pub use optik_io::mesh::MeshData as Mesh;

/// Loads a mesh by extension: `.obj`, `.obj.gz` or `.ply`.
pub fn load(path: &Path) -> Result<Mesh> {
    optik_io::mesh::read_mesh(path).map_err(|e| Error::invalid(e.to_string()))
}

/// Generated meshes and transforms for benchmarks and robustness checks.
pub trait BenchMesh: Sized {
    /// A closed unit icosphere (`optik::shapes::icosphere`: an icosahedron subdivided
    /// `subdivisions` times, edges shared exactly, counter-clockwise seen from outside).
    fn icosphere(subdivisions: u32) -> Self;
    /// The mesh scaled by `scale` and then moved by `offset`, rounded to f32.
    fn transformed(&self, scale: f64, offset: [f64; 3]) -> Self;
}

impl BenchMesh for Mesh {
    fn icosphere(subdivisions: u32) -> Mesh {
        let (positions, triangles) = optik::shapes::icosphere(subdivisions);
        Mesh {
            positions,
            triangles,
            ..Mesh::default()
        }
    }

    fn transformed(&self, scale: f64, offset: [f64; 3]) -> Mesh {
        Mesh {
            positions: self
                .positions
                .iter()
                .map(|p| std::array::from_fn(|k| (p[k] as f64 * scale + offset[k]) as f32))
                .collect(),
            ..self.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transformed_moves_positions_and_keeps_triangles() {
        let m = Mesh::icosphere(0);
        let t = m.transformed(2.0, [1.0, 0.0, 0.0]);
        assert_eq!(t.triangles, m.triangles);
        assert_eq!(t.positions[0][0], m.positions[0][0] * 2.0 + 1.0);
    }
}
