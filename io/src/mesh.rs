//! Triangle meshes from Wavefront OBJ (`.obj`, `.obj.gz`, through `tobj`) and PLY (`.ply`,
//! ASCII and binary of either endianness, through `ply-rs-bw`), mapped to one [`MeshData`].
//!
//! Triangles are numbered in the order their faces appear in the file (all OBJ objects merged in
//! file order); polygons are fan-triangulated as (v0, vi, vi+1). Materials are not read here.

use crate::IoError;
use std::io::{BufRead, BufReader};
use std::path::Path;

/// A triangle mesh: positions, optional per-position normals and texture coordinates, and
/// triangles as indices into the positions.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// One normal per position, or empty when the file gives none (or not for every vertex).
    pub normals: Vec<[f32; 3]>,
    /// One texture coordinate per position, or empty when the file gives none (or not for every
    /// vertex).
    pub uvs: Vec<[f32; 2]>,
    /// Vertex indices per triangle, each below `positions.len()`.
    pub triangles: Vec<[u32; 3]>,
}

impl MeshData {
    /// The bounding box of the positions: (min, max); (+inf, -inf) for no positions.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }
}

/// Reads a mesh by its file name's extension: `.obj`, `.obj.gz` or `.ply` (any letter case).
/// A file with no triangles is an error: nothing could ever be hit.
pub fn read_mesh(path: &Path) -> Result<MeshData, IoError> {
    let lower = path.to_string_lossy().to_ascii_lowercase();
    if lower.ends_with(".obj") || lower.ends_with(".obj.gz") {
        read_obj(path)
    } else if lower.ends_with(".ply") {
        read_ply(path)
    } else {
        Err(IoError::new(
            path,
            "unknown mesh format; expected a file ending in .obj, .obj.gz or .ply",
        ))
    }
}

fn open(path: &Path) -> Result<BufReader<std::fs::File>, IoError> {
    std::fs::File::open(path)
        .map(BufReader::new)
        .map_err(|e| IoError::os(path, "cannot open the mesh", e))
}

fn no_triangles(path: &Path, mesh: MeshData) -> Result<MeshData, IoError> {
    if mesh.triangles.is_empty() {
        return Err(IoError::new(
            path,
            format!(
                "the mesh has no triangles ({} vertices, no faces of 3 or more vertices); expected at least one triangle",
                mesh.positions.len()
            ),
        ));
    }
    Ok(mesh)
}

/// Reads a Wavefront OBJ file (`.obj`, or gzip-compressed when the name ends in `.gz`), all
/// objects and groups merged in file order. Points and lines are left out; a face index of 0
/// or past the vertices read so far is an error.
pub fn read_obj(path: &Path) -> Result<MeshData, IoError> {
    let file = open(path)?;
    let gz = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gz"));
    let mut reader: Box<dyn BufRead> = if gz {
        Box::new(BufReader::new(flate2::bufread::GzDecoder::new(file)))
    } else {
        Box::new(file)
    };
    let mesh = parse_obj(&mut reader).map_err(|e| IoError::new(path, e))?;
    no_triangles(path, mesh)
}

/// Parses OBJ text into a mesh (errors without the file name).
fn parse_obj(reader: &mut dyn BufRead) -> Result<MeshData, String> {
    let mut text = Vec::new();
    reader
        .read_to_end(&mut text)
        .map_err(|e| format!("cannot read the OBJ text: {e}"))?;
    check_face_indices(&text)?;
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials are the renderer's business (it reads the .mtl itself); here none is loaded.
    let (models, _materials) = tobj::load_obj_buf(&mut std::io::Cursor::new(text), &options, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| format!("not a valid OBJ file: {e}; expected `v x y z` lines and `f i j k ...` faces with 1-based or negative indices of existing vertices"))?;
    let mut mesh = MeshData::default();
    let mut all_normals = true;
    let mut all_uvs = true;
    for model in &models {
        let m = &model.mesh;
        let base = u32::try_from(mesh.positions.len())
            .map_err(|_| "more than 2^32 vertices; expected fewer".to_string())?;
        let n = m.positions.len() / 3;
        mesh.positions
            .extend(m.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
        all_normals &= m.normals.len() == 3 * n;
        all_uvs &= m.texcoords.len() == 2 * n;
        if all_normals {
            mesh.normals
                .extend(m.normals.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
        }
        if all_uvs {
            mesh.uvs
                .extend(m.texcoords.chunks_exact(2).map(|p| [p[0], p[1]]));
        }
        for t in m.indices.chunks_exact(3) {
            let tri = [t[0], t[1], t[2]].map(|i| i.checked_add(base));
            let [Some(a), Some(b), Some(c)] = tri else {
                return Err("more than 2^32 vertices; expected fewer".into());
            };
            mesh.triangles.push([a, b, c]);
        }
    }
    if !all_normals {
        mesh.normals.clear();
    }
    if !all_uvs {
        mesh.uvs.clear();
    }
    Ok(mesh)
}

/// Refuses face indices past the file's own vertices, texture coordinates and normals before
/// tobj sees them: tobj checks vertex indices but multiplies texture-coordinate and normal
/// indices unchecked (overflow, then an out-of-bounds panic, on `f 1/99999999999999999999 ...`).
fn check_face_indices(text: &[u8]) -> Result<(), String> {
    let lines = || text.split(|&b| b == b'\n').map(|l| l.trim_ascii());
    let count = |tag: &[u8]| {
        lines()
            .filter(|l| l.starts_with(tag) && l.get(tag.len()).is_some_and(u8::is_ascii_whitespace))
            .count() as u64
    };
    let counts = [count(b"v"), count(b"vt"), count(b"vn")];
    const KINDS: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    for (n, line) in lines().enumerate() {
        let Some(rest) = line.strip_prefix(b"f") else {
            continue;
        };
        if !rest.first().is_some_and(u8::is_ascii_whitespace) {
            continue;
        }
        for corner in rest
            .split(u8::is_ascii_whitespace)
            .filter(|c| !c.is_empty())
        {
            for (k, index) in corner.split(|&b| b == b'/').enumerate().take(3) {
                let Some(i) = std::str::from_utf8(index)
                    .ok()
                    .and_then(|s| s.parse::<i128>().ok())
                else {
                    continue; // empty (`1//3`) or not a number: tobj reports those.
                };
                if i == 0 || i.unsigned_abs() > u128::from(counts[k]) {
                    return Err(format!(
                        "not a valid OBJ file: line {}: face index {i} names one of {} {}; expected 1 to {} or -1 to -{}",
                        n + 1,
                        counts[k],
                        KINDS[k],
                        counts[k],
                        counts[k]
                    ));
                }
            }
        }
    }
    Ok(())
}

mod ply;
pub use ply::read_ply;

#[cfg(test)]
mod tests;
