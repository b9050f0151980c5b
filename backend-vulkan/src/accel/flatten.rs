//! Flattening OptiX's traversable graphs into Vulkan's single instance level.
//!
//! OptiX nests instance acceleration structures and transforms to any depth; Vulkan has one
//! top level over bottom levels. Every traversable here keeps its *flat list*: one entry per
//! path from it down to a bottom level, with what the path composes:
//! - transforms multiply (outermost first);
//! - SBT offsets add (OptiX sums instance offsets along the path); 24 bits count (Vulkan's
//!   field, `optik_api::semantics::sbt_index::INSTANCE_SBT_OFFSET_MASK`), of each offset and
//!   of the sum;
//! - visibility masks: a ray must pass every instance's mask on the path. That is one mask
//!   test when the masks nest (one's bits contain the other's: the smaller one decides);
//!   other combinations cannot be expressed by one Vulkan instance and are an error;
//! - instance flags (OptiX's bits, kept for the tables; their low four bits are Vulkan's):
//!   face flipping toggles per flip on the path; culling disabled and the micromap switches
//!   anywhere on the path stay set; forcing any-hit on or off: the innermost instance that
//!   forces decides (as on the CPU and wgpu backends);
//! - `rt_instance_id` / `rt_instance_index` report the instance closest to the geometry.

use optik_api::semantics::affine;
use optik_api::semantics::sbt_index::{INSTANCE_ID_MASK, INSTANCE_SBT_OFFSET_MASK};
use optik_api::{Error, IDENTITY_3X4, Instance, InstanceFlags, Matrix3x4, Result};

/// Vulkan instance flag bits (`VkGeometryInstanceFlagBitsKHR`), the same positions as
/// OptiX's first four instance flags.
pub mod vk_flags {
    /// The bits Vulkan instances carry.
    pub const VULKAN_BITS: u32 = 0xF;
    /// `TRIANGLE_FACING_CULL_DISABLE`.
    pub const CULL_DISABLE: u32 = 1;
    /// `FORCE_OPAQUE`.
    pub const FORCE_OPAQUE: u32 = 4;
    /// `FORCE_NO_OPAQUE`.
    pub const FORCE_NO_OPAQUE: u32 = 8;
}

/// Which object owns a path's bottom level, and so its primitives' boxes (what motion
/// transforms above bound again).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlatSource {
    /// A part of a geometry acceleration structure.
    Gas(optik_api::Accel),
    /// A motion transform's proxy for the path (its address, `Inner::proxies`).
    Proxy(u64),
}

/// One path from a traversable down to a bottom level: one Vulkan instance of every top
/// level that contains the traversable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlatInstance {
    /// Object-to-world along the path.
    pub transform: Matrix3x4,
    /// Summed SBT offsets.
    pub sbt_offset: u32,
    /// The combined visibility mask.
    pub mask: u8,
    /// Instance flags of the path (OptiX's bits; [`FlatInstance::vk_flags`] are Vulkan's).
    pub flags: u32,
    /// The bottom level's address; 0 makes the Vulkan instance inactive (its structure was
    /// destroyed: instances that name a destroyed traversable miss it).
    pub blas: u64,
    /// `rt_instance_id` of hits through this path.
    pub instance_id: u32,
    /// `rt_instance_index` of hits through this path.
    pub instance_index: u32,
    /// Whether an OptiX instance lies on the path (otherwise id and index are 0).
    pub in_instance: bool,
    /// The geometry table record of the bottom level's SBT GAS index 0.
    pub geometry_base: u32,
    /// Geometries (SBT records) of the bottom level.
    pub geometry_count: u32,
    /// The path's motion chain in the data table (the transforms between the Vulkan
    /// instance and the geometry, when one of them moves), or NONE.
    pub chain: u32,
    /// The owner of the bottom level (none in unit tests).
    pub source: Option<FlatSource>,
    /// Vulkan sees boxes at the path's end (custom primitives, spheres, curves, optik's
    /// triangles, motion transforms' proxies). Where a device mixes the driver's triangles
    /// with optik's, such paths select the second half of the hit records, so each half
    /// serves one Vulkan geometry type (docs/vulkan-backend.md §2.4).
    pub boxes: bool,
}

impl FlatInstance {
    /// A bottom level seen directly (a GAS traced without instances).
    pub fn bottom(blas: u64, flags: u32, geometry_base: u32, geometry_count: u32) -> Self {
        FlatInstance {
            transform: IDENTITY_3X4,
            sbt_offset: 0,
            mask: 0xFF,
            flags,
            blas,
            instance_id: 0,
            instance_index: 0,
            in_instance: false,
            geometry_base,
            geometry_count,
            chain: super::tables::NONE,
            source: None,
            boxes: false,
        }
    }

    /// The same path, over boxes or not.
    pub fn over_boxes(mut self, boxes: bool) -> Self {
        self.boxes = boxes;
        self
    }

    /// The same path with its owner named.
    pub fn owned_by(mut self, source: FlatSource) -> Self {
        self.source = Some(source);
        self
    }

    /// The largest hit record index a ray through this path can select (SBT offset and
    /// stride of a trace count 4 bits each).
    pub fn sbt_reach(&self) -> u64 {
        self.sbt_offset as u64 + 15 + 15 * self.geometry_count.saturating_sub(1) as u64
    }

    /// The Vulkan instance flags: OptiX's low four bits, with forcing any-hit off winning
    /// when both forces are set (optik_api::semantics::opacity).
    pub fn vk_flags(&self) -> u32 {
        use vk_flags::*;
        let mut f = self.flags & VULKAN_BITS;
        if f & (FORCE_OPAQUE | FORCE_NO_OPAQUE) == FORCE_OPAQUE | FORCE_NO_OPAQUE {
            f &= !FORCE_NO_OPAQUE;
        }
        f
    }

    /// The same path with its bottom level gone.
    pub fn inactive(mut self) -> Self {
        self.blas = 0;
        self
    }
}

/// The visibility mask a ray must match for both masks to pass.
fn combine_masks(outer: u8, inner: u8) -> Option<u8> {
    if outer & inner == outer {
        Some(outer)
    } else if outer & inner == inner {
        Some(inner)
    } else {
        None
    }
}

/// Instance flags of a path (OptiX bits): `outer` (the instance above) over `inner`.
fn combine_flags(outer: u32, inner: u32) -> u32 {
    use optik_api::InstanceFlags as F;
    let force = F::DISABLE_ANYHIT.0 | F::ENFORCE_ANYHIT.0;
    let accumulate = F::DISABLE_TRIANGLE_FACE_CULLING.0
        | F::FORCE_OPACITY_MICROMAP_2_STATE.0
        | F::DISABLE_OPACITY_MICROMAPS.0;
    let opacity = if inner & force != 0 {
        inner & force
    } else {
        outer & force
    };
    ((outer | inner) & accumulate) | ((outer ^ inner) & F::FLIP_TRIANGLE_FACING.0) | opacity
}

/// The flat list of instance `index` of an instance acceleration structure, over its
/// child's flat list.
pub fn through_instance(
    inst: &Instance,
    index: u32,
    child: &[FlatInstance],
) -> Result<Vec<FlatInstance>> {
    let outer_mask = (inst.visibility_mask & 0xFF) as u8;
    let outer_flags = inst.flags & InstanceFlags::ALL.0;
    child
        .iter()
        .map(|c| {
            let mask = combine_masks(outer_mask, c.mask).ok_or_else(|| {
                Error::unsupported(format!(
                    "instance {index} has visibility mask {outer_mask:#04x} over a nested instance with mask {:#04x}: Vulkan has one instance level, and a ray passing both masks is one mask test only when one mask's bits contain the other's",
                    c.mask
                ))
            })?;
            let sum = (inst.sbt_offset & INSTANCE_SBT_OFFSET_MASK).wrapping_add(c.sbt_offset) & INSTANCE_SBT_OFFSET_MASK;
            Ok(FlatInstance {
                transform: affine::mul(&inst.transform, &c.transform),
                sbt_offset: sum,
                mask,
                flags: combine_flags(outer_flags, c.flags),
                blas: c.blas,
                instance_id: if c.in_instance { c.instance_id } else { inst.instance_id & INSTANCE_ID_MASK },
                instance_index: if c.in_instance { c.instance_index } else { index },
                in_instance: true,
                ..*c
            })
        })
        .collect()
}

/// The flat list of a static transform over its child's.
pub fn through_transform(object_to_world: &Matrix3x4, child: &[FlatInstance]) -> Vec<FlatInstance> {
    child
        .iter()
        .map(|c| FlatInstance {
            transform: affine::mul(object_to_world, &c.transform),
            ..*c
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use optik_api::TraversableHandle;

    #[test]
    fn masks_compose_when_nested() {
        assert_eq!(combine_masks(0xFF, 0x0F), Some(0x0F));
        assert_eq!(combine_masks(0x01, 0xFF), Some(0x01));
        assert_eq!(combine_masks(0x00, 0x0F), Some(0x00));
        assert_eq!(combine_masks(0x01, 0x02), None);
    }

    #[test]
    fn flags_compose_innermost_force_decides() {
        use optik_api::InstanceFlags as F;
        let flip = F::FLIP_TRIANGLE_FACING.0;
        assert_eq!(combine_flags(flip, flip), 0);
        assert_eq!(combine_flags(flip, 0), flip);
        let cull = F::DISABLE_TRIANGLE_FACE_CULLING.0;
        assert_eq!(combine_flags(cull, 0), cull);
        let (off, on) = (F::DISABLE_ANYHIT.0, F::ENFORCE_ANYHIT.0);
        assert_eq!(combine_flags(on, off), off, "the inner instance decides");
        assert_eq!(combine_flags(off, 0), off);
        let omm = F::DISABLE_OPACITY_MICROMAPS.0 | F::FORCE_OPACITY_MICROMAP_2_STATE.0;
        assert_eq!(combine_flags(omm, 0), omm);
        let both = FlatInstance {
            flags: off | on,
            ..FlatInstance::bottom(0, 0, 0, 0)
        };
        assert_eq!(both.vk_flags(), vk_flags::FORCE_OPAQUE);
    }

    #[test]
    fn two_levels_sum_offsets_compose_transforms_and_keep_the_inner_instance() {
        let gas = [FlatInstance::bottom(0x1000, 0, 7, 1)];
        let mut inner = Instance::new(TraversableHandle(1));
        inner.instance_id = 5;
        inner.sbt_offset = 2;
        inner.transform[3] = 1.0;
        let level1 = through_instance(&inner, 3, &gas).unwrap();
        let mut outer = Instance::new(TraversableHandle(2));
        outer.instance_id = 9;
        outer.sbt_offset = 10;
        outer.transform[7] = 2.0;
        outer.visibility_mask = 0x0F;
        let level2 = through_instance(&outer, 1, &level1).unwrap();
        let f = level2[0];
        assert_eq!(f.sbt_offset, 12);
        assert_eq!((f.instance_id, f.instance_index), (5, 3));
        assert_eq!(f.mask, 0x0F);
        assert_eq!((f.transform[3], f.transform[7]), (1.0, 2.0));
        assert_eq!(f.geometry_base, 7);
        let mut clash = outer;
        clash.visibility_mask = 0x01;
        let mut inner2 = inner;
        inner2.visibility_mask = 0x02;
        let l1 = through_instance(&inner2, 0, &gas).unwrap();
        assert!(through_instance(&clash, 0, &l1).is_err());
    }
}
