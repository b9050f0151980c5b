//! Widening the binary BVH to 4-wide nodes: which binary nodes become a wide node's
//! children, and in which order.
//!
//! Every backend that walks 4-wide nodes (the CPU traversal, the wgpu megakernel) picks
//! children here, so both see the same tree and visit equal-distance candidates in the same
//! order; each keeps its own node encoding.

use super::bvh::BvhNode;

/// Children per wide node.
pub const WIDTH: usize = 4;

/// The binary nodes that become the children of the wide node made from `source`, in lane
/// order: its two children, then repeatedly the inner one with the largest surface area
/// replaced in place by its first child, its second appended, until there are four or only
/// leaves. A leaf `source` is its own only child (a leaf root).
pub fn children(binary: &[BvhNode], source: usize) -> Vec<usize> {
    let node = &binary[source];
    if node.is_leaf() {
        return vec![source];
    }
    let mut children = vec![node.first as usize, node.first as usize + 1];
    while children.len() < WIDTH {
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
        assert_eq!(children(&bin, 4), vec![4], "a leaf is its own child");
        assert_eq!(
            children(&bin, 2),
            vec![4, 5],
            "only leaves below: two lanes"
        );
    }
}
