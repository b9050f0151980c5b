//! The renderer's scene: one description that every loader produces and the renderer consumes.
//!
//! Loaders ([`mitsuba`] for Mitsuba 3 XML, [`obj`] for OBJ+MTL) turn files into a [`Scene`];
//! nothing here knows about files or about optik devices. Conventions follow Mitsuba 3: a
//! right-handed world, cameras looking down their local +z with +y up in `to_world`, film row 0
//! at the top, colours as linear RGB.

use glam::{Mat3, Mat4, Vec2, Vec3};

pub mod images;
pub mod mitsuba;
pub mod obj;
pub mod shapes;

/// Loads a scene file, choosing the loader by its extension: `.xml` is a Mitsuba 3 scene
/// (`defines` set its `$name` parameters, as Mitsuba's `-D name=value`), `.obj` an OBJ+MTL
/// model (which has no parameters; `defines` must be empty).
pub fn load(path: &std::path::Path, defines: &[(String, String)]) -> Result<Scene, SceneError> {
    let at = Location {
        file: path.to_path_buf(),
        line: 0,
    };
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "xml" => mitsuba::load(path, defines),
        "obj" if defines.is_empty() => obj::load(path),
        "obj" => Err(SceneError {
            at,
            message: "defines (-D) apply to Mitsuba XML scenes; an OBJ model has no parameters"
                .into(),
        }),
        _ => Err(SceneError {
            at,
            message: format!(
                "unknown scene format \".{ext}\"; expected a Mitsuba 3 scene (.xml) or an OBJ model (.obj)"
            ),
        }),
    }
}

/// Linear RGB.
pub type Rgb = Vec3;

/// Where in an input file something was written, for warnings and errors (`file:line`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Location {
    /// The file, as given or resolved.
    pub file: std::path::PathBuf,
    /// 1-based line (0 when unknown).
    pub line: u32,
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.file.display(), self.line)
    }
}

/// Something the loader ignored or replaced; rendering goes on.
#[derive(Clone, Debug, PartialEq)]
pub struct Warning {
    /// Where it was written.
    pub at: Location,
    /// What was ignored or replaced, and what is used instead.
    pub message: String,
}

/// A loader failure: the scene cannot be rendered sensibly, and nothing is written.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneError {
    /// Where the problem is.
    pub at: Location,
    /// What was wrong and what was expected.
    pub message: String,
}

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.at, self.message)
    }
}

impl std::error::Error for SceneError {}

/// A whole scene, ready to render.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// Image size and reconstruction filter.
    pub film: Film,
    /// Samples per pixel and seed.
    pub sampler: Sampler,
    /// The light transport algorithm and its settings.
    pub integrator: Integrator,
    /// Triangle meshes in world space (not in a shape group).
    pub meshes: Vec<Mesh>,
    /// Spheres in world space (not in a shape group), traced as optik's built-in spheres.
    pub spheres: Vec<Sphere>,
    /// Shape groups, placed only through [`Scene::instances`].
    pub groups: Vec<ShapeGroup>,
    /// Placements of shape groups (a two-level scene: an instance acceleration structure).
    pub instances: Vec<Instance>,
    /// Materials, indexed by [`MaterialId`].
    pub materials: Vec<Bsdf>,
    /// Images used by textures, indexed by [`ImageId`].
    pub images: Vec<Image>,
    /// Emitters that are not attached to a shape (point, spot, directional, constant, envmap).
    pub emitters: Vec<Emitter>,
    /// What the loader ignored or replaced.
    pub warnings: Vec<Warning>,
}

/// Index into [`Scene::materials`].
pub type MaterialId = u32;
/// Index into [`Scene::images`].
pub type ImageId = u32;

/// A pinhole camera (Mitsuba's `perspective` sensor).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Camera to world; the camera looks down its local +z, +y is up (Mitsuba's convention,
    /// where `lookat` builds this matrix with x = up × dir, i.e. the image x axis points left).
    pub to_world: Mat4,
    /// Field of view in degrees, measured along [`Camera::fov_axis`].
    pub fov_degrees: f32,
    /// The axis the field of view is measured along.
    pub fov_axis: FovAxis,
    /// Near clip distance.
    pub near_clip: f32,
    /// Far clip distance.
    pub far_clip: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            to_world: Mat4::IDENTITY,
            fov_degrees: 45.0,
            fov_axis: FovAxis::X,
            near_clip: 1e-2,
            far_clip: 1e4,
        }
    }
}

/// Which image axis a field of view is measured along (Mitsuba's `fov_axis`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FovAxis {
    /// Horizontal.
    #[default]
    X,
    /// Vertical.
    Y,
    /// The diagonal.
    Diagonal,
    /// The shorter image side.
    Smaller,
    /// The longer image side.
    Larger,
}

/// Image size and reconstruction filter (Mitsuba's `hdrfilm`).
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The pixel reconstruction filter.
    pub filter: Filter,
}

impl Default for Film {
    fn default() -> Self {
        Film {
            width: 768,
            height: 576,
            filter: Filter::default(),
        }
    }
}

/// A pixel reconstruction filter, as Mitsuba defines them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// One pixel wide, uniform.
    Box,
    /// A tent of the given radius in pixels (Mitsuba's default radius 1).
    Tent {
        /// Radius in pixels.
        radius: f32,
    },
    /// A truncated Gaussian (Mitsuba's default filter: stddev 0.5, truncated at 4 stddev).
    Gaussian {
        /// Standard deviation in pixels.
        stddev: f32,
    },
}

impl Default for Filter {
    fn default() -> Self {
        Filter::Gaussian { stddev: 0.5 }
    }
}

/// Samples per pixel and the seed of the per-pixel random numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampler {
    /// Samples per pixel.
    pub sample_count: u32,
    /// Seed; the same seed gives the same image on every backend and thread count.
    pub seed: u32,
}

impl Default for Sampler {
    fn default() -> Self {
        Sampler {
            sample_count: 4,
            seed: 0,
        }
    }
}

/// The light transport algorithm.
#[derive(Clone, Debug, PartialEq)]
pub enum Integrator {
    /// Mitsuba's `path`: unidirectional path tracing with next-event estimation, MIS and
    /// Russian roulette.
    Path(PathSettings),
    /// Mitsuba's `direct`: direct illumination only.
    Direct(DirectSettings),
    /// Mitsuba's `aov`: arbitrary output variables, one image per entry.
    Aov(Vec<Aov>),
}

impl Default for Integrator {
    fn default() -> Self {
        Integrator::Path(PathSettings::default())
    }
}

/// Settings of the `path` integrator (Mitsuba's defaults).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathSettings {
    /// Longest path in segments; `None` is unbounded (Mitsuba's -1).
    pub max_depth: Option<u32>,
    /// Depth from which Russian roulette starts (Mitsuba: 5).
    pub rr_depth: u32,
    /// Whether emitters seen directly by the camera are hidden.
    pub hide_emitters: bool,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings {
            max_depth: None,
            rr_depth: 5,
            hide_emitters: false,
        }
    }
}

/// Settings of the `direct` integrator (Mitsuba's defaults: one sample of each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DirectSettings {
    /// Emitter samples per shading point.
    pub emitter_samples: u32,
    /// BSDF samples per shading point.
    pub bsdf_samples: u32,
    /// Whether emitters seen directly by the camera are hidden.
    pub hide_emitters: bool,
}

impl Default for DirectSettings {
    fn default() -> Self {
        DirectSettings {
            emitter_samples: 1,
            bsdf_samples: 1,
            hide_emitters: false,
        }
    }
}

/// One output of the `aov` integrator.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Aov {
    /// The layer name (`albedo` in `albedo:albedo`).
    pub name: String,
    /// What it holds.
    pub kind: AovKind,
}

/// What an AOV holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AovKind {
    /// The BSDF's albedo at the first hit.
    Albedo,
    /// The shading normal at the first hit, in world space.
    ShadingNormal,
    /// The distance along the camera ray to the first hit.
    Depth,
}

/// A triangle mesh in world space (or in its shape group's space).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// A name for messages (the shape's id, or file and object name).
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (empty: use the face normal).
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates (empty: none).
    pub uvs: Vec<Vec2>,
    /// Three vertex indices per triangle, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
    /// The material.
    pub material: MaterialId,
    /// Radiance emitted from the front side when this mesh is an area light.
    pub emission: Option<Texture>,
    /// Whether the normals point inwards (Mitsuba's `flip_normals`).
    pub flip_normals: bool,
}

/// A sphere, traced as optik's built-in sphere primitive.
#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    /// A name for messages.
    pub name: String,
    /// Centre in world (or group) space.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
    /// The sphere's own frame in world (or group) space, a rotation: texture coordinates are
    /// Mitsuba's (φ / 2π, θ / π) of the hit point in this frame.
    pub rotation: Mat3,
    /// The material.
    pub material: MaterialId,
    /// Radiance emitted when this sphere is an area light.
    pub emission: Option<Texture>,
    /// Whether the normals point inwards.
    pub flip_normals: bool,
}

/// Shapes placed only through instances (Mitsuba's `shapegroup`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShapeGroup {
    /// The group's id.
    pub name: String,
    /// Its meshes, in group space.
    pub meshes: Vec<Mesh>,
    /// Its spheres, in group space.
    pub spheres: Vec<Sphere>,
}

/// One placement of a shape group.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Scene::groups`].
    pub group: u32,
    /// Group space to world.
    pub to_world: Mat4,
}

/// A colour or scalar that may vary over the surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// The same value everywhere (a scalar is stored as grey).
    Constant(Rgb),
    /// An image looked up by texture coordinates.
    Bitmap {
        /// The image.
        image: ImageId,
        /// Applied to the mesh's uv before the lookup (Mitsuba's `to_uv`).
        to_uv: Mat3,
        /// Bilinear (true) or nearest lookups.
        bilinear: bool,
        /// What lies outside [0, 1]² (Mitsuba's `wrap_mode`).
        wrap: WrapMode,
    },
    /// Mitsuba's `checkerboard`: `color0` where `floor(2u) + floor(2v)` is even.
    Checkerboard {
        /// First colour.
        color0: Rgb,
        /// Second colour.
        color1: Rgb,
        /// Applied to the mesh's uv before the lookup.
        to_uv: Mat3,
    },
}

/// How a bitmap continues outside [0, 1]² (Mitsuba's `wrap_mode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum WrapMode {
    /// Tiles (Mitsuba's default).
    #[default]
    Repeat,
    /// Tiles, every other tile mirrored.
    Mirror,
    /// The edge texels continue.
    Clamp,
}

/// A decoded image, linear RGB, row 0 at the top.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Image {
    /// The file it came from, for messages.
    pub path: std::path::PathBuf,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` linear RGB texels (8-bit sRGB files are decoded; float files kept).
    pub texels: Vec<Rgb>,
    /// Per-texel alpha when the file has one (used by `mask` opacity from a bitmap's alpha).
    pub alpha: Option<Vec<f32>>,
}

/// A microfacet distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Microfacet {
    /// Beckmann, Mitsuba's default.
    Beckmann,
    /// GGX (Trowbridge–Reitz).
    Ggx,
}

/// Roughness of a microfacet BSDF: Mitsuba's `alpha`, or `alpha_u` and `alpha_v`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roughness {
    /// The distribution.
    pub distribution: Microfacet,
    /// Roughness along the tangent.
    pub alpha_u: f32,
    /// Roughness along the bitangent.
    pub alpha_v: f32,
}

/// A material, as Mitsuba 3's BSDF plugins define them (same parameters and defaults).
#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflection.
    Diffuse {
        /// Albedo.
        reflectance: Texture,
    },
    /// The same BSDF on both sides (Mitsuba's `twosided` with one child; with two, front and
    /// back differ).
    TwoSided {
        /// Used on the front side.
        front: Box<Bsdf>,
        /// Used on the back side (seen with the normal flipped).
        back: Box<Bsdf>,
    },
    /// A smooth conductor (a mirror when `eta` = 0 and `k` = 1, Mitsuba's `material="none"`).
    Conductor {
        /// Real part of the relative index of refraction, per channel.
        eta: Rgb,
        /// Imaginary part (absorption), per channel.
        k: Rgb,
        /// Multiplies the Fresnel reflectance.
        specular_reflectance: Texture,
    },
    /// A rough conductor.
    RoughConductor {
        /// Real part of the index of refraction.
        eta: Rgb,
        /// Imaginary part.
        k: Rgb,
        /// The microfacet roughness.
        roughness: Roughness,
        /// Multiplies the Fresnel reflectance.
        specular_reflectance: Texture,
        /// Whether visible normals are sampled (Mitsuba's `sample_visible`, default true).
        sample_visible: bool,
    },
    /// A smooth dielectric interface.
    Dielectric {
        /// Interior index of refraction.
        int_ior: f32,
        /// Exterior index of refraction.
        ext_ior: f32,
        /// Multiplies reflection.
        specular_reflectance: Texture,
        /// Multiplies transmission.
        specular_transmittance: Texture,
    },
    /// A thin dielectric sheet (no refraction of direction).
    ThinDielectric {
        /// Interior index of refraction.
        int_ior: f32,
        /// Exterior index of refraction.
        ext_ior: f32,
        /// Multiplies reflection.
        specular_reflectance: Texture,
        /// Multiplies transmission.
        specular_transmittance: Texture,
    },
    /// A rough dielectric interface.
    RoughDielectric {
        /// Interior index of refraction.
        int_ior: f32,
        /// Exterior index of refraction.
        ext_ior: f32,
        /// The microfacet roughness.
        roughness: Roughness,
        /// Multiplies reflection.
        specular_reflectance: Texture,
        /// Multiplies transmission.
        specular_transmittance: Texture,
        /// Whether visible normals are sampled.
        sample_visible: bool,
    },
    /// A diffuse base under a smooth dielectric coating.
    Plastic {
        /// Albedo of the diffuse base.
        diffuse_reflectance: Texture,
        /// Multiplies the specular reflection.
        specular_reflectance: Texture,
        /// Interior index of refraction.
        int_ior: f32,
        /// Exterior index of refraction.
        ext_ior: f32,
        /// Mitsuba's `nonlinear` (internal scattering shifts colours).
        nonlinear: bool,
    },
    /// A diffuse base under a rough dielectric coating.
    RoughPlastic {
        /// Albedo of the diffuse base.
        diffuse_reflectance: Texture,
        /// Multiplies the specular reflection.
        specular_reflectance: Texture,
        /// Interior index of refraction.
        int_ior: f32,
        /// Exterior index of refraction.
        ext_ior: f32,
        /// Mitsuba's `nonlinear`.
        nonlinear: bool,
        /// The microfacet roughness (isotropic in Mitsuba's roughplastic).
        roughness: Roughness,
    },
    /// Opacity mask over another BSDF: the surface is there with probability `opacity`.
    Mask {
        /// Opacity in [0, 1] (the mean of the channels is used).
        opacity: Texture,
        /// The BSDF where the surface is there.
        inner: Box<Bsdf>,
    },
}

/// An emitter not attached to a shape (area emitters live on [`Mesh::emission`] and
/// [`Sphere::emission`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Emitter {
    /// An isotropic point light.
    Point {
        /// Position in world space.
        position: Vec3,
        /// Radiant intensity (W/sr).
        intensity: Rgb,
    },
    /// A spot light (Mitsuba's `spot`).
    Spot {
        /// Light to world; the light points down its local +z.
        to_world: Mat4,
        /// Radiant intensity at the centre.
        intensity: Rgb,
        /// Full cut-off half angle in degrees (Mitsuba: 20).
        cutoff_angle: f32,
        /// Half angle where the falloff starts, in degrees (Mitsuba: 0.75 × cutoff).
        beam_width: f32,
    },
    /// A light from one direction, as the sun.
    Directional {
        /// Direction the light travels, world space, normalised.
        direction: Vec3,
        /// Irradiance on a surface facing the light.
        irradiance: Rgb,
    },
    /// Uniform radiance from every direction at infinity.
    Constant {
        /// Radiance.
        radiance: Rgb,
    },
    /// An environment map at infinity (latitude-longitude), importance-sampled.
    EnvMap {
        /// The image.
        image: ImageId,
        /// Multiplies the image.
        scale: f32,
        /// Map to world (Mitsuba's envmap convention: +y up in the map's frame).
        to_world: Mat4,
    },
}

impl Scene {
    /// Every mesh and sphere with the transform that places it in the world: the scene's own
    /// shapes with the identity, then each instance's group shapes with its transform.
    pub fn placed_shapes(&self) -> impl Iterator<Item = (Mat4, ShapeRef<'_>)> {
        let top = self
            .meshes
            .iter()
            .map(|m| (Mat4::IDENTITY, ShapeRef::Mesh(m)))
            .chain(
                self.spheres
                    .iter()
                    .map(|s| (Mat4::IDENTITY, ShapeRef::Sphere(s))),
            );
        let instanced = self.instances.iter().flat_map(move |inst| {
            let group = &self.groups[inst.group as usize];
            group
                .meshes
                .iter()
                .map(move |m| (inst.to_world, ShapeRef::Mesh(m)))
                .chain(
                    group
                        .spheres
                        .iter()
                        .map(move |s| (inst.to_world, ShapeRef::Sphere(s))),
                )
        });
        top.chain(instanced)
    }
}

/// A borrowed mesh or sphere.
#[derive(Clone, Copy, Debug)]
pub enum ShapeRef<'a> {
    /// A triangle mesh.
    Mesh(&'a Mesh),
    /// A sphere.
    Sphere(&'a Sphere),
}
