//! PLY through `ply-rs-bw`: the header and payload parsing is the crate's; this maps the
//! `vertex` and `face` elements to [`MeshData`] and rejects what would silently give wrong
//! geometry (a vertex without x, y or z; a face index that is negative, fractional or past the
//! vertices).

use super::{MeshData, no_triangles};
use crate::IoError;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Property, PropertyAccess, PropertyAccessResult, PropertyType};
use std::path::Path;

/// Names of the texture coordinate pair, in the order they are looked for.
const UV_NAMES: [(&str, &str); 4] = [
    ("u", "v"),
    ("s", "t"),
    ("texture_u", "texture_v"),
    ("texture_s", "texture_t"),
];

/// One `vertex` element: every coordinate it may carry.
#[derive(Default)]
struct Vertex {
    p: [f64; 3],
    n: [f64; 3],
    uv: [f64; 2],
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v.into(),
        Property::UChar(v) => v.into(),
        Property::Short(v) => v.into(),
        Property::UShort(v) => v.into(),
        Property::Int(v) => v.into(),
        Property::UInt(v) => v.into(),
        Property::Float(v) => v.into(),
        Property::Double(v) => v,
        _ => return None,
    })
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let Some(v) = scalar(&property) else {
            return PropertyAccessResult::Ignored;
        };
        let slot = match name {
            "x" => &mut self.p[0],
            "y" => &mut self.p[1],
            "z" => &mut self.p[2],
            "nx" => &mut self.n[0],
            "ny" => &mut self.n[1],
            "nz" => &mut self.n[2],
            "u" | "s" | "texture_u" | "texture_s" => &mut self.uv[0],
            "v" | "t" | "texture_v" | "texture_t" => &mut self.uv[1],
            _ => return PropertyAccessResult::Ignored,
        };
        *slot = v;
        PropertyAccessResult::Set
    }
}

/// One `face` element: its vertex indices as read, checked later against the vertex count.
#[derive(Default)]
struct Face {
    indices: Vec<f64>,
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if name != "vertex_indices" && name != "vertex_index" {
            return PropertyAccessResult::Ignored;
        }
        // Every index type widens to f64 exactly (32-bit integers at most); fractional and
        // negative values are rejected when the face is mapped.
        self.indices = match property {
            Property::ListChar(l) => l.into_iter().map(f64::from).collect(),
            Property::ListUChar(l) => l.into_iter().map(f64::from).collect(),
            Property::ListShort(l) => l.into_iter().map(f64::from).collect(),
            Property::ListUShort(l) => l.into_iter().map(f64::from).collect(),
            Property::ListInt(l) => l.into_iter().map(f64::from).collect(),
            Property::ListUInt(l) => l.into_iter().map(f64::from).collect(),
            Property::ListFloat(l) => l.into_iter().map(f64::from).collect(),
            Property::ListDouble(l) => l,
            _ => return PropertyAccessResult::UnsupportedType,
        };
        PropertyAccessResult::Set
    }
}

/// Any other element: read past, nothing kept.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

fn has(e: &ElementDef, name: &str) -> bool {
    e.properties.contains_key(name)
}

/// Reads a PLY file: ASCII, binary little-endian or binary big-endian. The `vertex` element
/// needs `x`, `y` and `z`; `nx`/`ny`/`nz` and `u`/`v` (or `s`/`t`, `texture_u`/`texture_v`)
/// are kept when present. Faces (`vertex_indices` or `vertex_index`) with more than 3 vertices
/// are fan-triangulated.
pub fn read_ply(path: &Path) -> Result<MeshData, IoError> {
    let file_len = std::fs::metadata(path)
        .map_err(|e| IoError::os(path, "cannot open the mesh", e))?
        .len();
    let mut reader = Reader::new(super::open(path)?);
    let bad = |what: String| IoError::new(path, what);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| bad(format!("not a valid PLY header: {e}")))?;

    // Every element with properties takes at least one byte of the file, so a count past the
    // file's size is a lie; refusing it here keeps the claim from driving any work.
    for e in header.elements.values() {
        if e.count as u64 > file_len {
            return Err(bad(format!(
                "the header claims {} `{}` elements but the file has only {file_len} bytes",
                e.count, e.name
            )));
        }
        if e.count > 0 && e.properties.is_empty() {
            return Err(bad(format!(
                "element `{}` has {} entries but no properties; expected properties for each",
                e.name, e.count
            )));
        }
    }
    let vertex_def = header.elements.get("vertex");
    if let Some(v) = vertex_def {
        let missing: Vec<&str> = ["x", "y", "z"].into_iter().filter(|n| !has(v, n)).collect();
        if !missing.is_empty() {
            return Err(bad(format!(
                "the vertex element has no {} property; expected x, y and z",
                missing.join(", ")
            )));
        }
    }
    if let Some(f) = header.elements.get("face") {
        let list = ["vertex_indices", "vertex_index"]
            .into_iter()
            .find_map(|n| f.properties.get(n));
        match list {
            Some(p) if matches!(p.data_type, PropertyType::List(..)) => {}
            _ => {
                return Err(bad(
                    "the face element has no vertex_indices (or vertex_index) list; expected `property list uchar int vertex_indices`".into(),
                ));
            }
        }
    }

    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for e in header.elements.values() {
        let failed =
            |err: ply_rs_bw::parser::ParseError| bad(format!("the `{}` data: {err}", e.name));
        match e.name.as_str() {
            "vertex" => {
                vertices = Parser::<Vertex>::new()
                    .read_payload_for_element(&mut reader, e, &header)
                    .map_err(failed)?;
            }
            "face" => {
                faces = Parser::<Face>::new()
                    .read_payload_for_element(&mut reader, e, &header)
                    .map_err(failed)?;
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, e, &header)
                    .map_err(failed)?;
            }
        }
    }

    let mut mesh = MeshData {
        positions: vertices.iter().map(|v| v.p.map(|c| c as f32)).collect(),
        ..MeshData::default()
    };
    if let Some(v) = vertex_def {
        if ["nx", "ny", "nz"].iter().all(|n| has(v, n)) {
            mesh.normals = vertices.iter().map(|v| v.n.map(|c| c as f32)).collect();
        }
        if UV_NAMES.iter().any(|(a, b)| has(v, a) && has(v, b)) {
            mesh.uvs = vertices.iter().map(|v| v.uv.map(|c| c as f32)).collect();
        }
    }
    let count = vertices.len();
    for (k, face) in faces.iter().enumerate() {
        if face.indices.len() < 3 {
            return Err(bad(format!(
                "face {k} has {} vertices; expected at least 3",
                face.indices.len()
            )));
        }
        let mut ids = Vec::with_capacity(face.indices.len());
        for &i in &face.indices {
            if i.fract() != 0.0 || i < 0.0 || i >= count as f64 {
                // Fractions come from float lists: shown at their own (f32) precision.
                let shown = if i.fract() == 0.0 {
                    format!("{}", i as i64)
                } else {
                    format!("{}", i as f32)
                };
                return Err(bad(format!(
                    "face {k} uses vertex index {shown}; expected a whole number from 0 to {} (the file has {count} vertices)",
                    count as i64 - 1
                )));
            }
            // In range of `count`, itself from a Vec: fits u32 once checked below.
            ids.push(i as u64);
        }
        let ids: Vec<u32> = ids
            .into_iter()
            .map(u32::try_from)
            .collect::<Result<_, _>>()
            .map_err(|_| bad("more than 2^32 vertices; expected fewer".into()))?;
        for j in 1..ids.len() - 1 {
            mesh.triangles.push([ids[0], ids[j], ids[j + 1]]);
        }
    }
    no_triangles(path, mesh)
}
