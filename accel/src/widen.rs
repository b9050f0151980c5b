//! Widening the binary BVH to wide nodes: which binary nodes become a wide node's
//! children, and in which order.
//!
//! Every backend that walks wide nodes picks children here, with one rule: the wgpu
//! megakernel's nodes have [`WIDTH`] (4) children, the CPU traversal's eight
//! ([`children_up_to`]); each keeps its own node encoding. Opening the widest child first
//! makes an 8-wide node's children a refinement of the 4-wide node's.

use super::bvh::BvhNode;

/// Children per wide node of the GPU backends' 4-wide trees.
pub const WIDTH: usize = 4;

/// [`children_up_to`] four children ([`WIDTH`]).
pub fn children(binary: &[BvhNode], source: usize) -> Vec<usize> {
    children_up_to(binary, source, WIDTH)
}

/// The binary nodes that become the children of the wide node made from `source`, in lane
/// order: its two children, then repeatedly the inner one with the largest surface area
/// replaced in place by its first child, its second appended, until there are `width` or
/// only leaves. A leaf `source` is its own only child (a leaf root).
pub fn children_up_to(binary: &[BvhNode], source: usize, width: usize) -> Vec<usize> {
    let node = &binary[source];
    if node.is_leaf() {
        return vec![source];
    }
    let mut children = vec![node.first as usize, node.first as usize + 1];
    while children.len() < width {
        let widest = children
            .iter()
            .enumerate()
            .filter(|(_, c)| !binary[**c].is_leaf())
            .max_by(|(_, a), (_, b)| {
                let area = |c: usize| binary[c].aabb().half_area();
                area(**a).total_cmp(&area(**b))
            })
            .map(|(i, _)| i);
        let Some(i) = widest else { break };
        let inner = &binary[children[i]];
        children[i] = inner.first as usize;
        children.push(inner.first as usize + 1);
    }
    children
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(first: u32, count: u32, size: f32) -> BvhNode {
        BvhNode {
            min: [0.0; 3],
            first,
            max: [size; 3],
            count,
        }
    }

    #[test]
    fn the_widest_inner_child_opens_in_place() {
        // Root (children 2, 3); node 2 is a small inner node (children 4, 5), node 3 a
        // large one (children 6, 7), all grandchildren leaves. Node 3 opens first, in its
        // own lane; then node 2 opens in lane 0 and its second child goes last.
        let bin = vec![
            node(2, 0, 10.0),
            node(0, 0, 0.0),
            node(4, 0, 1.0),
            node(6, 0, 5.0),
            node(0, 1, 1.0),
            node(1, 1, 1.0),
            node(2, 1, 5.0),
            node(3, 1, 5.0),
        ];
        assert_eq!(children(&bin, 0), vec![4, 6, 7, 5]);
        assert_eq!(children_up_to(&bin, 0, 3), vec![2, 6, 7]);
        assert_eq!(
            children_up_to(&bin, 0, 8),
            vec![4, 6, 7, 5],
            "no more than the leaves below"
        );
        assert_eq!(children(&bin, 4), vec![4], "a leaf is its own child");
        assert_eq!(
            children(&bin, 2),
            vec![4, 5],
            "only leaves below: two lanes"
        );
    }
}
