//! The course's scenes: two boxes built in code (ex04–ex06), and OBJ models (ex07 on), either a
//! file or a Cornell box generated here so that the examples run without any download.

use crate::common::Result;
use std::path::Path;

/// A triangle mesh with its per-mesh data (the course's `TriangleMesh`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Shading normals, one per vertex, or empty.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates, one per vertex, or empty.
    pub texcoords: Vec<[f32; 2]>,
    /// Triangles as vertex indices.
    pub indices: Vec<[u32; 3]>,
    /// Diffuse colour (MTL `Kd`).
    pub diffuse: [f32; 3],
    /// Index of the diffuse texture in [`Model::textures`], if any (MTL `map_Kd`).
    pub texture: Option<u32>,
    /// The material's index in the OBJ's material list (`u32::MAX` without one).
    pub material_id: u32,
}

impl TriangleMesh {
    /// Adds an axis-aligned box of the given centre and size (the course's `addCube`): eight
    /// corners, twelve triangles.
    pub fn add_cube(&mut self, center: [f32; 3], size: [f32; 3]) {
        let first = self.positions.len() as u32;
        for corner in 0..8u32 {
            let p: [f32; 3] = std::array::from_fn(|axis| {
                let bit = ((corner >> axis) & 1) as f32;
                center[axis] + (bit - 0.5) * size[axis]
            });
            self.positions.push(p);
        }
        // The course's unit cube indices (corner bits x=1, y=2, z=4).
        const FACES: [[u32; 3]; 12] = [
            [0, 1, 3],
            [2, 3, 0],
            [5, 7, 6],
            [5, 6, 4],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [1, 5, 7],
            [1, 7, 3],
            [4, 0, 2],
            [4, 2, 6],
        ];
        self.indices
            .extend(FACES.iter().map(|f| f.map(|i| first + i)));
    }
}

/// The course's first scene: a flat floor box and a cube on the origin.
pub fn two_boxes() -> (TriangleMesh, TriangleMesh) {
    let mut floor = TriangleMesh {
        diffuse: [0.0, 1.0, 0.0],
        ..Default::default()
    };
    floor.add_cube([0.0, -1.5, 0.0], [10.0, 0.1, 10.0]);
    let mut cube = TriangleMesh {
        diffuse: [0.0, 1.0, 1.0],
        ..Default::default()
    };
    cube.add_cube([0.0, 0.0, 0.0], [2.0, 2.0, 2.0]);
    (floor, cube)
}

/// The two-box scene's camera: from (-10, 2, -12) at the origin, +y up.
pub const TWO_BOXES_CAMERA: ([f32; 3], [f32; 3], [f32; 3]) =
    ([-10.0, 2.0, -12.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]);

/// An RGBA8 texture (rows top to bottom), as the course loads them with `stb_image`.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureImage {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width × height` RGBA texels.
    pub rgba: Vec<[u8; 4]>,
}

/// An OBJ model: one mesh per (shape, material), its textures and bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The meshes.
    pub meshes: Vec<TriangleMesh>,
    /// Decoded `map_Kd` textures.
    pub textures: Vec<TextureImage>,
    /// Lower corner of the bounding box.
    pub min: [f32; 3],
    /// Upper corner of the bounding box.
    pub max: [f32; 3],
}

/// Where to look from and which lights to use for a model, derived from its bounds so that
/// any model the user gives is framed (the course hard-codes Sponza's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Framing {
    /// The camera (from, at, up).
    pub camera: ([f32; 3], [f32; 3], [f32; 3]),
    /// ex09's point light.
    pub point_light: [f32; 3],
    /// ex10's quad light: corner, first edge, second edge.
    pub quad_light: ([f32; 3], [f32; 3], [f32; 3]),
    /// ex10's light power (the course's `power`), scaled with the model.
    pub light_power: [f32; 3],
}

impl Model {
    /// A camera in front of the model's +z side looking at its centre, a point light below its
    /// top and a quad light a third of its width across just under its top.
    pub fn framing(&self) -> Framing {
        let c: [f32; 3] = std::array::from_fn(|i| 0.5 * (self.min[i] + self.max[i]));
        let s: [f32; 3] = std::array::from_fn(|i| (self.max[i] - self.min[i]).max(1e-6));
        let from = [c[0], c[1], self.max[2] + 1.55 * s[1].max(s[0])];
        let top = self.max[1] - 0.03 * s[1];
        let scale = (0.5 * s[1]) * (0.5 * s[1]);
        Framing {
            camera: (from, c, [0.0, 1.0, 0.0]),
            point_light: [c[0], self.max[1] - 0.1 * s[1], c[2]],
            quad_light: (
                [c[0] - s[0] / 6.0, top, c[2] - s[2] / 6.0],
                [s[0] / 3.0, 0.0, 0.0],
                [0.0, 0.0, s[2] / 3.0],
            ),
            light_power: [3.0 * scale, 3.0 * scale, 3.0 * scale],
        }
    }
}

/// Loads the model of `path`, or generates the Cornell box when `path` is `None`.
pub fn load_model(path: Option<&Path>) -> Result<Model> {
    match path {
        Some(p) => load_obj_file(p),
        None => generated_cornell_box(),
    }
}

fn load_options() -> tobj::LoadOptions {
    // One index per vertex (positions, normals and texcoords aligned) and triangles only, as
    // the course's loader produces.
    tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    }
}

/// Loads an OBJ file and its MTL; `map_Kd` textures must be 8-bit PNG files.
pub fn load_obj_file(path: &Path) -> Result<Model> {
    let (models, materials) = tobj::load_obj(path, &load_options())
        .map_err(|e| format!("cannot load {}: {e}", path.display()))?;
    let materials = materials.map_err(|e| {
        format!(
            "cannot load the materials of {}: {e} (an OBJ needs its MTL file beside it)",
            path.display()
        )
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    build_model(&models, &materials, |name| {
        read_png(&dir.join(name.replace('\\', "/")))
    })
}

/// Decodes an 8-bit PNG (grey, grey+alpha, RGB or RGBA) into RGBA8.
pub fn read_png(path: &Path) -> Result<TextureImage> {
    let file = std::fs::File::open(path)
        .map_err(|e| format!("cannot open texture {}: {e}", path.display()))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder
        .read_info()
        .map_err(|e| format!("cannot read texture {}: {e}", path.display()))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| format!("texture {} is too large", path.display()))?;
    let mut buf = vec![0; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format!("cannot decode texture {}: {e}", path.display()))?;
    let channels = info.color_type.samples();
    let rgba = buf[..info.buffer_size()]
        .chunks_exact(channels)
        .map(|t| match channels {
            1 => [t[0], t[0], t[0], 255],
            2 => [t[0], t[0], t[0], t[1]],
            3 => [t[0], t[1], t[2], 255],
            _ => [t[0], t[1], t[2], t[3]],
        })
        .collect();
    Ok(TextureImage {
        width: info.width,
        height: info.height,
        rgba,
    })
}

fn build_model(
    models: &[tobj::Model],
    materials: &[tobj::Material],
    mut load_texture: impl FnMut(&str) -> Result<TextureImage>,
) -> Result<Model> {
    let mut textures = Vec::new();
    let mut texture_ids = std::collections::HashMap::new();
    let mut meshes = Vec::new();
    let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for model in models {
        let m = &model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let material = m.material_id.and_then(|i| materials.get(i));
        let texture = match material.and_then(|mat| mat.diffuse_texture.clone()) {
            Some(name) => Some(match texture_ids.get(&name) {
                Some(&id) => id,
                None => {
                    let id = textures.len() as u32;
                    textures.push(load_texture(&name)?);
                    texture_ids.insert(name, id);
                    id
                }
            }),
            None => None,
        };
        let positions: Vec<[f32; 3]> = m
            .positions
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect();
        for p in &positions {
            for a in 0..3 {
                min[a] = min[a].min(p[a]);
                max[a] = max[a].max(p[a]);
            }
        }
        meshes.push(TriangleMesh {
            normals: m
                .normals
                .chunks_exact(3)
                .map(|n| [n[0], n[1], n[2]])
                .collect(),
            // OBJ's v runs up the image; textures are stored top row first (the course
            // flips rows at load instead; the result is the same).
            texcoords: m
                .texcoords
                .chunks_exact(2)
                .map(|t| [t[0], 1.0 - t[1]])
                .collect(),
            indices: m
                .indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
            positions,
            diffuse: material.and_then(|mat| mat.diffuse).unwrap_or([0.8; 3]),
            texture,
            material_id: m.material_id.map_or(u32::MAX, |i| i as u32),
        });
    }
    if meshes.is_empty() {
        return Err("the OBJ model has no triangles".into());
    }
    Ok(Model {
        meshes,
        textures,
        min,
        max,
    })
}

/// A checkerboard: 8 × 8 squares of `n / 8` texels, cream and brick red.
pub fn checker_texture(n: u32) -> TextureImage {
    let rgba = (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            if ((x * 8 / n) + (y * 8 / n)).is_multiple_of(2) {
                [230, 220, 190, 255]
            } else {
                [150, 50, 40, 255]
            }
        })
        .collect();
    TextureImage {
        width: n,
        height: n,
        rgba,
    }
}

/// The generated Cornell box's OBJ text: the box spans [-1, 1] × [0, 2] × [-1, 1], open
/// towards +z, with a textured floor, red and green side walls, two blocks and a light quad.
pub const CORNELL_OBJ: &str = "\
mtllib cornell.mtl
vt 0 0
vt 4 0
vt 4 4
vt 0 4
o floor
usemtl floor
v -1 0 -1
v -1 0 1
v 1 0 1
v 1 0 -1
f -4/1 -3/2 -2/3 -1/4
o ceiling
usemtl white
v -1 2 -1
v 1 2 -1
v 1 2 1
v -1 2 1
f -4 -3 -2 -1
o back
usemtl white
v -1 0 -1
v 1 0 -1
v 1 2 -1
v -1 2 -1
f -4 -3 -2 -1
o left
usemtl red
v -1 0 -1
v -1 2 -1
v -1 2 1
v -1 0 1
f -4 -3 -2 -1
o right
usemtl green
v 1 0 -1
v 1 0 1
v 1 2 1
v 1 2 -1
f -4 -3 -2 -1
o light
usemtl light
v -0.25 1.98 -0.25
v 0.25 1.98 -0.25
v 0.25 1.98 0.25
v -0.25 1.98 0.25
f -4 -3 -2 -1
o short_block
usemtl white
v 0.55 0 0.05
v 0.05 0 0.20
v 0.20 0 0.70
v 0.70 0 0.55
v 0.55 0.6 0.05
v 0.05 0.6 0.20
v 0.20 0.6 0.70
v 0.70 0.6 0.55
f -4 -3 -2 -1
f -8 -7 -3 -4
f -7 -6 -2 -3
f -6 -5 -1 -2
f -5 -8 -4 -1
o tall_block
usemtl white
v -0.05 0 -0.60
v -0.55 0 -0.75
v -0.70 0 -0.25
v -0.20 0 -0.10
v -0.05 1.2 -0.60
v -0.55 1.2 -0.75
v -0.70 1.2 -0.25
v -0.20 1.2 -0.10
f -4 -3 -2 -1
f -8 -7 -3 -4
f -7 -6 -2 -3
f -6 -5 -1 -2
f -5 -8 -4 -1
";

/// The generated Cornell box's materials; `checker.png` is [`checker_texture`].
pub const CORNELL_MTL: &str = "\
newmtl floor
Kd 0.8 0.8 0.8
map_Kd checker.png
newmtl white
Kd 0.75 0.75 0.75
newmtl red
Kd 0.63 0.065 0.05
newmtl green
Kd 0.14 0.45 0.091
newmtl light
Kd 0.78 0.78 0.78
Ke 17 12 4
";

/// The Cornell box of [`CORNELL_OBJ`], loaded through the same OBJ loader as files.
pub fn generated_cornell_box() -> Result<Model> {
    let mut obj = std::io::BufReader::new(CORNELL_OBJ.as_bytes());
    let (models, materials) = tobj::load_obj_buf(&mut obj, &load_options(), |_| {
        tobj::load_mtl_buf(&mut std::io::BufReader::new(CORNELL_MTL.as_bytes()))
    })
    .map_err(|e| format!("the generated Cornell box does not load: {e}"))?;
    let materials = materials.map_err(|e| format!("the generated MTL does not load: {e}"))?;
    build_model(&models, &materials, |name| match name {
        "checker.png" => Ok(checker_texture(64)),
        other => Err(format!("the generated scene has no texture {other}").into()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_generated_cornell_box_loads_with_its_texture() {
        let m = generated_cornell_box().unwrap();
        assert_eq!(m.meshes.len(), 8, "one mesh per object");
        assert_eq!(m.textures.len(), 1);
        let floor = &m.meshes[0];
        assert_eq!(floor.texture, Some(0));
        assert_eq!(floor.indices.len(), 2);
        assert_eq!(floor.texcoords.len(), floor.positions.len());
        assert_eq!(m.min, [-1.0, 0.0, -1.0]);
        assert_eq!(m.max, [1.0, 2.0, 1.0]);
        let blocks = m.meshes.iter().filter(|x| x.positions.len() == 8).count();
        assert_eq!(blocks, 2);
    }

    #[test]
    fn a_missing_obj_is_a_clear_error() {
        let err = load_model(Some(Path::new("/nonexistent/model.obj"))).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/model.obj"), "{err}");
    }
}
