//! Instance acceleration structures and transform traversables.
//!
//! An instance names its child by traversable handle; the child is resolved when the
//! structure is built (its box, its stack need) and again on the GPU at every visit, through
//! the device's handle table: a child destroyed later is simply missed.

use super::aabb::Aabb;
use super::bvh4::{Bvh4, NODE_VEC4S};
use super::layout::{self, HEADER_VEC4S, INSTANCE_VEC4S, kind};
use optik_api::decode::{self, BufferBytes};
use optik_api::semantics::{affine, motion, sbt_index};
use optik_api::{
    AccelBuildOptions, InstanceArray, Matrix3x4, MotionKinds, Result, SceneFeatures, SrtData,
    TransformDesc,
};
use optik_cpu::accel::{Aabb as CpuAabb, BuildQuality, Bvh};

/// What a parent needs to know about a child traversable.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ChildInfo {
    pub slot: u32,
    pub generation: u32,
    /// Its box in its own space, over all of its motion.
    pub bounds: Aabb,
    /// Stack entries its traversal needs below its root entry.
    pub stack_need: u32,
    /// BVH levels (instance and geometry structures) on its deepest path.
    pub levels: u32,
    pub features: SceneFeatures,
}

/// The slot/generation pair written for a missing child: never a live entry.
const NO_CHILD: [u32; 2] = [u32::MAX, 0];

/// An encoded instance structure or transform.
pub(crate) struct BuiltParent {
    pub words: Vec<[u32; 4]>,
    pub bounds: Aabb,
    pub stack_need: u32,
    pub levels: u32,
    pub features: SceneFeatures,
    pub refit: Option<Bvh4WithOrder>,
}

/// The trees of an instance structure's build, kept for updates: optik-cpu's binary BVH
/// and slot order, and the wide tree made from it.
#[derive(Clone, Debug)]
pub(crate) struct Bvh4WithOrder {
    binary: Bvh,
    bvh: Bvh4,
    order: Vec<u32>,
}

/// Builds (or, with `topology`, refits) an instance structure.
pub(crate) fn build_instances(
    options: &AccelBuildOptions,
    array: &InstanceArray,
    bytes: &dyn BufferBytes,
    resolve: &dyn Fn(u64) -> Result<Option<ChildInfo>>,
    topology: Option<&Bvh4WithOrder>,
) -> Result<BuiltParent> {
    let instances = decode::instances(array, bytes)?;
    let mut boxes = Vec::with_capacity(instances.len());
    let mut records: Vec<[u32; 4]> = Vec::with_capacity(instances.len() * INSTANCE_VEC4S as usize);
    let mut children = Vec::with_capacity(instances.len());
    for (i, inst) in instances.iter().enumerate() {
        let child = resolve(inst.traversable_handle)
            .map_err(|e| e.context(format!("instances[{i}].traversable_handle")))?;
        let inverse = affine::inverse(&inst.transform);
        let (bounds, w2o) = match (child, inverse) {
            (Some(c), Some(w2o)) => (c.bounds.transformed(&inst.transform), w2o),
            // A null child, or a transform that collapses space: nothing to hit.
            _ => (Aabb::EMPTY, [0.0; 12]),
        };
        boxes.push(bounds);
        records.extend(layout::matrix_rows(&w2o));
        records.extend(layout::matrix_rows(&inst.transform));
        records.push([
            inst.instance_id & sbt_index::INSTANCE_ID_MASK,
            inst.sbt_offset & sbt_index::INSTANCE_SBT_OFFSET_MASK,
            (inst.visibility_mask & sbt_index::VISIBILITY_MASK_BITS) | (inst.flags << 8),
            i as u32,
        ]);
        let link = child.map_or(NO_CHILD, |c| [c.slot, c.generation]);
        records.push([link[0], link[1], 0, 0]);
        children.push(child);
    }
    let cpu_boxes: Vec<CpuAabb> = boxes
        .iter()
        .map(|b| CpuAabb {
            min: b.min,
            max: b.max,
        })
        .collect();
    let topo = match topology {
        Some(t) => {
            let mut t = t.clone();
            let order = t.order.clone();
            t.binary.refit(|slot| cpu_boxes[order[slot] as usize]);
            t.bvh.refit_from_binary(t.binary.nodes());
            t
        }
        None => {
            let (binary, order) = Bvh::build(&cpu_boxes, BuildQuality::from_flags(options.flags))?;
            Bvh4WithOrder {
                bvh: Bvh4::from_binary(binary.nodes()),
                binary,
                order,
            }
        }
    };
    let node_rel = HEADER_VEC4S as u32;
    let inst_rel = node_rel + (topo.bvh.nodes.len() * NODE_VEC4S) as u32;
    let mut words = vec![
        [layout::kind_word(kind::IAS, 0, 0), 1, node_rel, inst_rel],
        [0; 4],
        [0, topo.bvh.nodes.len() as u32, 0, 0],
    ];
    topo.bvh.encode(&mut words);
    for &p in &topo.order {
        let at = p as usize * INSTANCE_VEC4S as usize;
        words.extend_from_slice(&records[at..at + INSTANCE_VEC4S as usize]);
    }
    let live: Vec<ChildInfo> = children.iter().flatten().copied().collect();
    // Entering one instance of a leaf pushes the rest of the leaf (when there is a rest), a
    // level marker and the child's root, then pops the root.
    let stack_need = topo.bvh.stack_need(|first, count| {
        let deepest = (first..first + count)
            .map(|slot| {
                children[topo.order[slot as usize] as usize]
                    .map_or(0, |c| 2u32.max(1 + c.stack_need))
            })
            .max()
            .unwrap_or(0);
        deepest + (count > 1) as u32
    });
    let features = SceneFeatures::of_parent(
        &live.iter().map(|c| c.features).collect::<Vec<_>>(),
        MotionKinds::default(),
        false,
    );
    Ok(BuiltParent {
        words,
        bounds: topo.bvh.bounds(),
        stack_need,
        levels: 1 + live.iter().map(|c| c.levels).max().unwrap_or(0),
        features,
        refit: Some(topo),
    })
}

/// Encodes a transform traversable over `child` (`None`: a null child).
pub(crate) fn build_transform(desc: &TransformDesc, child: Option<ChildInfo>) -> BuiltParent {
    let link = child.map_or(NO_CHILD, |c| [c.slot, c.generation]);
    let child_bounds = child.map_or(Aabb::EMPTY, |c| c.bounds);
    let (kind_id, keys, m, data, bounds, motion_kind, is_static): (
        u32,
        u32,
        Option<optik_api::MotionOptions>,
        Vec<[u32; 4]>,
        Aabb,
        MotionKinds,
        bool,
    ) = match desc {
        TransformDesc::Static {
            object_to_world,
            world_to_object,
            ..
        } => {
            let mut data = layout::matrix_rows(world_to_object).to_vec();
            data.extend(layout::matrix_rows(object_to_world));
            (
                kind::STATIC,
                1,
                None,
                data,
                child_bounds.transformed(object_to_world),
                MotionKinds::default(),
                true,
            )
        }
        TransformDesc::MatrixMotion { motion, keys, .. } => {
            let data = keys.iter().flat_map(layout::matrix_rows).collect();
            // Lerped matrices map a point to a blend of its key images: the union of the
            // key boxes holds every time.
            let bounds = keys
                .iter()
                .fold(Aabb::EMPTY, |b, k| b.union(child_bounds.transformed(k)));
            (
                kind::MATRIX_MOTION,
                keys.len() as u32,
                Some(*motion),
                data,
                bounds,
                MotionKinds {
                    matrix: true,
                    ..Default::default()
                },
                false,
            )
        }
        TransformDesc::SrtMotion { motion, keys, .. } => {
            let data = keys
                .iter()
                .flat_map(|k| {
                    let f: &[f32; 16] = bytemuck::cast_ref(k);
                    (0..4).map(move |v| std::array::from_fn(|c| f[v * 4 + c].to_bits()))
                })
                .collect();
            (
                kind::SRT_MOTION,
                keys.len() as u32,
                Some(*motion),
                data,
                srt_bounds(keys, &child_bounds),
                MotionKinds {
                    srt: true,
                    ..Default::default()
                },
                false,
            )
        }
    };
    let mut words = vec![
        [layout::kind_word(kind_id, 0, 0), keys, link[0], link[1]],
        [
            m.map_or(0.0f32, |m| m.time_begin).to_bits(),
            m.map_or(0.0f32, |m| m.time_end).to_bits(),
            m.map_or(0, |m| m.flags.0),
            HEADER_VEC4S as u32,
        ],
        [0; 4],
    ];
    words.extend(data);
    let features = SceneFeatures::of_parent(
        &child.iter().map(|c| c.features).collect::<Vec<_>>(),
        motion_kind,
        is_static,
    );
    BuiltParent {
        words,
        bounds: if child.is_some() { bounds } else { Aabb::EMPTY },
        stack_need: child.map_or(0, |c| c.stack_need),
        levels: child.map_or(0, |c| c.levels),
        features,
        refit: None,
    }
}

/// Sub-steps per key interval when bounding SRT motion.
const SRT_STEPS: usize = 32;

/// A box holding `child` under SRT motion at every time. Rotations move points along arcs,
/// which can leave the key boxes: the box of many sampled times is padded by how far an
/// arc between two samples strays from its chord, r·(1 − cos(Δ/2)) for a point at distance
/// r from the rotation centre turned by Δ between samples (doubled for safety).
fn srt_bounds(keys: &[SrtData], child: &Aabb) -> Aabb {
    if !child.is_usable() {
        return Aabb::EMPTY;
    }
    let corners: Vec<[f32; 3]> = (0..8)
        .map(|c| {
            std::array::from_fn(|i| {
                if c & (1 << i) != 0 {
                    child.max[i]
                } else {
                    child.min[i]
                }
            })
        })
        .collect();
    let reach = keys
        .iter()
        .flat_map(|k| {
            let scale_only = SrtData {
                qx: 0.0,
                qy: 0.0,
                qz: 0.0,
                qw: 1.0,
                tx: 0.0,
                ty: 0.0,
                tz: 0.0,
                ..*k
            };
            let m: Matrix3x4 = motion::srt_to_matrix(&scale_only);
            corners.iter().map(move |p| {
                let q = affine::transform_point(&m, *p);
                (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt()
            })
        })
        .fold(0.0f32, f32::max);
    let mut bounds = Aabb::EMPTY;
    let mut widest_turn = 0.0f32;
    for k in 0..keys.len().saturating_sub(1) {
        let mut previous: Option<[f32; 4]> = None;
        for s in 0..=SRT_STEPS {
            let at = motion::KeyPosition {
                key: k,
                t: s as f32 / SRT_STEPS as f32,
            };
            let key = motion::interpolate_srt(keys, at);
            bounds = bounds.union(child.transformed(&motion::srt_to_matrix(&key)));
            let q = [key.qx, key.qy, key.qz, key.qw];
            if let Some(p) = previous {
                let dot = (0..4).map(|i| p[i] * q[i]).sum::<f32>().abs().min(1.0);
                widest_turn = widest_turn.max(2.0 * dot.acos());
            }
            previous = Some(q);
        }
    }
    if keys.len() == 1 {
        bounds = child.transformed(&motion::srt_to_matrix(&keys[0]));
    }
    let pad = 2.0 * reach * (1.0 - (widest_turn * 0.5).cos());
    bounds.padded(pad).widened_relative()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srt_bounds_hold_the_arc() {
        // A unit box at x in [4, 5] turning 90° about z: at 45° it reaches x = y ≈ 3.2..,
        // with |p| up to √(25 + 1) — outside the union of the two key boxes.
        let child = Aabb {
            min: [4.0, -0.5, -0.5],
            max: [5.0, 0.5, 0.5],
        };
        let half = std::f32::consts::FRAC_PI_4;
        let k0 = SrtData::identity();
        let k1 = SrtData {
            qz: half.sin(),
            qw: half.cos(),
            ..SrtData::identity()
        };
        let b = srt_bounds(&[k0, k1], &child);
        for s in 0..=100 {
            let t = s as f32 / 100.0;
            let key = motion::interpolate_srt(&[k0, k1], motion::KeyPosition { key: 0, t });
            let m = motion::srt_to_matrix(&key);
            for c in 0..8 {
                let p: [f32; 3] = std::array::from_fn(|i| {
                    if c & (1 << i) != 0 {
                        child.max[i]
                    } else {
                        child.min[i]
                    }
                });
                let q = affine::transform_point(&m, p);
                for i in 0..3 {
                    assert!(b.min[i] <= q[i] && q[i] <= b.max[i], "{q:?} outside {b:?}");
                }
            }
        }
    }
}
