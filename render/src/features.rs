//! The effects a scene calls for, derived after loading: the pipeline is built from them
//! (one closest-hit program per BSDF kind, a shadow ray type only where next-event estimation
//! applies, payload registers sized by the integrator).

use crate::geometry::{HitGroupKey, Primitive};
use crate::material::{self, BsdfKind};
use crate::scene::{Emitter, Integrator, Scene, ShapeRef};
use std::collections::BTreeSet;

/// Payload registers of a path-traced radiance ray without and with the denoiser's AOVs
/// (scene.wgsl's P_* layout).
pub const PATH_PAYLOAD: u32 = 26;
/// With albedo and normal of the first hit.
pub const PATH_PAYLOAD_AOVS: u32 = 32;

/// Every emitter kind's name, as [`RenderFeatures::emitters`] holds them.
pub const EMITTER_KINDS: [&str; 6] = ["area", "point", "spot", "directional", "constant", "envmap"];

/// What a scene needs simulated.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderFeatures {
    /// BSDF kinds on some shape, each compiled as one closest-hit program per primitive type.
    pub bsdf_kinds: BTreeSet<BsdfKind>,
    /// The hit groups: (BSDF kind, primitive type, masked) present on some shape.
    pub hit_groups: BTreeSet<HitGroupKey>,
    /// Some material uses a checkerboard texture.
    pub checkerboard: bool,
    /// Some material uses a bitmap texture.
    pub bitmap: bool,
    /// Some material is an opacity mask (an any-hit program).
    pub masks: bool,
    /// Emitter kinds present (`area`, `point`, `spot`, `directional`, `constant`, `envmap`).
    pub emitters: BTreeSet<&'static str>,
    /// The primitive types that carry area emitters: their light table entries are sampled
    /// as triangles or as spheres (the visible cap), and only those samplers are compiled.
    pub area_on: BTreeSet<Primitive>,
    /// The scene has an environment (constant or envmap).
    pub environment: bool,
    /// The scene places shape groups through instances.
    pub instancing: bool,
    /// The scene has spheres.
    pub spheres: bool,
    /// The integrator's longest path (`None`: unbounded).
    pub max_depth: Option<u32>,
    /// Next-event estimation applies (some emitter can be sampled, a BSDF has a smooth lobe,
    /// and paths have a second vertex): the shadow ray type exists.
    pub shadow_rays: bool,
    /// Payload registers of the radiance ray.
    pub payload_values: u32,
    /// The integrator's name.
    pub integrator: &'static str,
}

impl RenderFeatures {
    /// The features of `scene` rendered with its integrator; `aovs` adds the first hit's
    /// albedo and normal to the payload.
    pub fn of(scene: &Scene, aovs: bool) -> RenderFeatures {
        let mut f = RenderFeatures::default();
        for (_, shape) in scene.placed_shapes() {
            let (material, emission, primitive) = match shape {
                ShapeRef::Mesh(m) => (m.material, m.emission.is_some(), Primitive::Triangles),
                ShapeRef::Sphere(s) => {
                    f.spheres = true;
                    (s.material, s.emission.is_some(), Primitive::Spheres)
                }
            };
            if emission {
                f.area_on.insert(primitive);
            }
            if let Some(b) = scene.materials.get(material as usize) {
                let masked = matches!(b, crate::scene::Bsdf::Mask { .. });
                if let Ok(e) = material::encode(b, &scene.images, "") {
                    let back = e.back.as_ref().map(|b| b.kind);
                    f.bsdf_kinds
                        .extend([Some(e.kind), back].into_iter().flatten());
                    f.hit_groups.insert(HitGroupKey {
                        kind: e.kind,
                        back,
                        primitive,
                        masked,
                    });
                }
                let t = material::texture_use(b);
                f.checkerboard |= t.checkerboard;
                f.bitmap |= t.bitmap;
                f.masks |= masked;
            }
        }
        if !f.area_on.is_empty() {
            f.emitters.insert("area");
        }
        for e in &scene.emitters {
            let name = match e {
                Emitter::Point { .. } => "point",
                Emitter::Spot { .. } => "spot",
                Emitter::Directional { .. } => "directional",
                Emitter::Constant { .. } => "constant",
                Emitter::EnvMap { .. } => "envmap",
            };
            f.emitters.insert(name);
            f.environment |= matches!(e, Emitter::Constant { .. } | Emitter::EnvMap { .. });
        }
        f.instancing = !scene.instances.is_empty();
        f.bitmap |= scene
            .emitters
            .iter()
            .any(|e| matches!(e, Emitter::EnvMap { .. }));
        let (name, max_depth) = match &scene.integrator {
            Integrator::Path(p) => ("path", p.max_depth),
            Integrator::Direct(_) => ("direct", Some(2)),
            Integrator::Aov(_) => ("aov", Some(1)),
        };
        f.integrator = name;
        f.max_depth = max_depth;
        let smooth = f.bsdf_kinds.iter().any(|k| k.smooth());
        f.shadow_rays = !f.emitters.is_empty() && smooth && max_depth.is_none_or(|d| d > 1);
        f.payload_values = if aovs {
            PATH_PAYLOAD_AOVS
        } else {
            PATH_PAYLOAD
        };
        f
    }

    /// Rays trace an instance acceleration structure: the scene has instances, or spheres
    /// (one GAS holds one primitive type).
    pub fn uses_ias(&self) -> bool {
        self.instancing || self.spheres
    }

    /// These features with every effect the renderer can compile switched on: every BSDF kind
    /// on every primitive type, masked and not, both texture kinds, masks, every emitter kind
    /// and the environment, instancing, spheres, shadow rays and the most payload registers.
    /// The benchmark mode's unspecialised pipeline; it renders the same image in expectation,
    /// only slower. The scene's own hit groups stay (its twosided pairs of BSDFs: every pair
    /// of kinds would be 64 more programs per primitive type).
    pub fn with_every_effect(&self) -> RenderFeatures {
        let bsdf_kinds: BTreeSet<BsdfKind> = BsdfKind::all().into_iter().collect();
        let mut hit_groups = self.hit_groups.clone();
        for &kind in &bsdf_kinds {
            for primitive in [Primitive::Triangles, Primitive::Spheres] {
                for masked in [false, true] {
                    hit_groups.insert(HitGroupKey {
                        kind,
                        back: None,
                        primitive,
                        masked,
                    });
                }
            }
        }
        RenderFeatures {
            bsdf_kinds,
            hit_groups,
            checkerboard: true,
            bitmap: true,
            masks: true,
            emitters: EMITTER_KINDS.iter().copied().collect(),
            area_on: [Primitive::Triangles, Primitive::Spheres]
                .into_iter()
                .collect(),
            environment: true,
            instancing: true,
            spheres: true,
            max_depth: self.max_depth,
            shadow_rays: true,
            payload_values: PATH_PAYLOAD_AOVS,
            integrator: self.integrator,
        }
    }

    /// The programs a pipeline for these features holds, in program group order: the path
    /// raygen, the radiance miss, the shadow miss (only with shadow rays), then each hit
    /// group's closest-hit program and, for masked materials, its any-hit program (each
    /// program once).
    pub fn programs(&self) -> Vec<String> {
        let mut v = vec!["raygen__path".to_string(), "miss__radiance".to_string()];
        if self.shadow_rays {
            v.push("miss__shadow".into());
        }
        for g in &self.hit_groups {
            for name in [
                Some(crate::programs::closest_hit_name(
                    g.kind,
                    g.back,
                    g.primitive,
                )),
                g.masked.then(|| crate::programs::any_hit_name(g.primitive)),
            ]
            .into_iter()
            .flatten()
            {
                if !v.contains(&name) {
                    v.push(name);
                }
            }
        }
        v
    }

    /// One line per feature, for `optik render --features`.
    pub fn describe(&self) -> String {
        let list = |v: Vec<&str>| {
            if v.is_empty() {
                "none".to_string()
            } else {
                v.join(", ")
            }
        };
        let mut s = String::new();
        s += &format!("integrator: {}\n", self.integrator);
        s += &format!(
            "max depth: {}\n",
            self.max_depth
                .map_or("unbounded".to_string(), |d| d.to_string())
        );
        s += &format!(
            "bsdfs: {}\n",
            list(self.bsdf_kinds.iter().map(|k| k.name()).collect())
        );
        let shared: BTreeSet<&str> = self
            .bsdf_kinds
            .iter()
            .flat_map(|k| k.needs().iter().map(|p| p.name()))
            .collect();
        s += &format!("shared bsdf code: {}\n", list(shared.into_iter().collect()));
        let mut tex = Vec::new();
        if self.checkerboard {
            tex.push("checkerboard");
        }
        if self.bitmap {
            tex.push("bitmap");
        }
        s += &format!("textures: {}\n", list(tex));
        s += &format!("masks: {}\n", self.masks);
        s += &format!(
            "emitters: {}\n",
            list(self.emitters.iter().copied().collect())
        );
        s += &format!(
            "area emitters on: {}\n",
            list(
                self.area_on
                    .iter()
                    .map(|p| match p {
                        Primitive::Triangles => "triangles",
                        Primitive::Spheres => "spheres",
                    })
                    .collect()
            )
        );
        s += &format!("environment: {}\n", self.environment);
        s += &format!("instancing: {}\n", self.instancing);
        s += &format!("spheres: {}\n", self.spheres);
        s += &format!(
            "traversal: {}\n",
            if self.uses_ias() {
                "instance acceleration structure"
            } else {
                "single GAS"
            }
        );
        s += &format!(
            "shadow rays (next-event estimation): {}\n",
            self.shadow_rays
        );
        s += &format!("payload registers: {}\n", self.payload_values);
        s
    }
}
