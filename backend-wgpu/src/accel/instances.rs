//! Instance acceleration structures and transform traversables.
//!
//! An instance names its child by traversable handle; the child is resolved when the
//! structure is built (its box, its stack need) and again on the GPU at every visit, through
//! the device's handle table: a child destroyed later is simply missed.

use super::bvh4::{Bvh4, NODE_VEC4S};
use super::layout::{self, HEADER_VEC4S, INSTANCE_VEC4S, kind};
use optik_accel::decode::{self, BufferBytes};
use optik_accel::{Aabb, BuildQuality, Bvh, TransformKind, motion_bounds};
use optik_api::semantics::{affine, sbt_index};
use optik_api::{
    AccelBuildOptions, InstanceArray, MotionKinds, Result, SceneFeatures, TransformDesc,
};

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

/// The trees of an instance structure's build, kept for updates: optik-accel's binary BVH
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
    let topo = match topology {
        Some(t) => {
            let mut t = t.clone();
            let order = t.order.clone();
            t.binary.refit(|slot| boxes[order[slot] as usize]);
            t.bvh.refit_from_binary(t.binary.nodes());
            t
        }
        None => {
            let (binary, order) = Bvh::build(&boxes, BuildQuality::from_flags(options.flags))?;
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
                motion_bounds(&TransformKind::of(desc), &child_bounds),
                MotionKinds::default(),
                true,
            )
        }
        TransformDesc::MatrixMotion { motion, keys, .. } => {
            let data = keys.iter().flat_map(layout::matrix_rows).collect();
            let bounds = motion_bounds(&TransformKind::of(desc), &child_bounds);
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
                motion_bounds(&TransformKind::of(desc), &child_bounds),
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
