//! Materials as the WGSL BSDF code reads them: a kind (one closest-hit program each), 40 floats
//! of parameters (MatParams in common.wgsl) and 64 floats of precomputed table (roughplastic's
//! rough-interface transmittance; read through `mat_extra` in WGSL).

use crate::RenderError;
use crate::scene::{Bsdf, Image, Microfacet, Roughness, Texture, WrapMode};
use glam::{Mat3, Vec3};

/// Floats of material parameters per SBT record.
pub const MAT_PARAMS: usize = 40;
/// Floats of precomputed table per SBT record, after the parameters.
pub const MAT_EXTRA: usize = crate::roughplastic::TABLE_RES;
/// Words one material takes where the WGSL reads it: its parameters, then its table. A
/// twosided pair's back side follows its front at this offset.
pub const MATERIAL_WORDS: usize = MAT_PARAMS + MAT_EXTRA;

// Parameter layout (common.wgsl repeats it): two texture slots of 13 floats, kind-specific
// scalars, the microfacet distribution, and the two-sided flag.
const TEX_A: usize = 0;
const TEX_B: usize = 13;
const SCALARS: usize = 26;
const MICROFACET: usize = 33;
const TWOSIDED: usize = 39;
/// roughplastic's scalar naming the record data word where its table starts.
const TABLE_AT: usize = SCALARS + 5;

/// A BSDF kind: one closest-hit program per kind present in a scene. `twosided` is not a kind:
/// with one nested BSDF it is a flag on the kind it wraps (Mitsuba's `twosided` only mirrors
/// directions); with two different ones, the hit group shades with a pair of kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum BsdfKind {
    /// Mitsuba's `diffuse`.
    Diffuse,
    /// Mitsuba's `conductor` (a delta reflection).
    Conductor,
    /// Mitsuba's `roughconductor`.
    RoughConductor,
    /// Mitsuba's `dielectric` (delta reflection and refraction).
    Dielectric,
    /// Mitsuba's `thindielectric` (delta reflection and straight transmission).
    ThinDielectric,
    /// Mitsuba's `roughdielectric`.
    RoughDielectric,
    /// Mitsuba's `plastic` (delta coating reflection over a diffuse base).
    Plastic,
    /// Mitsuba's `roughplastic`.
    RoughPlastic,
}

/// WGSL pieces shared by several kinds, assembled once per module.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SharedWgsl {
    /// Fresnel equations, reflection and refraction (fresnel.wgsl).
    Fresnel,
    /// Beckmann and GGX distributions and their sampling (microfacet.wgsl).
    Microfacet,
}

impl SharedWgsl {
    /// The piece's name in `--features`.
    pub fn name(self) -> &'static str {
        match self {
            SharedWgsl::Fresnel => "fresnel",
            SharedWgsl::Microfacet => "microfacet",
        }
    }

    /// The piece's source.
    pub fn wgsl(self) -> &'static str {
        match self {
            SharedWgsl::Fresnel => include_str!("wgsl/fresnel.wgsl"),
            SharedWgsl::Microfacet => include_str!("wgsl/microfacet.wgsl"),
        }
    }
}

impl BsdfKind {
    /// Every kind, in program order.
    pub const ALL: [BsdfKind; 8] = [
        BsdfKind::Diffuse,
        BsdfKind::Conductor,
        BsdfKind::RoughConductor,
        BsdfKind::Dielectric,
        BsdfKind::ThinDielectric,
        BsdfKind::RoughDielectric,
        BsdfKind::Plastic,
        BsdfKind::RoughPlastic,
    ];

    /// The name used in program names and `--features` (Mitsuba's plugin name).
    pub fn name(self) -> &'static str {
        match self {
            BsdfKind::Diffuse => "diffuse",
            BsdfKind::Conductor => "conductor",
            BsdfKind::RoughConductor => "roughconductor",
            BsdfKind::Dielectric => "dielectric",
            BsdfKind::ThinDielectric => "thindielectric",
            BsdfKind::RoughDielectric => "roughdielectric",
            BsdfKind::Plastic => "plastic",
            BsdfKind::RoughPlastic => "roughplastic",
        }
    }

    /// Every kind, in order: what the benchmark mode's all-effects pipeline compiles (the
    /// test `every_bsdf_source_belongs_to_a_kind` checks every bsdf_*.wgsl file is reached).
    pub fn all() -> Vec<BsdfKind> {
        BsdfKind::ALL.to_vec()
    }

    /// Whether the BSDF has a non-delta lobe, so that next-event estimation applies (Mitsuba's
    /// path integrator: `has_flag(bsdf.flags(), Smooth)`).
    pub fn smooth(self) -> bool {
        !matches!(
            self,
            BsdfKind::Conductor | BsdfKind::Dielectric | BsdfKind::ThinDielectric
        )
    }

    /// The WGSL source of the kind's `bsdf_<name>_{eval,sample,albedo}` functions.
    pub fn wgsl(self) -> &'static str {
        match self {
            BsdfKind::Diffuse => include_str!("wgsl/bsdf_diffuse.wgsl"),
            BsdfKind::Conductor => include_str!("wgsl/bsdf_conductor.wgsl"),
            BsdfKind::RoughConductor => include_str!("wgsl/bsdf_roughconductor.wgsl"),
            BsdfKind::Dielectric => include_str!("wgsl/bsdf_dielectric.wgsl"),
            BsdfKind::ThinDielectric => include_str!("wgsl/bsdf_thindielectric.wgsl"),
            BsdfKind::RoughDielectric => include_str!("wgsl/bsdf_roughdielectric.wgsl"),
            BsdfKind::Plastic => include_str!("wgsl/bsdf_plastic.wgsl"),
            BsdfKind::RoughPlastic => include_str!("wgsl/bsdf_roughplastic.wgsl"),
        }
    }

    /// The shared pieces the kind's WGSL calls.
    pub fn needs(self) -> &'static [SharedWgsl] {
        match self {
            BsdfKind::Diffuse => &[],
            BsdfKind::Conductor
            | BsdfKind::Dielectric
            | BsdfKind::ThinDielectric
            | BsdfKind::Plastic => &[SharedWgsl::Fresnel],
            BsdfKind::RoughConductor | BsdfKind::RoughDielectric | BsdfKind::RoughPlastic => {
                &[SharedWgsl::Fresnel, SharedWgsl::Microfacet]
            }
        }
    }
}

/// What a texture needs beyond constants: checkerboards and bitmaps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureUse {
    /// Some texture is a checkerboard.
    pub checkerboard: bool,
    /// Some texture is a bitmap.
    pub bitmap: bool,
}

/// A material encoded for the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoded {
    /// Which closest-hit program shades it.
    pub kind: BsdfKind,
    /// Its parameters.
    pub params: [f32; MAT_PARAMS],
    /// Its precomputed table (zeros where the kind has none).
    pub extra: [f32; MAT_EXTRA],
    /// The back side's BSDF of a twosided material with two different ones (Mitsuba's
    /// `twosided` with two children): hits from below are shaded by it.
    pub back: Option<Box<Encoded>>,
}

impl Encoded {
    /// The words the WGSL reads for this material when they are written from word `at` on (of
    /// the SBT record data, or of the probe's material buffer): parameters and table, then for
    /// a twosided pair the back side's, [`MATERIAL_WORDS`] further on. A roughplastic is told
    /// where its own table lies (the only kind that reads one).
    pub fn words(&self, at: usize) -> Vec<f32> {
        let sides = [Some(self), self.back.as_deref()].into_iter().flatten();
        let mut words = Vec::with_capacity(2 * MATERIAL_WORDS);
        for (i, side) in sides.enumerate() {
            let mut params = side.params;
            if side.kind == BsdfKind::RoughPlastic {
                params[TABLE_AT] = (at + i * MATERIAL_WORDS + MAT_PARAMS) as f32;
            }
            words.extend(params);
            words.extend(side.extra);
        }
        words
    }
}

/// Encodes `bsdf` for the WGSL BSDF code; `images` are the scene's bitmaps (plastics weigh
/// their lobes by the textures' means); `what` names it in errors.
pub fn encode(bsdf: &Bsdf, images: &[Image], what: &str) -> Result<Encoded, RenderError> {
    let mut e = Encoded {
        kind: BsdfKind::Diffuse,
        params: [0.0; MAT_PARAMS],
        extra: [0.0; MAT_EXTRA],
        back: None,
    };
    let p = &mut e.params;
    e.kind = match bsdf {
        Bsdf::Diffuse { reflectance } => {
            encode_texture(reflectance, &mut p[TEX_A..TEX_A + 13], what)?;
            BsdfKind::Diffuse
        }
        // The mask's opacity is the any-hit program's (see `opacity`); hits are shaded by the
        // inner BSDF.
        Bsdf::Mask { inner, .. } => return encode(inner, images, what),
        Bsdf::TwoSided { front, back } => {
            for side in [front, back] {
                if matches!(
                    **side,
                    Bsdf::TwoSided { .. }
                        | Bsdf::Dielectric { .. }
                        | Bsdf::ThinDielectric { .. }
                        | Bsdf::RoughDielectric { .. }
                        | Bsdf::Mask { .. }
                ) {
                    // Mitsuba refuses transmissive children ("Only materials without a
                    // transmission component can be nested").
                    return Err(RenderError::Invalid(format!(
                        "{what}: twosided around {}: expected a BSDF without transmission",
                        bsdf_name(side)
                    )));
                }
            }
            let mut inner = encode(front, images, what)?;
            if front == back {
                inner.params[TWOSIDED] = 1.0;
            } else {
                inner.back = Some(Box::new(encode(back, images, what)?));
            }
            return Ok(inner);
        }
        Bsdf::Conductor {
            eta,
            k,
            specular_reflectance,
        } => {
            encode_texture(specular_reflectance, &mut p[TEX_A..TEX_A + 13], what)?;
            p[SCALARS..SCALARS + 3].copy_from_slice(&eta.to_array());
            p[SCALARS + 3..SCALARS + 6].copy_from_slice(&k.to_array());
            BsdfKind::Conductor
        }
        Bsdf::RoughConductor {
            eta,
            k,
            roughness,
            specular_reflectance,
            sample_visible,
        } => {
            encode_texture(specular_reflectance, &mut p[TEX_A..TEX_A + 13], what)?;
            p[SCALARS..SCALARS + 3].copy_from_slice(&eta.to_array());
            p[SCALARS + 3..SCALARS + 6].copy_from_slice(&k.to_array());
            encode_roughness(roughness, *sample_visible, p, what)?;
            BsdfKind::RoughConductor
        }
        Bsdf::Dielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        }
        | Bsdf::ThinDielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => {
            encode_texture(specular_reflectance, &mut p[TEX_A..TEX_A + 13], what)?;
            encode_texture(specular_transmittance, &mut p[TEX_B..TEX_B + 13], what)?;
            p[SCALARS] = relative_ior(*int_ior, *ext_ior, false, what)?;
            if matches!(bsdf, Bsdf::Dielectric { .. }) {
                BsdfKind::Dielectric
            } else {
                BsdfKind::ThinDielectric
            }
        }
        Bsdf::RoughDielectric {
            int_ior,
            ext_ior,
            roughness,
            specular_reflectance,
            specular_transmittance,
            sample_visible,
        } => {
            encode_texture(specular_reflectance, &mut p[TEX_A..TEX_A + 13], what)?;
            encode_texture(specular_transmittance, &mut p[TEX_B..TEX_B + 13], what)?;
            p[SCALARS] = relative_ior(*int_ior, *ext_ior, true, what)?;
            encode_roughness(roughness, *sample_visible, p, what)?;
            BsdfKind::RoughDielectric
        }
        Bsdf::Plastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
        } => {
            encode_texture(diffuse_reflectance, &mut p[TEX_A..TEX_A + 13], what)?;
            encode_texture(specular_reflectance, &mut p[TEX_B..TEX_B + 13], what)?;
            let eta = relative_ior(*int_ior, *ext_ior, false, what)?;
            p[SCALARS] = eta;
            p[SCALARS + 1] = 1.0 / (eta * eta);
            p[SCALARS + 2] =
                specular_sampling_weight(diffuse_reflectance, specular_reflectance, images, what)?;
            p[SCALARS + 3] = f32::from(u8::from(*nonlinear));
            p[SCALARS + 4] = crate::roughplastic::fresnel_diffuse_reflectance(1.0 / eta);
            BsdfKind::Plastic
        }
        Bsdf::RoughPlastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            roughness,
        } => {
            encode_texture(diffuse_reflectance, &mut p[TEX_A..TEX_A + 13], what)?;
            encode_texture(specular_reflectance, &mut p[TEX_B..TEX_B + 13], what)?;
            let eta = relative_ior(*int_ior, *ext_ior, true, what)?;
            if roughness.alpha_u != roughness.alpha_v {
                return Err(RenderError::Invalid(format!(
                    "{what}: roughplastic with alpha_u {} and alpha_v {}: Mitsuba's roughplastic \
                     is isotropic; expected one alpha",
                    roughness.alpha_u, roughness.alpha_v
                )));
            }
            p[SCALARS] = eta;
            p[SCALARS + 1] = 1.0 / (eta * eta);
            p[SCALARS + 2] =
                specular_sampling_weight(diffuse_reflectance, specular_reflectance, images, what)?;
            p[SCALARS + 3] = f32::from(u8::from(*nonlinear));
            encode_roughness(roughness, true, p, what)?;
            let alpha = roughness.alpha_u.max(1e-4);
            let tables = crate::roughplastic::Tables::new(roughness.distribution, alpha, eta);
            p[SCALARS + 4] = tables.internal_reflectance;
            e.extra = tables.external_transmittance;
            BsdfKind::RoughPlastic
        }
    };
    Ok(e)
}

/// int_ior / ext_ior, checked as Mitsuba checks it (rough interfaces need differing indices).
fn relative_ior(int_ior: f32, ext_ior: f32, rough: bool, what: &str) -> Result<f32, RenderError> {
    if !(int_ior > 0.0 && ext_ior > 0.0 && int_ior.is_finite() && ext_ior.is_finite()) {
        return Err(RenderError::Invalid(format!(
            "{what}: int_ior {int_ior} and ext_ior {ext_ior}: expected positive indices of refraction"
        )));
    }
    if rough && int_ior == ext_ior {
        return Err(RenderError::Invalid(format!(
            "{what}: int_ior and ext_ior are both {int_ior}: a rough interface needs differing indices"
        )));
    }
    Ok(int_ior / ext_ior)
}

/// Distribution, alpha_u, alpha_v and sample_visible at MICROFACET.
fn encode_roughness(
    r: &Roughness,
    sample_visible: bool,
    p: &mut [f32; MAT_PARAMS],
    what: &str,
) -> Result<(), RenderError> {
    if !(r.alpha_u >= 0.0 && r.alpha_v >= 0.0 && r.alpha_u.is_finite() && r.alpha_v.is_finite()) {
        return Err(RenderError::Invalid(format!(
            "{what}: roughness alpha_u {} alpha_v {}: expected finite values of at least 0",
            r.alpha_u, r.alpha_v
        )));
    }
    p[MICROFACET] = match r.distribution {
        Microfacet::Beckmann => 0.0,
        Microfacet::Ggx => 1.0,
    };
    p[MICROFACET + 1] = r.alpha_u;
    p[MICROFACET + 2] = r.alpha_v;
    p[MICROFACET + 3] = f32::from(u8::from(sample_visible));
    Ok(())
}

/// Plastic's probability weight of the specular lobe: `s_mean / (d_mean + s_mean)` of the
/// textures' means (Mitsuba's `Texture::mean`: a bitmap's is its texels' mean luminance).
fn specular_sampling_weight(
    diffuse: &Texture,
    specular: &Texture,
    images: &[Image],
    what: &str,
) -> Result<f32, RenderError> {
    let mean = |t: &Texture| -> Result<f32, RenderError> {
        let m = |c: Vec3| (c.x + c.y + c.z) / 3.0;
        match t {
            Texture::Constant(c) => Ok(m(*c)),
            Texture::Checkerboard { color0, color1, .. } => Ok(0.5 * (m(*color0) + m(*color1))),
            Texture::Bitmap { image, .. } => {
                let img = images.get(*image as usize).ok_or_else(|| {
                    RenderError::Invalid(format!(
                        "{what}: image {image} of {}: expected an image of the scene",
                        images.len()
                    ))
                })?;
                Ok(bitmap_mean(img))
            }
        }
    };
    let (d, s) = (mean(diffuse)?, mean(specular)?);
    Ok(s / (d + s))
}

/// Mitsuba's bitmap `mean()`: the mean luminance of the (linear) texels.
fn bitmap_mean(img: &Image) -> f32 {
    let lum = Vec3::new(0.212671, 0.715160, 0.072169);
    let sum: f64 = img.texels.iter().map(|t| f64::from(t.dot(lum))).sum();
    (sum / img.texels.len().max(1) as f64) as f32
}

/// The opacity texture of a masked material (13 floats, as `tex_rgb` reads them), or `None`
/// for an opaque one; `what` names it in errors.
pub fn opacity(bsdf: &Bsdf, what: &str) -> Result<Option<[f32; 13]>, RenderError> {
    let Bsdf::Mask { opacity, inner } = bsdf else {
        return Ok(None);
    };
    if matches!(**inner, Bsdf::Mask { .. }) {
        return Err(RenderError::Unsupported(format!(
            "{what}: a mask inside a mask (supported: one mask around another BSDF)"
        )));
    }
    let mut out = [0.0; 13];
    encode_texture(opacity, &mut out, what)?;
    Ok(Some(out))
}

/// Mitsuba's plugin name of a BSDF.
pub fn bsdf_name(bsdf: &Bsdf) -> &'static str {
    match bsdf {
        Bsdf::Diffuse { .. } => "diffuse",
        Bsdf::TwoSided { .. } => "twosided",
        Bsdf::Conductor { .. } => "conductor",
        Bsdf::RoughConductor { .. } => "roughconductor",
        Bsdf::Dielectric { .. } => "dielectric",
        Bsdf::ThinDielectric { .. } => "thindielectric",
        Bsdf::RoughDielectric { .. } => "roughdielectric",
        Bsdf::Plastic { .. } => "plastic",
        Bsdf::RoughPlastic { .. } => "roughplastic",
        Bsdf::Mask { .. } => "mask",
    }
}

/// Which texture kinds `bsdf` uses.
pub fn texture_use(bsdf: &Bsdf) -> TextureUse {
    let mut u = TextureUse::default();
    let mut note = |t: &Texture| match t {
        Texture::Constant(_) => {}
        Texture::Checkerboard { .. } => u.checkerboard = true,
        Texture::Bitmap { .. } => u.bitmap = true,
    };
    match bsdf {
        Bsdf::Diffuse { reflectance } => note(reflectance),
        Bsdf::TwoSided { front, back } => {
            let (a, b) = (texture_use(front), texture_use(back));
            return TextureUse {
                checkerboard: a.checkerboard || b.checkerboard,
                bitmap: a.bitmap || b.bitmap,
            };
        }
        Bsdf::Conductor {
            specular_reflectance,
            ..
        }
        | Bsdf::RoughConductor {
            specular_reflectance,
            ..
        } => note(specular_reflectance),
        Bsdf::Dielectric {
            specular_reflectance,
            specular_transmittance,
            ..
        }
        | Bsdf::ThinDielectric {
            specular_reflectance,
            specular_transmittance,
            ..
        }
        | Bsdf::RoughDielectric {
            specular_reflectance,
            specular_transmittance,
            ..
        } => {
            note(specular_reflectance);
            note(specular_transmittance);
        }
        Bsdf::Plastic {
            diffuse_reflectance,
            specular_reflectance,
            ..
        }
        | Bsdf::RoughPlastic {
            diffuse_reflectance,
            specular_reflectance,
            ..
        } => {
            note(diffuse_reflectance);
            note(specular_reflectance);
        }
        Bsdf::Mask { opacity, inner } => {
            note(opacity);
            let i = texture_use(inner);
            u.checkerboard |= i.checkerboard;
            u.bitmap |= i.bitmap;
        }
    }
    u
}

/// Writes a texture's 13 floats (tex_rgb in common.wgsl): kind (0 constant, 1 checkerboard,
/// 2 bilinear bitmap, 3 nearest bitmap), then colour 0 and colour 1 (a bitmap: its image id),
/// then `to_uv` as two rows of a 3x3 affine matrix.
pub fn encode_texture(t: &Texture, out: &mut [f32], what: &str) -> Result<(), RenderError> {
    match t {
        Texture::Constant(c) => {
            out[0] = 0.0;
            out[1..4].copy_from_slice(&c.to_array());
        }
        Texture::Checkerboard {
            color0,
            color1,
            to_uv,
        } => {
            out[0] = 1.0;
            out[1..4].copy_from_slice(&color0.to_array());
            out[4..7].copy_from_slice(&color1.to_array());
            out[7..13].copy_from_slice(&affine_rows(to_uv));
        }
        Texture::Bitmap {
            image,
            to_uv,
            bilinear,
            wrap,
        } => {
            // Image ids index the texel table's directory (exact as f32 below 2^24).
            if *image >= 1 << 24 {
                return Err(RenderError::Invalid(format!(
                    "{what}: image {image}; expected fewer than 2^24 images"
                )));
            }
            out[0] = if *bilinear { 2.0 } else { 3.0 };
            out[1] = *image as f32;
            out[2] = match wrap {
                WrapMode::Repeat => 0.0,
                WrapMode::Mirror => 1.0,
                WrapMode::Clamp => 2.0,
            };
            out[7..13].copy_from_slice(&affine_rows(to_uv));
        }
    }
    Ok(())
}

/// The top two rows of a 3x3 affine uv transform.
fn affine_rows(m: &Mat3) -> [f32; 6] {
    let r0 = m.row(0);
    let r1 = m.row(1);
    [r0.x, r0.y, r0.z, r1.x, r1.y, r1.z]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A textured plastic weighs its specular lobe by the bitmap's mean luminance, as Mitsuba's
    /// `BitmapTexture::mean`, and an image id outside the scene is an error.
    #[test]
    fn plastic_with_a_bitmap_weighs_lobes_by_its_mean_luminance() {
        let image = Image {
            path: "t.png".into(),
            width: 2,
            height: 1,
            texels: vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
            alpha: None,
        };
        let bsdf = Bsdf::Plastic {
            diffuse_reflectance: Texture::Bitmap {
                image: 0,
                to_uv: Mat3::IDENTITY,
                bilinear: true,
                wrap: WrapMode::Repeat,
            },
            specular_reflectance: Texture::Constant(Vec3::splat(0.5)),
            int_ior: 1.5,
            ext_ior: 1.0,
            nonlinear: false,
        };
        let d = (0.212671 + 0.715160) / 2.0;
        let e = encode(&bsdf, std::slice::from_ref(&image), "t").unwrap();
        assert!((e.params[SCALARS + 2] - 0.5 / (d + 0.5)).abs() < 1e-6);
        let err = encode(&bsdf, &[], "t").unwrap_err().to_string();
        assert!(err.contains("image 0 of 0"), "{err}");
    }
}
