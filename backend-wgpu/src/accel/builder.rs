//! The binary BVH every structure starts from, in optik-cpu's node layout.
//!
//! Interim: this calls obvhs's PLOC builder directly, with the parameters optik-cpu uses,
//! until `optik_cpu::accel` (built on the same crate) lands on main; then this module
//! becomes a call to it. The layout below is the contract: `nodes[0]` is the root; an inner
//! node (`count == 0`) has its children at `first` and `first + 1`; a leaf covers primitive
//! slots `first .. first + count`; `order[slot]` is the primitive's index in the input.

use super::aabb::Aabb;
use optik_api::{BuildFlags, Error, Result};

/// One node of a binary BVH.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BinaryNode {
    pub bounds: Aabb,
    pub first: u32,
    pub count: u32,
}

/// Builds a binary BVH over the primitives with usable boxes, at most `max_leaf` per leaf.
/// Returns the nodes (empty when nothing is usable) and the slot order.
pub(crate) fn build(
    boxes: &[Aabb],
    max_leaf: u32,
    flags: BuildFlags,
) -> Result<(Vec<BinaryNode>, Vec<u32>)> {
    let included: Vec<u32> = (0..boxes.len() as u32)
        .filter(|&i| boxes[i as usize].is_usable())
        .collect();
    if included.is_empty() {
        return Ok((Vec::new(), Vec::new()));
    }
    let mut params = if flags.contains(BuildFlags::PREFER_FAST_TRACE) {
        obvhs::BvhBuildParams::medium_build()
    } else if flags.contains(BuildFlags::PREFER_FAST_BUILD) {
        obvhs::BvhBuildParams::very_fast_build()
    } else {
        obvhs::BvhBuildParams::fast_build()
    };
    // Spatial splits would put a primitive in several leaves, so a ray could meet it twice;
    // any-hit semantics (one call per primitive) forbid that.
    params.pre_split = false;
    let max_leaf = max_leaf.clamp(1, 8);
    params.max_prims_per_leaf = max_leaf.min(params.max_prims_per_leaf.max(1));
    // obvhs sizes its tree by the box count: give it the usable boxes only.
    let obvhs_boxes: Vec<obvhs::aabb::Aabb> = included
        .iter()
        .map(|&i| {
            let b = boxes[i as usize];
            obvhs::aabb::Aabb::new(b.min.into(), b.max.into())
        })
        .collect();
    // obvhs asserts on inputs it does not expect; a panic must not cross the API.
    let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut bvh = obvhs::ploc::PlocBuilder::with_capacity(included.len()).build(
            params.ploc_search_distance,
            &obvhs_boxes,
            (0..included.len() as u32).collect(),
            params.sort_precision,
            params.search_depth_threshold,
        );
        let mut reinsertion = obvhs::bvh2::reinsertion::ReinsertionOptimizer::default();
        reinsertion.run(&mut bvh, params.reinsertion_batch_ratio, None);
        obvhs::bvh2::leaf_collapser::collapse(
            &mut bvh,
            params.max_prims_per_leaf,
            params.collapse_traversal_cost,
        );
        bvh
    }))
    .map_err(|_| Error::backend("the BVH builder (obvhs) failed on these primitives"))?;
    let (mut nodes, local) = convert(&built);
    let order: Vec<u32> = local.iter().map(|&i| included[i as usize]).collect();
    if order.len() != included.len() || nodes.iter().any(|n| n.count > max_leaf) {
        return Err(Error::backend(format!(
            "the BVH builder placed {} of {} primitives in leaves of at most {max_leaf}",
            order.len(),
            included.len()
        )));
    }
    refit(&mut nodes, |slot| boxes[order[slot] as usize]);
    Ok((nodes, order))
}

/// Recomputes every box from the primitives' boxes by slot, keeping the topology.
pub(crate) fn refit(nodes: &mut [BinaryNode], slot_box: impl Fn(usize) -> Aabb) {
    for i in (0..nodes.len()).rev() {
        let n = nodes[i];
        nodes[i].bounds = if n.count > 0 {
            (n.first..n.first + n.count).fold(Aabb::EMPTY, |acc, s| {
                let b = slot_box(s as usize);
                if b.is_usable() { acc.union(b) } else { acc }
            })
        } else {
            nodes[n.first as usize]
                .bounds
                .union(nodes[n.first as usize + 1].bounds)
        };
    }
}

/// obvhs's tree in optik's layout: depth-first, siblings adjacent, children after parents,
/// leaves' primitives renumbered into consecutive slots.
fn convert(src: &obvhs::bvh2::Bvh2) -> (Vec<BinaryNode>, Vec<u32>) {
    let placeholder = BinaryNode {
        bounds: Aabb::EMPTY,
        first: 0,
        count: 0,
    };
    let mut nodes = vec![placeholder];
    let mut order = Vec::with_capacity(src.primitive_indices.len());
    let mut stack = vec![(0usize, 0usize)];
    while let Some((s, d)) = stack.pop() {
        let n = &src.nodes[s];
        if n.is_leaf() {
            let first = order.len() as u32;
            for k in 0..n.prim_count {
                order.push(src.primitive_indices[(n.first_index + k) as usize]);
            }
            nodes[d] = BinaryNode {
                first,
                count: n.prim_count,
                ..placeholder
            };
        } else {
            let c = nodes.len();
            nodes.push(placeholder);
            nodes.push(placeholder);
            nodes[d] = BinaryNode {
                first: c as u32,
                count: 0,
                ..placeholder
            };
            stack.push((n.first_index as usize + 1, c + 1));
            stack.push((n.first_index as usize, c));
        }
    }
    (nodes, order)
}
