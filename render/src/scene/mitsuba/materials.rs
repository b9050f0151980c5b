//! BSDF and texture plugins, with Mitsuba 3's parameters and defaults.

use super::data::{CONDUCTORS, IORS};
use super::xml::{Object, Value};
use super::{Builder, err};
use crate::scene::{Bsdf, Microfacet, Rgb, Roughness, SceneError, Texture, WrapMode};
use glam::{DMat4, Mat3, Vec3};
use std::rc::Rc;

/// 3×3 uv transform from a 4×4 one, as Mitsuba's `Transform4f::extract` (upper-left 2×2 and
/// the x/y translation).
fn to_uv(m: DMat4) -> Mat3 {
    let c = m.to_cols_array_2d();
    Mat3::from_cols(
        Vec3::new(c[0][0] as f32, c[0][1] as f32, 0.0),
        Vec3::new(c[1][0] as f32, c[1][1] as f32, 0.0),
        Vec3::new(c[3][0] as f32, c[3][1] as f32, 1.0),
    )
}

/// A named IOR (`"bk7"`), case-insensitive, as Mitsuba's `lookup_ior`.
pub fn named_ior(name: &str) -> Option<f32> {
    let lower = name.trim().to_ascii_lowercase();
    IORS.iter().find(|(n, _)| *n == lower).map(|&(_, v)| v)
}

/// A named conductor's (eta, k) in linear RGB, as Mitsuba 3's RGB variants compute them.
pub fn named_conductor(name: &str) -> Option<(Rgb, Rgb)> {
    CONDUCTORS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, e, k)| (Rgb::from(e), Rgb::from(k)))
}

impl Builder<'_> {
    /// The material index of a BSDF object (shared when several shapes refer to it).
    pub(crate) fn material(&mut self, obj: &Rc<Object>) -> Result<u32, SceneError> {
        let key = Rc::as_ptr(obj);
        if let Some(&id) = self.materials.get(&key) {
            return Ok(id);
        }
        let bsdf = self.bsdf(obj)?;
        let id = self.scene.materials.len() as u32;
        self.scene.materials.push(bsdf);
        self.materials.insert(key, id);
        Ok(id)
    }

    /// Mitsuba's default for a shape without a BSDF: diffuse, reflectance 0.5.
    pub(crate) fn default_material(&mut self) -> u32 {
        if let Some(id) = self.default_material {
            return id;
        }
        let id = self.scene.materials.len() as u32;
        self.scene.materials.push(Bsdf::Diffuse {
            reflectance: Texture::Constant(Vec3::splat(0.5)),
        });
        self.default_material = Some(id);
        id
    }

    fn ior(&mut self, obj: &Object, name: &str, default: &str) -> Result<f32, SceneError> {
        let Some(p) = obj.prop(name) else {
            return Ok(named_ior(default).unwrap_or(1.0));
        };
        match &p.value {
            Value::Float(v) => Ok(*v as f32),
            Value::Integer(v) => Ok(*v as f32),
            Value::String(s) => named_ior(s).ok_or_else(|| {
                let names: Vec<&str> = IORS.iter().map(|(n, _)| *n).collect();
                err(&p.at, format!("\"{s}\" is not a known index of refraction; expected a number or one of {}", names.join(", ")))
            }),
            _ => Err(self.wrong(obj, p, "a <float> or a named IOR <string>")),
        }
    }

    fn roughness(&mut self, obj: &Object, anisotropic: bool) -> Result<Roughness, SceneError> {
        let distribution = match self.string(obj, "distribution")? {
            None => Microfacet::Beckmann,
            Some((d, at)) => match d.to_ascii_lowercase().as_str() {
                "beckmann" => Microfacet::Beckmann,
                "ggx" => Microfacet::Ggx,
                _ => {
                    return Err(err(
                        &at,
                        format!("distribution \"{d}\" is unknown; expected beckmann or ggx"),
                    ));
                }
            },
        };
        let has_uv = obj.has("alpha_u") || obj.has("alpha_v");
        let (alpha_u, alpha_v) = if has_uv && anisotropic {
            if !(obj.has("alpha_u") && obj.has("alpha_v")) || obj.has("alpha") {
                return Err(err(
                    &obj.at,
                    "give either alpha, or both alpha_u and alpha_v",
                ));
            }
            (
                self.scalar(obj, "alpha_u", 0.1)?,
                self.scalar(obj, "alpha_v", 0.1)?,
            )
        } else {
            let a = self.scalar(obj, "alpha", 0.1)?;
            (a, a)
        };
        Ok(Roughness {
            distribution,
            alpha_u,
            alpha_v,
        })
    }

    /// A scalar parameter that Mitsuba allows to be a texture; optik takes a constant.
    fn scalar(&mut self, obj: &Object, name: &str, default: f32) -> Result<f32, SceneError> {
        let c = self.color(obj, name, default, false, true)?;
        Ok((c.x + c.y + c.z) / 3.0)
    }

    /// (eta, k) of a conductor: explicit values, or `material` (Mitsuba's default "none": a
    /// perfect mirror, eta 0 and k 1).
    fn conductor_ior(&mut self, obj: &Object) -> Result<(Rgb, Rgb), SceneError> {
        let material = self.string(obj, "material")?;
        if obj.has("eta") || material.as_ref().is_none_or(|(m, _)| m == "none") {
            if let Some((m, at)) = &material
                && m != "none"
            {
                return Err(err(at, "give either eta and k, or material, not both"));
            }
            let eta = self.color(obj, "eta", 0.0, false, true)?;
            let k = self.color(obj, "k", 1.0, false, true)?;
            return Ok((eta, k));
        }
        let (m, at) = material.unwrap_or_default();
        named_conductor(&m).ok_or_else(|| {
            let names: Vec<&str> = CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
            err(&at, format!("material \"{m}\" is not one of Mitsuba's conductors; expected none or one of {}", names.join(", ")))
        })
    }

    /// The nested BSDFs of an object (twosided, mask, bumpmap …).
    fn inner_bsdfs(&mut self, obj: &Object) -> Result<Vec<Rc<Object>>, SceneError> {
        Ok(self
            .children(obj, "bsdf")?
            .into_iter()
            .map(|(_, o, _)| o)
            .collect())
    }

    fn one_inner(&mut self, obj: &Object) -> Result<Bsdf, SceneError> {
        let inner = self.inner_bsdfs(obj)?;
        match inner.as_slice() {
            [one] => self.bsdf(one),
            _ => Err(err(
                &obj.at,
                format!(
                    "<bsdf type=\"{}\"> needs exactly one nested <bsdf>, not {}",
                    obj.plugin,
                    inner.len()
                ),
            )),
        }
    }

    /// Builds a BSDF description.
    pub(crate) fn bsdf(&mut self, obj: &Rc<Object>) -> Result<Bsdf, SceneError> {
        self.visit(obj);
        let o: &Object = obj;
        Ok(match o.plugin.as_str() {
            "diffuse" => Bsdf::Diffuse {
                reflectance: self.texture(o, "reflectance", 0.5)?,
            },
            "twosided" => {
                let inner = self.inner_bsdfs(o)?;
                match inner.as_slice() {
                    [one] => {
                        let b = self.bsdf(one)?;
                        Bsdf::TwoSided {
                            front: Box::new(b.clone()),
                            back: Box::new(b),
                        }
                    }
                    [front, back] => Bsdf::TwoSided {
                        front: Box::new(self.bsdf(front)?),
                        back: Box::new(self.bsdf(back)?),
                    },
                    _ => {
                        return Err(err(
                            &o.at,
                            format!(
                                "twosided needs one or two nested <bsdf>s, not {}",
                                inner.len()
                            ),
                        ));
                    }
                }
            }
            "conductor" => {
                let (eta, k) = self.conductor_ior(o)?;
                Bsdf::Conductor {
                    eta,
                    k,
                    specular_reflectance: self.texture(o, "specular_reflectance", 1.0)?,
                }
            }
            "roughconductor" => {
                let (eta, k) = self.conductor_ior(o)?;
                Bsdf::RoughConductor {
                    eta,
                    k,
                    roughness: self.roughness(o, true)?,
                    specular_reflectance: self.texture(o, "specular_reflectance", 1.0)?,
                    sample_visible: self.boolean(o, "sample_visible", true)?,
                }
            }
            "dielectric" | "thindielectric" => {
                let int_ior = self.ior(o, "int_ior", "bk7")?;
                let ext_ior = self.ior(o, "ext_ior", "air")?;
                let specular_reflectance = self.texture(o, "specular_reflectance", 1.0)?;
                let specular_transmittance = self.texture(o, "specular_transmittance", 1.0)?;
                if o.plugin == "dielectric" {
                    Bsdf::Dielectric {
                        int_ior,
                        ext_ior,
                        specular_reflectance,
                        specular_transmittance,
                    }
                } else {
                    Bsdf::ThinDielectric {
                        int_ior,
                        ext_ior,
                        specular_reflectance,
                        specular_transmittance,
                    }
                }
            }
            "roughdielectric" => Bsdf::RoughDielectric {
                int_ior: self.ior(o, "int_ior", "bk7")?,
                ext_ior: self.ior(o, "ext_ior", "air")?,
                roughness: self.roughness(o, true)?,
                specular_reflectance: self.texture(o, "specular_reflectance", 1.0)?,
                specular_transmittance: self.texture(o, "specular_transmittance", 1.0)?,
                sample_visible: self.boolean(o, "sample_visible", true)?,
            },
            "plastic" => Bsdf::Plastic {
                diffuse_reflectance: self.texture(o, "diffuse_reflectance", 0.5)?,
                specular_reflectance: self.texture(o, "specular_reflectance", 1.0)?,
                int_ior: self.ior(o, "int_ior", "polypropylene")?,
                ext_ior: self.ior(o, "ext_ior", "air")?,
                nonlinear: self.boolean(o, "nonlinear", false)?,
            },
            "roughplastic" => {
                // Mitsuba's roughplastic is isotropic; sample_visible is read by its microfacet model.
                let roughness = self.roughness(o, false)?;
                self.boolean(o, "sample_visible", true)?;
                Bsdf::RoughPlastic {
                    diffuse_reflectance: self.texture(o, "diffuse_reflectance", 0.5)?,
                    specular_reflectance: self.texture(o, "specular_reflectance", 1.0)?,
                    int_ior: self.ior(o, "int_ior", "polypropylene")?,
                    ext_ior: self.ior(o, "ext_ior", "air")?,
                    nonlinear: self.boolean(o, "nonlinear", false)?,
                    roughness,
                }
            }
            "mask" => {
                let opacity = self.texture(o, "opacity", 0.5)?;
                Bsdf::Mask {
                    opacity,
                    inner: Box::new(self.one_inner(o)?),
                }
            }
            "bumpmap" | "normalmap" => {
                self.warn(&o.at, format!("{} is not supported: its nested BSDF is used without the perturbed normals", o.plugin));
                self.one_inner(o)?
            }
            other => {
                self.warn(&o.at, format!("the BSDF \"{other}\" is not supported; a diffuse BSDF of reflectance 0.5 is used"));
                Bsdf::Diffuse {
                    reflectance: Texture::Constant(Vec3::splat(0.5)),
                }
            }
        })
    }

    /// A texture-valued parameter (Mitsuba's `get_texture`): float, `<rgb>`, `<spectrum>` or a
    /// nested texture; `default` when absent.
    pub(crate) fn texture(
        &mut self,
        obj: &Object,
        name: &str,
        default: f32,
    ) -> Result<Texture, SceneError> {
        if obj.props.iter().any(|p| p.name == name) {
            return Ok(Texture::Constant(
                self.color(obj, name, default, false, false)?,
            ));
        }
        match self.named_child(obj, name)? {
            Some((child, _)) => self.texture_object(&child, false, false),
            None => Ok(Texture::Constant(Rgb::splat(default))),
        }
    }

    /// An emitted-radiance parameter (Mitsuba's `get_emissive_texture`).
    pub(crate) fn emissive_texture(
        &mut self,
        obj: &Object,
        name: &str,
        default: f32,
    ) -> Result<Texture, SceneError> {
        if obj.props.iter().any(|p| p.name == name) {
            return Ok(Texture::Constant(
                self.color(obj, name, default, true, false)?,
            ));
        }
        match self.named_child(obj, name)? {
            Some((child, _)) => self.texture_object(&child, true, false),
            None => Ok(Texture::Constant(Rgb::splat(default))),
        }
    }

    /// A `<texture>` (or `<spectrum type=..>`) object.
    pub(crate) fn texture_object(
        &mut self,
        obj: &Rc<Object>,
        emitter: bool,
        unbounded: bool,
    ) -> Result<Texture, SceneError> {
        self.visit(obj);
        let o: &Object = obj;
        match (o.tag.as_str(), o.plugin.as_str()) {
            ("texture", "bitmap") => {
                let (name, at) = self.string(o, "filename")?.ok_or_else(|| {
                    err(&o.at, "the bitmap texture has no filename; expected <string name=\"filename\" value=\"…\"/>")
                })?;
                let raw = self.boolean(o, "raw", false)?;
                let bilinear = match self.string(o, "filter_type")? {
                    None => true,
                    Some((f, at)) => match f.as_str() {
                        "bilinear" => true,
                        "nearest" => false,
                        other => {
                            self.warn(&at, format!("filter_type \"{other}\" is not one of Mitsuba 3's (bilinear, nearest); bilinear is used"));
                            true
                        }
                    },
                };
                let wrap = match self.string(o, "wrap_mode")? {
                    None => WrapMode::Repeat,
                    Some((w, at)) => match w.as_str() {
                        "repeat" => WrapMode::Repeat,
                        "mirror" => WrapMode::Mirror,
                        "clamp" => WrapMode::Clamp,
                        other => {
                            return Err(err(
                                &at,
                                format!(
                                    "wrap_mode \"{other}\" is not one of Mitsuba's: repeat, mirror, clamp"
                                ),
                            ));
                        }
                    },
                };
                let to_uv = self
                    .transform(o, "to_uv")?
                    .map(to_uv)
                    .unwrap_or(Mat3::IDENTITY);
                let image = self.image(&name, &at, raw)?;
                Ok(Texture::Bitmap {
                    image,
                    to_uv,
                    bilinear,
                    wrap,
                })
            }
            ("texture", "checkerboard") => Ok(Texture::Checkerboard {
                color0: self.color(o, "color0", 0.4, emitter, unbounded)?,
                color1: self.color(o, "color1", 0.2, emitter, unbounded)?,
                to_uv: self
                    .transform(o, "to_uv")?
                    .map(to_uv)
                    .unwrap_or(Mat3::IDENTITY),
            }),
            (_, "uniform") => Ok(Texture::Constant(Rgb::splat(
                self.float_or(o, "value", 1.0)?,
            ))),
            (_, "srgb") | (_, "d65") => {
                let c = self.color(o, "color", 1.0, emitter, unbounded)?;
                let scale = self.float_or(o, "scale", 1.0)?;
                Ok(Texture::Constant(c * scale))
            }
            (tag, other) => {
                self.warn(&o.at, format!("<{tag} type=\"{other}\"> is not supported; the constant 0.5 is used instead"));
                Ok(Texture::Constant(Rgb::splat(0.5)))
            }
        }
    }
}
