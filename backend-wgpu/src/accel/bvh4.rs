//! The four-wide BVH the GPU traverses, made by widening the binary BVH optik-accel builds
//! (`optik_accel::Bvh`), with the children `optik_accel::widen` picks, in its order.
//!
//! Nodes are numbered
//! breadth-first, so children come after parents. Every wide child remembers the binary node
//! it stands for, so a refit of the binary tree (updates) carries over without changing the
//! topology. The GPU layout (`optik_api::wgsl::BVH4`): 128 bytes per node, child boxes as f32.

use optik_accel::{Aabb, BvhNode, widen};

/// Child kind of an empty slot.
pub(crate) const KIND_EMPTY: u32 = 0;
/// Child kind of an inner node.
pub(crate) const KIND_INNER: u32 = 1;
/// Vec4s per node on the GPU.
pub(crate) const NODE_VEC4S: usize = 8;

/// One four-wide node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Node4 {
    pub bounds: [Aabb; 4],
    /// Inner: node index. Leaf: first slot.
    pub child: [u32; 4],
    /// [`KIND_EMPTY`], [`KIND_INNER`], or `n + 1` for a leaf of `n` slots.
    pub kind: [u32; 4],
    /// The binary node each child stands for.
    pub source: [u32; 4],
}

/// A four-wide BVH; empty when the structure holds nothing that can be hit.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Bvh4 {
    pub nodes: Vec<Node4>,
}

impl Bvh4 {
    /// Widens a binary BVH: `bin[0]` is the root; an inner node's children are at `first`
    /// and `first + 1`; a leaf covers slots `first .. first + count` (optik-accel's layout).
    pub fn from_binary(bin: &[BvhNode]) -> Bvh4 {
        if bin.is_empty() {
            return Bvh4::default();
        }
        let empty = Node4 {
            bounds: [Aabb::EMPTY; 4],
            child: [0; 4],
            kind: [KIND_EMPTY; 4],
            source: [0; 4],
        };
        let mut nodes = vec![empty];
        // A leaf root is its own only child.
        let mut queue = std::collections::VecDeque::from([(0usize, 0usize)]);
        while let Some((b, w)) = queue.pop_front() {
            for (slot, &c) in widen::children(bin, b).iter().enumerate() {
                let child = bin[c];
                nodes[w].bounds[slot] = child.aabb();
                nodes[w].source[slot] = c as u32;
                if child.count > 0 {
                    nodes[w].child[slot] = child.first;
                    nodes[w].kind[slot] = child.count + 1;
                } else {
                    let index = nodes.len();
                    nodes.push(empty);
                    nodes[w].child[slot] = index as u32;
                    nodes[w].kind[slot] = KIND_INNER;
                    queue.push_back((c, index));
                }
            }
        }
        Bvh4 { nodes }
    }

    /// Takes the boxes of a refit binary tree (the one this was widened from).
    pub fn refit_from_binary(&mut self, bin: &[BvhNode]) {
        for n in &mut self.nodes {
            for c in 0..4 {
                if n.kind[c] != KIND_EMPTY
                    && let Some(b) = bin.get(n.source[c] as usize)
                {
                    n.bounds[c] = b.aabb();
                }
            }
        }
    }

    /// The box of the whole tree.
    pub fn bounds(&self) -> Aabb {
        self.nodes
            .first()
            .map(|n| n.bounds())
            .unwrap_or(Aabb::EMPTY)
    }

    /// The deepest traversal stack a ray can need, beyond the root's own entry.
    ///
    /// The GPU pops an entry, pushes the node's hit children (at most four) and pops the
    /// nearest; the others wait below it. So a node of k children needs
    /// max(k, k − 1 + the most any child needs); a leaf needs `leaf_need(first, count)`
    /// (0 for primitives; instances need room for their child structures).
    pub fn stack_need(&self, leaf_need: impl Fn(u32, u32) -> u32) -> u32 {
        let mut need = vec![0u32; self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let n = &self.nodes[i];
            let mut k = 0;
            let mut deepest = 0;
            for c in 0..4 {
                let child_need = match n.kind[c] {
                    KIND_EMPTY => continue,
                    KIND_INNER => need[n.child[c] as usize],
                    kind => leaf_need(n.child[c], kind - 1),
                };
                k += 1;
                deepest = deepest.max(child_need);
            }
            need[i] = if k == 0 { 0 } else { k.max(k - 1 + deepest) };
        }
        need.first().copied().unwrap_or(0)
    }

    /// The GPU words of the nodes (`NODE_VEC4S` vec4s each).
    pub fn encode(&self, out: &mut Vec<[u32; 4]>) {
        for n in &self.nodes {
            let corner = |f: &dyn Fn(&Aabb) -> f32| -> [u32; 4] {
                std::array::from_fn(|c| {
                    if n.kind[c] == KIND_EMPTY || !n.bounds[c].is_usable() {
                        0
                    } else {
                        f(&n.bounds[c]).to_bits()
                    }
                })
            };
            out.push(corner(&|b| b.min[0]));
            out.push(corner(&|b| b.max[0]));
            out.push(corner(&|b| b.min[1]));
            out.push(corner(&|b| b.max[1]));
            out.push(corner(&|b| b.min[2]));
            out.push(corner(&|b| b.max[2]));
            out.push(n.child);
            // A child whose box emptied in a refit can hold nothing a ray could hit.
            out.push(std::array::from_fn(|c| {
                if n.bounds[c].is_usable() {
                    n.kind[c]
                } else {
                    KIND_EMPTY
                }
            }));
        }
    }
}

impl Node4 {
    /// The union of the children's boxes.
    pub fn bounds(&self) -> Aabb {
        (0..4)
            .filter(|&c| self.kind[c] != KIND_EMPTY)
            .fold(Aabb::EMPTY, |acc, c| acc.union(&self.bounds[c]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use optik_accel::{BuildQuality, Bvh};

    fn boxes(n: usize) -> Vec<Aabb> {
        (0..n)
            .map(|i| {
                let x = (i * 37 % 101) as f32;
                Aabb {
                    min: [x, (i % 7) as f32, 0.0],
                    max: [x + 0.5, (i % 7) as f32 + 1.0, 1.0],
                }
            })
            .collect()
    }

    #[test]
    fn widening_keeps_every_slot_once_and_boxes_hold_children() {
        for n in [1usize, 2, 5, 33, 1000] {
            let b = boxes(n);
            let (bin, order) = Bvh::build(&b, BuildQuality::Balanced).unwrap();
            let bvh = Bvh4::from_binary(bin.nodes());
            let mut seen = vec![0u32; order.len()];
            for (i, node) in bvh.nodes.iter().enumerate() {
                for c in 0..4 {
                    match node.kind[c] {
                        KIND_EMPTY => {}
                        KIND_INNER => {
                            let child = node.child[c] as usize;
                            assert!(child > i, "children come after parents");
                            assert_eq!(node.bounds[c], bvh.nodes[child].bounds());
                        }
                        k => {
                            for s in node.child[c]..node.child[c] + k - 1 {
                                seen[s as usize] += 1;
                                let pb = b[order[s as usize] as usize];
                                assert_eq!(node.bounds[c].union(&pb), node.bounds[c]);
                            }
                        }
                    }
                }
            }
            assert!(
                seen.iter().all(|&s| s == 1),
                "every slot in exactly one leaf"
            );
            let need = bvh.stack_need(|_, _| 0);
            assert!((1..=3 * bvh.nodes.len() as u32 + 1).contains(&need));
        }
    }

    #[test]
    fn refits_follow_the_binary_tree() {
        let b = boxes(200);
        let (mut bin, order) = Bvh::build(&b, BuildQuality::Balanced).unwrap();
        let mut bvh = Bvh4::from_binary(bin.nodes());
        let moved: Vec<Aabb> = b.iter().map(|x| x.padded(0.5)).collect();
        bin.refit(|slot| moved[order[slot] as usize]);
        bvh.refit_from_binary(bin.nodes());
        assert_eq!(
            bvh,
            Bvh4::from_binary(bin.nodes()),
            "same topology, new boxes"
        );
        assert_eq!(bvh.bounds().min[0], -0.5);
    }

    #[test]
    fn stack_need_of_a_hand_made_tree() {
        // Root with an inner child (three leaves) and a leaf: widening opens everything
        // into one node of four leaves, needing max(4, 3 + the leaves' need).
        let node = |first, count| BvhNode {
            min: [0.0; 3],
            first,
            max: [1.0; 3],
            count,
        };
        let bin = vec![
            node(2, 0),
            node(0, 0),
            node(4, 0),
            node(0, 1),
            node(6, 0),
            node(1, 1),
            node(2, 1),
            node(3, 1),
        ];
        let bvh = Bvh4::from_binary(&bin);
        assert_eq!(bvh.nodes.len(), 1);
        assert_eq!(bvh.stack_need(|_, _| 0), 4);
        assert_eq!(bvh.stack_need(|_, _| 5), 8);
    }
}
