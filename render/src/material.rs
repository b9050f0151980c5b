//! Materials as the WGSL BSDF code reads them: a kind (one closest-hit program each) and 24
//! floats of parameters (MatParams in common.wgsl).

use crate::RenderError;
use crate::scene::{Bsdf, Texture, WrapMode};
use glam::Mat3;

/// Floats of material parameters per SBT record.
pub const MAT_PARAMS: usize = 24;

/// A BSDF kind: one closest-hit program per kind present in a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum BsdfKind {
    /// Mitsuba's `diffuse`.
    Diffuse,
}

impl BsdfKind {
    /// The name used in program names and `--features` (`diffuse`).
    pub fn name(self) -> &'static str {
        match self {
            BsdfKind::Diffuse => "diffuse",
        }
    }

    /// Whether the BSDF has a non-delta lobe, so that next-event estimation applies.
    pub fn smooth(self) -> bool {
        match self {
            BsdfKind::Diffuse => true,
        }
    }

    /// The WGSL source of the kind's `bsdf_<name>_{eval,sample,albedo}` functions.
    pub fn wgsl(self) -> &'static str {
        match self {
            BsdfKind::Diffuse => include_str!("wgsl/bsdf_diffuse.wgsl"),
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
}

/// Encodes `bsdf` for the WGSL BSDF code; `what` names it in errors.
pub fn encode(bsdf: &Bsdf, what: &str) -> Result<Encoded, RenderError> {
    let mut params = [0.0; MAT_PARAMS];
    let kind = match bsdf {
        Bsdf::Diffuse { reflectance } => {
            encode_texture(reflectance, &mut params[0..13], what)?;
            BsdfKind::Diffuse
        }
        // The mask's opacity is the any-hit program's (see `opacity`); hits are shaded by the
        // inner BSDF.
        Bsdf::Mask { inner, .. } => return encode(inner, what),
        other => {
            return Err(RenderError::Unsupported(format!(
                "{what}: BSDF {} (supported: diffuse)",
                bsdf_name(other)
            )));
        }
    };
    Ok(Encoded { kind, params })
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
