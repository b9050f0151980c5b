//! Triangle meshes from `.obj`, `.obj.gz` and `.ply` files.
//!
//! Triangles are numbered in the order their faces appear in the file; polygons are
//! fan-triangulated as (v0, vi, vi+1). Materials, normals and texture coordinates are ignored:
//! ray casting needs positions.

use optik::{Error, Result};
use std::io::Read;
use std::path::Path;

/// Positions and triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Vertex indices per triangle.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The bounding box: (min, max).
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

/// Loads a mesh by extension: `.obj`, `.obj.gz` or `.ply`.
pub fn load(path: &Path) -> Result<Mesh> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::from(e).context(&name))?;
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(".obj.gz") {
        let mut text = String::new();
        flate2::read::GzDecoder::new(&bytes[..])
            .read_to_string(&mut text)
            .map_err(|e| Error::invalid(format!("{name}: not a gzip-compressed text file: {e}")))?;
        parse_obj(&text, &name)
    } else if lower.ends_with(".obj") {
        let text = String::from_utf8_lossy(&bytes);
        parse_obj(&text, &name)
    } else if lower.ends_with(".ply") {
        parse_ply(&bytes, &name)
    } else {
        Err(Error::invalid(format!(
            "{name}: unknown mesh format; expected .obj, .obj.gz or .ply"
        )))
    }
}

/// Parses Wavefront OBJ text.
pub fn parse_obj(text: &str, name: &str) -> Result<Mesh> {
    let mut mesh = Mesh::default();
    let mut face: Vec<u32> = Vec::new();
    for (lineno, line) in text.lines().enumerate() {
        let at = || format!("{name}:{}", lineno + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut p = [0f32; 3];
                for c in &mut p {
                    *c = words.next().and_then(|w| w.parse().ok()).ok_or_else(|| {
                        Error::invalid(format!("{}: a vertex needs three numbers: {line:?}", at()))
                    })?;
                }
                mesh.positions.push(p);
            }
            Some("f") => {
                face.clear();
                for w in words {
                    let first = w.split('/').next().unwrap_or("");
                    let i: i64 = first
                        .parse()
                        .map_err(|_| Error::invalid(format!("{}: bad face index {w:?}", at())))?;
                    let n = mesh.positions.len() as i64;
                    let idx = if i > 0 { i - 1 } else { n + i };
                    if i == 0 || idx < 0 || idx >= n {
                        return Err(Error::invalid(format!(
                            "{}: face index {i} refers to no vertex ({n} defined so far)",
                            at()
                        )));
                    }
                    face.push(idx as u32);
                }
                if face.len() < 3 {
                    return Err(Error::invalid(format!(
                        "{}: a face needs at least 3 vertices",
                        at()
                    )));
                }
                for k in 1..face.len() - 1 {
                    mesh.triangles.push([face[0], face[k], face[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok(mesh)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum PlyType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl PlyType {
    fn parse(s: &str) -> Option<PlyType> {
        Some(match s {
            "char" | "int8" => PlyType::I8,
            "uchar" | "uint8" => PlyType::U8,
            "short" | "int16" => PlyType::I16,
            "ushort" | "uint16" => PlyType::U16,
            "int" | "int32" => PlyType::I32,
            "uint" | "uint32" => PlyType::U32,
            "float" | "float32" => PlyType::F32,
            "double" | "float64" => PlyType::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            PlyType::I8 | PlyType::U8 => 1,
            PlyType::I16 | PlyType::U16 => 2,
            PlyType::I32 | PlyType::U32 | PlyType::F32 => 4,
            PlyType::F64 => 8,
        }
    }
}

enum PlyProperty {
    Scalar(String, PlyType),
    List(String, PlyType, PlyType),
}

struct PlyElement {
    name: String,
    count: usize,
    properties: Vec<PlyProperty>,
}

/// Reads values of a PLY body, ASCII or binary.
enum PlyReader<'a> {
    Ascii(std::str::SplitAsciiWhitespace<'a>),
    Binary {
        data: &'a [u8],
        pos: usize,
        big_endian: bool,
    },
}

impl PlyReader<'_> {
    fn read(&mut self, t: PlyType, name: &str) -> Result<f64> {
        match self {
            PlyReader::Ascii(words) => {
                words
                    .next()
                    .and_then(|w| w.parse::<f64>().ok())
                    .ok_or_else(|| {
                        Error::invalid(format!(
                            "{name}: the PLY body ends early or holds a non-number"
                        ))
                    })
            }
            PlyReader::Binary {
                data,
                pos,
                big_endian,
            } => {
                let n = t.size();
                let b = data
                    .get(*pos..*pos + n)
                    .ok_or_else(|| Error::invalid(format!("{name}: the PLY body ends early")))?;
                *pos += n;
                let mut a = [0u8; 8];
                a[..n].copy_from_slice(b);
                if *big_endian {
                    a[..n].reverse();
                }
                Ok(match t {
                    PlyType::I8 => a[0] as i8 as f64,
                    PlyType::U8 => a[0] as f64,
                    PlyType::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
                    PlyType::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
                    PlyType::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    PlyType::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    PlyType::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    PlyType::F64 => f64::from_le_bytes(a),
                })
            }
        }
    }
}

/// Parses a PLY file (ASCII, binary little- or big-endian).
pub fn parse_ply(bytes: &[u8], name: &str) -> Result<Mesh> {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n" || w == b"end_header\r")
        .ok_or_else(|| Error::invalid(format!("{name}: not a PLY file (no end_header line)")))?;
    let header = std::str::from_utf8(&bytes[..end])
        .map_err(|_| Error::invalid(format!("{name}: PLY header is not text")))?;
    let mut body_start = end + 11;
    if bytes.get(end + 10) == Some(&b'\r') && bytes.get(body_start) == Some(&b'\n') {
        body_start += 1;
    }
    let mut lines = header.lines();
    if lines.next().map(str::trim) != Some("ply") {
        return Err(Error::invalid(format!(
            "{name}: not a PLY file (first line is not `ply`)"
        )));
    }
    let mut format = "";
    let mut elements: Vec<PlyElement> = Vec::new();
    for line in lines {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, _] => format = f,
            ["element", n, c] => elements.push(PlyElement {
                name: n.to_string(),
                count: c.parse().map_err(|_| {
                    Error::invalid(format!("{name}: bad element count in {line:?}"))
                })?,
                properties: Vec::new(),
            }),
            ["property", "list", ct, it, n] => {
                let (Some(ct), Some(it)) = (PlyType::parse(ct), PlyType::parse(it)) else {
                    return Err(Error::invalid(format!(
                        "{name}: unknown PLY type in {line:?}"
                    )));
                };
                let e = elements
                    .last_mut()
                    .ok_or_else(|| Error::invalid(format!("{name}: property before element")))?;
                e.properties.push(PlyProperty::List(n.to_string(), ct, it));
            }
            ["property", t, n] => {
                let t = PlyType::parse(t).ok_or_else(|| {
                    Error::invalid(format!("{name}: unknown PLY type in {line:?}"))
                })?;
                let e = elements
                    .last_mut()
                    .ok_or_else(|| Error::invalid(format!("{name}: property before element")))?;
                e.properties.push(PlyProperty::Scalar(n.to_string(), t));
            }
            _ => {}
        }
    }
    let body = &bytes[body_start..];
    let mut reader = match format {
        "ascii" => PlyReader::Ascii(
            std::str::from_utf8(body)
                .map_err(|_| Error::invalid(format!("{name}: ASCII PLY body is not text")))?
                .split_ascii_whitespace(),
        ),
        "binary_little_endian" => PlyReader::Binary {
            data: body,
            pos: 0,
            big_endian: false,
        },
        "binary_big_endian" => PlyReader::Binary {
            data: body,
            pos: 0,
            big_endian: true,
        },
        f => {
            return Err(Error::invalid(format!(
                "{name}: PLY format {f:?} is not ascii or binary"
            )));
        }
    };
    let mut mesh = Mesh::default();
    for e in &elements {
        for _ in 0..e.count {
            let mut p = [0f32; 3];
            for prop in &e.properties {
                match prop {
                    PlyProperty::Scalar(n, t) => {
                        let v = reader.read(*t, name)?;
                        if e.name == "vertex" {
                            match n.as_str() {
                                "x" => p[0] = v as f32,
                                "y" => p[1] = v as f32,
                                "z" => p[2] = v as f32,
                                _ => {}
                            }
                        }
                    }
                    PlyProperty::List(n, ct, it) => {
                        let count = reader.read(*ct, name)? as usize;
                        let mut face = Vec::with_capacity(count);
                        for _ in 0..count {
                            face.push(reader.read(*it, name)?);
                        }
                        if e.name == "face" && (n == "vertex_indices" || n == "vertex_index") {
                            if count < 3 {
                                return Err(Error::invalid(format!(
                                    "{name}: a face has {count} vertices; at least 3 are needed"
                                )));
                            }
                            for k in 1..count - 1 {
                                mesh.triangles.push([
                                    face[0] as u32,
                                    face[k] as u32,
                                    face[k + 1] as u32,
                                ]);
                            }
                        }
                    }
                }
            }
            if e.name == "vertex" {
                mesh.positions.push(p);
            }
        }
    }
    let n = mesh.positions.len() as u32;
    if let Some((i, t)) = mesh
        .triangles
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&v| v >= n))
    {
        return Err(Error::invalid(format!(
            "{name}: triangle {i} uses vertex {t:?} but the file has {n} vertices"
        )));
    }
    Ok(mesh)
}

impl Mesh {
    /// A closed unit icosphere (`optik::shapes::icosphere`: an icosahedron subdivided
    /// `subdivisions` times, edges shared exactly, counter-clockwise seen from outside).
    pub fn icosphere(subdivisions: u32) -> Mesh {
        let (positions, triangles) = optik::shapes::icosphere(subdivisions);
        Mesh {
            positions,
            triangles,
        }
    }

    /// The mesh scaled by `scale` and then moved by `offset`, rounded to f32.
    pub fn transformed(&self, scale: f64, offset: [f64; 3]) -> Mesh {
        Mesh {
            positions: self
                .positions
                .iter()
                .map(|p| std::array::from_fn(|k| (p[k] as f64 * scale + offset[k]) as f32))
                .collect(),
            triangles: self.triangles.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_fans_polygons_in_file_order() {
        let m = parse_obj(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf -4/1/1 -2//3 -1\n",
            "t.obj",
        )
        .unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
        let e = parse_obj("v 0 0 0\nf 1 2 3\n", "t.obj").unwrap_err();
        assert!(
            e.message()
                .starts_with("t.obj:2: face index 2 refers to no vertex"),
            "{e}"
        );
    }

    #[test]
    fn ply_ascii_and_binary() {
        let ascii = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
        let m = parse_ply(ascii, "a.ply").unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
        for v in [[0.0f64, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.5]] {
            for c in v {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        bin.push(3);
        for i in [0u32, 1, 2] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let m = parse_ply(&bin, "b.ply").unwrap();
        assert_eq!(m.positions[2], [0.0, 2.0, 0.5]);
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        bin.truncate(bin.len() - 2);
        assert!(
            parse_ply(&bin, "b.ply")
                .unwrap_err()
                .message()
                .contains("ends early")
        );
    }
}
