//! The scene as the programs read it: vertex, sphere and texel tables, one SBT hit record per
//! shape, the acceleration structures (one GAS per primitive type and shape group; an IAS over
//! them when the scene has spheres or instances) and the light table.

use crate::error::RenderError;
use crate::material::{self, BsdfKind, MATERIAL_WORDS};
use crate::scene::{Emitter, Mesh, Scene, Sphere, Texture};
use glam::{Mat3, Mat4, Vec3};

/// SBT record data words before the mask's opacity texture (scene.wgsl's record layout).
pub const SBT_OPACITY: usize = 10;
/// Where the material parameters start in the record data.
pub const SBT_MATERIAL: usize = SBT_OPACITY + 13;
/// Words of SBT record data: room for a twosided pair's two materials (`Encoded::words`).
pub const RECORD_DATA_WORDS: usize = SBT_MATERIAL + 2 * MATERIAL_WORDS;
/// Floats per light table entry (scene.wgsl's LIGHT_WORDS).
pub const LIGHT_WORDS: usize = 32;
/// Floats per sphere table entry: centre, radius, world-to-local rotation rows, spare.
pub const SPHERE_WORDS: usize = 16;

/// The primitive type of a GAS and its hit groups.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Primitive {
    /// Triangle meshes.
    Triangles,
    /// optik's built-in spheres.
    Spheres,
}

/// A hit group: the BSDF kind's closest-hit program for one primitive type, with the mask's
/// any-hit program when the material is masked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct HitGroupKey {
    /// The BSDF kind shading hits (on the front side when `back` is set).
    pub kind: BsdfKind,
    /// The kind shading hits on the back side: a twosided material with two different BSDFs.
    pub back: Option<BsdfKind>,
    /// The primitive type.
    pub primitive: Primitive,
    /// Whether an opacity mask's any-hit program runs.
    pub masked: bool,
}

/// One shape's SBT hit record and what its build input needs.
pub struct Record {
    /// Which hit group shades it.
    pub group: HitGroupKey,
    /// Triangles: vertex base and count, triangle base and count; spheres: the table index.
    pub geometry: Geometry,
    /// The record's data words.
    pub data: [u32; RECORD_DATA_WORDS],
}

/// Where a record's primitives are.
pub enum Geometry {
    /// A range of the vertex and index tables.
    Triangles {
        /// First vertex.
        vertex_base: u32,
        /// Vertices.
        vertex_count: u32,
        /// First triangle.
        triangle_base: u32,
        /// Triangles.
        triangle_count: u32,
    },
    /// One sphere of the sphere table.
    Sphere(u32),
}

/// One GAS: its records are `records[first..first + count]` (its SBT offset is `first`).
pub struct Gas {
    /// The primitive type of all its inputs.
    pub primitive: Primitive,
    /// First record.
    pub first: u32,
    /// Records (build inputs).
    pub count: u32,
}

/// The scene flattened into the tables the programs read.
#[derive(Default)]
pub struct Tables {
    /// Vertex positions (object space of their GAS).
    pub positions: Vec<f32>,
    /// Vertex normals.
    pub normals: Vec<f32>,
    /// Texture coordinates.
    pub uvs: Vec<f32>,
    /// Triangle indices.
    pub indices: Vec<u32>,
    /// Spheres, [`SPHERE_WORDS`] floats each.
    pub spheres: Vec<f32>,
    /// Texels of every bitmap, RGBA floats.
    pub texels: Vec<f32>,
    /// The light table, [`LIGHT_WORDS`] floats per entry.
    pub lights: Vec<f32>,
    /// Light table entries.
    pub light_count: u32,
    /// Hit records in SBT order.
    pub records: Vec<Record>,
    /// The GASes.
    pub gases: Vec<Gas>,
    /// IAS instances (GAS index, object to world); empty when one GAS is traced directly.
    pub instances: Vec<(u32, Mat4)>,
    /// Radiance of a constant environment.
    pub env_radiance: Vec3,
    /// Selection probability of a constant environment over 4π.
    pub env_pdf: f32,
    /// The light table entry of the environment map (`u32::MAX`: none).
    pub env_light: u32,
}

impl Tables {
    /// Whether rays trace an IAS (spheres next to triangles, or instances).
    pub fn uses_ias(&self) -> bool {
        !self.instances.is_empty()
    }

    /// Flattens `scene`.
    pub fn build(scene: &Scene) -> Result<Tables, RenderError> {
        let mut t = Tables {
            env_light: u32::MAX,
            ..Tables::default()
        };
        t.upload_images(scene)?;
        // Top level: world-space meshes and spheres.
        let tri = t.add_gas(scene, Primitive::Triangles, &scene.meshes, &[])?;
        let sph = t.add_gas(scene, Primitive::Spheres, &[], &scene.spheres)?;
        let mut placed: Vec<(u32, Mat4)> = tri
            .iter()
            .chain(sph.iter())
            .map(|&g| (g, Mat4::IDENTITY))
            .collect();
        // Groups: one BLAS per primitive type, placed by every instance.
        let mut group_gases = Vec::new();
        for g in &scene.groups {
            if let Some(m) = g.meshes.iter().find(|m| m.emission.is_some()) {
                return Err(RenderError::Unsupported(format!(
                    "mesh `{}` in shape group `{}` emits light: emitters cannot be instanced (as in Mitsuba)",
                    m.name, g.name
                )));
            }
            if let Some(s) = g.spheres.iter().find(|s| s.emission.is_some()) {
                return Err(RenderError::Unsupported(format!(
                    "sphere `{}` in shape group `{}` emits light: emitters cannot be instanced (as in Mitsuba)",
                    s.name, g.name
                )));
            }
            let a = t.add_gas(scene, Primitive::Triangles, &g.meshes, &[])?;
            let b = t.add_gas(scene, Primitive::Spheres, &[], &g.spheres)?;
            group_gases.push([a, b]);
        }
        for inst in &scene.instances {
            let gases = group_gases.get(inst.group as usize).ok_or_else(|| {
                RenderError::Invalid(format!(
                    "an instance of shape group {} of {}",
                    inst.group,
                    scene.groups.len()
                ))
            })?;
            for g in gases.iter().flatten() {
                placed.push((*g, inst.to_world));
            }
        }
        if !(placed.len() == 1 && placed[0].1 == Mat4::IDENTITY && sph.is_none()) {
            t.instances = placed;
        }
        t.lights(scene)?;
        Ok(t)
    }

    /// Adds one GAS of `meshes` or `spheres` (one primitive type); `None` when it is empty.
    fn add_gas(
        &mut self,
        scene: &Scene,
        primitive: Primitive,
        meshes: &[Mesh],
        spheres: &[Sphere],
    ) -> Result<Option<u32>, RenderError> {
        let first = self.records.len() as u32;
        for mesh in meshes {
            self.add_mesh(scene, mesh)?;
        }
        for sphere in spheres {
            self.add_sphere(scene, sphere)?;
        }
        let count = self.records.len() as u32 - first;
        if count == 0 {
            return Ok(None);
        }
        self.gases.push(Gas {
            primitive,
            first,
            count,
        });
        Ok(Some(self.gases.len() as u32 - 1))
    }

    /// The record words shared by meshes and spheres (emission and material) and the hit group
    /// that shades the shape.
    fn record(
        &mut self,
        scene: &Scene,
        material: u32,
        emission: &Option<Texture>,
        primitive: Primitive,
        what: &str,
    ) -> Result<([u32; RECORD_DATA_WORDS], HitGroupKey), RenderError> {
        let bsdf = scene.materials.get(material as usize).ok_or_else(|| {
            RenderError::Invalid(format!(
                "{what}: material {material} of {}",
                scene.materials.len()
            ))
        })?;
        let enc = material::encode(bsdf, &scene.images, what)?;
        let opacity = material::opacity(bsdf, what)?;
        let emission = match emission {
            None => Vec3::ZERO,
            Some(Texture::Constant(c)) => *c,
            Some(_) => {
                return Err(RenderError::Unsupported(format!(
                    "{what}: textured emission (supported: constant radiance)"
                )));
            }
        };
        let mut data = [0u32; RECORD_DATA_WORDS];
        for (i, c) in emission.to_array().iter().enumerate() {
            data[6 + i] = c.to_bits();
        }
        for (i, v) in opacity.iter().flatten().enumerate() {
            data[SBT_OPACITY + i] = v.to_bits();
        }
        for (word, v) in data[SBT_MATERIAL..].iter_mut().zip(enc.words(SBT_MATERIAL)) {
            *word = v.to_bits();
        }
        let group = HitGroupKey {
            kind: enc.kind,
            back: enc.back.as_ref().map(|b| b.kind),
            primitive,
            masked: opacity.is_some(),
        };
        Ok((data, group))
    }

    /// The texel table: a directory of four floats per image (first texel, width, height,
    /// spare), then every image's texels as RGBA floats.
    fn upload_images(&mut self, scene: &Scene) -> Result<(), RenderError> {
        let dir = scene.images.len();
        let mut base = dir;
        let mut data = Vec::new();
        for img in &scene.images {
            let n = img.width as usize * img.height as usize;
            if n == 0 || img.texels.len() != n {
                return Err(RenderError::Invalid(format!(
                    "image {} is {}x{} with {} texels (expected width × height, at least one)",
                    img.path.display(),
                    img.width,
                    img.height,
                    img.texels.len()
                )));
            }
            self.texels
                .extend_from_slice(&[base as f32, img.width as f32, img.height as f32, 0.0]);
            if base + n >= 1 << 24 {
                return Err(RenderError::Invalid(format!(
                    "image {}: the scene's images hold more than 2^24 texels, the most optik-render indexes",
                    img.path.display()
                )));
            }
            for (i, c) in img.texels.iter().enumerate() {
                let a = img.alpha.as_ref().and_then(|a| a.get(i)).copied();
                data.extend_from_slice(&[c.x, c.y, c.z, a.unwrap_or(1.0)]);
            }
            base += n;
        }
        self.texels.extend(data);
        Ok(())
    }

    fn add_mesh(&mut self, scene: &Scene, mesh: &Mesh) -> Result<(), RenderError> {
        if mesh.indices.is_empty() {
            return Ok(());
        }
        let what = format!("mesh `{}`", mesh.name);
        let nv = mesh.positions.len();
        if let Some(bad) = mesh.indices.iter().flatten().find(|&&i| i as usize >= nv) {
            return Err(RenderError::Invalid(format!(
                "{what}: vertex index {bad} with {nv} vertices"
            )));
        }
        if !mesh.normals.is_empty() && mesh.normals.len() != nv {
            return Err(RenderError::Invalid(format!(
                "{what}: {} normals for {nv} vertices (expected one per vertex or none)",
                mesh.normals.len()
            )));
        }
        if !mesh.uvs.is_empty() && mesh.uvs.len() != nv {
            return Err(RenderError::Invalid(format!(
                "{what}: {} texture coordinates for {nv} vertices (expected one per vertex or none)",
                mesh.uvs.len()
            )));
        }
        let (mut data, group) = self.record(
            scene,
            mesh.material,
            &mesh.emission,
            Primitive::Triangles,
            &what,
        )?;
        let vertex_base = (self.positions.len() / 3) as u32;
        let triangle_base = (self.indices.len() / 3) as u32;
        for p in &mesh.positions {
            self.positions.extend_from_slice(&p.to_array());
        }
        let normal_base = if mesh.normals.is_empty() {
            u32::MAX
        } else {
            let base = (self.normals.len() / 3) as u32;
            for n in &mesh.normals {
                self.normals
                    .extend_from_slice(&n.normalize_or_zero().to_array());
            }
            base
        };
        let uv_base = if mesh.uvs.is_empty() {
            u32::MAX
        } else {
            let base = (self.uvs.len() / 2) as u32;
            for uv in &mesh.uvs {
                self.uvs.extend_from_slice(&uv.to_array());
            }
            base
        };
        self.indices.extend(mesh.indices.iter().flatten());
        data[0] = vertex_base;
        data[1] = triangle_base;
        data[2] = normal_base;
        data[3] = uv_base;
        // Face normals come from the winding, as Mitsuba computes them.
        data[4] = u32::from(mesh.flip_normals);
        self.records.push(Record {
            group,
            geometry: Geometry::Triangles {
                vertex_base,
                vertex_count: nv as u32,
                triangle_base,
                triangle_count: mesh.indices.len() as u32,
            },
            data,
        });
        Ok(())
    }

    fn add_sphere(&mut self, scene: &Scene, sphere: &Sphere) -> Result<(), RenderError> {
        let what = format!("sphere `{}`", sphere.name);
        if !(sphere.radius > 0.0 && sphere.radius.is_finite() && sphere.center.is_finite()) {
            return Err(RenderError::Invalid(format!(
                "{what}: centre {} and radius {}; expected a finite centre and a positive radius",
                sphere.center, sphere.radius
            )));
        }
        let (mut data, group) = self.record(
            scene,
            sphere.material,
            &sphere.emission,
            Primitive::Spheres,
            &what,
        )?;
        let index = (self.spheres.len() / SPHERE_WORDS) as u32;
        let mut e = [0.0f32; SPHERE_WORDS];
        e[0..3].copy_from_slice(&sphere.center.to_array());
        e[3] = sphere.radius;
        // World to local: the transpose of the (orthonormal) local-to-world rotation.
        let to_local = sphere.rotation.transpose();
        for r in 0..3 {
            e[4 + 3 * r..7 + 3 * r].copy_from_slice(&to_local.row(r).to_array());
        }
        self.spheres.extend_from_slice(&e);
        data[0] = index;
        data[4] = u32::from(sphere.flip_normals);
        self.records.push(Record {
            group,
            geometry: Geometry::Sphere(index),
            data,
        });
        Ok(())
    }

    /// The light table: area emitters of the top level (meshes by triangle area, spheres by
    /// the solid angle of their visible cap), then the scene's other emitters; each emitter is
    /// chosen with the same probability, as Mitsuba's uniform emitter sampling.
    fn lights(&mut self, scene: &Scene) -> Result<(), RenderError> {
        let (lo, hi) = crate::scene::shapes::bounds(
            self.positions
                .chunks_exact(3)
                .map(Vec3::from_slice)
                .collect::<Vec<_>>()
                .iter(),
        );
        let mut lo = lo;
        let mut hi = hi;
        for (to_world, shape) in scene.placed_shapes() {
            if let crate::scene::ShapeRef::Sphere(s) = shape {
                let c = to_world.transform_point3(s.center);
                let r = s.radius * to_world.x_axis.truncate().length();
                lo = lo.min(c - Vec3::splat(r));
                hi = hi.max(c + Vec3::splat(r));
            }
            if let crate::scene::ShapeRef::Mesh(m) = shape
                && to_world != Mat4::IDENTITY
            {
                for p in &m.positions {
                    let w = to_world.transform_point3(*p);
                    lo = lo.min(w);
                    hi = hi.max(w);
                }
            }
        }
        let radius = if lo.x <= hi.x {
            (hi - lo).length() * 0.5
        } else {
            1.0
        };
        // Beyond the scene from any point inside it (Mitsuba: twice the bounding sphere).
        let far = 2.0 * radius * 1.01 + 1.0;

        // Top-level records are the first ones (groups cannot emit).
        let emissive: Vec<usize> = (0..self.records.len())
            .filter(|&i| {
                let d = &self.records[i].data;
                (6..9).any(|k| f32::from_bits(d[k]) > 0.0)
            })
            .collect();
        let emitter_count = emissive.len() + scene.emitters.len();
        if emitter_count == 0 {
            return Ok(());
        }
        let select = 1.0 / emitter_count as f32;
        let mut cdf = 0.0f64;
        let mut entries: Vec<[f32; LIGHT_WORDS]> = Vec::new();
        let mut push =
            |entries: &mut Vec<[f32; LIGHT_WORDS]>, mut e: [f32; LIGHT_WORDS], w: f64| {
                cdf += w;
                e[1] = cdf as f32;
                entries.push(e);
            };
        for ri in emissive {
            let rec = &self.records[ri];
            let le: [f32; 3] = std::array::from_fn(|k| f32::from_bits(rec.data[6 + k]));
            let flip_sign = if rec.data[4] != 0 { -1.0 } else { 1.0 };
            match rec.geometry {
                Geometry::Sphere(index) => {
                    let s = &self.spheres[index as usize * SPHERE_WORDS..];
                    let mut e = [0.0f32; LIGHT_WORDS];
                    e[0] = 4.0;
                    e[2..5].copy_from_slice(&le);
                    e[5] = select;
                    e[6..10].copy_from_slice(&s[0..4]);
                    e[10] = flip_sign;
                    self.records[ri].data[5] = select.to_bits();
                    push(&mut entries, e, select as f64);
                }
                Geometry::Triangles {
                    vertex_base,
                    triangle_base,
                    triangle_count,
                    ..
                } => {
                    let triangles: Vec<[Vec3; 3]> = (0..triangle_count)
                        .map(|k| {
                            let ti = ((triangle_base + k) * 3) as usize;
                            std::array::from_fn(|c| {
                                let v = (vertex_base + self.indices[ti + c]) as usize * 3;
                                Vec3::from_slice(&self.positions[v..v + 3])
                            })
                        })
                        .collect();
                    let areas: Vec<f64> = triangles
                        .iter()
                        .map(|p| 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length() as f64)
                        .collect();
                    let total: f64 = areas.iter().sum();
                    if total <= 0.0 {
                        continue;
                    }
                    // Hits on this mesh weigh emission against next-event estimation with
                    // this area pdf.
                    self.records[ri].data[5] = ((select as f64 / total) as f32).to_bits();
                    for (p, a) in triangles.iter().zip(&areas) {
                        if *a <= 0.0 {
                            continue;
                        }
                        let mut e = [0.0f32; LIGHT_WORDS];
                        e[2..5].copy_from_slice(&le);
                        e[5] = (select as f64 / total) as f32;
                        e[6..9].copy_from_slice(&p[0].to_array());
                        e[9..12].copy_from_slice(&(p[1] - p[0]).to_array());
                        e[12..15].copy_from_slice(&(p[2] - p[0]).to_array());
                        e[15] = flip_sign;
                        push(&mut entries, e, select as f64 * a / total);
                    }
                }
            }
        }
        for em in &scene.emitters {
            let mut e = [0.0f32; LIGHT_WORDS];
            e[5] = select;
            match em {
                Emitter::Point {
                    position,
                    intensity,
                } => {
                    e[0] = 1.0;
                    e[2..5].copy_from_slice(&intensity.to_array());
                    e[6..9].copy_from_slice(&position.to_array());
                }
                Emitter::Directional {
                    direction,
                    irradiance,
                } => {
                    e[0] = 2.0;
                    e[2..5].copy_from_slice(&irradiance.to_array());
                    e[6..9].copy_from_slice(&direction.normalize_or_zero().to_array());
                    e[9] = far;
                }
                Emitter::Constant { radiance } => {
                    if self.env_light != u32::MAX || self.env_pdf > 0.0 {
                        return Err(RenderError::Invalid(
                            "more than one environment emitter (constant or envmap); Mitsuba allows one".into(),
                        ));
                    }
                    e[0] = 3.0;
                    e[2..5].copy_from_slice(&radiance.to_array());
                    e[9] = far;
                    self.env_radiance = *radiance;
                    self.env_pdf = select / (4.0 * std::f32::consts::PI);
                }
                Emitter::Spot {
                    to_world,
                    intensity,
                    cutoff_angle,
                    beam_width,
                } => {
                    let cutoff = cutoff_angle.to_radians();
                    let beam = beam_width.to_radians();
                    if !(cutoff > 0.0 && beam > 0.0 && beam <= cutoff) {
                        return Err(RenderError::Invalid(format!(
                            "spot light: cutoff_angle {cutoff_angle} and beam_width {beam_width}; expected 0 < beam_width <= cutoff_angle (degrees)"
                        )));
                    }
                    let inv = Mat3::from_mat4(*to_world).inverse();
                    if !inv.is_finite() {
                        return Err(RenderError::Invalid(
                            "spot light: its to_world cannot be inverted".into(),
                        ));
                    }
                    e[0] = 5.0;
                    e[2..5].copy_from_slice(&intensity.to_array());
                    e[6..9].copy_from_slice(&to_world.w_axis.truncate().to_array());
                    for r in 0..3 {
                        e[9 + 3 * r..12 + 3 * r].copy_from_slice(&inv.row(r).to_array());
                    }
                    e[18] = cutoff.cos();
                    e[19] = beam.cos();
                    e[20] = cutoff;
                    // Mitsuba: 1 / (cutoff - beam width); a hard edge when they agree.
                    e[21] = if cutoff > beam {
                        1.0 / (cutoff - beam)
                    } else {
                        f32::INFINITY
                    };
                }
                Emitter::EnvMap {
                    image,
                    scale,
                    to_world,
                } => {
                    if self.env_light != u32::MAX || self.env_pdf > 0.0 {
                        return Err(RenderError::Invalid(
                            "more than one environment emitter (constant or envmap); Mitsuba allows one".into(),
                        ));
                    }
                    let img = scene.images.get(*image as usize).ok_or_else(|| {
                        RenderError::Invalid(format!(
                            "envmap: image {image} of {}",
                            scene.images.len()
                        ))
                    })?;
                    let cdf_base = self.envmap_distribution(img)?;
                    let m = Mat3::from_mat4(*to_world);
                    let inv = m.inverse();
                    if !inv.is_finite() {
                        return Err(RenderError::Invalid(
                            "envmap: its to_world cannot be inverted".into(),
                        ));
                    }
                    e[0] = 6.0;
                    e[2..5].copy_from_slice(&[*scale; 3]);
                    for r in 0..3 {
                        e[6 + 3 * r..9 + 3 * r].copy_from_slice(&inv.row(r).to_array());
                        e[18 + 3 * r..21 + 3 * r].copy_from_slice(&m.row(r).to_array());
                    }
                    e[15] = f32::from_bits(*image);
                    e[16] = f32::from_bits(cdf_base);
                    e[17] = far;
                    self.env_light = entries.len() as u32;
                }
            }
            push(&mut entries, e, select as f64);
        }
        self.light_count = entries.len() as u32;
        self.lights = entries.into_iter().flatten().collect();
        Ok(())
    }

    /// The envmap's sampling tables, appended to the texel table (returns their first float):
    /// the row CDF (H rows of cells, H + 1 floats), each row's column CDF (W + 1 floats each),
    /// then each cell's probability. Cell (i, j) lies between texel columns i, i + 1 (periodic)
    /// and rows j, j + 1, where Mitsuba interpolates the radiance bilinearly; its weight is the
    /// mean luminance of its corners times sin θ at its centre, plus a small floor so that
    /// every direction with radiance can be sampled.
    fn envmap_distribution(&mut self, img: &crate::scene::Image) -> Result<u32, RenderError> {
        let (w, h) = (img.width as usize, img.height as usize);
        if w < 1 || h < 2 || img.texels.len() != w * h {
            return Err(RenderError::Invalid(format!(
                "envmap {}: {}x{} pixels; expected at least 1x2",
                img.path.display(),
                img.width,
                img.height
            )));
        }
        let rows = h - 1;
        let lum = |x: usize, y: usize| {
            let c = img.texels[y * w + x % w];
            (0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z).max(0.0) as f64
        };
        let mut cells = vec![0.0f64; rows * w];
        for j in 0..rows {
            let theta = (j as f64 + 0.5) / rows as f64 * std::f64::consts::PI;
            for i in 0..w {
                let m = (lum(i, j) + lum(i + 1, j) + lum(i, j + 1) + lum(i + 1, j + 1)) / 4.0;
                cells[j * w + i] = m * theta.sin();
            }
        }
        let mean = cells.iter().sum::<f64>() / cells.len() as f64;
        let floor = if mean > 0.0 { 1e-3 * mean } else { 1.0 };
        for c in &mut cells {
            *c += floor;
        }
        let total: f64 = cells.iter().sum();
        let base = self.texels.len();
        if base + rows + 1 + rows * (w + 1) + rows * w >= u32::MAX as usize {
            return Err(RenderError::Invalid(format!(
                "envmap {}: too large for optik-render's tables",
                img.path.display()
            )));
        }
        let mut acc = 0.0f64;
        self.texels.push(0.0);
        for j in 0..rows {
            acc += cells[j * w..(j + 1) * w].iter().sum::<f64>();
            self.texels.push((acc / total) as f32);
        }
        *self.texels.last_mut().unwrap_or(&mut 0.0) = 1.0;
        for j in 0..rows {
            let row = &cells[j * w..(j + 1) * w];
            let sum: f64 = row.iter().sum();
            let mut acc = 0.0f64;
            self.texels.push(0.0);
            for c in row {
                acc += c;
                self.texels.push((acc / sum) as f32);
            }
            let last = self.texels.len() - 1;
            self.texels[last] = 1.0;
        }
        self.texels.extend(cells.iter().map(|c| (c / total) as f32));
        Ok(base as u32)
    }
}
