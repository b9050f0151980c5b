//! Mitsuba 3's XML grammar: files become a tree of objects with typed properties.
//!
//! This layer knows tags, not plugins: it applies `<default>`/`$name` substitution, `<include>`,
//! `<alias>`, `<path>`, `<transform>` composition, the version < 2.0 upgrade, and records where
//! every object and property was written so that later stages can name `file:line`.

use super::spectrum::Spectrum;
use crate::scene::{Location, SceneError, Warning};
use glam::{DMat3, DMat4, DVec3};
use std::cell::Cell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// A property value as written.
#[derive(Clone, Debug)]
pub enum Value {
    /// `<float>`.
    Float(f64),
    /// `<integer>`.
    Integer(i64),
    /// `<boolean>`.
    Boolean(bool),
    /// `<string>`.
    String(String),
    /// `<point>`.
    Point(DVec3),
    /// `<vector>`.
    Vector(DVec3),
    /// `<rgb>`.
    Rgb(DVec3),
    /// `<spectrum>` (not yet reduced to RGB: that depends on whether an emitter uses it).
    Spectrum(Spectrum),
    /// `<transform>`, composed.
    Transform(DMat4),
}

impl Value {
    /// The tag that writes this kind of value, for messages.
    pub fn kind(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Point(_) => "point",
            Value::Vector(_) => "vector",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) => "spectrum",
            Value::Transform(_) => "transform",
        }
    }
}

/// A named property of an object.
#[derive(Debug)]
pub struct Prop {
    /// Its name (after the version upgrade).
    pub name: String,
    /// Its value.
    pub value: Value,
    /// Where it was written.
    pub at: Location,
    /// Whether a plugin read it (the rest are reported as ignored).
    pub used: Cell<bool>,
}

/// A nested object, written inline or through `<ref>`.
#[derive(Debug)]
pub struct Child {
    /// The slot name (`name=`), if any.
    pub name: Option<String>,
    /// The object, inline or referenced by id.
    pub target: Target,
    /// Where the child (or its `<ref>`) was written.
    pub at: Location,
    /// Whether a plugin took it.
    pub used: Cell<bool>,
}

/// The object a [`Child`] stands for.
#[derive(Debug)]
pub enum Target {
    /// Written in place.
    Inline(Rc<Object>),
    /// `<ref id=".."/>`, resolved through [`Document::ids`].
    Ref(String),
}

/// An object element: `<scene>`, `<bsdf type=..>`, `<shape type=..>`, …
#[derive(Debug)]
pub struct Object {
    /// The tag (`bsdf`, `shape`, `texture`, `spectrum`, …).
    pub tag: String,
    /// The plugin (`type=`); `scene` for the root.
    pub plugin: String,
    /// `id=`, if given.
    pub id: Option<String>,
    /// Where it was written.
    pub at: Location,
    /// Its properties, in file order.
    pub props: Vec<Prop>,
    /// Its nested objects, in file order.
    pub children: Vec<Child>,
}

impl Object {
    /// The property called `name`, marked as used.
    pub fn prop(&self, name: &str) -> Option<&Prop> {
        let p = self.props.iter().rev().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    /// Whether a property or named child called `name` exists (without marking it used).
    pub fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
            || self
                .children
                .iter()
                .any(|c| c.name.as_deref() == Some(name))
    }
}

/// A parsed scene: the root object, every object by id, and the search paths for files.
#[derive(Debug)]
pub struct Document {
    /// The `<scene>` element.
    pub root: Rc<Object>,
    /// Objects by `id` (and `<alias>` names).
    pub ids: HashMap<String, Rc<Object>>,
    /// Folders files are looked up in: the scene's folder, then `<path>` entries.
    pub search_paths: Vec<PathBuf>,
    /// Warnings from parsing.
    pub warnings: Vec<Warning>,
}

impl Document {
    /// The object a child stands for.
    pub fn resolve<'a>(&'a self, child: &'a Child) -> Result<&'a Rc<Object>, SceneError> {
        match &child.target {
            Target::Inline(o) => Ok(o),
            Target::Ref(id) => self.ids.get(id).ok_or_else(|| SceneError {
                at: child.at.clone(),
                message: format!("<ref id=\"{id}\"> names no object; expected the id of an object declared in the scene"),
            }),
        }
    }

    /// Finds a file named in the scene: absolute, or relative to a search path. Missing files
    /// resolve to the first candidate, so the error names the place it was expected.
    pub fn find_file(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        for dir in self.search_paths.iter().rev() {
            let candidate = dir.join(p);
            if candidate.exists() {
                return candidate;
            }
        }
        self.search_paths
            .first()
            .map(|d| d.join(p))
            .unwrap_or_else(|| p.to_path_buf())
    }
}

/// State shared by every file of one scene while parsing.
struct Parser<'d> {
    defines: &'d [(String, String)],
    /// `<default>` values seen so far.
    defaults: HashMap<String, String>,
    /// Which `-D` names were substituted somewhere.
    defines_used: Vec<bool>,
    ids: HashMap<String, Rc<Object>>,
    search_paths: Vec<PathBuf>,
    warnings: Vec<Warning>,
    /// Files being included, to stop include cycles.
    stack: Vec<PathBuf>,
}

/// Parses a scene file and everything it includes.
pub fn parse_file(path: &Path, defines: &[(String, String)]) -> Result<Document, SceneError> {
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut parser = Parser {
        defines,
        defaults: HashMap::new(),
        defines_used: vec![false; defines.len()],
        ids: HashMap::new(),
        search_paths: vec![dir],
        warnings: Vec::new(),
        stack: Vec::new(),
    };
    let (props, children, at) = parser.file(path)?;
    let root = Rc::new(Object {
        tag: "scene".into(),
        plugin: "scene".into(),
        id: None,
        at: at.clone(),
        props,
        children,
    });
    for (i, (name, _)) in defines.iter().enumerate() {
        if !parser.defines_used[i] {
            parser.warnings.push(Warning {
                at: Location {
                    file: path.to_path_buf(),
                    line: 0,
                },
                message: format!("the define {name}=… is not used by the scene (no ${name} in it)"),
            });
        }
    }
    let doc = Document {
        root,
        ids: parser.ids,
        search_paths: parser.search_paths,
        warnings: parser.warnings,
    };
    check_refs(&doc, &doc.root)?;
    Ok(doc)
}

/// Every `<ref>` must name an object, used or not (Mitsuba rejects such files too).
fn check_refs(doc: &Document, obj: &Object) -> Result<(), SceneError> {
    for child in &obj.children {
        match &child.target {
            Target::Inline(o) => check_refs(doc, o)?,
            Target::Ref(_) => {
                doc.resolve(child)?;
            }
        }
    }
    Ok(())
}

fn err(at: &Location, message: impl Into<String>) -> SceneError {
    SceneError {
        at: at.clone(),
        message: message.into(),
    }
}

/// Line (1-based) of a byte offset.
fn line_of(text: &str, pos: usize) -> u32 {
    let end = pos.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count() as u32
        + 1
}

/// `major.minor.patch` → whether the file predates Mitsuba 2 (and needs the upgrade).
fn parse_version(v: &str, at: &Location) -> Result<bool, SceneError> {
    let major = v
        .trim()
        .split('.')
        .next()
        .and_then(|m| m.trim().parse::<u32>().ok())
        .ok_or_else(|| {
            err(
                at,
                format!(
                    "version=\"{v}\" is not a version; expected major.minor.patch such as \"3.0.0\""
                ),
            )
        })?;
    Ok(major < 2)
}

/// Mitsuba's camelCase → snake_case for pre-2.0 property names (`intIOR` → `int_ior`).
pub fn camel_to_snake(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

type Parsed = (Vec<Prop>, Vec<Child>, Location);

impl Parser<'_> {
    /// Parses one file whose root is `<scene>`; returns the root's properties and children.
    fn file(&mut self, path: &Path) -> Result<Parsed, SceneError> {
        let at0 = Location {
            file: path.to_path_buf(),
            line: 0,
        };
        let text = std::fs::read_to_string(path)
            .map_err(|e| err(&at0, format!("cannot read the scene file: {e}")))?;
        let doc = roxmltree::Document::parse(&text).map_err(|e| {
            let pos = e.pos();
            err(
                &Location {
                    file: path.to_path_buf(),
                    line: pos.row,
                },
                format!("not well-formed XML: {e}"),
            )
        })?;
        let root = doc.root_element();
        let at = Location {
            file: path.to_path_buf(),
            line: line_of(&text, root.range().start),
        };
        if root.tag_name().name() != "scene" {
            return Err(err(
                &at,
                format!(
                    "the root element is <{}>; expected <scene version=\"3.0.0\">",
                    root.tag_name().name()
                ),
            ));
        }
        let version = root.attribute("version").ok_or_else(|| {
            err(
                &at,
                "<scene> has no version attribute; expected e.g. version=\"3.0.0\"",
            )
        })?;
        let version = self.substitute(version, &at)?;
        let v1 = parse_version(&version, &at)?;
        self.stack.push(path.to_path_buf());
        let mut obj = Building {
            props: Vec::new(),
            children: Vec::new(),
        };
        let file = FileCtx {
            path,
            text: &text,
            v1,
        };
        for node in root.children().filter(|n| n.is_element()) {
            self.element(&file, node, &mut obj, true)?;
        }
        self.stack.pop();
        Ok((obj.props, obj.children, at))
    }

    /// Replaces `$name` with `-D` values first, then `<default>`s; an unset name is an error.
    fn substitute(&mut self, value: &str, at: &Location) -> Result<String, SceneError> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut out = String::with_capacity(value.len());
        let bytes = value.as_bytes();
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i] == b'$' && !(i > 0 && bytes[i - 1] == b'\\') {
                let start = i + 1;
                let mut end = start;
                while end < bytes.len()
                    && (bytes[end].is_ascii_alphanumeric() || bytes[end] == b'_')
                {
                    end += 1;
                }
                let name = &value[start..end];
                let found = self.defines.iter().position(|(k, _)| k == name);
                let replacement = if let Some(k) = found {
                    self.defines_used[k] = true;
                    self.defines[k].1.clone()
                } else if let Some(v) = self.defaults.get(name) {
                    v.clone()
                } else {
                    return Err(err(
                        at,
                        format!(
                            "${name} is not set; expected a <default name=\"{name}\" value=\"…\"/> before it or a define {name}=… (-D)"
                        ),
                    ));
                };
                out.push_str(&replacement);
                i = end;
            } else {
                let ch = value[i..].chars().next().unwrap_or(' ');
                out.push(ch);
                i += ch.len_utf8();
            }
        }
        Ok(out)
    }

    fn attr(
        &mut self,
        node: roxmltree::Node,
        name: &str,
        at: &Location,
    ) -> Result<Option<String>, SceneError> {
        match node.attribute(name) {
            Some(v) => self.substitute(v, at).map(Some),
            None => Ok(None),
        }
    }

    fn required(
        &mut self,
        node: roxmltree::Node,
        name: &str,
        at: &Location,
    ) -> Result<String, SceneError> {
        self.attr(node, name, at)?.ok_or_else(|| {
            err(
                at,
                format!(
                    "<{}> has no {name} attribute; it is required",
                    node.tag_name().name()
                ),
            )
        })
    }

    /// One element inside an object (or the scene).
    fn element(
        &mut self,
        file: &FileCtx,
        node: roxmltree::Node,
        parent: &mut Building,
        at_root: bool,
    ) -> Result<(), SceneError> {
        let at = file.at(node);
        let tag = node.tag_name().name();
        let name = self
            .attr(node, "name", &at)?
            .map(|n| if file.v1 { camel_to_snake(&n) } else { n });
        let named = |name: &Option<String>, at: &Location| -> Result<String, SceneError> {
            name.clone().ok_or_else(|| {
                err(
                    at,
                    format!("<{tag}> has no name attribute; properties need one"),
                )
            })
        };
        let push = |parent: &mut Building, name: String, value: Value, at: Location| {
            parent.props.push(Prop {
                name,
                value,
                at,
                used: Cell::new(false),
            });
        };
        match tag {
            "float" => {
                let n = named(&name, &at)?;
                let v = self.required(node, "value", &at)?;
                push(parent, n, Value::Float(parse_f64(&v, &at)?), at);
            }
            "integer" => {
                let n = named(&name, &at)?;
                let v = self.required(node, "value", &at)?;
                let i = v.trim().parse::<i64>().map_err(|_| {
                    err(
                        &at,
                        format!("could not parse the integer \"{v}\"; expected a whole number"),
                    )
                })?;
                push(parent, n, Value::Integer(i), at);
            }
            "boolean" => {
                let n = named(&name, &at)?;
                let v = self.required(node, "value", &at)?;
                let b = match v.trim().to_ascii_lowercase().as_str() {
                    "true" => true,
                    "false" => false,
                    _ => {
                        return Err(err(
                            &at,
                            format!("could not parse the boolean \"{v}\"; expected true or false"),
                        ));
                    }
                };
                push(parent, n, Value::Boolean(b), at);
            }
            "string" => {
                let n = named(&name, &at)?;
                let v = self.required(node, "value", &at)?;
                push(parent, n, Value::String(v), at);
            }
            "point" | "vector" => {
                let n = named(&name, &at)?;
                let v = self.xyz(node, &at, None)?;
                push(
                    parent,
                    n,
                    if tag == "point" {
                        Value::Point(v)
                    } else {
                        Value::Vector(v)
                    },
                    at,
                );
            }
            "rgb" => {
                let n = named(&name, &at)?;
                let v = self.required(node, "value", &at)?;
                let nums = parse_list(&v, &at)?;
                let c = match nums.as_slice() {
                    [g] => DVec3::splat(*g),
                    [r, g, b] => DVec3::new(*r, *g, *b),
                    _ => {
                        return Err(err(
                            &at,
                            format!(
                                "<rgb value=\"{v}\"> has {} numbers; expected 1 or 3",
                                nums.len()
                            ),
                        ));
                    }
                };
                push(parent, n, Value::Rgb(c), at);
            }
            "spectrum" if node.attribute("type").is_none() => {
                let n = named(&name, &at)?;
                let value = self.attr(node, "value", &at)?;
                let filename = self.attr(node, "filename", &at)?;
                let s = match (value, filename) {
                    (Some(v), None) => Spectrum::parse(&v, &at)?,
                    (None, Some(f)) => {
                        let path = find_in(&self.search_paths, &f);
                        Spectrum::from_file(&path, &at)?
                    }
                    _ => {
                        return Err(err(
                            &at,
                            "<spectrum> needs either value=\"…\" or filename=\"…\" (one of them)",
                        ));
                    }
                };
                push(parent, n, Value::Spectrum(s), at);
            }
            "transform" => {
                let n = named(&name, &at)?;
                let m = self.transform(file, node)?;
                push(parent, n, Value::Transform(m), at);
            }
            "ref" => {
                let id = self.required(node, "id", &at)?;
                parent.children.push(Child {
                    name,
                    target: Target::Ref(id),
                    at,
                    used: Cell::new(false),
                });
            }
            "default" => {
                if !at_root {
                    return Err(err(&at, "<default> must be a child of <scene>"));
                }
                let n = self.required(node, "name", &at)?;
                let v = self.required(node, "value", &at)?;
                // Defines given by the caller win; the first <default> of a name wins too.
                self.defaults.entry(n).or_insert(v);
            }
            "include" => {
                let f = self.required(node, "filename", &at)?;
                let dir = file
                    .path
                    .parent()
                    .map(Path::to_path_buf)
                    .unwrap_or_default();
                let mut candidates = vec![dir];
                candidates.extend(self.search_paths.iter().cloned());
                let path = find_in(&candidates, &f);
                if !path.exists() {
                    return Err(err(
                        &at,
                        format!("<include>: the file {} does not exist", path.display()),
                    ));
                }
                if self.stack.iter().any(|p| p == &path) {
                    return Err(err(
                        &at,
                        format!("<include>: {} includes itself", path.display()),
                    ));
                }
                let (props, children, _) = self.file(&path)?;
                parent.props.extend(props);
                parent.children.extend(children);
            }
            "alias" => {
                let id = self.required(node, "id", &at)?;
                let alias = self.required(node, "as", &at)?;
                let target = self.ids.get(&id).cloned().ok_or_else(|| {
                    err(
                        &at,
                        format!("<alias>: no object with id \"{id}\" is declared before it"),
                    )
                })?;
                if self.ids.contains_key(&alias) {
                    return Err(err(
                        &at,
                        format!("<alias>: the id \"{alias}\" is already taken"),
                    ));
                }
                self.ids.insert(alias, target);
            }
            "path" => {
                if !at_root {
                    return Err(err(&at, "<path> must be a child of <scene>"));
                }
                let v = self.required(node, "value", &at)?;
                let dir = file
                    .path
                    .parent()
                    .map(|d| d.join(&v))
                    .unwrap_or_else(|| PathBuf::from(&v));
                if !dir.is_dir() {
                    return Err(err(
                        &at,
                        format!("<path>: the folder {} does not exist", dir.display()),
                    ));
                }
                self.search_paths.push(dir);
            }
            "scene" | "bsdf" | "emitter" | "film" | "integrator" | "rfilter" | "sampler"
            | "sensor" | "shape" | "texture" | "medium" | "phase" | "volume" | "spectrum" => {
                let plugin = self.required(node, "type", &at)?;
                let id = self.attr(node, "id", &at)?;
                let mut obj = Building {
                    props: Vec::new(),
                    children: Vec::new(),
                };
                for child in node.children().filter(|n| n.is_element()) {
                    self.element(file, child, &mut obj, false)?;
                }
                if file.v1 {
                    upgrade_v1(&plugin, &mut obj, &at);
                }
                let object = Rc::new(Object {
                    tag: tag.to_string(),
                    plugin,
                    id: id.clone(),
                    at: at.clone(),
                    props: obj.props,
                    children: obj.children,
                });
                if let Some(id) = id
                    && self.ids.insert(id.clone(), object.clone()).is_some()
                {
                    return Err(err(
                        &at,
                        format!("the id \"{id}\" is used twice; ids must be unique"),
                    ));
                }
                parent.children.push(Child {
                    name,
                    target: Target::Inline(object),
                    at,
                    used: Cell::new(false),
                });
            }
            other => {
                return Err(err(&at, format!("<{other}> is not a Mitsuba 3 element")));
            }
        }
        Ok(())
    }

    /// `value="x, y, z"` or `x= y= z=` (missing components take `fill`, or are an error).
    fn xyz(
        &mut self,
        node: roxmltree::Node,
        at: &Location,
        fill: Option<f64>,
    ) -> Result<DVec3, SceneError> {
        if let Some(v) = self.attr(node, "value", at)? {
            let nums = parse_list(&v, at)?;
            return match nums.as_slice() {
                [s] if fill.is_some() => Ok(DVec3::splat(*s)),
                [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
                _ => Err(err(
                    at,
                    format!("value=\"{v}\" has {} numbers; expected 3", nums.len()),
                )),
            };
        }
        let mut out = [0.0; 3];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            out[k] = match self.attr(node, axis, at)? {
                Some(v) => parse_f64(&v, at)?,
                None => fill.ok_or_else(|| {
                    err(
                        at,
                        format!(
                            "<{}> has no {axis} attribute; expected x, y and z or value",
                            node.tag_name().name()
                        ),
                    )
                })?,
            };
        }
        Ok(DVec3::from(out))
    }

    /// `<transform>`: each step left-multiplies what came before, as in Mitsuba.
    fn transform(&mut self, file: &FileCtx, node: roxmltree::Node) -> Result<DMat4, SceneError> {
        let mut m = DMat4::IDENTITY;
        for step in node.children().filter(|n| n.is_element()) {
            let at = file.at(step);
            let s = match step.tag_name().name() {
                "translate" => DMat4::from_translation(self.xyz(step, &at, Some(0.0))?),
                "scale" => DMat4::from_scale(self.xyz(step, &at, Some(1.0))?),
                "rotate" => {
                    let axis = self.xyz(step, &at, Some(0.0))?;
                    if axis == DVec3::ZERO {
                        return Err(err(
                            &at,
                            "<rotate> has a zero axis; expected x, y or z (or value) to be non-zero",
                        ));
                    }
                    let angle = parse_f64(&self.required(step, "angle", &at)?, &at)?;
                    DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
                }
                "matrix" => {
                    let v = self.required(step, "value", &at)?;
                    let nums = parse_list(&v, &at)?;
                    match nums.len() {
                        16 => DMat4::from_cols_array(&nums.try_into().unwrap_or([0.0; 16]))
                            .transpose(),
                        9 => {
                            let m3 = DMat3::from_cols_array(&nums.try_into().unwrap_or([0.0; 9]))
                                .transpose();
                            DMat4::from_mat3(m3)
                        }
                        n => {
                            return Err(err(
                                &at,
                                format!(
                                    "<matrix> has {n} numbers; expected 16 (4×4) or 9 (3×3), row by row"
                                ),
                            ));
                        }
                    }
                }
                "lookat" => {
                    let origin = parse_vec3(&self.required(step, "origin", &at)?, &at)?;
                    let target = parse_vec3(&self.required(step, "target", &at)?, &at)?;
                    let up = match self.attr(step, "up", &at)? {
                        Some(u) => parse_vec3(&u, &at)?,
                        None => DVec3::ZERO,
                    };
                    look_at(origin, target, up).ok_or_else(|| {
                        err(&at, "<lookat> is degenerate (origin = target, or up parallel to the view direction)")
                    })?
                }
                other => {
                    return Err(err(
                        &at,
                        format!(
                            "<{other}> is not a transform step; expected translate, rotate, scale, matrix or lookat"
                        ),
                    ));
                }
            };
            m = s * m;
        }
        Ok(m)
    }
}

/// Mitsuba's `look_at`: columns (left = up × dir, up' = dir × left, dir, origin); a zero `up`
/// is replaced by one perpendicular to the view direction.
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).normalize_or_zero();
    if dir == DVec3::ZERO {
        return None;
    }
    let up = if up == DVec3::ZERO {
        coordinate_system(dir).0
    } else {
        up.normalize()
    };
    let left = up.cross(dir).normalize_or_zero();
    if left == DVec3::ZERO || !left.is_finite() {
        return None;
    }
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// Two vectors perpendicular to `n` (Duff et al.'s branchless frame, as Mitsuba builds it).
fn coordinate_system(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(n.x * n.x * a * sign + 1.0, b * sign, -n.x * sign),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Pre-2.0 files: Mitsuba's per-object upgrade (property names were already made snake_case).
fn upgrade_v1(plugin: &str, obj: &mut Building, at: &Location) {
    if plugin == "diffuse" {
        for p in obj
            .props
            .iter_mut()
            .filter(|p| p.name == "diffuse_reflectance")
        {
            p.name = "reflectance".into();
        }
        for c in obj
            .children
            .iter_mut()
            .filter(|c| c.name.as_deref() == Some("diffuse_reflectance"))
        {
            c.name = Some("reflectance".into());
        }
    }
    let mut offset = DVec3::ZERO;
    let mut scale = DVec3::ONE;
    let mut any = false;
    obj.props.retain(|p| {
        let slot = match p.name.as_str() {
            "uoffset" => &mut offset.x,
            "voffset" => &mut offset.y,
            "uscale" => &mut scale.x,
            "vscale" => &mut scale.y,
            _ => return true,
        };
        if let Value::Float(v) = p.value {
            *slot = v;
        } else if let Value::Integer(v) = p.value {
            *slot = v as f64;
        }
        any = true;
        false
    });
    if any {
        let m = DMat4::from_scale(scale) * DMat4::from_translation(offset);
        obj.props.push(Prop {
            name: "to_uv".into(),
            value: Value::Transform(m),
            at: at.clone(),
            used: Cell::new(false),
        });
    }
}

struct Building {
    props: Vec<Prop>,
    children: Vec<Child>,
}

struct FileCtx<'a> {
    path: &'a Path,
    text: &'a str,
    v1: bool,
}

impl FileCtx<'_> {
    fn at(&self, node: roxmltree::Node) -> Location {
        Location {
            file: self.path.to_path_buf(),
            line: line_of(self.text, node.range().start),
        }
    }
}

fn find_in(dirs: &[PathBuf], name: &str) -> PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        return p.to_path_buf();
    }
    for d in dirs.iter().rev() {
        if d.join(p).exists() {
            return d.join(p);
        }
    }
    dirs.first()
        .map(|d| d.join(p))
        .unwrap_or_else(|| p.to_path_buf())
}

/// One number, as Mitsuba reads it.
pub fn parse_f64(s: &str, at: &Location) -> Result<f64, SceneError> {
    let t = s.trim();
    t.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            err(
                at,
                format!("could not parse the number \"{s}\"; expected a finite decimal number"),
            )
        })
}

/// Numbers separated by commas and/or white space.
pub fn parse_list(s: &str, at: &Location) -> Result<Vec<f64>, SceneError> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| parse_f64(t, at))
        .collect()
}

fn parse_vec3(s: &str, at: &Location) -> Result<DVec3, SceneError> {
    let v = parse_list(s, at)?;
    match v.as_slice() {
        [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(err(
            at,
            format!("\"{s}\" has {} numbers; expected 3", v.len()),
        )),
    }
}
