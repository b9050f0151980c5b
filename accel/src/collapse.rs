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
//! The decisions go bottom-up, the rewrite top-down, both split between threads over the
//! top `SPLIT_DEPTH` levels (rayon's current pool, as obvhs's own passes); the output layout
//! is fixed by the tree alone (a node's children pair, then the left child's descendants,
//! then the right's), so it is the same on any number of threads.

use obvhs::bvh2::{Bvh2, node::Bvh2Node};
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

/// The most primitives any leaf holds (obvhs's limit, which the backends' encodings share).
const MAX_LEAF: u32 = 255;

/// Levels split between threads (at most `2^SPLIT_DEPTH` tasks); below them a subtree is one
/// task, walked with an explicit stack (trees can be deep).
const SPLIT_DEPTH: u32 = 8;

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
    collapse_split(bvh, costs, SPLIT_DEPTH)
}

/// [`collapse`], split between threads over the top `split` levels.
fn collapse_split(bvh: &mut Bvh2, costs: LeafCosts, split: u32) {
    if bvh.nodes.is_empty() || bvh.nodes[0].is_leaf() {
        return;
    }
    let per_node = || (0..bvh.nodes.len()).map(|_| AtomicU32::new(0)).collect();
    let pass = Pass {
        nodes: &bvh.nodes,
        prims: &bvh.primitive_indices,
        costs,
        split,
        below: per_node(),
        under: per_node(),
    };
    pass.decide(0, 0);
    let mut nodes = vec![Bvh2Node::default(); 1 + pass.get(&pass.below, 0) as usize];
    let mut prims = vec![0u32; pass.get(&pass.under, 0) as usize];
    let (root, below_root) = nodes.split_at_mut(1);
    root[0] = pass.emit(0, below_root, 1, &mut prims, 0, 0);
    bvh.nodes = nodes;
    bvh.primitive_indices = prims;
    bvh.parents.clear();
    bvh.primitives_to_nodes.clear();
    bvh.children_are_ordered_after_parents = true;
}

/// One collapse: the tree read, and per node (each written by one task) what the rewrite
/// needs.
struct Pass<'a> {
    nodes: &'a [Bvh2Node],
    prims: &'a [u32],
    costs: LeafCosts,
    /// Levels split between threads.
    split: u32,
    /// Output nodes below it: 0 exactly when it is (or becomes) a leaf.
    below: Vec<AtomicU32>,
    /// Primitives below it.
    under: Vec<AtomicU32>,
}

impl Pass<'_> {
    fn get(&self, v: &[AtomicU32], i: usize) -> u32 {
        v[i].load(Relaxed)
    }

    /// Node `i`'s primitives if it is (or becomes) a leaf, else 0 (decided nodes only).
    fn leaf_prims(&self, i: usize) -> u32 {
        if self.get(&self.below, i) == 0 {
            self.get(&self.under, i)
        } else {
            0
        }
    }

    /// Decides the subtree of `i` (at `depth`), children before parents.
    fn decide(&self, i: usize, depth: u32) {
        if depth >= self.split || self.nodes[i].is_leaf() {
            return self.decide_serially(i);
        }
        let c = self.nodes[i].first_index as usize;
        rayon::join(
            || self.decide(c, depth + 1),
            || self.decide(c + 1, depth + 1),
        );
        self.decide_node(i);
    }

    fn decide_serially(&self, root: usize) {
        let first_child = |i: usize| {
            let n = &self.nodes[i];
            (!n.is_leaf()).then_some(n.first_index as usize)
        };
        for i in crate::children_first(root, first_child) {
            self.decide_node(i);
        }
    }

    /// The rule of the module docs for node `i`, whose children are decided.
    fn decide_node(&self, i: usize) {
        let n = &self.nodes[i];
        if n.is_leaf() {
            self.under[i].store(n.prim_count, Relaxed);
            return;
        }
        let c = n.first_index as usize;
        let (l, r) = (self.leaf_prims(c), self.leaf_prims(c + 1));
        let total = self.get(&self.under, c) + self.get(&self.under, c + 1);
        self.under[i].store(total, Relaxed);
        if l > 0 && r > 0 && total <= self.costs.max_prims.min(MAX_LEAF) {
            let costs = &self.costs;
            let merged = n.aabb().half_area() * costs.leaf(total);
            let split = n.aabb().half_area() * costs.node
                + self.nodes[c].aabb().half_area() * costs.leaf(l)
                + self.nodes[c + 1].aabb().half_area() * costs.leaf(r);
            if merged <= split {
                // A leaf now: nothing below it (`below` stays 0).
                return;
            }
        }
        let below = 2 + self.get(&self.below, c) + self.get(&self.below, c + 1);
        self.below[i].store(below, Relaxed);
    }

    /// Writes the nodes below `i` to `region` (output index `base` onwards) and its
    /// primitives to `prims` (from `prim_base`); returns `i`'s own output node.
    fn emit(
        &self,
        i: usize,
        region: &mut [Bvh2Node],
        base: usize,
        prims: &mut [u32],
        prim_base: u32,
        depth: u32,
    ) -> Bvh2Node {
        let own = self.output_node(i, base, prims, 0, prim_base);
        if own.is_leaf() {
            return own;
        }
        if depth >= self.split {
            self.emit_serially(i, region, base, prims, prim_base);
            return own;
        }
        let c = self.nodes[i].first_index as usize;
        let (pair, rest) = region.split_at_mut(2);
        let (left, right) = rest.split_at_mut(self.get(&self.below, c) as usize);
        let (left_prims, right_prims) = prims.split_at_mut(self.get(&self.under, c) as usize);
        let right_base = base + 2 + left.len();
        let right_prim_base = prim_base + left_prims.len() as u32;
        let (a, b) = rayon::join(
            || self.emit(c, left, base + 2, left_prims, prim_base, depth + 1),
            || {
                self.emit(
                    c + 1,
                    right,
                    right_base,
                    right_prims,
                    right_prim_base,
                    depth + 1,
                )
            },
        );
        pair[0] = a;
        pair[1] = b;
        own
    }

    /// [`Pass::emit`] for an inner node, on one thread.
    fn emit_serially(
        &self,
        root: usize,
        region: &mut [Bvh2Node],
        base: usize,
        prims: &mut [u32],
        prim_base: u32,
    ) {
        // (inner node, output index of its children pair, its first primitive)
        let mut stack = vec![(root, base, prim_base)];
        while let Some((i, pair, first_prim)) = stack.pop() {
            let c = self.nodes[i].first_index as usize;
            let left_below = pair + 2;
            let right_below = left_below + self.get(&self.below, c) as usize;
            let right_prim = first_prim + self.get(&self.under, c);
            for (k, below, prim) in [
                (c, left_below, first_prim),
                (c + 1, right_below, right_prim),
            ] {
                let node = self.output_node(k, below, prims, prim - prim_base, prim);
                region[pair - base + k - c] = node;
                if !node.is_leaf() {
                    stack.push((k, below, prim));
                }
            }
        }
    }

    /// Node `i`'s output: a leaf with its subtree's primitives copied to `prims[at..]`
    /// (output index `prim`), or an inner node whose children pair is at `pair`.
    fn output_node(
        &self,
        i: usize,
        pair: usize,
        prims: &mut [u32],
        at: u32,
        prim: u32,
    ) -> Bvh2Node {
        let n = &self.nodes[i];
        let count = self.leaf_prims(i);
        if count == 0 {
            return Bvh2Node::new(*n.aabb(), 0, pair as u32);
        }
        self.gather(i, prims, at as usize);
        Bvh2Node::new(*n.aabb(), count, prim)
    }

    /// Copies the primitives of subtree `i`'s leaves, left to right, to `prims[at..]`;
    /// returns where they end. Recursive: a subtree that becomes one leaf holds at most 255
    /// primitives, so it is at most 255 levels deep.
    fn gather(&self, i: usize, prims: &mut [u32], at: usize) -> usize {
        let n = &self.nodes[i];
        if n.is_leaf() {
            let k = n.first_index as usize;
            let src = &self.prims[k..k + n.prim_count as usize];
            prims[at..at + src.len()].copy_from_slice(src);
            return at + src.len();
        }
        let c = n.first_index as usize;
        let at = self.gather(c, prims, at);
        self.gather(c + 1, prims, at)
    }
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

    /// The split rewrite (tasks over the top levels) and the serial one give the same
    /// tree: a deep random tree (obvhs's, over 20 000 boxes) collapsed with every split
    /// depth from none to deeper than the tree.
    #[test]
    fn split_and_serial_rewrites_agree() {
        let mut next = crate::testing::uniform(3);
        let boxes: Vec<obvhs::aabb::Aabb> = (0..20_000)
            .map(|_| {
                let c = [next() * 50.0, next() * 50.0, next() * 50.0];
                let e = [next(), next(), next()];
                Aabb {
                    min: c,
                    max: [c[0] + e[0], c[1] + e[1], c[2] + e[2]],
                }
                .to_obvhs()
            })
            .collect();
        let built = obvhs::ploc::PlocBuilder::with_capacity(boxes.len()).build(
            obvhs::ploc::PlocSearchDistance::Minimum,
            &boxes,
            (0..boxes.len() as u32).collect(),
            obvhs::ploc::SortPrecision::U64,
            1,
        );
        let bytes = |b: &Bvh2| {
            (
                bytemuck::cast_slice::<Bvh2Node, u8>(&b.nodes).to_vec(),
                b.primitive_indices.clone(),
            )
        };
        let mut serial = built.clone();
        collapse_split(&mut serial, COSTS, 0);
        assert!(serial.nodes.len() < built.nodes.len(), "leaves merged");
        for split in [1, 3, SPLIT_DEPTH, 40] {
            let mut split_tree = built.clone();
            collapse_split(&mut split_tree, COSTS, split);
            assert!(bytes(&split_tree) == bytes(&serial), "split depth {split}");
        }
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
