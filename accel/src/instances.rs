//! Instance acceleration structures and transform traversables.
//!
//! Children are named by handle. Building resolves each handle once: an invalid one is an
//! error; the null handle makes an instance that nothing hits. Traversal resolves them again
//! against the launch's [`SceneTable`], so a child destroyed after the build simply misses.

use super::aabb::Aabb;
use super::bvh::{BuildQuality, Bvh};
use super::gas::GasEncoding;
use super::handle::{Resolved, SceneTable};
use crate::decode::{self, BufferBytes};
use optik_api::semantics::{affine, motion, sbt_index};
use optik_api::{
    AccelBuildOptions, Error, InstanceArray, Matrix3x4, MotionKinds, MotionOptions, Result,
    SceneFeatures, SrtData, TransformDesc, TraversableHandle,
};

/// One instance, per slot, as traversal reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct InstanceRecord {
    /// Object-to-world, 3×4 row-major.
    pub object_to_world: Matrix3x4,
    /// World-to-object (the inverse, computed in f64).
    pub world_to_object: Matrix3x4,
    /// The child's handle.
    pub child: u64,
    /// `rt_instance_id` (masked to the bits that count).
    pub instance_id: u32,
    /// `rt_instance_index`: the instance's position in the build input.
    pub instance_index: u32,
    /// Added to hit SBT indices (masked).
    pub sbt_offset: u32,
    /// Visibility mask (low 8 bits).
    pub mask: u32,
    /// [`optik_api::InstanceFlags`] bits.
    pub flags: u32,
    /// Padding to a multiple of 8 bytes.
    pub pad: u32,
}

/// A built instance acceleration structure.
#[derive(Clone, Debug, PartialEq)]
pub struct Ias {
    /// The BVH over instance slots (world-space boxes of the children over all times).
    pub bvh: Bvh,
    /// Per slot.
    pub instances: Vec<InstanceRecord>,
    /// The root box.
    pub bounds: Aabb,
    /// What the structure and its children contain.
    pub features: SceneFeatures,
    /// Levels of instances and transforms above geometry, this one included.
    pub depth: u32,
    /// The build quality used.
    pub quality: BuildQuality,
}

/// A child a build resolved: its bounds in its parent's object space and its features.
struct Child {
    bounds: Aabb,
    features: SceneFeatures,
}

fn resolve_child<E: GasEncoding>(
    scene: &SceneTable<E>,
    handle: TraversableHandle,
    what: &dyn Fn() -> String,
) -> Result<Option<Child>> {
    match scene.resolve(handle) {
        Resolved::Null => Ok(None),
        Resolved::Invalid => Err(Error::new(
            optik_api::ErrorKind::InvalidHandle,
            format!(
                "{}: traversable handle {:#x} is not a live acceleration structure or transform of this device (destroyed, or from another device)",
                what(),
                handle.0
            ),
        )),
        Resolved::Live(t) => Ok(Some(Child {
            bounds: t.bounds(),
            features: t.features(),
        })),
    }
}

fn check_depth(depth: u32, limit: u32, what: &str) -> Result<()> {
    if depth > limit {
        return Err(Error::limit(format!(
            "{what} would make a traversable graph {depth} levels deep; this device allows at most {limit} (instances and transforms nested, plus the geometry)"
        )));
    }
    Ok(())
}

struct DecodedInstances {
    records: Vec<InstanceRecord>,
    boxes: Vec<Aabb>,
    features: SceneFeatures,
    depth: u32,
}

fn decode_instances<E: GasEncoding>(
    input: &InstanceArray,
    bytes: &dyn BufferBytes,
    scene: &SceneTable<E>,
    max_graph_depth: u32,
) -> Result<DecodedInstances> {
    let instances = decode::instances(input, bytes).map_err(|e| e.context("build_inputs[0]"))?;
    let mut records = Vec::with_capacity(instances.len());
    let mut boxes = Vec::with_capacity(instances.len());
    let mut children = Vec::new();
    for (i, inst) in instances.iter().enumerate() {
        let handle = TraversableHandle(inst.traversable_handle);
        let child = resolve_child(scene, handle, &|| format!("build_inputs[0] instance {i}"))?;
        let inverse = affine::inverse(&inst.transform);
        let world_to_object = inverse.unwrap_or([0.0; 12]);
        let b = match (&child, inverse) {
            // A singular transform flattens its child to nothing a ray can hit.
            (Some(c), Some(_)) => c.bounds.transformed(&inst.transform),
            _ => Aabb::EMPTY,
        };
        if let Some(c) = child {
            children.push(c.features);
        }
        boxes.push(b);
        records.push(InstanceRecord {
            object_to_world: inst.transform,
            world_to_object,
            child: if inverse.is_some() {
                inst.traversable_handle
            } else {
                0
            },
            instance_id: inst.instance_id & sbt_index::INSTANCE_ID_MASK,
            instance_index: i as u32,
            sbt_offset: inst.sbt_offset & sbt_index::INSTANCE_SBT_OFFSET_MASK,
            mask: inst.visibility_mask & sbt_index::VISIBILITY_MASK_BITS,
            flags: inst.flags,
            pad: 0,
        });
    }
    let features = SceneFeatures::of_parent(&children, MotionKinds::default(), false);
    check_depth(
        features.depth + 1,
        max_graph_depth,
        "this instance acceleration structure",
    )?;
    Ok(DecodedInstances {
        records,
        boxes,
        depth: features.depth,
        features,
    })
}

impl Ias {
    /// Builds an instance structure from a validated input; children resolve in `scene`.
    pub fn build<E: GasEncoding>(
        options: &AccelBuildOptions,
        input: &InstanceArray,
        bytes: &dyn BufferBytes,
        scene: &SceneTable<E>,
        max_graph_depth: u32,
    ) -> Result<Ias> {
        let d = decode_instances(input, bytes, scene, max_graph_depth)?;
        let quality = BuildQuality::from_flags(options.flags);
        let (bvh, order) = Bvh::build(&d.boxes, quality)?;
        Ok(Ias {
            bounds: bvh.bounds(),
            instances: order.iter().map(|&i| d.records[i as usize]).collect(),
            bvh,
            features: d.features,
            depth: d.depth,
            quality,
        })
    }

    /// Refits to new instance transforms and children (same count). Instances left out at
    /// build (null child, singular transform) stay out. On error nothing changes.
    pub fn refit<E: GasEncoding>(
        &mut self,
        input: &InstanceArray,
        bytes: &dyn BufferBytes,
        scene: &SceneTable<E>,
        max_graph_depth: u32,
    ) -> Result<()> {
        let d = decode_instances(input, bytes, scene, max_graph_depth)?;
        let slot_of: Vec<u32> = self.instances.iter().map(|r| r.instance_index).collect();
        self.instances = slot_of.iter().map(|&i| d.records[i as usize]).collect();
        self.bvh.refit(|slot| d.boxes[slot_of[slot] as usize]);
        self.bounds = self.bvh.bounds();
        self.features = d.features;
        self.depth = d.depth;
        Ok(())
    }

    /// Bytes the structure occupies.
    pub fn size_in_bytes(&self) -> u64 {
        self.bvh.size_in_bytes()
            + (self.instances.len() * std::mem::size_of::<InstanceRecord>()) as u64
    }
}

/// What a transform does.
#[derive(Clone, Debug, PartialEq)]
pub enum TransformKind {
    /// A fixed transform.
    Static {
        /// Object-to-world.
        object_to_world: Matrix3x4,
        /// Its inverse.
        world_to_object: Matrix3x4,
    },
    /// Matrix keys, interpolated element-wise.
    MatrixMotion {
        /// Keys and time range.
        motion: MotionOptions,
        /// Object-to-world per key.
        keys: Vec<Matrix3x4>,
    },
    /// SRT keys, interpolated with nlerp.
    SrtMotion {
        /// Keys and time range.
        motion: MotionOptions,
        /// The keys.
        keys: Vec<SrtData>,
    },
}

impl TransformKind {
    /// What a transform description does.
    pub fn of(desc: &TransformDesc) -> TransformKind {
        match desc {
            TransformDesc::Static {
                object_to_world,
                world_to_object,
                ..
            } => TransformKind::Static {
                object_to_world: *object_to_world,
                world_to_object: *world_to_object,
            },
            TransformDesc::MatrixMotion { motion, keys, .. } => TransformKind::MatrixMotion {
                motion: *motion,
                keys: keys.clone(),
            },
            TransformDesc::SrtMotion { motion, keys, .. } => TransformKind::SrtMotion {
                motion: *motion,
                keys: keys.clone(),
            },
        }
    }
}

/// A transform traversable.
#[derive(Clone, Debug, PartialEq)]
pub struct Transform {
    /// The transform.
    pub kind: TransformKind,
    /// The child's handle.
    pub child: TraversableHandle,
    /// The child's box in this transform's parent space, over all times.
    pub bounds: Aabb,
    /// What the transform and its child contain.
    pub features: SceneFeatures,
    /// Levels of instances and transforms above geometry, this one included.
    pub depth: u32,
}

/// Sub-steps per key interval when bounding SRT motion (see [`srt_motion_bounds`]).
const SRT_BOUND_STEPS: usize = 32;

/// A box holding `child` at every time of an SRT key interval `a → b`.
///
/// Samples the interpolated transform at `SRT_BOUND_STEPS + 1` times and pads the union of
/// the sampled boxes by how far any point can move between samples: its speed is at most
/// `ω·r + |S₁p − S₀p| + |T₁ − T₀|` per unit of interval time, where `r` bounds `|S(t)p|`
/// and ω bounds the angular speed of nlerp (`2|q₁ − q₀| / min|lerp(q₀, q₁)|`).
fn srt_interval_bounds(child: &Aabb, a: &SrtData, b: &SrtData) -> Aabb {
    let s = |k: &SrtData| -> Matrix3x4 {
        [
            k.sx, k.a, k.b, k.pvx, 0.0, k.sy, k.c, k.pvy, 0.0, 0.0, k.sz, k.pvz,
        ]
    };
    let (sa, sb) = (s(a), s(b));
    let len = |v: [f32; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let mut r = 0.0f32;
    let mut ds = 0.0f32;
    for c in child.corners() {
        let (x0, x1) = (
            affine::transform_point(&sa, c),
            affine::transform_point(&sb, c),
        );
        r = r.max(len(x0)).max(len(x1));
        ds = ds.max(len([x1[0] - x0[0], x1[1] - x0[1], x1[2] - x0[2]]));
    }
    let dt = len([b.tx - a.tx, b.ty - a.ty, b.tz - a.tz]);
    let (qa, qb) = ([a.qx, a.qy, a.qz, a.qw], [b.qx, b.qy, b.qz, b.qw]);
    let dot: f32 = (0..4).map(|i| qa[i] * qb[i]).sum();
    let dq = (0..4).map(|i| (qb[i] - qa[i]).powi(2)).sum::<f32>().sqrt();
    let min_len = ((1.0 + dot) * 0.5).max(0.0).sqrt();
    if min_len < 1e-3 {
        // Opposite quaternions: nlerp passes near zero and may spin arbitrarily fast. Bound
        // by the ball the rotation cannot leave.
        let mut t = Aabb::point([a.tx, a.ty, a.tz]);
        t.grow([b.tx, b.ty, b.tz]);
        return t.padded(r).rounded_out();
    }
    let omega = 2.0 * dq / min_len;
    let speed = omega * r + ds + dt;
    let keys = [*a, *b];
    let mut out = Aabb::EMPTY;
    for j in 0..=SRT_BOUND_STEPS {
        let at = motion::KeyPosition {
            key: 0,
            t: j as f32 / SRT_BOUND_STEPS as f32,
        };
        let m = motion::srt_to_matrix(&motion::interpolate_srt(&keys, at));
        out = out.union(&child.transformed(&m));
    }
    out.padded(speed / (2 * SRT_BOUND_STEPS) as f32)
        .rounded_out()
}

/// A box holding `child` (a box in the transform's child space) under `kind` at every
/// time, in the transform's parent space: the one bound every backend uses for transforms.
pub fn motion_bounds(kind: &TransformKind, child: &Aabb) -> Aabb {
    if !child.is_valid() {
        return Aabb::EMPTY;
    }
    match kind {
        TransformKind::Static {
            object_to_world, ..
        } => child.transformed(object_to_world),
        TransformKind::MatrixMotion { keys, .. } => matrix_motion_bounds(keys, child),
        TransformKind::SrtMotion { keys, .. } => srt_motion_bounds(keys, child),
    }
}

/// A box holding `child` under matrix motion through `keys` at every time: a point under
/// lerped matrices moves on the segment between its keyed positions, so the union of the
/// key boxes holds it.
pub fn matrix_motion_bounds(keys: &[Matrix3x4], child: &Aabb) -> Aabb {
    keys.iter()
        .fold(Aabb::EMPTY, |acc, m| acc.union(&child.transformed(m)))
}

/// A box holding `child` under SRT motion through `keys` at every time (empty for an
/// invalid child box, and for fewer than two keys, which validation refuses).
pub fn srt_motion_bounds(keys: &[SrtData], child: &Aabb) -> Aabb {
    if !child.is_valid() {
        return Aabb::EMPTY;
    }
    keys.windows(2).fold(Aabb::EMPTY, |acc, w| {
        acc.union(&srt_interval_bounds(child, &w[0], &w[1]))
    })
}

impl Transform {
    /// A transform from a validated description (`optik_core::validate::transform` passed).
    pub fn new<E: GasEncoding>(
        desc: &TransformDesc,
        scene: &SceneTable<E>,
        max_graph_depth: u32,
    ) -> Result<Transform> {
        let child = desc.child();
        let resolved = resolve_child(scene, child, &|| "transform child".to_string())?;
        let kind = TransformKind::of(desc);
        let (motion_kind, is_static) = match &kind {
            TransformKind::Static { .. } => (MotionKinds::default(), true),
            TransformKind::MatrixMotion { .. } => (
                MotionKinds {
                    matrix: true,
                    ..Default::default()
                },
                false,
            ),
            TransformKind::SrtMotion { .. } => (
                MotionKinds {
                    srt: true,
                    ..Default::default()
                },
                false,
            ),
        };
        let (child_bounds, child_features) = match &resolved {
            Some(c) => (c.bounds, vec![c.features]),
            None => (Aabb::EMPTY, Vec::new()),
        };
        let features = SceneFeatures::of_parent(&child_features, motion_kind, is_static);
        check_depth(features.depth + 1, max_graph_depth, "this transform")?;
        Ok(Transform {
            bounds: motion_bounds(&kind, &child_bounds),
            kind,
            child,
            depth: features.depth,
            features,
        })
    }

    /// The object-to-world matrix at `time` (`None`: the child vanishes then). Without
    /// `motion` (a pipeline compiled without motion blur) the first key is used.
    pub fn object_to_world_at(&self, time: f32, use_motion: bool) -> Option<Matrix3x4> {
        match &self.kind {
            TransformKind::Static {
                object_to_world, ..
            } => Some(*object_to_world),
            TransformKind::MatrixMotion { motion: m, keys } => {
                if !use_motion {
                    return Some(keys[0]);
                }
                motion::resolve_key(m, time).map(|at| motion::interpolate_matrix(keys, at))
            }
            TransformKind::SrtMotion { motion: m, keys } => {
                if !use_motion {
                    return Some(motion::srt_to_matrix(&keys[0]));
                }
                motion::resolve_key(m, time)
                    .map(|at| motion::srt_to_matrix(&motion::interpolate_srt(keys, at)))
            }
        }
    }

    /// Bytes the transform occupies.
    pub fn size_in_bytes(&self) -> u64 {
        let keys = match &self.kind {
            TransformKind::Static { .. } => 96,
            TransformKind::MatrixMotion { keys, .. } => keys.len() * 48,
            TransformKind::SrtMotion { keys, .. } => keys.len() * 64,
        };
        (keys + 32) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quat(axis: [f32; 3], angle: f32) -> [f32; 4] {
        let (s, c) = (angle * 0.5).sin_cos();
        [axis[0] * s, axis[1] * s, axis[2] * s, c]
    }

    #[test]
    fn instance_records_are_128_bytes() {
        assert_eq!(std::mem::size_of::<InstanceRecord>(), 128);
    }

    #[test]
    fn srt_bounds_hold_every_sampled_time() {
        let child = Aabb {
            min: [1.0, -0.5, 0.0],
            max: [2.0, 0.5, 0.3],
        };
        for angle in [0.0f32, 0.5, 1.5, 3.0] {
            let q0 = quat([0.0, 0.0, 1.0], 0.0);
            let q1 = quat([0.3, 0.2, 0.93], angle);
            let a = SrtData {
                qx: q0[0],
                qy: q0[1],
                qz: q0[2],
                qw: q0[3],
                pvx: 0.5,
                ..SrtData::identity()
            };
            let b = SrtData {
                sx: 2.0,
                a: 0.3,
                qx: q1[0],
                qy: q1[1],
                qz: q1[2],
                qw: q1[3],
                tx: 3.0,
                ty: -1.0,
                ..SrtData::identity()
            };
            let bounds = srt_interval_bounds(&child, &a, &b);
            for j in 0..=1000 {
                let at = motion::KeyPosition {
                    key: 0,
                    t: j as f32 / 1000.0,
                };
                let m = motion::srt_to_matrix(&motion::interpolate_srt(&[a, b], at));
                for c in child.corners() {
                    let p = affine::transform_point(&m, c);
                    for k in 0..3 {
                        assert!(
                            bounds.min[k] <= p[k] && p[k] <= bounds.max[k],
                            "angle {angle}, t {}: {p:?} outside {bounds:?}",
                            at.t
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn srt_bounds_hold_the_arc_outside_the_key_boxes() {
        // A box at x in [4, 5] turning 90° about z: at 45° its far corner is at
        // |p| = √(25 + 0.25 + 0.25), on the diagonal, outside the union of the key boxes.
        let child = Aabb {
            min: [4.0, -0.5, -0.5],
            max: [5.0, 0.5, 0.5],
        };
        let q = quat([0.0, 0.0, 1.0], std::f32::consts::FRAC_PI_2);
        let k0 = SrtData::identity();
        let k1 = SrtData {
            qx: q[0],
            qy: q[1],
            qz: q[2],
            qw: q[3],
            ..SrtData::identity()
        };
        let keys = [k0, k1];
        let bounds = srt_motion_bounds(&keys, &child);
        let kind = TransformKind::SrtMotion {
            motion: MotionOptions {
                num_keys: 2,
                flags: optik_api::MotionFlags::default(),
                time_begin: 0.0,
                time_end: 1.0,
            },
            keys: keys.to_vec(),
        };
        assert_eq!(motion_bounds(&kind, &child), bounds);
        let keys_only = matrix_motion_bounds(
            &[motion::srt_to_matrix(&k0), motion::srt_to_matrix(&k1)],
            &child,
        );
        let mut outside_keys = false;
        for s in 0..=100 {
            let at = motion::KeyPosition {
                key: 0,
                t: s as f32 / 100.0,
            };
            let m = motion::srt_to_matrix(&motion::interpolate_srt(&keys, at));
            for c in child.corners() {
                let p = affine::transform_point(&m, c);
                outside_keys |= (0..3).any(|i| p[i] < keys_only.min[i] || p[i] > keys_only.max[i]);
                for i in 0..3 {
                    assert!(
                        bounds.min[i] <= p[i] && p[i] <= bounds.max[i],
                        "{p:?} outside {bounds:?}"
                    );
                }
            }
        }
        assert!(outside_keys, "the test's arc leaves the key boxes");
        assert_eq!(srt_motion_bounds(&keys, &Aabb::EMPTY), Aabb::EMPTY);
    }
}
