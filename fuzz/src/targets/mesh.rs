//! The mesh readers `optik trace` and the renderer use (`optik_io::mesh`, over tobj and
//! ply-rs-bw): OBJ text and PLY in ASCII and binary.

use super::file::with_file;
use crate::{Outcome, Target};

/// OBJ meshes.
pub const OBJ: Target = Target {
    name: "obj",
    seeds: obj_seeds,
    dictionary: &[
        b"v ", b"vt ", b"vn ", b"f ", b"/", b"-1", b"o ", b"g ", b"usemtl ", b"\n", b"1e30",
        b"nan", b"-0",
    ],
    run: run_obj,
};

/// PLY meshes.
pub const PLY: Target = Target {
    name: "ply",
    seeds: ply_seeds,
    dictionary: &[
        b"ply\n",
        b"format ascii 1.0\n",
        b"format binary_little_endian 1.0\n",
        b"format binary_big_endian 1.0\n",
        b"element vertex ",
        b"element face ",
        b"property float x\n",
        b"property list uchar int vertex_indices\n",
        b"property list float float vertex_indices\n",
        b"end_header\n",
        b"4294967295",
        b"1e30",
        b"-1",
    ],
    run: run_ply,
};

fn obj_seeds() -> Vec<Vec<u8>> {
    vec![
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nf 1/1/1 2/1/1 3/1/1\n".to_vec(),
        b"o quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n".to_vec(),
    ]
}

fn ply_seeds() -> Vec<Vec<u8>> {
    let ascii = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n".to_vec();
    let mut binary = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        binary.extend_from_slice(&v.to_le_bytes());
    }
    binary.push(3);
    for i in [0u32, 1, 2] {
        binary.extend_from_slice(&i.to_le_bytes());
    }
    vec![ascii, binary]
}

fn outcome(read: Option<Result<optik_io::mesh::MeshData, optik_io::IoError>>) -> Outcome {
    match read {
        Some(Ok(mesh)) => check(&mesh),
        _ => Outcome::Rejected,
    }
}

/// An accepted mesh must be usable: every index names a vertex, and the optional attributes
/// are absent or one per vertex.
fn check(mesh: &optik_io::mesh::MeshData) -> Outcome {
    let n = mesh.positions.len();
    if mesh.triangles.iter().flatten().any(|&i| i as usize >= n) {
        return Outcome::Finding("a triangle indexes past the vertices".into());
    }
    if !(mesh.normals.is_empty() || mesh.normals.len() == n)
        || !(mesh.uvs.is_empty() || mesh.uvs.len() == n)
    {
        return Outcome::Finding("normals or uvs do not match the vertices".into());
    }
    Outcome::Accepted
}

fn run_obj(data: &[u8]) -> Outcome {
    outcome(with_file("obj", data, optik_io::mesh::read_obj))
}

fn run_ply(data: &[u8]) -> Outcome {
    outcome(with_file("ply", data, optik_io::mesh::read_ply))
}
