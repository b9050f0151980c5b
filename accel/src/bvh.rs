//! The binary BVH every acceleration structure uses: built by obvhs's PLOC builder, stored in
//! optik's own node layout, which every backend widens or encodes (`widen`).
//!
//! Layout (the contract with the backends' traversals and encodings):
//! - `nodes()[0]` is the root; `nodes()[1]` is unused padding;
//! - an inner node (`count == 0`) has its two children at `first` (always even) and
//!   `first + 1`, so siblings share one 64-byte cache line (the array is 64-byte aligned);
//! - a leaf (`count` above 0) covers primitive slots `first .. first + count`;
//! - children come after their parent, so a reverse sweep refits the tree.
//!
//! A structure's per-primitive arrays are stored in slot order, so a leaf reads them
//! contiguously; `primitive_order[slot]` maps a slot back to the primitive's place in the
//! build inputs. Primitives that can never be hit (NaN or infinite coordinates, degenerate
//! triangles) get no slot at all.
//!
//! Boxes are exact unions of the primitives' f32 boxes (min/max, no rounding), so the box
//! test alone decides how conservative traversal is.

use super::aabb::Aabb;
use super::collapse::LeafCosts;
use crate::PARALLEL_MIN_LEN;
use optik_api::{BuildFlags, Error, Result};
use rayon::prelude::*;

/// One BVH node (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BvhNode {
    /// Smallest corner of the node's box.
    pub min: [f32; 3],
    /// Inner node: index of the first child. Leaf: first primitive slot.
    pub first: u32,
    /// Largest corner of the node's box.
    pub max: [f32; 3],
    /// 0 for an inner node; the number of primitive slots of a leaf.
    pub count: u32,
}

impl BvhNode {
    /// Whether the node is a leaf.
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// The node's box.
    pub fn aabb(&self) -> Aabb {
        Aabb {
            min: self.min,
            max: self.max,
        }
    }

    fn set_aabb(&mut self, b: Aabb) {
        self.min = b.min;
        self.max = b.max;
    }
}

/// Two sibling nodes: the unit of storage, one cache line.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct NodePair([BvhNode; 2]);

/// A binary BVH over primitive slots.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    /// The nodes in sibling pairs; empty when the structure holds no primitive.
    pairs: Vec<NodePair>,
    /// The deepest leaf's depth (the root has depth 1); sizes traversal stacks.
    pub depth: u32,
}

/// How much build time to spend for traversal speed, from the build flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuildQuality {
    /// `PREFER_FAST_BUILD`.
    FastBuild,
    /// Neither flag.
    Balanced,
    /// `PREFER_FAST_TRACE`.
    FastTrace,
}

impl BuildQuality {
    /// The quality the flags ask for (`PREFER_FAST_TRACE` wins when both are set).
    pub fn from_flags(flags: BuildFlags) -> BuildQuality {
        if flags.contains(BuildFlags::PREFER_FAST_TRACE) {
            BuildQuality::FastTrace
        } else if flags.contains(BuildFlags::PREFER_FAST_BUILD) {
            BuildQuality::FastBuild
        } else {
            BuildQuality::Balanced
        }
    }

    /// The obvhs parameters. Spatial pre-splits are never used: a split primitive sits in
    /// several leaves and would meet a ray more than once, which any-hit semantics forbid.
    /// The presets were chosen by measurement (docs/cpu-backend.md, "BVH").
    pub fn params(self) -> obvhs::BvhBuildParams {
        let mut p = match self {
            BuildQuality::FastBuild => obvhs::BvhBuildParams::very_fast_build(),
            BuildQuality::Balanced => obvhs::BvhBuildParams::fast_build(),
            BuildQuality::FastTrace => obvhs::BvhBuildParams::medium_build(),
        };
        p.pre_split = false;
        p
    }
}

impl Bvh {
    /// Builds a BVH over the primitives `i` with `boxes[i]` valid and finite; returns it with
    /// the slot order (`order[slot]` = the primitive's index in `boxes`). Leaves are priced
    /// per primitive (obvhs's collapse).
    pub fn build(boxes: &[Aabb], quality: BuildQuality) -> Result<(Bvh, Vec<u32>)> {
        Bvh::build_with(boxes, quality, None)
    }

    /// [`Bvh::build`], with leaves priced by `leaf_costs` when given (a backend that tests
    /// primitives a block at a time: [`LeafCosts`]) instead of per primitive. Such a tree is
    /// built top-down by the block-priced binned SAH (`crate::sah`) unless `quality` asks
    /// for the fastest build (then, as every other tree, by obvhs's PLOC); the reinsertion
    /// passes and the collapse are the same for both.
    pub fn build_with(
        boxes: &[Aabb],
        quality: BuildQuality,
        leaf_costs: Option<LeafCosts>,
    ) -> Result<(Bvh, Vec<u32>)> {
        // Primitive by primitive on the current rayon pool (in order, each entry its own),
        // as the steps after obvhs's: otherwise a serial share of every build.
        let included: Vec<u32> = (0..boxes.len() as u32)
            .into_par_iter()
            .with_min_len(PARALLEL_MIN_LEN)
            .filter(|&i| boxes[i as usize].is_valid() && boxes[i as usize].is_finite())
            .collect();
        if included.is_empty() {
            return Ok((Bvh::default(), Vec::new()));
        }
        let params = quality.params();
        // obvhs reads every box it is given, so it only sees the included ones, scaled so
        // that no surface area it computes overflows (see `topology_scale`).
        let scale = topology_scale(largest_magnitude(boxes, &included));
        let obvhs_boxes: Vec<obvhs::aabb::Aabb> = included
            .par_iter()
            .with_min_len(PARALLEL_MIN_LEN)
            .map(|&i| boxes[i as usize].scaled(scale).to_obvhs())
            .collect();
        // obvhs asserts on inputs it does not expect; a panic must not cross the API.
        let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut bvh = match leaf_costs {
                Some(costs) if quality != BuildQuality::FastBuild => {
                    crate::sah::build(&obvhs_boxes, costs.block)
                }
                _ => obvhs::ploc::PlocBuilder::with_capacity(included.len()).build(
                    params.ploc_search_distance,
                    &obvhs_boxes,
                    (0..included.len() as u32).collect(),
                    params.sort_precision,
                    params.search_depth_threshold,
                ),
            };
            let mut reinsertion = obvhs::bvh2::reinsertion::ReinsertionOptimizer::default();
            reinsertion.run(&mut bvh, params.reinsertion_batch_ratio, None);
            match leaf_costs {
                Some(costs) => crate::collapse::collapse(&mut bvh, costs),
                None => obvhs::bvh2::leaf_collapser::collapse(
                    &mut bvh,
                    params.max_prims_per_leaf.clamp(1, 255),
                    params.collapse_traversal_cost,
                ),
            }
            reinsertion.run(
                &mut bvh,
                params.reinsertion_batch_ratio
                    * params.post_collapse_reinsertion_batch_ratio_multiplier,
                None,
            );
            bvh
        }))
        .map_err(|_| Error::backend("the BVH builder failed on these primitives"))?;
        let (mut bvh, order) = convert(&built);
        let order: Vec<u32> = order
            .par_iter()
            .with_min_len(PARALLEL_MIN_LEN)
            .map(|&k| included[k as usize])
            .collect();
        if order.len() != included.len() {
            return Err(Error::backend(format!(
                "the BVH builder placed {} of {} primitives in leaves",
                order.len(),
                included.len()
            )));
        }
        bvh.refit(|slot| boxes[order[slot] as usize]);
        Ok((bvh, order))
    }

    /// The nodes: root at 0, padding at 1, sibling pairs from 2 (see the module docs).
    pub fn nodes(&self) -> &[BvhNode] {
        bytemuck::cast_slice(&self.pairs)
    }

    fn nodes_mut(&mut self) -> &mut [BvhNode] {
        bytemuck::cast_slice_mut(&mut self.pairs)
    }

    /// Recomputes every box from the primitives' boxes by slot, keeping the topology.
    /// Invalid (NaN, empty) primitive boxes count as empty.
    pub fn refit(&mut self, slot_box: impl Fn(usize) -> Aabb) {
        let nodes = self.nodes_mut();
        for i in (0..nodes.len()).rev() {
            if i == 1 {
                continue;
            }
            let n = nodes[i];
            let b = if n.is_leaf() {
                (n.first..n.first + n.count).fold(Aabb::EMPTY, |acc, s| {
                    let b = slot_box(s as usize);
                    if b.is_valid() && b.is_finite() {
                        acc.union(&b)
                    } else {
                        acc
                    }
                })
            } else {
                nodes[n.first as usize]
                    .aabb()
                    .union(&nodes[n.first as usize + 1].aabb())
            };
            nodes[i].set_aabb(b);
        }
    }

    /// The root box (empty without nodes).
    pub fn bounds(&self) -> Aabb {
        self.nodes()
            .first()
            .map(|n| n.aabb())
            .unwrap_or(Aabb::EMPTY)
    }

    /// Bytes the nodes occupy.
    pub fn size_in_bytes(&self) -> u64 {
        (self.pairs.len() * std::mem::size_of::<NodePair>()) as u64
    }
}

/// Coordinates up to this magnitude reach obvhs unchanged: its surface areas (products of
/// two extents, each at most twice this) stay far from `f32::MAX`.
const TOPOLOGY_LIMIT: f32 = (1u64 << 40) as f32;

/// The power of two the builder's boxes are multiplied by: 1 for every scene whose
/// coordinates stay within [`TOPOLOGY_LIMIT`], less for larger ones.
///
/// obvhs's PLOC merge costs are surface areas: with coordinates near `f32::MAX` an extent
/// overflows to infinity, and a flat box then has area `∞ · 0 = NaN`; the NaN costs break
/// PLOC's pairing and it indexes out of bounds (fuzz input accel-705066: flat triangles
/// from x = -3e38 to 3e38). Only the tree's shape comes from these boxes (`refit` puts the
/// exact ones back), and SAH costs are scale-invariant, so a uniform power-of-two scale
/// (exact, order-preserving) gives the tree the unscaled boxes would, without the overflow.
fn topology_scale(largest: f32) -> f32 {
    if largest <= TOPOLOGY_LIMIT {
        return 1.0;
    }
    // largest <= f32::MAX < 2^128, so the exponent is at most 88 and 2^-88 is a normal f32.
    let exponent = (largest / TOPOLOGY_LIMIT).log2().ceil() as i32;
    2.0f32.powi(-exponent)
}

/// The largest magnitude of any coordinate of the `included` boxes (0 for none). Maxima are
/// exact in any order, so the pool's threads find what one pass would.
fn largest_magnitude(boxes: &[Aabb], included: &[u32]) -> f32 {
    included
        .par_iter()
        .with_min_len(PARALLEL_MIN_LEN)
        .map(|&i| {
            let b = &boxes[i as usize];
            b.min
                .iter()
                .chain(b.max.iter())
                .fold(0.0f32, |m, v| m.max(v.abs()))
        })
        .reduce(|| 0.0, f32::max)
}

/// Converts obvhs's tree into optik's layout: depth-first, siblings adjacent, children after
/// parents, leaves' primitives renumbered into consecutive slots.
fn convert(src: &obvhs::bvh2::Bvh2) -> (Bvh, Vec<u32>) {
    let placeholder = BvhNode {
        min: [0.0; 3],
        first: 0,
        max: [0.0; 3],
        count: 0,
    };
    let mut nodes = Vec::with_capacity(src.nodes.len() + 1);
    let mut order = Vec::with_capacity(src.primitive_indices.len());
    let mut depth = 0;
    // The root, and padding so that every sibling pair starts at an even index.
    nodes.push(placeholder);
    nodes.push(placeholder);
    let mut stack = vec![(0usize, 0usize, 1u32)];
    while let Some((s, d, level)) = stack.pop() {
        depth = depth.max(level);
        let n = &src.nodes[s];
        if n.is_leaf() {
            let first = order.len() as u32;
            for k in 0..n.prim_count {
                order.push(src.primitive_indices[(n.first_index + k) as usize]);
            }
            nodes[d] = BvhNode {
                first,
                count: n.prim_count,
                ..placeholder
            };
        } else {
            let c = nodes.len();
            nodes.push(placeholder);
            nodes.push(placeholder);
            nodes[d] = BvhNode {
                first: c as u32,
                count: 0,
                ..placeholder
            };
            stack.push((n.first_index as usize + 1, c + 1, level + 1));
            stack.push((n.first_index as usize, c, level + 1));
        }
    }
    let pairs = nodes
        .chunks(2)
        .map(|p| NodePair([p[0], p.get(1).copied().unwrap_or(placeholder)]))
        .collect();
    (Bvh { pairs, depth }, order)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Leaves priced as a backend with 4-primitive blocks would (the CPU's constants).
    const BLOCKS: LeafCosts = LeafCosts {
        block: 4,
        visit: 0.0,
        node: 0.3,
        max_prims: 24,
    };

    fn unit_box(x: f32) -> Aabb {
        Aabb {
            min: [x, 0.0, 0.0],
            max: [x + 0.5, 1.0, 1.0],
        }
    }

    fn check_structure(bvh: &Bvh, order: &[u32], boxes: &[Aabb]) {
        let mut seen = vec![false; order.len()];
        for (i, n) in bvh.nodes().iter().enumerate() {
            if i == 1 {
                continue;
            }
            if n.is_leaf() {
                for s in n.first..n.first + n.count {
                    assert!(!seen[s as usize], "slot {s} in two leaves");
                    seen[s as usize] = true;
                    let b = boxes[order[s as usize] as usize];
                    for a in 0..3 {
                        assert!(n.min[a] <= b.min[a] && b.max[a] <= n.max[a]);
                    }
                }
            } else {
                assert!(n.first as usize > i, "children come after parents");
                assert!(n.first.is_multiple_of(2), "siblings share a pair");
                for c in [n.first, n.first + 1] {
                    let cb = bvh.nodes()[c as usize].aabb();
                    assert_eq!(n.aabb(), n.aabb().union(&cb));
                }
            }
        }
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn builds_cover_every_valid_primitive_once() {
        for n in [1usize, 2, 3, 17, 1000] {
            let boxes: Vec<Aabb> = (0..n)
                .map(|i| unit_box((i * 7 % 13) as f32 + i as f32 * 0.01))
                .collect();
            for q in [
                BuildQuality::FastBuild,
                BuildQuality::Balanced,
                BuildQuality::FastTrace,
            ] {
                for costs in [None, Some(BLOCKS)] {
                    let (bvh, order) = Bvh::build_with(&boxes, q, costs).unwrap();
                    assert_eq!(order.len(), n);
                    check_structure(&bvh, &order, &boxes);
                    assert!(bvh.depth >= 1);
                    let most = bvh.nodes().iter().map(|n| n.count).max().unwrap_or(0);
                    assert!(most <= costs.map_or(255, |c| c.max_prims), "{most}-leaf");
                }
            }
        }
    }

    /// obvhs's parallel build (PLOC, reinsertion, leaf collapse on the caller's rayon pool)
    /// splits its work by the pool's thread count; the tree must not depend on it, or
    /// results would change with `--threads` where ties between coplanar triangles follow
    /// the tree (docs/cpu-backend.md, "BVH").
    #[test]
    fn builds_are_the_same_tree_on_any_number_of_threads() {
        // Many boxes with equal Morton codes and equal areas: ties at every step.
        let mut next = crate::testing::uniform(7);
        let boxes: Vec<Aabb> = (0..40_000)
            .map(|i| {
                if i % 4 == 0 {
                    unit_box((i % 97) as f32)
                } else {
                    let c = [next() * 100.0, next() * 100.0, next() * 5.0];
                    Aabb {
                        min: c,
                        max: [c[0] + next(), c[1] + next(), c[2]],
                    }
                }
            })
            .collect();
        for (q, costs) in [
            (BuildQuality::FastBuild, None),
            (BuildQuality::Balanced, None),
            (BuildQuality::FastTrace, None),
            (BuildQuality::FastTrace, Some(BLOCKS)),
        ] {
            let build = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .expect("a thread pool");
                pool.install(|| Bvh::build_with(&boxes, q, costs))
                    .expect("a build")
            };
            let (one, one_order) = build(1);
            check_structure(&one, &one_order, &boxes);
            let bytes = |b: &Bvh| bytemuck::cast_slice::<NodePair, u8>(&b.pairs).to_vec();
            for threads in [2, 3, 8] {
                let (many, many_order) = build(threads);
                assert_eq!(
                    many_order, one_order,
                    "{q:?}, {threads} threads: slot order"
                );
                assert!(
                    bytes(&many) == bytes(&one),
                    "{q:?}, {threads} threads: nodes"
                );
            }
        }
    }

    #[test]
    fn invalid_boxes_get_no_slot() {
        let mut boxes: Vec<Aabb> = (0..10).map(|i| unit_box(i as f32)).collect();
        boxes[3].min[1] = f32::NAN;
        boxes[5] = Aabb::EMPTY;
        boxes[7].max[2] = f32::INFINITY;
        let (bvh, order) = Bvh::build(&boxes, BuildQuality::Balanced).unwrap();
        assert_eq!(order.len(), 7);
        assert!(!order.contains(&3) && !order.contains(&5) && !order.contains(&7));
        assert!(bvh.bounds().is_finite());
        let (empty, none) = Bvh::build(&[Aabb::EMPTY], BuildQuality::Balanced).unwrap();
        assert!(empty.nodes().is_empty() && none.is_empty());
        let (bvh, _) = Bvh::build(
            &[unit_box(0.0), unit_box(1.0), unit_box(2.0)],
            BuildQuality::Balanced,
        )
        .unwrap();
        assert_eq!(
            bvh.nodes().as_ptr() as usize % 64,
            0,
            "pairs are cache-line aligned"
        );
    }

    #[test]
    fn refit_follows_moved_primitives_and_skips_nan() {
        let boxes: Vec<Aabb> = (0..50).map(|i| unit_box(i as f32)).collect();
        let (mut bvh, order) = Bvh::build(&boxes, BuildQuality::Balanced).unwrap();
        let mut moved: Vec<Aabb> = boxes.iter().map(|b| b.padded(0.25)).collect();
        moved[10].min[0] = f32::NAN;
        bvh.refit(|s| moved[order[s] as usize]);
        moved[10] = Aabb::EMPTY;
        check_structure(&bvh, &order, &moved);
        assert_eq!(bvh.bounds().min[0], -0.25);
    }

    #[test]
    fn flat_primitives_spanning_the_float_range_build() {
        // Fuzz input accel-705066 in small: flat boxes (zero z extent) at x = ±3e38. obvhs
        // saw extents of ∞, areas of ∞ · 0 = NaN, and indexed out of bounds; the build
        // returned a backend error.
        let boxes: Vec<Aabb> = (0..8)
            .map(|i| {
                let x = if i % 2 == 0 { -3e38 } else { 3e38 };
                Aabb {
                    min: [x, i as f32, 0.0],
                    max: [x, i as f32 + 1.0, 0.0],
                }
            })
            .collect();
        for q in [
            BuildQuality::FastBuild,
            BuildQuality::Balanced,
            BuildQuality::FastTrace,
        ] {
            let (bvh, order) = Bvh::build(&boxes, q).expect("a build over finite boxes");
            assert_eq!(order.len(), boxes.len());
            check_structure(&bvh, &order, &boxes);
            assert_eq!(
                bvh.bounds().min,
                [-3e38, 0.0, 0.0],
                "exact boxes, not scaled ones"
            );
            assert_eq!(bvh.bounds().max, [3e38, 8.0, 0.0]);
        }
    }

    #[test]
    fn builder_boxes_are_scaled_only_beyond_the_limit() {
        let at = |v: f32| Aabb::point([v, -v, 0.0]);
        let scale = |boxes: &[Aabb]| {
            let all: Vec<u32> = (0..boxes.len() as u32).collect();
            topology_scale(largest_magnitude(boxes, &all))
        };
        assert_eq!(scale(&[at(1e12)]), 1.0);
        assert_eq!(scale(&[at(-f32::MAX), at(1.0)]), 2.0f32.powi(-88));
        assert_eq!(scale(&[]), 1.0);
        for v in [2e12f32, 1e20, 3e38, f32::MAX] {
            let s = scale(&[at(v)]);
            assert!(
                s.log2().fract() == 0.0,
                "a power of two, so scaling is exact"
            );
            assert!(
                v * s <= TOPOLOGY_LIMIT && v * s > TOPOLOGY_LIMIT / 2.0,
                "{v}: {s}"
            );
        }
    }
}
