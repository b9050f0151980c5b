//! The 8-wide BVH the CPU traversal walks, collapsed from optik-accel's binary [`Bvh`]
//! (`optik_accel::widen`: for triangle structures the wide tree of least cost by the surface
//! area heuristic, [`TRIANGLE_WIDE_COSTS`]; for every other structure the widest child opened
//! first), and triangles packed four to a block for the 4-lane triangle test.
//!
//! Why: a binary node costs two box tests and a decision per step; an 8-wide node tests its
//! eight children in one 8-lane slab test (AVX where the CPU has it, two 4-lane halves
//! elsewhere, bit for bit the same), so a ray takes about a third as many steps, and four
//! triangles of a leaf share one 4-lane watertight test (docs/cpu-backend.md,
//! "Performance"). Eight children rather than four: the walk is a chain of dependent
//! loads and tests, so fewer steps is less waiting (measured in docs/cpu-backend.md, issue
//! 14 item 3).
//!
//! Layout:
//! - [`WideNode`] (256 bytes, four cache lines): the children's boxes as structure of arrays
//!   (`min[axis][child]`), then per child `first` and `count`. `count == 0`: an inner child,
//!   `first` its node index; `count > 0`: a leaf of `count` primitives, `first` its first
//!   block (triangle structures with blocks) or its first slot (every other structure).
//!   Unused children have the empty box (`+∞` minimum, `−∞` maximum), which no ray enters.
//! - `nodes[0]` is the root; children come after parents.
//! - Every child box is the box of the binary node it came from, so the wide BVH is exactly
//!   as conservative as the binary one (boxes are exact unions of primitive boxes). In a
//!   triangle structure an inner binary node may be a leaf itself, of its subtree's
//!   consecutive slots, where that costs less than a node ([`TRIANGLE_WIDE_COSTS`]).
//! - [`TriangleBlock`] (176 bytes): the vertices of up to four consecutive slots of one
//!   leaf, as `vertices[vertex][axis][lane]`, then what a hit needs next, in its last 32
//!   bytes (reading it from `Gas::primitives` cost a cache miss per candidate): each
//!   lane's primitive index, the first lane's slot, each lane's [`PrimitiveClass`] (the
//!   rest of its [`PrimitiveInfo`]: SBT index, flags, build input, shared by many
//!   primitives: `WideBvh::classes`) and the lanes used. A leaf of `count` triangles has
//!   `ceil(count / 4)` consecutive blocks; lanes past the leaf's last triangle hold zeros,
//!   and the traversal masks them out. Blocks exist for static triangle structures (one
//!   motion key); moving triangles are interpolated per slot instead.
//!
//! Why 176 bytes and not a full record per lane (224): a block test reads the vertices of
//! blocks spread over an array larger than L2; a fifth less array, the same lines per test,
//! ran bunny incoherent rays 2–5 % faster (docs/cpu-backend.md, "Smaller triangle blocks").
//! The records moved to an array of their own cost a miss per candidate and lost 6 %.

use optik_accel::widen::{self, OptimalWidening, WideChild, WideCosts};
use optik_accel::{Aabb, Bvh, BvhNode, GasEncoding, Geometry, LeafCosts, PrimitiveInfo};
use rayon::prelude::*;

/// Children per node.
pub const NODE_WIDTH: usize = 8;

/// Triangles per block (the lanes of the triangle test).
pub const BLOCK_WIDTH: usize = 4;

/// How a triangle structure's wide tree is chosen from its binary one
/// ([`OptimalWidening`]): the tree of least surface-area cost where a wide node's test costs
/// two triangle block tests and a leaf its blocks, up to [`TRIANGLE_LEAF_COSTS`]'s largest
/// leaf (so an inner binary node of few triangles becomes a leaf where its node would cost
/// more). Against opening the widest child first with small all-leaf nodes merged (the
/// rule before): bunny and Breakfast Room rays 1–5 % faster, results identical; node costs
/// of 1.5 and 3 measured within 2 % of 2 (docs/cpu-backend.md, "Wide nodes chosen by the
/// heuristic").
pub const TRIANGLE_WIDE_COSTS: WideCosts = WideCosts {
    width: NODE_WIDTH,
    node: 2.0,
    leaf: triangle_leaf_cost,
};

/// A leaf of `count` static triangles: its blocks, if it may hold that many.
fn triangle_leaf_cost(count: u32) -> Option<f32> {
    (count <= TRIANGLE_LEAF_COSTS.max_prims).then(|| TriangleBlock::blocks_of(count) as f32)
}

/// How the builder prices leaves of static triangles, which the walk tests a block at a time:
/// a leaf costs its blocks (not its triangles), entering it nothing more, a binary node 0.3
/// of a block test (three binary levels make one 8-wide step), up to six blocks a leaf.
/// Chosen by measurement (docs/cpu-backend.md, "Leaves priced by the block"): on the
/// Breakfast Room 14–20 % faster than obvhs's per-triangle pricing, the bunny within 3 %;
/// node costs from 0.25 to 0.45 all land within 3 % of each other.
pub const TRIANGLE_LEAF_COSTS: LeafCosts = LeafCosts {
    block: BLOCK_WIDTH as u32,
    visit: 0.0,
    node: 0.3,
    max_prims: 6 * BLOCK_WIDTH as u32,
};

/// A node of the 8-wide BVH (see the module docs).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WideNode {
    /// `min[axis][child]`: the children's smallest corners.
    pub min: [[f32; NODE_WIDTH]; 3],
    /// `max[axis][child]`: the children's largest corners.
    pub max: [[f32; NODE_WIDTH]; 3],
    /// Inner child: its node index. Leaf: its first block or first slot.
    pub first: [u32; NODE_WIDTH],
    /// 0 for an inner (or unused) child; the number of primitives of a leaf.
    pub count: [u32; NODE_WIDTH],
}

// `WideNode::rows` reads `min` and `max` as six consecutive rows.
const _: () = assert!(std::mem::offset_of!(WideNode, min) == 0);
const _: () = assert!(std::mem::offset_of!(WideNode, max) == 3 * NODE_WIDTH * 4);

impl WideNode {
    /// The union of the children's boxes, `[min, max]` (unused children change nothing).
    pub fn union(&self) -> [[f32; 3]; 2] {
        [
            self.min
                .map(|row| row.into_iter().fold(f32::INFINITY, f32::min)),
            self.max
                .map(|row| row.into_iter().fold(f32::NEG_INFINITY, f32::max)),
        ]
    }

    /// A node whose children are all unused.
    pub const EMPTY: WideNode = WideNode {
        min: [[f32::INFINITY; NODE_WIDTH]; 3],
        max: [[f32::NEG_INFINITY; NODE_WIDTH]; 3],
        first: [0; NODE_WIDTH],
        count: [0; NODE_WIDTH],
    };

    /// The boxes as six rows: `min[0..3]`, then `max[0..3]` (the slab test picks a ray's
    /// near and far row per axis once, not per node).
    #[inline(always)]
    pub fn rows(&self) -> &[[f32; NODE_WIDTH]; 6] {
        // SAFETY: `repr(C)`: `min` at offset 0 and `max` right after it (asserted above),
        // both arrays of `[f32; NODE_WIDTH]` rows, so the first six rows are these.
        unsafe { &*(self as *const WideNode).cast::<[[f32; NODE_WIDTH]; 6]>() }
    }

    fn set_box(&mut self, child: usize, b: &Aabb) {
        for axis in 0..3 {
            self.min[axis][child] = b.min[axis];
            self.max[axis][child] = b.max[axis];
        }
    }
}

/// Up to four triangles of one leaf, lane by lane (see the module docs).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleBlock {
    /// `vertices[vertex][axis][lane]`.
    pub vertices: [[[f32; BLOCK_WIDTH]; 3]; 3],
    /// Each lane's `PrimitiveInfo::primitive_index` (0 for an unused lane).
    pub primitives: [u32; BLOCK_WIDTH],
    /// The slot of lane 0's triangle: lane `i` holds slot `first_slot + i`.
    pub first_slot: u32,
    /// Each lane's index in `WideBvh::classes`; [`CLASS_IN_GAS`] where the record is read
    /// from `Gas::primitives` instead (0 for an unused lane).
    pub classes: [u16; BLOCK_WIDTH],
    /// The lanes that hold a triangle (the first `lanes`).
    pub lanes: u32,
}

// The vertices fill the first 144 bytes, what a hit reads the last 32: 176 in all.
const _: () = assert!(std::mem::size_of::<TriangleBlock>() == 176);

/// A lane whose record is read from `Gas::primitives[slot]`: its structure has more classes
/// than a block's 16-bit index holds.
pub const CLASS_IN_GAS: u16 = u16::MAX;

/// What a primitive's [`PrimitiveInfo`] holds besides its index: fields that whole build
/// inputs (or the primitives sharing an SBT offset) have in common.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct PrimitiveClass {
    /// The build input.
    pub input: u32,
    /// `PrimitiveInfo::sbt_gas_index`.
    pub sbt_gas_index: u32,
    /// `PrimitiveInfo::geometry_flags`.
    pub geometry_flags: u32,
}

impl PrimitiveClass {
    fn of(info: &PrimitiveInfo) -> PrimitiveClass {
        PrimitiveClass {
            input: info.input,
            sbt_gas_index: info.sbt_gas_index,
            geometry_flags: info.geometry_flags,
        }
    }

    /// The distinct classes of `infos`, sorted (so the same on any number of threads);
    /// `None` when there are more than `most`.
    fn distinct(infos: &[PrimitiveInfo], most: usize) -> Option<Vec<PrimitiveClass>> {
        let mut all = infos
            .par_chunks(CLASS_CHUNK)
            .map(|chunk| {
                // Neighbouring slots mostly share a class: only changes reach the set.
                let mut set = std::collections::HashSet::new();
                let mut last = None;
                for info in chunk {
                    let class = PrimitiveClass::of(info);
                    if last != Some(class) {
                        set.insert(class);
                        last = Some(class);
                        if set.len() > most {
                            return None;
                        }
                    }
                }
                Some(set)
            })
            .try_reduce(std::collections::HashSet::new, |mut a, b| {
                a.extend(b);
                (a.len() <= most).then_some(a)
            })?
            .into_iter()
            .collect::<Vec<_>>();
        all.sort_unstable();
        Some(all)
    }
}

/// Records a job of [`PrimitiveClass::distinct`] reads.
const CLASS_CHUNK: usize = 16384;

impl TriangleBlock {
    /// The block of the `lanes` triangles from slot `first` (at most [`BLOCK_WIDTH`]); the
    /// lanes beyond hold no triangle. `classes`: the structure's (`None`: records stay in
    /// `Gas::primitives`).
    fn of_slots(
        tris: &SlotTriangles<'_>,
        classes: Option<&[PrimitiveClass]>,
        first: u32,
        lanes: u32,
    ) -> TriangleBlock {
        let lanes = lanes.min(BLOCK_WIDTH as u32);
        let mut block = TriangleBlock {
            vertices: [[[0.0; BLOCK_WIDTH]; 3]; 3],
            primitives: [0; BLOCK_WIDTH],
            first_slot: first,
            classes: [0; BLOCK_WIDTH],
            lanes,
        };
        for lane in 0..lanes as usize {
            let slot = first + lane as u32;
            let tri = &tris.vertices[slot as usize];
            for (v, vertex) in tri.iter().enumerate() {
                for (axis, &c) in vertex.iter().enumerate() {
                    block.vertices[v][axis][lane] = c;
                }
            }
            let info = &tris.infos[slot as usize];
            block.primitives[lane] = info.primitive_index;
            block.classes[lane] = classes
                .and_then(|c| c.binary_search(&PrimitiveClass::of(info)).ok())
                .map_or(CLASS_IN_GAS, |i| i as u16);
        }
        block
    }

    /// The slot of lane `lane`'s triangle.
    #[inline(always)]
    pub fn slot(&self, lane: usize) -> u32 {
        self.first_slot + lane as u32
    }

    /// The record of lane `lane`'s triangle (a lane that holds one), from the block and
    /// `classes` (`WideBvh::classes`), or from `primitives` (`Gas::primitives`) for a lane
    /// of [`CLASS_IN_GAS`].
    #[inline(always)]
    pub fn info(
        &self,
        lane: usize,
        classes: &[PrimitiveClass],
        primitives: &[PrimitiveInfo],
    ) -> PrimitiveInfo {
        match classes.get(self.classes[lane] as usize) {
            Some(c) => PrimitiveInfo {
                primitive_index: self.primitives[lane],
                sbt_gas_index: c.sbt_gas_index,
                geometry_flags: c.geometry_flags,
                input: c.input,
            },
            None => primitives
                .get(self.slot(lane) as usize)
                .copied()
                .unwrap_or(bytemuck::Zeroable::zeroed()),
        }
    }

    /// Lanes holding triangles in block `index` of a leaf of `count` triangles, as a
    /// bit mask (lane `i` is bit `i`).
    #[inline]
    pub fn lane_mask(count: u32, index: u32) -> u32 {
        let lanes = count
            .saturating_sub(index * BLOCK_WIDTH as u32)
            .min(BLOCK_WIDTH as u32);
        (1 << lanes) - 1
    }

    /// The blocks a leaf of `count` triangles has.
    #[inline]
    pub fn blocks_of(count: u32) -> u32 {
        count.div_ceil(BLOCK_WIDTH as u32)
    }
}

/// What triangle blocks are packed from, per slot.
#[derive(Clone, Copy, Debug)]
pub struct SlotTriangles<'a> {
    /// The static vertices.
    pub vertices: &'a [[[f32; 3]; 3]],
    /// The primitive records (`Gas::primitives`).
    pub infos: &'a [PrimitiveInfo],
}

/// The 8-wide BVH of a geometry structure.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WideBvh {
    /// Root first; empty when the structure holds no primitive.
    pub nodes: Vec<WideNode>,
    /// Triangle blocks (empty unless built from static triangles); leaves then point here.
    pub blocks: Vec<TriangleBlock>,
    /// The distinct [`PrimitiveClass`]es of the blocks' triangles, sorted (empty without
    /// blocks, or where there are too many for a block's 16-bit index: [`CLASS_IN_GAS`]).
    pub classes: Vec<PrimitiveClass>,
    /// The deepest leaf's level (the root's children are level 1); sizes traversal stacks.
    pub depth: u32,
    /// The union of the root node's child boxes, `[min, max]`, as `build` made them (`None`:
    /// not known, as for a structure made by hand; traversal then never skips by it).
    pub root_bounds: Option<[[f32; 3]; 2]>,
}

impl WideBvh {
    /// Collapses `bvh` into eight-wide nodes. With `triangles` (per slot, the static
    /// vertices and the primitive records), the wide tree is the one of least cost
    /// ([`TRIANGLE_WIDE_COSTS`]) and its leaves point to triangle blocks packed from them;
    /// without, each node opens its widest inner child first.
    ///
    /// The nodes are made in one pass over the tree, which also gives each leaf its range of
    /// blocks (in the order the pass meets the leaves); the blocks are then filled on the
    /// current rayon pool, each from its own slots: the same layout on any number of threads.
    pub fn build(bvh: &Bvh, triangles: Option<SlotTriangles<'_>>) -> WideBvh {
        let widening = match triangles {
            Some(_) => Widening::Optimal(TRIANGLE_WIDE_COSTS),
            None => Widening::Widest,
        };
        WideBvh::build_with(bvh, triangles, widening, CLASS_IN_GAS as usize)
    }

    /// [`WideBvh::build`] with the children chosen by `widening`, blocks indexing at most
    /// `class_limit` classes (more: every lane's record read from the structure's).
    fn build_with(
        bvh: &Bvh,
        triangles: Option<SlotTriangles<'_>>,
        widening: Widening,
        class_limit: usize,
    ) -> WideBvh {
        let binary = bvh.nodes();
        let mut wide = WideBvh::default();
        if binary.is_empty() {
            return wide;
        }
        let optimal = match widening {
            Widening::Optimal(costs) => Some(OptimalWidening::new(binary, costs)),
            Widening::Widest => None,
        };
        let children = |source: usize| match &optimal {
            Some(o) => o.children(binary, source),
            None => widen::children_up_to(binary, source, NODE_WIDTH)
                .into_iter()
                .map(|c| match binary[c] {
                    BvhNode { first, count, .. } if count > 0 => WideChild::Leaf {
                        node: c,
                        first,
                        count,
                    },
                    _ => WideChild::Node(c),
                })
                .collect(),
        };
        // Per block: its leaf's first slot in the block and the triangles it holds.
        let mut block_slots: Vec<(u32, u32)> = Vec::new();
        wide.nodes.push(WideNode::EMPTY);
        // (a wide node's children, that wide node, the level of those children)
        let mut stack = vec![(children(0), 0usize, 1u32)];
        while let Some((below, target, level)) = stack.pop() {
            wide.depth = wide.depth.max(level);
            let mut node = WideNode::EMPTY;
            for (lane, &child) in below.iter().enumerate() {
                node.set_box(lane, &binary[child.node()].aabb());
                match child {
                    WideChild::Node(c) => {
                        node.first[lane] = wide.nodes.len() as u32;
                        wide.nodes.push(WideNode::EMPTY);
                        stack.push((children(c), node.first[lane] as usize, level + 1));
                    }
                    WideChild::Leaf { first, count, .. } => {
                        node.count[lane] = count;
                        node.first[lane] = match triangles {
                            Some(_) => {
                                let start = block_slots.len() as u32;
                                for b in 0..TriangleBlock::blocks_of(count) {
                                    let done = b * BLOCK_WIDTH as u32;
                                    let lanes = (count - done).min(BLOCK_WIDTH as u32);
                                    block_slots.push((first + done, lanes));
                                }
                                start
                            }
                            None => first,
                        };
                    }
                }
            }
            wide.nodes[target] = node;
        }
        if let Some(tris) = triangles {
            let classes = PrimitiveClass::distinct(tris.infos, class_limit);
            block_slots
                .par_iter()
                .map(|&(first, lanes)| {
                    TriangleBlock::of_slots(&tris, classes.as_deref(), first, lanes)
                })
                .collect_into_vec(&mut wide.blocks);
            wide.classes = classes.unwrap_or_default();
        }
        wide.root_bounds = Some(wide.nodes[0].union());
        wide
    }

    /// Bytes the nodes and blocks occupy.
    pub fn size_in_bytes(&self) -> u64 {
        (self.nodes.len() * std::mem::size_of::<WideNode>()
            + self.blocks.len() * std::mem::size_of::<TriangleBlock>()
            + self.classes.len() * std::mem::size_of::<PrimitiveClass>()) as u64
    }
}

/// How [`WideBvh::build_with`] chooses a wide node's children.
#[derive(Clone, Copy)]
enum Widening {
    /// The widest inner child opened first (`widen::children_up_to`).
    Widest,
    /// The tree of least cost under these costs ([`OptimalWidening`]).
    Optimal(WideCosts),
}

impl GasEncoding for WideBvh {
    /// Static triangles get blocks; every other structure gets nodes only.
    fn encode(bvh: &Bvh, geometry: &Geometry, primitives: &[PrimitiveInfo]) -> WideBvh {
        let triangles = geometry.static_triangles().map(|vertices| SlotTriangles {
            vertices,
            infos: primitives,
        });
        WideBvh::build(bvh, triangles)
    }

    /// Static triangles are tested in blocks ([`TRIANGLE_LEAF_COSTS`]); every other leaf one
    /// primitive at a time.
    fn leaf_costs(geometry: &Geometry) -> Option<LeafCosts> {
        geometry.static_triangles().map(|_| TRIANGLE_LEAF_COSTS)
    }

    fn size_in_bytes(&self) -> u64 {
        WideBvh::size_in_bytes(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use optik_accel::BuildQuality;

    fn boxes(n: usize) -> Vec<Aabb> {
        (0..n)
            .map(|i| {
                let x = (i * 7 % 13) as f32 + i as f32 * 0.01;
                Aabb {
                    min: [x, (i % 5) as f32, 0.0],
                    max: [x + 0.5, (i % 5) as f32 + 1.0, 1.0],
                }
            })
            .collect()
    }

    /// Every slot is reached exactly once, each child box holds what is below it, and
    /// leaves keep the binary tree's leaves.
    fn check(wide: &WideBvh, slots: usize, slot_box: impl Fn(usize) -> Aabb) {
        let mut seen = vec![0u32; slots];
        let mut stack = vec![(0usize, Aabb::EMPTY, true)];
        while let Some((n, parent, root)) = stack.pop() {
            let node = &wide.nodes[n];
            for lane in 0..NODE_WIDTH {
                let b = Aabb {
                    min: std::array::from_fn(|a| node.min[a][lane]),
                    max: std::array::from_fn(|a| node.max[a][lane]),
                };
                if !root && b.is_valid() {
                    assert_eq!(parent.union(&b), parent, "child box inside its parent");
                }
                if node.count[lane] > 0 {
                    let count = node.count[lane];
                    let mut leaf_slots = Vec::new();
                    if wide.blocks.is_empty() {
                        leaf_slots.extend(node.first[lane]..node.first[lane] + count);
                    } else {
                        for k in 0..TriangleBlock::blocks_of(count) {
                            let block = &wide.blocks[(node.first[lane] + k) as usize];
                            let mask = TriangleBlock::lane_mask(count, k);
                            assert_eq!(mask, (1 << block.lanes) - 1);
                            leaf_slots.extend((0..block.lanes as usize).map(|l| block.slot(l)));
                        }
                    }
                    assert_eq!(leaf_slots.len(), count as usize);
                    for s in leaf_slots {
                        seen[s as usize] += 1;
                        assert_eq!(
                            b.union(&slot_box(s as usize)),
                            b,
                            "slot {s} in its leaf box"
                        );
                    }
                } else if b.is_valid() {
                    assert!(node.first[lane] as usize > n, "children after parents");
                    stack.push((node.first[lane] as usize, b, false));
                }
            }
        }
        assert!(seen.iter().all(|&k| k == 1), "{seen:?}");
    }

    /// Each triangle's box.
    fn boxes_of(tris: &[[[f32; 3]; 3]]) -> Vec<Aabb> {
        tris.iter()
            .map(|t| {
                let mut b = Aabb::EMPTY;
                t.iter().for_each(|&p| b.grow(p));
                b
            })
            .collect()
    }

    #[test]
    fn collapse_keeps_every_slot_once() {
        for n in [1usize, 2, 3, 5, 17, 1000] {
            let b = boxes(n);
            let (bvh, order) = Bvh::build(&b, BuildQuality::Balanced).unwrap();
            let wide = WideBvh::build(&bvh, None);
            assert!(wide.blocks.is_empty());
            check(&wide, n, |s| b[order[s] as usize]);
            assert!(wide.depth <= bvh.depth, "{} > {}", wide.depth, bvh.depth);
        }
    }

    #[test]
    fn triangle_blocks_hold_each_leaf_in_order() {
        let n = 300;
        let tris: Vec<[[f32; 3]; 3]> = (0..n)
            .map(|i| {
                let x = (i * 37 % 101) as f32;
                [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.5], [x, 1.0, 1.0]]
            })
            .collect();
        let b = boxes_of(&tris);
        let (bvh, order) = Bvh::build(&b, BuildQuality::FastTrace).unwrap();
        let slotted: Vec<[[f32; 3]; 3]> = order.iter().map(|&i| tris[i as usize]).collect();
        let infos: Vec<PrimitiveInfo> = (0..n as u32)
            .map(|s| PrimitiveInfo {
                primitive_index: order[s as usize],
                sbt_gas_index: s % 3,
                geometry_flags: s % 2,
                input: 0,
            })
            .collect();
        let wide = WideBvh::build(
            &bvh,
            Some(SlotTriangles {
                vertices: &slotted,
                infos: &infos,
            }),
        );
        check(&wide, n, |s| b[order[s] as usize]);
        // Six classes (three SBT indices by two flag sets), sorted.
        assert_eq!(wide.classes.len(), 6);
        assert!(wide.classes.is_sorted());
        for block in &wide.blocks {
            for lane in 0..BLOCK_WIDTH {
                let s = block.slot(lane);
                if lane >= block.lanes as usize {
                    assert_eq!(block.primitives[lane], 0);
                    assert_eq!(block.classes[lane], 0);
                    assert!(block.vertices.iter().flatten().all(|row| row[lane] == 0.0));
                    continue;
                }
                assert_eq!(block.info(lane, &wide.classes, &[]), infos[s as usize]);
                for (v, vertex) in slotted[s as usize].iter().enumerate() {
                    for (a, &c) in vertex.iter().enumerate() {
                        assert_eq!(block.vertices[v][a][lane], c);
                    }
                }
            }
        }
        // The blocks are filled on the current rayon pool: the same structure, block
        // layout included, on one thread as on four.
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                WideBvh::build(
                    &bvh,
                    Some(SlotTriangles {
                        vertices: &slotted,
                        infos: &infos,
                    }),
                )
            })
        };
        assert_eq!(on(1), wide);
        assert_eq!(on(4), wide);
        assert_eq!(WideBvh::build(&Bvh::default(), None), WideBvh::default());
        // More classes than blocks may index: every lane's record is the structure's.
        let few = WideBvh::build_with(
            &bvh,
            Some(SlotTriangles {
                vertices: &slotted,
                infos: &infos,
            }),
            Widening::Optimal(TRIANGLE_WIDE_COSTS),
            5,
        );
        assert!(few.classes.is_empty());
        assert_eq!(few.nodes, wide.nodes);
        for block in &few.blocks {
            for lane in 0..block.lanes as usize {
                assert_eq!(block.classes[lane], CLASS_IN_GAS);
                let s = block.slot(lane) as usize;
                assert_eq!(block.info(lane, &few.classes, &infos), infos[s]);
            }
        }
    }

    /// The classes are the records' distinct (input, SBT index, flags), sorted, across
    /// the jobs' chunks; more than the limit gives none.
    #[test]
    fn classes_are_the_distinct_records_sorted() {
        let n = 3 * CLASS_CHUNK + 5;
        let infos: Vec<PrimitiveInfo> = (0..n as u32)
            .map(|i| PrimitiveInfo {
                primitive_index: i,
                // Runs of one class, and a class met only in the last chunk.
                sbt_gas_index: (i / 1000) % 7 + u32::from(i as usize == n - 1) * 100,
                geometry_flags: (i / 5000) % 2,
                input: i / 20000,
            })
            .collect();
        let want: std::collections::BTreeSet<PrimitiveClass> =
            infos.iter().map(PrimitiveClass::of).collect();
        let want: Vec<PrimitiveClass> = want.into_iter().collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let got = pool.install(|| PrimitiveClass::distinct(&infos, want.len()));
        assert_eq!(got.as_ref(), Some(&want));
        assert_eq!(PrimitiveClass::distinct(&infos, want.len() - 1), None);
    }

    /// Triangles of one unit square's size scattered over a 101 × 97 grid.
    fn scattered(i: usize) -> [[f32; 3]; 3] {
        let (x, y) = ((i * 37 % 101) as f32, (i * 53 % 97) as f32);
        [[x, y, 0.0], [x + 1.0, y, 0.5], [x, y + 1.0, 1.0]]
    }

    /// The cost of `wide` under `costs`, as [`OptimalWidening`] prices a tree: per wide node
    /// its box's half area times the node cost (the root's box: the union of its children),
    /// per leaf its box's half area times its blocks.
    fn tree_cost(wide: &WideBvh, costs: WideCosts) -> f32 {
        fn node(wide: &WideBvh, i: usize, area: f32, costs: WideCosts) -> f32 {
            let n = &wide.nodes[i];
            let mut cost = area * costs.node;
            for lane in (0..NODE_WIDTH).filter(|&l| n.min[0][l] <= n.max[0][l]) {
                let b = Aabb {
                    min: std::array::from_fn(|a| n.min[a][lane]),
                    max: std::array::from_fn(|a| n.max[a][lane]),
                };
                cost += match n.count[lane] {
                    0 => node(wide, n.first[lane] as usize, b.half_area(), costs),
                    count => b.half_area() * (costs.leaf)(count).unwrap_or(count as f32),
                };
            }
            cost
        }
        let [min, max] = wide.nodes[0].union();
        node(wide, 0, Aabb { min, max }.half_area(), costs)
    }

    /// A triangle structure's wide tree is the one of least cost: what `OptimalWidening`
    /// computed, no more than opening the widest child first costs, with inner binary nodes
    /// of few triangles made leaves (fewer nodes), and every slot still reached once,
    /// inside its leaf's box.
    #[test]
    fn triangle_trees_are_the_cheapest_widening() {
        let tris: Vec<[[f32; 3]; 3]> = (0..2000).map(scattered).collect();
        let b = boxes_of(&tris);
        let (bvh, order) =
            Bvh::build_with(&b, BuildQuality::FastTrace, Some(TRIANGLE_LEAF_COSTS)).unwrap();
        let slotted: Vec<[[f32; 3]; 3]> = order.iter().map(|&i| tris[i as usize]).collect();
        let infos = vec![bytemuck::Zeroable::zeroed(); tris.len()];
        let triangles = Some(SlotTriangles {
            vertices: &slotted,
            infos: &infos,
        });
        let optimal = WideBvh::build(&bvh, triangles);
        let widest = WideBvh::build_with(&bvh, triangles, Widening::Widest, CLASS_IN_GAS as usize);
        check(&optimal, b.len(), |s| b[order[s] as usize]);
        check(&widest, b.len(), |s| b[order[s] as usize]);
        let costs = TRIANGLE_WIDE_COSTS;
        let (got, greedy) = (tree_cost(&optimal, costs), tree_cost(&widest, costs));
        let want = OptimalWidening::new(bvh.nodes(), costs).cost(bvh.nodes());
        // The root's box is its children's union here and the binary root's there.
        assert!((got - want).abs() <= 1e-3 * want, "{got} against {want}");
        assert!(got < greedy, "{got} against {greedy}");
        assert!(optimal.nodes.len() < widest.nodes.len());
        assert!(optimal.depth <= widest.depth);
    }

    /// Static triangles get leaves priced by the block (48 triangles with one box, which the
    /// block-priced build halves, make leaves of 24, where the per-primitive pricing stops
    /// at 8); moving triangles and other primitives keep the per-primitive pricing, as their
    /// leaves are tested one primitive at a time.
    #[test]
    fn static_triangle_leaves_are_priced_by_the_block() {
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let one_key = Geometry::Triangles(optik_accel::Triangles {
            keys: vec![vec![tri; 40]],
            micromaps: None,
        });
        let two_keys = Geometry::Triangles(optik_accel::Triangles {
            keys: vec![vec![tri; 40]; 2],
            micromaps: None,
        });
        let custom = Geometry::Custom(optik_accel::CustomPrimitives {
            keys: vec![vec![Aabb::point([0.0; 3]); 40]],
        });
        assert_eq!(
            <WideBvh as GasEncoding>::leaf_costs(&one_key),
            Some(TRIANGLE_LEAF_COSTS)
        );
        assert_eq!(<WideBvh as GasEncoding>::leaf_costs(&two_keys), None);
        assert_eq!(<WideBvh as GasEncoding>::leaf_costs(&custom), None);
        let b = vec![Aabb::from_six([0.0, 0.0, 0.0, 1.0, 1.0, 0.0]); 48];
        let largest = |costs| {
            let (bvh, _) = Bvh::build_with(&b, BuildQuality::FastTrace, costs).unwrap();
            bvh.nodes().iter().map(|n| n.count).max().unwrap()
        };
        assert_eq!(largest(Some(TRIANGLE_LEAF_COSTS)), 24);
        assert_eq!(largest(None), 8);
    }

    #[test]
    fn lane_masks() {
        assert_eq!(TriangleBlock::lane_mask(1, 0), 0b1);
        assert_eq!(TriangleBlock::lane_mask(4, 0), 0b1111);
        assert_eq!(TriangleBlock::lane_mask(7, 0), 0b1111);
        assert_eq!(TriangleBlock::lane_mask(7, 1), 0b111);
        assert_eq!(TriangleBlock::blocks_of(8), 2);
        assert_eq!(TriangleBlock::blocks_of(9), 3);
    }
}
