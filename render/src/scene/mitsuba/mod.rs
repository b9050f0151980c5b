//! Mitsuba 3 XML scenes (`scene.xml`) → [`Scene`].
//!
//! [`xml`] reads the grammar into objects with typed properties; this module instantiates the
//! plugins optik supports with Mitsuba's parameter names and defaults (src/bsdfs, src/emitters,
//! src/shapes of Mitsuba 3.9.1). Whatever is not supported, or written but not read, becomes a
//! [`Warning`] naming the file and line; what makes the scene meaningless (no sensor, a missing
//! mesh, a malformed number, an unset `$name`, an unknown `<ref>`) is a [`SceneError`].

pub mod data;
mod materials;
pub use materials::{named_conductor, named_ior};
mod shapes;
pub mod spectrum;
pub mod xml;

use super::{
    Aov, AovKind, Camera, DirectSettings, Emitter, Film, Filter, FovAxis, Integrator, Location,
    PathSettings, Rgb, Sampler, Scene, SceneError, Warning,
};
use glam::{DMat4, DVec3, Mat4};
use std::collections::HashMap;
use std::path::Path;
use std::rc::Rc;
use xml::{Document, Object, Value};

/// Loads a Mitsuba 3 XML scene; `defines` set `$name` parameters (Mitsuba's `-D name=value`),
/// overriding `<default>`s.
pub fn load(path: &Path, defines: &[(String, String)]) -> Result<Scene, SceneError> {
    let doc = xml::parse_file(path, defines)?;
    let mut b = Builder::new(&doc);
    b.scene.warnings = doc.warnings.clone();
    b.build()?;
    b.report_unused();
    Ok(b.scene)
}

/// Instantiates plugins; remembers shared objects so a `<ref>`ed BSDF becomes one material.
pub(crate) struct Builder<'d> {
    doc: &'d Document,
    scene: Scene,
    /// Every object a plugin read, for reporting properties nobody read.
    visited: Vec<Rc<Object>>,
    materials: HashMap<*const Object, u32>,
    images: HashMap<(std::path::PathBuf, bool), u32>,
    groups: HashMap<*const Object, u32>,
    default_material: Option<u32>,
}

/// A nested object: its slot name, the object, and where it (or its `<ref>`) was written.
type Nested = (Option<String>, Rc<Object>, Location);

fn err(at: &Location, message: impl Into<String>) -> SceneError {
    SceneError {
        at: at.clone(),
        message: message.into(),
    }
}

/// A 4×4 transform as f32.
fn mat4(m: DMat4) -> Mat4 {
    m.as_mat4()
}

impl<'d> Builder<'d> {
    fn new(doc: &'d Document) -> Self {
        Builder {
            doc,
            scene: Scene::default(),
            visited: Vec::new(),
            materials: HashMap::new(),
            images: HashMap::new(),
            groups: HashMap::new(),
            default_material: None,
        }
    }

    fn warn(&mut self, at: &Location, message: impl Into<String>) {
        self.scene.warnings.push(Warning {
            at: at.clone(),
            message: message.into(),
        });
    }

    /// Marks an object as read by a plugin.
    fn visit(&mut self, obj: &Rc<Object>) {
        if !self.visited.iter().any(|o| Rc::ptr_eq(o, obj)) {
            self.visited.push(obj.clone());
        }
    }

    /// The nested objects of `obj` (inline or referenced), optionally only those of one tag;
    /// each returned child is marked used.
    fn children(&self, obj: &Object, tag: &str) -> Result<Vec<Nested>, SceneError> {
        let mut out = Vec::new();
        for c in &obj.children {
            let o = self.doc.resolve(c)?;
            if o.tag == tag || (tag == "texture" && o.tag == "spectrum") {
                c.used.set(true);
                out.push((c.name.clone(), o.clone(), c.at.clone()));
            }
        }
        Ok(out)
    }

    /// The nested object in slot `name` (e.g. `<texture name="reflectance">`).
    fn named_child(
        &self,
        obj: &Object,
        name: &str,
    ) -> Result<Option<(Rc<Object>, Location)>, SceneError> {
        for c in obj.children.iter().rev() {
            if c.name.as_deref() == Some(name) {
                c.used.set(true);
                return Ok(Some((self.doc.resolve(c)?.clone(), c.at.clone())));
            }
        }
        Ok(None)
    }

    fn build(&mut self) -> Result<(), SceneError> {
        let root = self.doc.root.clone();
        self.visit(&root);
        let mut sensor_seen = false;
        let mut integrator_seen = false;
        for c in &root.children {
            let obj = self.doc.resolve(c)?.clone();
            // Objects declared at the top with an id are built when something refers to them.
            let declared_only = matches!(obj.tag.as_str(), "bsdf" | "texture" | "spectrum")
                || (obj.tag == "shape" && obj.plugin == "shapegroup");
            c.used.set(true);
            match obj.tag.as_str() {
                "sensor" if sensor_seen => {
                    self.warn(
                        &obj.at,
                        "a second <sensor> is ignored; optik renders the first one",
                    );
                }
                "sensor" => {
                    sensor_seen = true;
                    self.sensor(&obj)?;
                }
                "integrator" if integrator_seen => {
                    self.warn(
                        &obj.at,
                        "a second <integrator> is ignored; the first one is used",
                    );
                }
                "integrator" => {
                    integrator_seen = true;
                    self.scene.integrator = self.integrator(&obj)?;
                }
                "shape" if declared_only => {
                    self.shape_group(&obj)?;
                }
                "shape" => {
                    let mut out = shapes::Shapes::default();
                    self.shape(&obj, &mut out)?;
                    self.scene.meshes.extend(out.meshes);
                    self.scene.spheres.extend(out.spheres);
                    self.scene.instances.extend(out.instances);
                }
                "emitter" => self.emitter(&obj)?,
                _ if declared_only => {
                    if obj.id.is_none() {
                        self.warn(
                            &obj.at,
                            format!(
                                "a <{}> at the top level without an id is never used",
                                obj.tag
                            ),
                        );
                    }
                }
                other => {
                    self.warn(
                        &obj.at,
                        format!(
                            "<{other} type=\"{}\"> is not supported and is ignored",
                            obj.plugin
                        ),
                    );
                }
            }
        }
        if !sensor_seen {
            return Err(err(
                &root.at,
                "the scene has no <sensor>; expected a <sensor type=\"perspective\">",
            ));
        }
        Ok(())
    }

    /// Warns about every property or nested object of a read object that no plugin read.
    fn report_unused(&mut self) {
        let mut warnings = Vec::new();
        for obj in &self.visited {
            for p in &obj.props {
                if !p.used.get() {
                    warnings.push(Warning {
                        at: p.at.clone(),
                        message: format!(
                            "<{} name=\"{}\"> of <{} type=\"{}\"> is not used by optik and is ignored",
                            p.value.kind(),
                            p.name,
                            obj.tag,
                            obj.plugin
                        ),
                    });
                }
            }
            for c in &obj.children {
                if !c.used.get() {
                    let what = match self.doc.resolve(c) {
                        Ok(o) => format!("<{} type=\"{}\">", o.tag, o.plugin),
                        Err(_) => "a <ref>".to_string(),
                    };
                    warnings.push(Warning {
                        at: c.at.clone(),
                        message: format!(
                            "{what} inside <{} type=\"{}\"> is not used and is ignored",
                            obj.tag, obj.plugin
                        ),
                    });
                }
            }
        }
        warnings.sort_by(|a, b| (&a.at.file, a.at.line).cmp(&(&b.at.file, b.at.line)));
        self.scene.warnings.extend(warnings);
    }

    // ---- typed property access (Mitsuba's Properties::get with defaults) ----

    fn wrong(&self, obj: &Object, p: &xml::Prop, expected: &str) -> SceneError {
        err(
            &p.at,
            format!(
                "\"{}\" of <{} type=\"{}\"> is a <{}>; expected {expected}",
                p.name,
                obj.tag,
                obj.plugin,
                p.value.kind()
            ),
        )
    }

    pub(crate) fn float(&self, obj: &Object, name: &str) -> Result<Option<f64>, SceneError> {
        match obj.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Float(v) => Ok(Some(*v)),
                Value::Integer(v) => Ok(Some(*v as f64)),
                _ => Err(self.wrong(obj, p, "a <float>")),
            },
        }
    }

    pub(crate) fn float_or(
        &self,
        obj: &Object,
        name: &str,
        default: f64,
    ) -> Result<f32, SceneError> {
        Ok(self.float(obj, name)?.unwrap_or(default) as f32)
    }

    pub(crate) fn int(&self, obj: &Object, name: &str) -> Result<Option<i64>, SceneError> {
        match obj.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Integer(v) => Ok(Some(*v)),
                _ => Err(self.wrong(obj, p, "an <integer>")),
            },
        }
    }

    /// A non-negative integer that fits u32.
    pub(crate) fn count(&self, obj: &Object, name: &str, default: u32) -> Result<u32, SceneError> {
        match self.int(obj, name)? {
            None => Ok(default),
            Some(v) => u32::try_from(v).map_err(|_| {
                let at = obj
                    .props
                    .iter()
                    .rev()
                    .find(|p| p.name == name)
                    .map(|p| p.at.clone())
                    .unwrap_or_default();
                err(
                    &at,
                    format!(
                        "\"{name}\" is {v}; expected a whole number from 0 to {}",
                        u32::MAX
                    ),
                )
            }),
        }
    }

    pub(crate) fn boolean(
        &self,
        obj: &Object,
        name: &str,
        default: bool,
    ) -> Result<bool, SceneError> {
        match obj.prop(name) {
            None => Ok(default),
            Some(p) => match &p.value {
                Value::Boolean(v) => Ok(*v),
                _ => Err(self.wrong(obj, p, "a <boolean>")),
            },
        }
    }

    pub(crate) fn string(
        &self,
        obj: &Object,
        name: &str,
    ) -> Result<Option<(String, Location)>, SceneError> {
        match obj.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::String(v) => Ok(Some((v.clone(), p.at.clone()))),
                _ => Err(self.wrong(obj, p, "a <string>")),
            },
        }
    }

    pub(crate) fn point(&self, obj: &Object, name: &str) -> Result<Option<DVec3>, SceneError> {
        match obj.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Point(v) | Value::Vector(v) => Ok(Some(*v)),
                _ => Err(self.wrong(obj, p, "a <point> or <vector>")),
            },
        }
    }

    pub(crate) fn transform(&self, obj: &Object, name: &str) -> Result<Option<DMat4>, SceneError> {
        match obj.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Transform(v) => Ok(Some(*v)),
                _ => Err(self.wrong(obj, p, "a <transform>")),
            },
        }
    }

    /// A colour-valued parameter that optik keeps as one RGB value (emitter intensities,
    /// conductor indices): float, `<rgb>` or `<spectrum>`; a texture there is not supported.
    pub(crate) fn color(
        &mut self,
        obj: &Object,
        name: &str,
        default: f32,
        emitter: bool,
        unbounded: bool,
    ) -> Result<Rgb, SceneError> {
        if let Some(p) = obj.prop(name) {
            return match &p.value {
                Value::Float(v) => Ok(Rgb::splat(*v as f32)),
                Value::Integer(v) => Ok(Rgb::splat(*v as f32)),
                Value::Rgb(c) => Ok(c.as_vec3()),
                Value::Spectrum(s) => Ok(s.to_rgb(emitter, unbounded)),
                _ => Err(self.wrong(obj, p, "a <float>, <rgb> or <spectrum>")),
            };
        }
        if let Some((child, at)) = self.named_child(obj, name)? {
            match self.texture_object(&child, emitter, unbounded)? {
                super::Texture::Constant(c) => return Ok(c),
                _ => self.warn(
                    &at,
                    format!("a textured \"{name}\" is not supported here; the constant {default} is used instead"),
                ),
            }
        }
        Ok(Rgb::splat(default))
    }

    // ---- sensor, film, sampler ----

    fn sensor(&mut self, obj: &Rc<Object>) -> Result<(), SceneError> {
        self.visit(obj);
        match obj.plugin.as_str() {
            "perspective" => {}
            "thinlens" => self.warn(
                &obj.at,
                "the thinlens sensor is rendered as a pinhole (perspective) camera; its aperture is ignored",
            ),
            other => {
                self.warn(&obj.at, format!("the sensor \"{other}\" is not supported; it is rendered as a perspective camera"));
            }
        }
        // The film decides the aspect ratio, which fov_axis smaller/larger depend on.
        for (_, film, _) in self.children(obj, "film")? {
            self.scene.film = self.film(&film)?;
        }
        for (_, sampler, _) in self.children(obj, "sampler")? {
            self.scene.sampler = self.sampler(&sampler)?;
        }
        let mut camera = Camera::default();
        if let Some(m) = self.transform(obj, "to_world")? {
            camera.to_world = mat4(m);
        }
        let fov = self.float(obj, "fov")?;
        let focal = self.string(obj, "focal_length")?;
        match (fov, focal) {
            (Some(_), Some((_, at))) => {
                return Err(err(
                    &at,
                    "the sensor gives both fov and focal_length; expected one of them",
                ));
            }
            (Some(fov), None) => {
                camera.fov_degrees = fov as f32;
                if let Some((axis, at)) = self.string(obj, "fov_axis")? {
                    camera.fov_axis = match axis.to_ascii_lowercase().as_str() {
                        "x" => FovAxis::X,
                        "y" => FovAxis::Y,
                        "diagonal" => FovAxis::Diagonal,
                        "smaller" => FovAxis::Smaller,
                        "larger" => FovAxis::Larger,
                        _ => {
                            return Err(err(
                                &at,
                                format!(
                                    "fov_axis \"{axis}\" is unknown; expected x, y, diagonal, smaller or larger"
                                ),
                            ));
                        }
                    };
                }
            }
            (None, focal) => {
                // Mitsuba: a 35 mm film's diagonal (√(36² + 24²) mm) at the focal length.
                let (f, at) = focal.unwrap_or_else(|| ("50mm".to_string(), obj.at.clone()));
                let mm = f.trim().trim_end_matches("mm");
                let value = mm
                    .trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|v| *v > 0.0)
                    .ok_or_else(|| {
                        err(
                            &at,
                            format!("focal_length \"{f}\" is not a length; expected e.g. \"50mm\""),
                        )
                    })?;
                camera.fov_degrees = (2.0
                    * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * value)).atan())
                .to_degrees() as f32;
                camera.fov_axis = FovAxis::Diagonal;
            }
        }
        camera.near_clip = self.float_or(obj, "near_clip", 1e-2)?;
        camera.far_clip = self.float_or(obj, "far_clip", 1e4)?;
        if !(camera.fov_degrees > 0.0 && camera.fov_degrees < 180.0) {
            return Err(err(
                &obj.at,
                format!(
                    "the field of view is {}°; expected more than 0 and less than 180",
                    camera.fov_degrees
                ),
            ));
        }
        if !(camera.near_clip > 0.0 && camera.far_clip > camera.near_clip) {
            return Err(err(
                &obj.at,
                "near_clip must be positive and below far_clip",
            ));
        }
        self.scene.camera = camera;
        Ok(())
    }

    fn film(&mut self, obj: &Rc<Object>) -> Result<Film, SceneError> {
        self.visit(obj);
        if obj.plugin != "hdrfilm" {
            self.warn(
                &obj.at,
                format!(
                    "the film \"{}\" is read as an hdrfilm (size and filter only)",
                    obj.plugin
                ),
            );
        }
        // Output encodings do not change the image; only unusual ones are worth a warning.
        for (name, fine) in [
            ("pixel_format", &["rgb", "rgba"][..]),
            ("component_format", &["float16", "float32"][..]),
            ("file_format", &["openexr", "exr"][..]),
        ] {
            if let Some((v, at)) = self.string(obj, name)?
                && !fine.contains(&v.to_ascii_lowercase().as_str())
            {
                self.warn(
                    &at,
                    format!("{name} \"{v}\" is ignored; optik writes RGB float images"),
                );
            }
        }
        let mut film = Film {
            width: self.count(obj, "width", 768)?,
            height: self.count(obj, "height", 576)?,
            filter: Filter::default(),
        };
        if film.width == 0 || film.height == 0 {
            return Err(err(
                &obj.at,
                format!(
                    "the film is {}×{}; expected at least 1×1",
                    film.width, film.height
                ),
            ));
        }
        for (_, f, _) in self.children(obj, "rfilter")? {
            self.visit(&f);
            film.filter = match f.plugin.as_str() {
                "box" => Filter::Box,
                "tent" => Filter::Tent {
                    radius: self.float_or(&f, "radius", 1.0)?,
                },
                "gaussian" => Filter::Gaussian {
                    stddev: self.float_or(&f, "stddev", 0.5)?,
                },
                other => {
                    self.warn(&f.at, format!("the reconstruction filter \"{other}\" is not supported; a gaussian (stddev 0.5) is used"));
                    Filter::default()
                }
            };
        }
        Ok(film)
    }

    fn sampler(&mut self, obj: &Rc<Object>) -> Result<Sampler, SceneError> {
        self.visit(obj);
        if obj.plugin != "independent" {
            self.warn(
                &obj.at,
                format!(
                    "the sampler \"{}\" is rendered as an independent sampler",
                    obj.plugin
                ),
            );
        }
        let sample_count = self.count(obj, "sample_count", 4)?;
        if sample_count == 0 {
            return Err(err(
                &obj.at,
                "sample_count is 0; expected at least 1 sample per pixel",
            ));
        }
        Ok(Sampler {
            sample_count,
            seed: self.count(obj, "seed", 0)?,
        })
    }

    // ---- integrators ----

    fn integrator(&mut self, obj: &Rc<Object>) -> Result<Integrator, SceneError> {
        self.visit(obj);
        match obj.plugin.as_str() {
            "path" => Ok(Integrator::Path(self.path_settings(obj)?)),
            "direct" => {
                let shading = self.count(obj, "shading_samples", 1)?;
                Ok(Integrator::Direct(DirectSettings {
                    emitter_samples: self.count(obj, "emitter_samples", shading)?,
                    bsdf_samples: self.count(obj, "bsdf_samples", shading)?,
                    hide_emitters: self.boolean(obj, "hide_emitters", false)?,
                }))
            }
            "aov" => {
                let (list, at) = self.string(obj, "aovs")?.ok_or_else(|| {
                    err(&obj.at, "the aov integrator has no \"aovs\" string; expected e.g. \"albedo:albedo,nn:sh_normal\"")
                })?;
                let mut aovs = Vec::new();
                for entry in list.split(',').map(str::trim).filter(|e| !e.is_empty()) {
                    let (name, kind) = entry.split_once(':').ok_or_else(|| {
                        err(
                            &at,
                            format!(
                                "aov entry \"{entry}\" is not name:type; expected e.g. \"dd:depth\""
                            ),
                        )
                    })?;
                    let kind = match kind.trim() {
                        "albedo" => AovKind::Albedo,
                        "sh_normal" => AovKind::ShadingNormal,
                        "depth" => AovKind::Depth,
                        other => {
                            self.warn(&at, format!("the AOV type \"{other}\" ({name}) is not supported and is left out; optik has albedo, sh_normal and depth"));
                            continue;
                        }
                    };
                    aovs.push(Aov {
                        name: name.trim().to_string(),
                        kind,
                    });
                }
                for (_, inner, at) in self.children(obj, "integrator")? {
                    self.warn(&at, format!("the <integrator type=\"{}\"> inside aov is not rendered; optik's aov integrator writes only the AOVs", inner.plugin));
                }
                Ok(Integrator::Aov(aovs))
            }
            "moment" => {
                let inner = self.children(obj, "integrator")?;
                self.warn(&obj.at, "the moment integrator is unwrapped: its first nested integrator is rendered, without second moments");
                match inner.into_iter().next() {
                    Some((_, i, _)) => self.integrator(&i),
                    None => Err(err(
                        &obj.at,
                        "the moment integrator has no nested <integrator>",
                    )),
                }
            }
            other => {
                self.warn(&obj.at, format!("the integrator \"{other}\" is not supported; it is rendered with path (max_depth, rr_depth, hide_emitters read)"));
                Ok(Integrator::Path(self.path_settings(obj)?))
            }
        }
    }

    fn path_settings(&mut self, obj: &Object) -> Result<PathSettings, SceneError> {
        let max_depth = match self.int(obj, "max_depth")? {
            None | Some(-1) => None,
            Some(d) if d >= 0 => Some(u32::try_from(d).unwrap_or(u32::MAX)),
            Some(d) => {
                return Err(err(
                    &obj.at,
                    format!("max_depth is {d}; expected -1 (unbounded) or a depth ≥ 0"),
                ));
            }
        };
        Ok(PathSettings {
            max_depth,
            rr_depth: self.count(obj, "rr_depth", 5)?,
            hide_emitters: self.boolean(obj, "hide_emitters", false)?,
        })
    }

    // ---- emitters not attached to shapes ----

    fn emitter(&mut self, obj: &Rc<Object>) -> Result<(), SceneError> {
        self.visit(obj);
        let to_world = self.transform(obj, "to_world")?;
        let emitter = match obj.plugin.as_str() {
            "point" => {
                let position = match (self.point(obj, "position")?, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(err(
                            &obj.at,
                            "the point emitter gives both position and to_world; expected one",
                        ));
                    }
                    (Some(p), None) => p,
                    (None, Some(m)) => m.transform_point3(DVec3::ZERO),
                    (None, None) => DVec3::ZERO,
                };
                Emitter::Point {
                    position: position.as_vec3(),
                    intensity: self.color(obj, "intensity", 1.0, true, false)?,
                }
            }
            "spot" => {
                let cutoff_angle = self.float_or(obj, "cutoff_angle", 20.0)?;
                Emitter::Spot {
                    to_world: mat4(to_world.unwrap_or(DMat4::IDENTITY)),
                    intensity: self.color(obj, "intensity", 1.0, true, false)?,
                    cutoff_angle,
                    beam_width: self.float_or(obj, "beam_width", cutoff_angle as f64 * 0.75)?,
                }
            }
            "directional" => {
                let direction = match (self.point(obj, "direction")?, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(err(
                            &obj.at,
                            "the directional emitter gives both direction and to_world; expected one",
                        ));
                    }
                    (Some(d), None) => d,
                    (None, Some(m)) => m.transform_vector3(DVec3::Z),
                    (None, None) => DVec3::Z,
                };
                let direction = direction.normalize_or_zero();
                if direction == DVec3::ZERO {
                    return Err(err(&obj.at, "the directional emitter's direction is zero"));
                }
                Emitter::Directional {
                    direction: direction.as_vec3(),
                    irradiance: self.color(obj, "irradiance", 1.0, true, false)?,
                }
            }
            "constant" => Emitter::Constant {
                radiance: self.color(obj, "radiance", 1.0, true, false)?,
            },
            "envmap" => {
                let (name, at) = self.string(obj, "filename")?.ok_or_else(|| {
                    err(&obj.at, "the envmap has no filename; expected an EXR or HDR latitude-longitude image")
                })?;
                let image = self.image(&name, &at, false)?;
                Emitter::EnvMap {
                    image,
                    scale: self.float_or(obj, "scale", 1.0)?,
                    to_world: mat4(to_world.unwrap_or(DMat4::IDENTITY)),
                }
            }
            "area" => {
                self.warn(
                    &obj.at,
                    "an area emitter must be nested in a shape; this one is ignored",
                );
                return Ok(());
            }
            other => {
                self.warn(&obj.at, format!("the emitter \"{other}\" is not supported and is ignored (the scene gets no light from it)"));
                return Ok(());
            }
        };
        self.scene.emitters.push(emitter);
        Ok(())
    }

    /// Loads (once) an image named in the scene.
    pub(crate) fn image(
        &mut self,
        name: &str,
        at: &Location,
        raw: bool,
    ) -> Result<u32, SceneError> {
        let path = self.doc.find_file(name);
        if let Some(&id) = self.images.get(&(path.clone(), raw)) {
            return Ok(id);
        }
        let img = super::images::load_image(&path, raw).map_err(|m| err(at, m))?;
        let id = self.scene.images.len() as u32;
        self.scene.images.push(img);
        self.images.insert((path, raw), id);
        Ok(id)
    }
}
