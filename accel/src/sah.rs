//! A top-down binned SAH builder whose splits count primitives in whole blocks, for
//! structures whose leaves a backend tests a block at a time (the CPU's triangle blocks).
//!
//! Why our own: obvhs builds by PLOC (bottom-up clustering of Morton-ordered boxes) and has
//! no top-down SAH builder. PLOC knows nothing of blocks, so the collapse that turns its
//! subtrees into leaves can only choose among the clusters it was given: on the bunny 80 %
//! of the block lanes held a triangle, and the wide tree's expected cost by the surface-area
//! heuristic was 11 % above Embree's, whose binned SAH prices each side of a split by its
//! blocks (`ceil(n / 4)`), so that splits fall where whole blocks do. Built this way the
//! bunny's blocks are 95 % full and its rays 6–8 % faster (docs/cpu-backend.md, "A binned
//! SAH build priced by the block").
//!
//! The rule: at each node, the primitives' centroids are binned into equal bins per axis
//! ([`BINS`]; 8 or 16 for nodes of at most 8 or 16 primitives, whose bins would mostly be
//! empty); the split between two bins of one axis that minimises
//! `area(left) · blocks(n_left) + area(right) · blocks(n_right)` (`blocks(n) = ceil(n /
//! block)`) partitions them, down to single primitives; [`crate::collapse`] then decides the
//! leaves. Where no bin boundary separates the centroids (all in one bin), or below the top
//! [`BINNED_DEPTH`] levels, the primitives are split at the median of the longest centroid
//! axis instead, which bounds the tree's depth for any input.
//!
//! Layout (as obvhs's trees): the root at 0, a node's two children side by side, children
//! after their parent; leaves hold one primitive each. Subtrees of at least
//! [`PARALLEL_LEAST`] primitives build their two children on two threads (rayon's current
//! pool); each writes only its own primitives and nodes, whose places follow from the split
//! alone (a subtree of `n` primitives has `2n − 1` nodes), so the tree is the same on any
//! number of threads.

use crate::PARALLEL_MIN_LEN;
use obvhs::aabb::Aabb;
use obvhs::bvh2::{Bvh2, DEFAULT_MAX_STACK_DEPTH, node::Bvh2Node};
use rayon::prelude::*;
use std::mem::MaybeUninit;

/// Bins per axis (Embree's binned builder uses 32 too).
const BINS: usize = 32;

/// Levels (the root's is 1) whose splits are binned; below them, median splits (which halve
/// the primitives, so no tree grows deeper than this plus `log2` of its primitives).
const BINNED_DEPTH: u32 = 48;

/// Subtrees with this many primitives or more build their two children on two threads.
const PARALLEL_LEAST: usize = 4096;

/// Nodes with this many primitives or more bin them into two sets of bins (see
/// [`Build::bins`]).
const TWO_BIN_SETS_LEAST: usize = 256;

/// Nodes with this many primitives or more bin them (and bound their centroids) in chunks of
/// this many on the pool's threads: the top levels are otherwise a serial share of the build
/// (the root's binning alone, one pass over every primitive, ran on one thread of two while
/// the other waited).
const PARALLEL_BINNING_LEAST: usize = 1 << 15;

/// Builds a binary tree over `boxes` (all valid and finite), primitives priced in blocks of
/// `block` (1: the plain SAH).
pub fn build(boxes: &[Aabb], block: u32) -> Bvh2 {
    build_tuned(boxes, block, Tuning::DEFAULT)
}

/// Where the builder changes method. None changes the tree: only [`Tuning::binned_depth`]
/// does, and the tests vary the others to show that.
#[derive(Clone, Copy)]
struct Tuning {
    /// Levels from the root's (1) up to which splits are binned ([`BINNED_DEPTH`]).
    binned_depth: u32,
    /// [`PARALLEL_BINNING_LEAST`].
    parallel_binning_least: usize,
    /// [`TWO_BIN_SETS_LEAST`].
    two_bin_sets_least: usize,
}

impl Tuning {
    const DEFAULT: Tuning = Tuning {
        binned_depth: BINNED_DEPTH,
        parallel_binning_least: PARALLEL_BINNING_LEAST,
        two_bin_sets_least: TWO_BIN_SETS_LEAST,
    };
}

/// [`build`] with `tuning`.
fn build_tuned(boxes: &[Aabb], block: u32, tuning: Tuning) -> Bvh2 {
    let mut bvh = Bvh2::default();
    if boxes.is_empty() {
        return bvh;
    }
    let centroids: Vec<[f32; 3]> = boxes
        .par_iter()
        .with_min_len(PARALLEL_MIN_LEN)
        .map(|b| b.center().into())
        .collect();
    let build = Build {
        boxes,
        centroids: &centroids,
        block: block.max(1),
        tuning,
    };
    let mut prims: Vec<u32> = (0..boxes.len() as u32).collect();
    // The nodes are written once each by the recursion, so they are not initialised first:
    // their pages (the Breakfast Room's are 17 MB) are first touched by the thread that
    // builds their subtree, not by one serial pass before any thread shares the work.
    let count = 2 * boxes.len() - 1;
    let mut nodes: Vec<Bvh2Node> = Vec::with_capacity(count);
    let (root, below) = nodes.spare_capacity_mut()[..count].split_at_mut(1);
    let (node, depth) = build.subtree(&mut prims, 0, below, 1, 1);
    root[0].write(node);
    // SAFETY: the root is written above, and `subtree` writes every one of its `below`
    // entries (a subtree of `m` primitives writes its two children into the first two of its
    // `2m − 2` and hands the rest, `2 · left − 2` and `2 · right − 2`, to its children; a
    // single primitive has none), so all `count` are initialised.
    unsafe { nodes.set_len(count) };
    bvh.nodes = nodes;
    bvh.primitive_indices = prims;
    bvh.children_are_ordered_after_parents = true;
    bvh.max_depth = (depth as usize).max(DEFAULT_MAX_STACK_DEPTH);
    bvh
}

/// What every subtree's build reads.
struct Build<'a> {
    boxes: &'a [Aabb],
    centroids: &'a [[f32; 3]],
    block: u32,
    tuning: Tuning,
}

/// One bin: the boxes of the primitives whose centroids fall in it, and their number.
#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        bounds: Aabb::INVALID,
        count: 0,
    };
}

impl Build<'_> {
    /// Builds the subtree of `prims` (the primitives from `prim_at` on) into `below` (its
    /// `2 · prims.len() − 2` descendants, from node `below_at` on, every one of which it
    /// writes) and returns its root with the subtree's depth (`depth` is the root's).
    fn subtree(
        &self,
        prims: &mut [u32],
        prim_at: u32,
        below: &mut [MaybeUninit<Bvh2Node>],
        below_at: u32,
        depth: u32,
    ) -> (Bvh2Node, u32) {
        if prims.len() == 1 {
            return (
                Bvh2Node::new(self.boxes[prims[0] as usize], 1, prim_at),
                depth,
            );
        }
        let total = prims.len();
        let left_len = self.split(prims, depth);
        let (pair, rest) = below.split_at_mut(2);
        let (left_below, right_below) = rest.split_at_mut(2 * (left_len - 1));
        let (left_prims, right_prims) = prims.split_at_mut(left_len);
        let right_prim_at = prim_at + left_len as u32;
        let right_below_at = below_at + 2 + left_below.len() as u32;
        let mut left =
            move || self.subtree(left_prims, prim_at, left_below, below_at + 2, depth + 1);
        let mut right = move || {
            self.subtree(
                right_prims,
                right_prim_at,
                right_below,
                right_below_at,
                depth + 1,
            )
        };
        let ((l, ld), (r, rd)) = if total >= PARALLEL_LEAST {
            rayon::join(left, right)
        } else {
            (left(), right())
        };
        pair[0].write(l);
        pair[1].write(r);
        (
            Bvh2Node::new(l.aabb().union(r.aabb()), 0, below_at),
            ld.max(rd),
        )
    }

    /// Reorders `prims` (two or more) into the left child's and the right child's; returns
    /// the left child's number, between 1 and `prims.len() − 1`.
    fn split(&self, prims: &mut [u32], depth: u32) -> usize {
        let chunk = self.tuning.parallel_binning_least;
        let (lo, hi) = if prims.len() >= chunk {
            // Minima and maxima are exact, and merged by the rule one pass applies (the
            // earlier of two equal values kept; rayon merges neighbours in order): the same
            // bounds.
            prims
                .par_chunks(chunk)
                .map(|chunk| self.centroid_bounds(chunk))
                .reduce(|| NO_BOUNDS, merged_bounds)
        } else {
            self.centroid_bounds(prims)
        };
        let best = if depth > self.tuning.binned_depth {
            None
        } else if prims.len() <= 8 {
            self.best_bin::<8>(prims, lo, hi)
        } else if prims.len() <= 16 {
            self.best_bin::<16>(prims, lo, hi)
        } else {
            self.best_bin::<BINS>(prims, lo, hi)
        };
        if let Some((axis, bin, scale, bins)) = best {
            let in_left = |p: u32| self.bin_of(p, axis, lo[axis], scale, bins) <= bin;
            let left_len = partition(prims, in_left);
            if left_len > 0 && left_len < prims.len() {
                return left_len;
            }
        }
        // The median along the longest centroid axis (any split, if all centroids agree).
        let axis = (0..3)
            .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
            .unwrap_or(0);
        let mid = prims.len() / 2;
        prims.select_nth_unstable_by(mid, |&a, &b| {
            let (ca, cb) = (self.centroids[a as usize], self.centroids[b as usize]);
            ca[axis].total_cmp(&cb[axis]).then(a.cmp(&b))
        });
        mid
    }

    /// The smallest and largest centroid coordinates of `prims`, per axis.
    fn centroid_bounds(&self, prims: &[u32]) -> Bounds {
        prims.iter().fold(NO_BOUNDS, |bounds, &p| {
            let c = self.centroids[p as usize];
            merged_bounds(bounds, (c, c))
        })
    }

    /// The bin of primitive `p`'s centroid along `axis` (bins from `lo`, `scale` per unit).
    fn bin_of(&self, p: u32, axis: usize, lo: f32, scale: f32, bins: usize) -> usize {
        let x = (self.centroids[p as usize][axis] - lo) * scale;
        // `as` saturates (and maps NaN to 0); the last bin takes the top edge. To `u32` rather
        // than `usize`: the same bin for every `x` (both saturate, and any `x` at or above the
        // last bin is clamped to it), with a shorter saturation.
        (x as u32).min(bins as u32 - 1) as usize
    }

    /// The cheapest split between `N` bins: `(axis, last bin of the left child, scale, N)`,
    /// or `None` where no axis has centroids in two bins. Not inlined: its bins (a few
    /// kilobytes) would otherwise sit in every level's frame of the recursion.
    #[inline(never)]
    fn best_bin<const N: usize>(
        &self,
        prims: &[u32],
        lo: [f32; 3],
        hi: [f32; 3],
    ) -> Option<(usize, usize, f32, usize)> {
        let scale: [f32; 3] = std::array::from_fn(|k| {
            let extent = hi[k] - lo[k];
            if extent > 0.0 { N as f32 / extent } else { 0.0 }
        });
        let chunk = self.tuning.parallel_binning_least;
        let bins = if prims.len() >= chunk {
            // Unions of boxes and sums of counts are exact in any order: the same bins as
            // one pass.
            prims
                .par_chunks(chunk)
                .map(|chunk| self.bins::<N>(chunk, lo, scale))
                .reduce(
                    || [[Bin::EMPTY; N]; 3],
                    |mut a, b| {
                        merge_bins(&mut a, &b);
                        a
                    },
                )
        } else {
            self.bins::<N>(prims, lo, scale)
        };
        let blocks = |n: u32| n.div_ceil(self.block) as f32;
        let mut best: Option<(f32, usize, usize)> = None;
        for k in 0..3 {
            if scale[k] <= 0.0 {
                continue;
            }
            // The right sides' costs, from the top bin down: `right_cost[i]` prices bins
            // `i..` (NaN: all empty).
            let mut right_cost = [0.0f32; N];
            let (mut bounds, mut count) = (Aabb::INVALID, 0u32);
            for i in (1..N).rev() {
                bounds = bounds.union(&bins[k][i].bounds);
                count += bins[k][i].count;
                right_cost[i] = if count > 0 {
                    bounds.half_area() * blocks(count)
                } else {
                    f32::NAN
                };
            }
            let (mut bounds, mut count) = (Aabb::INVALID, 0u32);
            for i in 0..N - 1 {
                bounds = bounds.union(&bins[k][i].bounds);
                count += bins[k][i].count;
                let right = right_cost[i + 1];
                if count == 0 || right.is_nan() {
                    continue;
                }
                let cost = bounds.half_area() * blocks(count) + right;
                // Strictly cheaper: ties keep the lower axis and bin (a fixed choice).
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, k, i));
                }
            }
        }
        best.map(|(_, k, i)| (k, i, scale[k], N))
    }

    /// `prims` binned into `N` bins per axis (from `lo`, `scale` bins per unit; no bins
    /// along an axis whose scale is 0).
    fn bins<const N: usize>(&self, prims: &[u32], lo: [f32; 3], scale: [f32; 3]) -> [[Bin; N]; 3] {
        let add = |bins: &mut [[Bin; N]; 3], p: u32| {
            let b = &self.boxes[p as usize];
            for k in 0..3 {
                if scale[k] > 0.0 {
                    let bin = &mut bins[k][self.bin_of(p, k, lo[k], scale[k], N)];
                    bin.bounds = bin.bounds.union(b);
                    bin.count += 1;
                }
            }
        };
        let mut bins = [[Bin::EMPTY; N]; 3];
        if prims.len() < self.tuning.two_bin_sets_least {
            for &p in prims {
                add(&mut bins, p);
            }
            return bins;
        }
        // Neighbours often fall in the same bin, and each update of a bin waits for the
        // last: alternate primitives go to two sets of bins, merged at the end (unions and
        // counts are exact in any order, so the same bins).
        let mut odd = [[Bin::EMPTY; N]; 3];
        for pair in prims.chunks(2) {
            add(&mut bins, pair[0]);
            if let Some(&p) = pair.get(1) {
                add(&mut odd, p);
            }
        }
        merge_bins(&mut bins, &odd);
        bins
    }
}

/// Per axis, the smallest and largest coordinates of some centroids.
type Bounds = ([f32; 3], [f32; 3]);

/// The bounds of no centroid.
const NO_BOUNDS: Bounds = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);

/// The bounds of `a`'s centroids and `b`'s, `a`'s value kept where they are equal. By
/// comparisons rather than `f32::min` and `max`, whose NaN handling costs instructions in the
/// binning's hottest loop: centroids of finite boxes are never NaN. (Where the two could
/// differ, the sign of a zero bound, no extent or bin changes.)
#[inline(always)]
fn merged_bounds((alo, ahi): Bounds, (blo, bhi): Bounds) -> Bounds {
    (
        std::array::from_fn(|k| if blo[k] < alo[k] { blo[k] } else { alo[k] }),
        std::array::from_fn(|k| if bhi[k] > ahi[k] { bhi[k] } else { ahi[k] }),
    )
}

/// Adds `from`'s bins to `into`'s (unions and counts: exact in any order).
fn merge_bins<const N: usize>(into: &mut [[Bin; N]; 3], from: &[[Bin; N]; 3]) {
    for (a, b) in into.iter_mut().flatten().zip(from.iter().flatten()) {
        a.bounds = a.bounds.union(&b.bounds);
        a.count += b.count;
    }
}

/// Moves the elements for which `left` holds to the front (order otherwise unspecified but
/// fixed by the input) and returns their number.
fn partition(prims: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let (mut i, mut j) = (0, prims.len());
    while i < j {
        if left(prims[i]) {
            i += 1;
        } else {
            j -= 1;
            prims.swap(i, j);
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(x: f32, y: f32, z: f32) -> Aabb {
        Aabb::new([x, y, z].into(), [x + 1.0, y + 1.0, z + 1.0].into())
    }

    /// Walks the tree: every primitive in exactly one leaf, every box the union of its
    /// children's (or its primitive's), children after their parent; returns the depth.
    fn check(bvh: &Bvh2, boxes: &[Aabb]) -> u32 {
        let mut seen = vec![false; boxes.len()];
        let mut depth = 0;
        let mut stack = vec![(0usize, 1u32)];
        while let Some((i, d)) = stack.pop() {
            depth = depth.max(d);
            let n = &bvh.nodes[i];
            if n.is_leaf() {
                assert_eq!(n.prim_count, 1, "leaves hold one primitive");
                let p = bvh.primitive_indices[n.first_index as usize] as usize;
                assert!(!seen[p], "primitive {p} in two leaves");
                seen[p] = true;
                assert_eq!(n.aabb(), &boxes[p]);
            } else {
                let c = n.first_index as usize;
                assert!(c > i, "children after their parent");
                let (l, r) = (&bvh.nodes[c], &bvh.nodes[c + 1]);
                assert_eq!(n.aabb(), &l.aabb().union(r.aabb()));
                stack.push((c, d + 1));
                stack.push((c + 1, d + 1));
            }
        }
        assert!(seen.iter().all(|&s| s), "every primitive in a leaf");
        assert_eq!(bvh.nodes.len(), 2 * boxes.len() - 1);
        depth
    }

    /// A fixed pseudo-random point cloud (xorshift).
    fn cloud(n: usize) -> Vec<Aabb> {
        let mut u = crate::testing::uniform(0x9E37_79B9_7F4A_7C15);
        let mut f = || u() * 100.0;
        (0..n).map(|_| unit_box(f(), f(), f())).collect()
    }

    #[test]
    fn splits_fall_where_whole_blocks_do() {
        // Twelve boxes in a row: by primitives every split costs more the further it is
        // from the middle (6 | 6); by blocks of four, 4 | 8 costs 3 block tests' worth of
        // area where 6 | 6 costs 4, so the first split leaves one whole block on the left.
        let boxes: Vec<Aabb> = (0..12).map(|i| unit_box(i as f32, 0.0, 0.0)).collect();
        let left_of_root = |block| {
            let bvh = build(&boxes, block);
            check(&bvh, &boxes);
            let c = bvh.nodes[0].first_index as usize;
            let size = bvh.nodes[c].aabb().diagonal().x;
            size.round() as u32
        };
        assert_eq!(left_of_root(1), 6, "the plain SAH splits in the middle");
        assert_eq!(
            left_of_root(4),
            4,
            "priced by blocks, one whole block on the left"
        );
    }

    #[test]
    fn every_primitive_once_with_exact_boxes() {
        for n in [1, 2, 3, 5, 17, 1000, 10_000] {
            let boxes = cloud(n);
            check(&build(&boxes, 4), &boxes);
        }
        // Identical boxes: no bin separates them, so median splits; still a valid tree of
        // logarithmic depth.
        let same = vec![unit_box(1.0, 2.0, 3.0); 1000];
        let depth = check(&build(&same, 4), &same);
        assert!(depth <= 11, "depth {depth} for 1000 equal boxes");
    }

    #[test]
    fn median_splits_below_the_binned_levels() {
        // 999 boxes in a cluster and one far away: the SAH's first split cuts off the far
        // one, so binned splits make a lopsided tree; median splits halve at every level.
        let mut boxes = cloud(999);
        boxes.push(unit_box(1.0e6, 0.0, 0.0));
        let depth_binned_to = |levels| {
            let tuning = Tuning {
                binned_depth: levels,
                ..Tuning::DEFAULT
            };
            check(&build_tuned(&boxes, 4, tuning), &boxes)
        };
        assert_eq!(
            depth_binned_to(0),
            11,
            "median splits only: ceil(log2 1000) + 1 levels"
        );
        assert_eq!(
            depth_binned_to(1),
            12,
            "one binned split (999 | 1), then medians"
        );
        let binned = depth_binned_to(BINNED_DEPTH);
        assert!(binned > 11 && binned <= BINNED_DEPTH + 11, "depth {binned}");
    }

    #[test]
    fn the_tree_is_the_same_on_any_number_of_threads() {
        let boxes = cloud(3 * PARALLEL_LEAST);
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool")
                .install(|| build(&boxes, 4))
        };
        let (one, four) = (on(1), on(4));
        check(&one, &boxes);
        assert_same_tree(&one, &four);
    }

    #[test]
    fn binning_in_chunks_and_in_two_sets_changes_no_split() {
        let boxes = cloud(3 * PARALLEL_LEAST);
        let one_pass = Tuning {
            parallel_binning_least: usize::MAX,
            two_bin_sets_least: usize::MAX,
            ..Tuning::DEFAULT
        };
        // Chunks of 100 (the root's 12 288 primitives bounded and binned in 123 chunks, down
        // to nodes of 100), two sets of bins from nodes of 3 on, on four threads.
        let split_up = Tuning {
            parallel_binning_least: 100,
            two_bin_sets_least: 3,
            ..Tuning::DEFAULT
        };
        let four = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .expect("a thread pool");
        let reference = build_tuned(&boxes, 4, one_pass);
        check(&reference, &boxes);
        assert_same_tree(
            &reference,
            &four.install(|| build_tuned(&boxes, 4, split_up)),
        );
        assert_same_tree(&reference, &build(&boxes, 4));
    }

    fn assert_same_tree(a: &Bvh2, b: &Bvh2) {
        assert_eq!(a.primitive_indices, b.primitive_indices);
        let key = |b: &Bvh2| -> Vec<_> {
            b.nodes
                .iter()
                .map(|n| (*n.aabb(), n.prim_count, n.first_index))
                .collect()
        };
        assert_eq!(key(a), key(b));
    }
}
