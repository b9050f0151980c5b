//! Leaf collapse for leaves tested a block of primitives at a time.
//!
//! obvhs's collapse (after madmann91's `bvh`) prices a leaf by its primitive count: merging two
//! leaves of two triangles costs as much as testing four triangles one by one. A backend that
//! tests a block of `block` primitives at once (the CPU's 4-lane triangle test) pays per
//! block, not per primitive, so the same surface-area rule with the count rounded up to whole
//! blocks collapses where obvhs's would not, and stops where a leaf would start a new block.
//!
//! The rule is obvhs's greedy bottom-up one, with the costs of [`LeafCosts`]: a node whose two
//! children are leaves becomes one leaf when
//! `area(node) · leaf(n) ≤ area(node) · node + area(left) · leaf(n_l) + area(right) · leaf(n_r)`,
//! `leaf(n) = visit + ceil(n / block)` (one block test costs 1), and `n ≤ max_prims`.
//! The pass is serial and its result depends only on the tree it is given.

use obvhs::bvh2::{Bvh2, node::Bvh2Node};

/// The most primitives any leaf holds (obvhs's limit, which the backends' encodings share).
const MAX_LEAF: u32 = 255;

/// What a leaf and a node cost, in block tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafCosts {
    /// Primitives one block test covers.
    pub block: u32,
    /// The cost of entering a leaf, beyond its block tests.
    pub visit: f32,
    /// The cost of traversing one binary node.
    pub node: f32,
    /// The most primitives a leaf may hold (at most 255).
    pub max_prims: u32,
}

impl LeafCosts {
    fn leaf(&self, count: u32) -> f32 {
        self.visit + count.div_ceil(self.block.max(1)) as f32
    }
}

/// Collapses `bvh`'s leaves by `costs` and rewrites it compactly (root at 0, children after
/// their parent, primitives of a leaf in the left-to-right order of the subtree it replaces).
pub fn collapse(bvh: &mut Bvh2, costs: LeafCosts) {
    let nodes = &bvh.nodes;
    if nodes.is_empty() || nodes[0].is_leaf() {
        return;
    }
    // Post-order: every node after both its children.
    let mut post = Vec::with_capacity(nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        post.push(i);
        if !nodes[i].is_leaf() {
            let c = nodes[i].first_index as usize;
            stack.push(c);
            stack.push(c + 1);
        }
    }
    // counts[i]: primitives under i if i is (or became) a leaf, 0 if it stays inner.
    let mut counts = vec![0u32; nodes.len()];
    for &i in post.iter().rev() {
        let n = &nodes[i];
        if n.is_leaf() {
            counts[i] = n.prim_count;
            continue;
        }
        let c = n.first_index as usize;
        let (l, r) = (counts[c], counts[c + 1]);
        let total = l + r;
        if l == 0 || r == 0 || total > costs.max_prims.min(MAX_LEAF) {
            continue;
        }
        let merged = n.aabb().half_area() * costs.leaf(total);
        let split = n.aabb().half_area() * costs.node
            + nodes[c].aabb().half_area() * costs.leaf(l)
            + nodes[c + 1].aabb().half_area() * costs.leaf(r);
        if merged <= split {
            counts[i] = total;
        }
    }
    // Re-emit: a collapsed node becomes a leaf over its subtree's primitives.
    let mut out_nodes: Vec<Bvh2Node> = Vec::with_capacity(nodes.len());
    let mut out_prims: Vec<u32> = Vec::with_capacity(bvh.primitive_indices.len());
    out_nodes.push(nodes[0]);
    let mut todo = vec![(0usize, 0usize)];
    let mut gather = Vec::new();
    while let Some((src, dst)) = todo.pop() {
        let n = nodes[src];
        if counts[src] > 0 {
            let first = out_prims.len() as u32;
            gather.push(src);
            while let Some(j) = gather.pop() {
                let m = &nodes[j];
                if m.is_leaf() {
                    let k = m.first_index as usize;
                    out_prims
                        .extend_from_slice(&bvh.primitive_indices[k..k + m.prim_count as usize]);
                } else {
                    gather.push(m.first_index as usize + 1);
                    gather.push(m.first_index as usize);
                }
            }
            out_nodes[dst] = Bvh2Node::new(*n.aabb(), out_prims.len() as u32 - first, first);
        } else {
            let c = out_nodes.len();
            out_nodes.push(nodes[n.first_index as usize]);
            out_nodes.push(nodes[n.first_index as usize + 1]);
            out_nodes[dst] = Bvh2Node::new(*n.aabb(), 0, c as u32);
            todo.push((n.first_index as usize + 1, c + 1));
            todo.push((n.first_index as usize, c));
        }
    }
    bvh.nodes = out_nodes;
    bvh.primitive_indices = out_prims;
    bvh.parents.clear();
    bvh.primitives_to_nodes.clear();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Aabb;

    const COSTS: LeafCosts = LeafCosts {
        block: 4,
        visit: 0.0,
        node: 0.3,
        max_prims: 8,
    };

    fn node(b: Aabb, count: u32, first: u32) -> Bvh2Node {
        Bvh2Node::new(b.to_obvhs(), count, first)
    }

    fn cube(lo: f32, hi: f32) -> Aabb {
        Aabb {
            min: [lo; 3],
            max: [hi; 3],
        }
    }

    /// A root over two leaves of `left` and `right` primitives with boxes `a` and `b`.
    fn two_leaves(a: Aabb, left: u32, b: Aabb, right: u32) -> Bvh2 {
        Bvh2 {
            nodes: vec![
                node(a.union(&b), 0, 1),
                node(a, left, 0),
                node(b, right, left),
            ],
            primitive_indices: (0..left + right).rev().collect(),
            ..Bvh2::default()
        }
    }

    fn leaves(bvh: &Bvh2) -> Vec<u32> {
        bvh.nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| n.prim_count)
            .collect()
    }

    /// Same boxes, same rule: four primitives fill one block and merge; five would need a
    /// second block, which the children's smaller boxes do not pay for. A per-primitive
    /// price cannot tell these apart.
    #[test]
    fn leaves_merge_while_they_fill_whole_blocks() {
        // Children of a third of the parent's area each: merged costs 1 block (4) or 2
        // (5) over the parent, split 0.3 over the parent plus 1 block over each child.
        let (a, b) = (cube(0.0, 1.0), cube(0.5, 1.5));
        let ratio = a.to_obvhs().half_area() / a.union(&b).to_obvhs().half_area();
        assert!(ratio > 0.35 && ratio < 0.45, "{ratio}");
        let mut four = two_leaves(a, 2, b, 2);
        collapse(&mut four, COSTS);
        assert_eq!(leaves(&four), vec![4]);
        assert_eq!(
            four.primitive_indices,
            vec![3, 2, 1, 0],
            "subtree order kept"
        );
        let mut five = two_leaves(a, 4, b, 1);
        collapse(&mut five, COSTS);
        assert_eq!(leaves(&five), vec![4, 1]);
        assert_eq!(five.nodes.len(), 3);
    }

    #[test]
    fn far_apart_leaves_stay_apart_and_no_leaf_exceeds_the_limit() {
        let mut apart = two_leaves(cube(0.0, 1.0), 1, cube(10.0, 11.0), 1);
        collapse(&mut apart, COSTS);
        assert_eq!(leaves(&apart), vec![1, 1]);
        // Identical boxes always merge, up to `max_prims`.
        let mut same = two_leaves(cube(0.0, 1.0), 4, cube(0.0, 1.0), 4);
        collapse(&mut same, COSTS);
        assert_eq!(leaves(&same), vec![8]);
        let mut over = two_leaves(cube(0.0, 1.0), 5, cube(0.0, 1.0), 4);
        collapse(&mut over, COSTS);
        assert_eq!(leaves(&over), vec![5, 4]);
    }

    /// Merges climb: a merged pair merges again with its sibling when that pays, and the
    /// tree is re-emitted compactly with children after parents.
    #[test]
    fn merges_climb_and_the_tree_is_compact() {
        let b = cube(0.0, 1.0);
        let far = cube(100.0, 101.0);
        // root → (inner → (leaf 1, leaf 1), leaf 2 far away)
        let mut bvh = Bvh2 {
            nodes: vec![
                node(b.union(&far), 0, 1),
                node(b, 0, 3),
                node(far, 2, 2),
                node(b, 1, 0),
                node(b, 1, 1),
            ],
            primitive_indices: vec![0, 1, 2, 3],
            ..Bvh2::default()
        };
        collapse(&mut bvh, COSTS);
        assert_eq!(bvh.nodes.len(), 3);
        assert_eq!(leaves(&bvh), vec![2, 2]);
        assert_eq!(bvh.nodes[0].first_index, 1);
        let mut prims: Vec<u32> = bvh.primitive_indices.clone();
        prims.sort();
        assert_eq!(prims, vec![0, 1, 2, 3]);
        // The near pair merged under the root's first child, in subtree order.
        let first = bvh.nodes[1];
        let k = first.first_index as usize;
        assert_eq!(&bvh.primitive_indices[k..k + 2], &[0, 1]);
    }
}
