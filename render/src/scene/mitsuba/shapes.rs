//! Shape plugins: meshes from files, Mitsuba's built-in shapes, spheres, shape groups and
//! instances.

use super::xml::Object;
use super::{Builder, err, mat4};
use crate::scene::{Instance, Mesh, SceneError, ShapeGroup, Sphere, Texture, shapes as geo};
use glam::{DMat4, DVec3};
use std::rc::Rc;

/// Shapes produced while reading a part of the scene (the top level or one shape group).
#[derive(Default)]
pub struct Shapes {
    pub meshes: Vec<Mesh>,
    pub spheres: Vec<Sphere>,
    pub instances: Vec<Instance>,
}

/// Latitude rings and longitude segments of a sphere that has to be tessellated.
const SPHERE_RINGS: u32 = 48;
const SPHERE_SEGMENTS: u32 = 96;

impl Builder<'_> {
    /// The material and area emission of a shape, from its nested `<bsdf>` and `<emitter>`.
    fn shape_material(&mut self, obj: &Object) -> Result<(u32, Option<Texture>), SceneError> {
        let bsdfs = self.children(obj, "bsdf")?;
        let material = match bsdfs.as_slice() {
            [] => self.default_material(),
            [(_, b, _), rest @ ..] => {
                for (_, _, at) in rest {
                    self.warn(at, "a shape takes one BSDF; this further one is ignored");
                }
                self.material(b)?
            }
        };
        let mut emission = None;
        for (_, e, at) in self.children(obj, "emitter")? {
            self.visit(&e);
            if e.plugin == "area" {
                if e.has("to_world") {
                    return Err(err(
                        &e.at,
                        "an area emitter takes its placement from the shape; to_world is not allowed",
                    ));
                }
                emission = Some(self.emissive_texture(&e, "radiance", 1.0)?);
            } else {
                self.warn(&at, format!("a <emitter type=\"{}\"> inside a shape is not supported (only area); it is ignored", e.plugin));
            }
        }
        Ok((material, emission))
    }

    /// Reads a shape into `out`.
    pub(crate) fn shape(&mut self, obj: &Rc<Object>, out: &mut Shapes) -> Result<(), SceneError> {
        self.visit(obj);
        let o: &Object = obj;
        let name =
            o.id.clone()
                .unwrap_or_else(|| format!("{} ({})", o.plugin, o.at));
        let to_world = self.transform(o, "to_world")?.unwrap_or(DMat4::IDENTITY);
        let mesh = match o.plugin.as_str() {
            "obj" | "ply" => {
                let (file, at) = self.string(o, "filename")?.ok_or_else(|| {
                    err(&o.at, format!("the {} shape has no filename; expected <string name=\"filename\" value=\"…\"/>", o.plugin))
                })?;
                let path = self.doc.find_file(&file);
                let mut mesh = if o.plugin == "obj" {
                    let flip = self.boolean(o, "flip_tex_coords", true)?;
                    crate::scene::obj::read_obj_mesh(&path, flip).map_err(|m| err(&at, m))?
                } else {
                    read_ply(&path).map_err(|m| err(&at, m))?
                };
                if self.boolean(o, "face_normals", false)? {
                    mesh.normals.clear();
                }
                mesh
            }
            "rectangle" => geo::rectangle(),
            "cube" => geo::cube(),
            "disk" => geo::disk(),
            "sphere" => {
                let center = self.point(o, "center")?.unwrap_or(DVec3::ZERO);
                let radius = self.float(o, "radius")?.unwrap_or(1.0);
                let (material, emission) = self.shape_material(o)?;
                let flip_normals = self.boolean(o, "flip_normals", false)?;
                let m = to_world
                    * DMat4::from_translation(center)
                    * DMat4::from_scale(DVec3::splat(radius));
                match uniform_scale(&m) {
                    Some(scale) => out.spheres.push(Sphere {
                        name,
                        center: m.transform_point3(DVec3::ZERO).as_vec3(),
                        radius: scale as f32,
                        rotation: (glam::DMat3::from_mat4(m) * (1.0 / scale)).as_mat3(),
                        material,
                        emission,
                        flip_normals,
                    }),
                    None => {
                        self.warn(&o.at, "this sphere's to_world scales unevenly, which a sphere primitive cannot express; it is tessellated into triangles");
                        let mut mesh = geo::uv_sphere(SPHERE_RINGS, SPHERE_SEGMENTS);
                        geo::transform_mesh(&mut mesh, &mat4(m));
                        out.meshes.push(Mesh {
                            name,
                            material,
                            emission,
                            flip_normals,
                            ..mesh
                        });
                    }
                }
                return Ok(());
            }
            "instance" => {
                let groups: Vec<_> = self.children(o, "shape")?;
                let [(_, group, at)] = groups.as_slice() else {
                    return Err(err(
                        &o.at,
                        "an instance needs exactly one <ref> to a shapegroup",
                    ));
                };
                if group.plugin != "shapegroup" {
                    return Err(err(
                        at,
                        format!(
                            "an instance must refer to a shapegroup, not a {} shape",
                            group.plugin
                        ),
                    ));
                }
                let group = self.shape_group(group)?;
                out.instances.push(Instance {
                    group,
                    to_world: mat4(to_world),
                });
                return Ok(());
            }
            "shapegroup" => {
                return Err(err(
                    &o.at,
                    "a shapegroup cannot be nested in another shape group",
                ));
            }
            other => {
                self.warn(
                    &o.at,
                    format!("the shape \"{other}\" is not supported and is left out of the scene"),
                );
                return Ok(());
            }
        };
        let (material, emission) = self.shape_material(o)?;
        let flip_normals = self.boolean(o, "flip_normals", false)?;
        let mut mesh = Mesh {
            name,
            material,
            emission,
            flip_normals,
            ..mesh
        };
        geo::transform_mesh(&mut mesh, &mat4(to_world));
        out.meshes.push(mesh);
        Ok(())
    }

    /// Reads a shape group once; returns its index in [`crate::scene::Scene::groups`].
    pub(crate) fn shape_group(&mut self, obj: &Rc<Object>) -> Result<u32, SceneError> {
        let key = Rc::as_ptr(obj);
        if let Some(&id) = self.groups.get(&key) {
            return Ok(id);
        }
        self.visit(obj);
        let mut out = Shapes::default();
        for (_, s, _) in self.children(obj, "shape")? {
            if s.plugin == "instance" || s.plugin == "shapegroup" {
                return Err(err(
                    &s.at,
                    "a shapegroup holds plain shapes; nested instances and groups are not supported",
                ));
            }
            self.shape(&s, &mut out)?;
        }
        // Mitsuba's shapegroup refuses emitters ("Instancing of emitters is not supported").
        let emitter = out
            .meshes
            .iter()
            .filter(|m| m.emission.is_some())
            .map(|m| &m.name);
        let mut emitter = emitter.chain(
            out.spheres
                .iter()
                .filter(|s| s.emission.is_some())
                .map(|s| &s.name),
        );
        if let Some(name) = emitter.next() {
            return Err(err(
                &obj.at,
                format!(
                    "the shape `{name}` in this shapegroup is an area emitter; Mitsuba does not instance emitters (place it outside the group)"
                ),
            ));
        }
        let id = self.scene.groups.len() as u32;
        let name = obj
            .id
            .clone()
            .unwrap_or_else(|| format!("shapegroup ({})", obj.at));
        self.scene.groups.push(ShapeGroup {
            name,
            meshes: out.meshes,
            spheres: out.spheres,
        });
        self.groups.insert(key, id);
        Ok(id)
    }
}

/// The scale of a similarity transform (rotation × uniform scale + translation), if it is one.
fn uniform_scale(m: &DMat4) -> Option<f64> {
    let cols = [
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    ];
    let s = cols[0].length();
    let same = cols.iter().all(|c| (c.length() - s).abs() <= 1e-5 * s);
    let orthogonal = cols[0].dot(cols[1]).abs() <= 1e-5 * s * s
        && cols[1].dot(cols[2]).abs() <= 1e-5 * s * s
        && cols[0].dot(cols[2]).abs() <= 1e-5 * s * s;
    (s > 0.0 && same && orthogonal).then_some(s)
}

/// PLY meshes through optik-io.
fn read_ply(path: &std::path::Path) -> Result<Mesh, String> {
    let data = optik_io::mesh::read_ply(path).map_err(|e| e.to_string())?;
    Ok(Mesh {
        name: path.display().to_string(),
        positions: data.positions.iter().map(|&p| p.into()).collect(),
        normals: data.normals.iter().map(|&n| n.into()).collect(),
        uvs: data.uvs.iter().map(|&t| t.into()).collect(),
        indices: data.triangles,
        ..Mesh::default()
    })
}
