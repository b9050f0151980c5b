//! OBJ+MTL models as scenes (`optik render model.obj`), and OBJ files as meshes for Mitsuba's
//! `obj` shape.
//!
//! A model becomes one [`Mesh`] per (object × material), read with `tobj` (polygons
//! triangulated, one index per vertex). Materials map as follows (render/README.md, "OBJ+MTL
//! models", has the table):
//! - `Ke` above zero: the mesh is an area light of radiance `Ke` (front side only, as Mitsuba);
//! - `illum 7`, or `d` < 1 with an `Ni` other than 1: a smooth `dielectric` of `int_ior` = `Ni`;
//! - `Ks` above zero: a `roughplastic` over `Kd`/`map_Kd` with `int_ior` = `Ni` (1.5 when
//!   absent) whose specular reflectance is `Ks` over the coating's normal-incidence Fresnel
//!   reflectance (so `Ks` = 0.04 with `Ni` 1.5 is the plain coating), or, when `Kd` is black, a
//!   conductor reflecting `Ks` (a tinted mirror); the roughness is `alpha = sqrt(2 / (Ns + 2))`
//!   (Beckmann), and `Ns` ≥ 10⁴ is smooth;
//! - otherwise `diffuse` with `Kd`, or `map_Kd` (an sRGB bitmap) when given;
//! - `d` < 1 without refraction (or `map_d`): a `mask` of that opacity around the material;
//! - everything except dielectrics is two-sided: OBJ models rarely keep a consistent winding.
//!
//! The camera looks down -z at the centre of the model's bounding box from far enough away
//! that the bounding sphere fits a 45° field of view along the image's shorter side, +y up.
//! A model with no emitting material is lit by a constant environment of radiance 1.

use super::images::load_image;
use super::{
    Bsdf, Camera, Emitter, FovAxis, ImageId, Location, Mesh, Microfacet, Roughness, Scene,
    SceneError, Texture, Warning,
};
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The vertical field of view of the framing camera, along the shorter image side.
pub const FRAMING_FOV_DEGREES: f32 = 45.0;

fn load_options() -> tobj::LoadOptions {
    tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    }
}

/// Converts one `tobj` model's mesh; `flip_v` turns v into 1 - v (Mitsuba's `flip_tex_coords`).
fn convert(model: &tobj::Model, name: String, flip_v: bool) -> Mesh {
    let m = &model.mesh;
    let positions: Vec<Vec3> = m
        .positions
        .chunks_exact(3)
        .map(|p| Vec3::new(p[0], p[1], p[2]))
        .collect();
    let n = positions.len();
    let normals: Vec<Vec3> = if m.normals.len() == 3 * n {
        m.normals
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect()
    } else {
        Vec::new()
    };
    let uvs: Vec<Vec2> = if m.texcoords.len() == 2 * n {
        m.texcoords
            .chunks_exact(2)
            .map(|t| Vec2::new(t[0], if flip_v { 1.0 - t[1] } else { t[1] }))
            .collect()
    } else {
        Vec::new()
    };
    Mesh {
        name,
        positions,
        normals,
        uvs,
        indices: m
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        ..Mesh::default()
    }
}

/// Appends `other` to `mesh`; attributes only one side has are dropped.
fn append(mesh: &mut Mesh, other: Mesh) {
    let base = mesh.positions.len() as u32;
    let keep_normals =
        (mesh.positions.is_empty() || !mesh.normals.is_empty()) && !other.normals.is_empty();
    let keep_uvs = (mesh.positions.is_empty() || !mesh.uvs.is_empty()) && !other.uvs.is_empty();
    mesh.positions.extend(other.positions);
    if keep_normals {
        mesh.normals.extend(other.normals);
    } else {
        mesh.normals.clear();
    }
    if keep_uvs {
        mesh.uvs.extend(other.uvs);
    } else {
        mesh.uvs.clear();
    }
    mesh.indices
        .extend(other.indices.into_iter().map(|t| t.map(|i| i + base)));
}

/// Reads an OBJ file as one mesh (all objects and groups merged; materials ignored), as
/// Mitsuba's `obj` shape does. The error says what was wrong.
pub fn read_obj_mesh(path: &Path, flip_tex_coords: bool) -> Result<Mesh, String> {
    if !path.exists() {
        return Err(format!("the mesh file {} does not exist", path.display()));
    }
    let (models, _) = tobj::load_obj(path, &load_options())
        .map_err(|e| format!("cannot read the OBJ file {}: {e}", path.display()))?;
    let mut mesh = Mesh {
        name: path.display().to_string(),
        ..Mesh::default()
    };
    for model in &models {
        append(&mut mesh, convert(model, String::new(), flip_tex_coords));
    }
    if mesh.indices.is_empty() {
        return Err(format!(
            "the OBJ file {} has no triangles; expected at least one face",
            path.display()
        ));
    }
    Ok(mesh)
}

fn rgb(c: Option<[f32; 3]>) -> Vec3 {
    c.map(Vec3::from).unwrap_or(Vec3::ZERO)
}

/// The emitted radiance `Ke`, when above zero.
fn emission(m: &tobj::Material) -> Option<Vec3> {
    let ke = Vec3::from(m.emissive?);
    (ke.max_element() > 0.0).then_some(ke)
}

/// Normal-incidence Fresnel reflectance of an interface with relative index `eta`.
fn fresnel0(eta: f32) -> f32 {
    ((eta - 1.0) / (eta + 1.0)).powi(2)
}

struct MaterialMapper<'a> {
    dir: &'a Path,
    file: &'a Path,
    images: Vec<super::Image>,
    image_ids: HashMap<PathBuf, ImageId>,
    warnings: Vec<Warning>,
}

impl MaterialMapper<'_> {
    fn bitmap(&mut self, name: &str, raw: bool) -> Result<Texture, SceneError> {
        let path = self.dir.join(name.replace('\\', "/"));
        let id = match self.image_ids.get(&path) {
            Some(&id) => id,
            None => {
                let img = load_image(&path, raw).map_err(|message| SceneError {
                    at: Location {
                        file: self.file.to_path_buf(),
                        line: 0,
                    },
                    message,
                })?;
                let id = self.images.len() as ImageId;
                self.images.push(img);
                self.image_ids.insert(path, id);
                id
            }
        };
        Ok(Texture::Bitmap {
            image: id,
            to_uv: Mat3::IDENTITY,
            bilinear: true,
            wrap: super::WrapMode::Repeat,
        })
    }

    fn map(&mut self, m: &tobj::Material) -> Result<Bsdf, SceneError> {
        let kd = rgb(m.diffuse);
        let ks = rgb(m.specular);
        let d = m.dissolve.unwrap_or(1.0);
        let ni = m.optical_density.unwrap_or(1.5);
        let illum = m.illumination_model.unwrap_or(2);
        let refracts = illum == 7 || (d < 1.0 && m.optical_density.is_some_and(|n| n != 1.0));
        if refracts {
            return Ok(Bsdf::Dielectric {
                int_ior: ni,
                ext_ior: 1.000_277,
                specular_reflectance: Texture::Constant(Vec3::ONE),
                specular_transmittance: Texture::Constant(Vec3::ONE),
            });
        }
        let diffuse = match &m.diffuse_texture {
            Some(t) => self.bitmap(t, false)?,
            None => Texture::Constant(kd),
        };
        let ns = m.shininess.unwrap_or(0.0).max(0.0);
        let alpha = (2.0 / (ns + 2.0)).sqrt();
        let smooth = ns >= 1e4;
        let roughness = Roughness {
            distribution: Microfacet::Beckmann,
            alpha_u: alpha,
            alpha_v: alpha,
        };
        let base = if ks.max_element() > 0.0 {
            if kd.max_element() <= 0.0 && m.diffuse_texture.is_none() {
                // A perfect mirror (eta 0, k 1: Mitsuba's material="none") tinted by Ks.
                let (eta, k, spec) = (Vec3::ZERO, Vec3::ONE, Texture::Constant(ks));
                if smooth {
                    Bsdf::Conductor {
                        eta,
                        k,
                        specular_reflectance: spec,
                    }
                } else {
                    Bsdf::RoughConductor {
                        eta,
                        k,
                        roughness,
                        specular_reflectance: spec,
                        sample_visible: true,
                    }
                }
            } else {
                let spec = (ks / fresnel0(ni.max(1.0 + 1e-3))).min(Vec3::ONE);
                if smooth {
                    Bsdf::Plastic {
                        diffuse_reflectance: diffuse,
                        specular_reflectance: Texture::Constant(spec),
                        int_ior: ni,
                        ext_ior: 1.000_277,
                        nonlinear: false,
                    }
                } else {
                    Bsdf::RoughPlastic {
                        diffuse_reflectance: diffuse,
                        specular_reflectance: Texture::Constant(spec),
                        int_ior: ni,
                        ext_ior: 1.000_277,
                        nonlinear: false,
                        roughness,
                    }
                }
            }
        } else {
            Bsdf::Diffuse {
                reflectance: diffuse,
            }
        };
        let two_sided = Bsdf::TwoSided {
            front: Box::new(base.clone()),
            back: Box::new(base),
        };
        let opacity = match &m.dissolve_texture {
            Some(t) => Some(self.bitmap(t, true)?),
            None if d < 1.0 => Some(Texture::Constant(Vec3::splat(d))),
            None => None,
        };
        Ok(match opacity {
            Some(opacity) => Bsdf::Mask {
                opacity,
                inner: Box::new(two_sided),
            },
            None => two_sided,
        })
    }
}

/// Loads an OBJ+MTL model as a scene (mapping in the module documentation).
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let at = Location {
        file: path.to_path_buf(),
        line: 0,
    };
    if !path.exists() {
        return Err(SceneError {
            at,
            message: "the OBJ file does not exist".into(),
        });
    }
    let (models, materials) = tobj::load_obj(path, &load_options()).map_err(|e| SceneError {
        at: at.clone(),
        message: format!("cannot read the OBJ file: {e}"),
    })?;
    let mut scene = Scene::default();
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            scene.warnings.push(Warning {
                at: at.clone(),
                message: format!(
                    "its materials could not be read ({e}); every surface is grey diffuse"
                ),
            });
            Vec::new()
        }
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut mapper = MaterialMapper {
        dir,
        file: path,
        images: Vec::new(),
        image_ids: HashMap::new(),
        warnings: Vec::new(),
    };
    for m in &materials {
        scene.materials.push(mapper.map(m)?);
    }
    let default_material = scene.materials.len() as u32;
    let grey = Bsdf::Diffuse {
        reflectance: Texture::Constant(Vec3::splat(0.5)),
    };
    scene.materials.push(Bsdf::TwoSided {
        front: Box::new(grey.clone()),
        back: Box::new(grey),
    });
    for model in &models {
        let mat = model.mesh.material_id.filter(|&i| i < materials.len());
        let label = match mat {
            Some(i) => format!("{} ({})", model.name, materials[i].name),
            None => model.name.clone(),
        };
        let mut mesh = convert(model, label, false);
        if mesh.indices.is_empty() {
            continue;
        }
        mesh.material = mat.map(|i| i as u32).unwrap_or(default_material);
        mesh.emission = mat
            .and_then(|i| emission(&materials[i]))
            .map(Texture::Constant);
        scene.meshes.push(mesh);
    }
    if scene.meshes.is_empty() {
        return Err(SceneError {
            at,
            message: "the OBJ file has no triangles; expected at least one face".into(),
        });
    }
    scene.images = mapper.images;
    scene.warnings.extend(mapper.warnings);
    if scene.meshes.iter().all(|m| m.emission.is_none()) {
        scene.emitters.push(Emitter::Constant {
            radiance: Vec3::ONE,
        });
    }
    scene.camera = framing_camera(&scene);
    Ok(scene)
}

/// A camera looking down -z at the bounding box's centre, its bounding sphere filling a
/// [`FRAMING_FOV_DEGREES`] view along the shorter image side.
pub fn framing_camera(scene: &Scene) -> Camera {
    let (lo, hi) = super::shapes::bounds(scene.meshes.iter().flat_map(|m| m.positions.iter()));
    let centre = (lo + hi) / 2.0;
    let radius = ((hi - lo).length() / 2.0).max(1e-6);
    let half = (FRAMING_FOV_DEGREES / 2.0).to_radians();
    let distance = radius / half.sin();
    let origin = centre + Vec3::Z * distance;
    // Mitsuba's look_at: columns (up × dir, up', dir, origin).
    let dir = Vec3::NEG_Z;
    let left = Vec3::Y.cross(dir);
    let to_world = Mat4::from_cols(
        left.extend(0.0),
        Vec3::Y.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    );
    Camera {
        to_world,
        fov_degrees: FRAMING_FOV_DEGREES,
        fov_axis: FovAxis::Smaller,
        near_clip: (distance - radius).max(distance * 1e-4),
        far_clip: distance + radius * 2.0,
    }
}
