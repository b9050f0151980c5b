//! Widening the binary BVH to wide nodes: which binary nodes become a wide node's
//! children, and in which order.
//!
//! Two rules, each backend keeping its own node encoding:
//!
//! - [`children_up_to`]: open the widest inner child until the node is full. The wgpu
//!   megakernel's 4-wide nodes ([`WIDTH`]) and the CPU's 8-wide nodes of every structure
//!   but static triangles; opening the widest child first makes an 8-wide node's children a
//!   refinement of the 4-wide node's.
//! - [`OptimalWidening`]: the children, and which inner binary nodes become leaves, that
//!   minimise the surface area heuristic of the whole wide tree under a cost model
//!   ([`WideCosts`]), by dynamic programming over the binary tree (the conversion of Ylitie,
//!   Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
//!   BVHs", 2017). The CPU's triangle blocks use it (docs/cpu-backend.md, "Wide nodes chosen
//!   by the heuristic"). Large trees are priced on the current rayon pool, subtree by
//!   subtree; every choice depends on its subtree alone, so the same on any number of
//!   threads.

use super::bvh::BvhNode;
use rayon::prelude::*;

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

/// The most children [`OptimalWidening`] gives a wide node.
pub const MAX_WIDTH: usize = 8;

/// The cost model of [`OptimalWidening`], in units of whatever `leaf` counts (the CPU: one
/// triangle block test), each weighted by the surface area of the box it is paid for.
#[derive(Clone, Copy, Debug)]
pub struct WideCosts {
    /// Children per wide node (2 to [`MAX_WIDTH`]).
    pub width: usize,
    /// Testing one wide node's children.
    pub node: f32,
    /// Testing a leaf of `count` primitives; `None` where a leaf may not hold that many.
    pub leaf: fn(u32) -> Option<f32>,
}

/// A child of a wide node chosen by [`OptimalWidening::children`]: a binary node whose box
/// the child has, and either a wide node of its own or a leaf of consecutive slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WideChild {
    /// This inner binary node becomes a wide node of its own, whose children
    /// [`OptimalWidening::children`] gives.
    Node(usize),
    /// Binary node `node`'s slots (`first`, `count` of them) become one leaf.
    Leaf {
        /// The binary node whose subtree the leaf holds (a binary leaf, or an inner node
        /// whose slots are consecutive).
        node: usize,
        /// The leaf's first slot.
        first: u32,
        /// Its slots.
        count: u32,
    },
}

impl WideChild {
    /// The binary node whose box the child has.
    pub fn node(&self) -> usize {
        match *self {
            WideChild::Node(node) | WideChild::Leaf { node, .. } => node,
        }
    }
}

/// The SAH-optimal wide tree over a binary tree: for every binary node, the least cost of
/// its subtree when it fills `1..=width` children of its parent wide node (one child: a
/// leaf, if its slots may be one, or a wide node; more: its two children share them), and
/// the choices that give it.
///
/// A wide node made from binary node `n` costs `area(n) · node` plus its children's costs;
/// a leaf `area · leaf(count)`. Binary leaves stay leaves (priced by `leaf`, or by their
/// count where `leaf` refuses them); an inner node may become a leaf when its slots are
/// consecutive and `leaf` accepts their number.
pub struct OptimalWidening {
    width: usize,
    node_cost: f32,
    /// Per binary node, what its subtree costs and how (the padding node: [`Choice::NONE`]).
    choices: Vec<Choice>,
}

/// One binary node's entry of the programme.
#[derive(Clone, Copy, Debug)]
struct Choice {
    /// The least cost of the node's subtree filling at most `i + 1` children.
    cost: [f32; MAX_WIDTH],
    /// Per `i + 1` children: 0 when fewer children cost as little (or, for one, when the
    /// node is one child), else the children its first child takes.
    split: [u8; MAX_WIDTH],
    /// As one child: a leaf (else a wide node).
    leaf: bool,
    /// Its slots when they are consecutive (`first`, `count`).
    slots: Option<(u32, u32)>,
}

impl Choice {
    /// The entry of a node that is no one's child (the padding after the root).
    const NONE: Choice = Choice {
        cost: [f32::INFINITY; MAX_WIDTH],
        split: [0; MAX_WIDTH],
        leaf: false,
        slots: None,
    };
}

/// Levels whose subtrees the programme prices on separate rayon tasks (at most
/// `2^SPLIT_DEPTH` tasks); below them a subtree is one task, walked with an explicit stack.
const SPLIT_DEPTH: u32 = 6;

/// Trees of fewer binary nodes are priced on the calling thread: a task costs more than
/// such a tree.
const PARALLEL_MIN_NODES: usize = 2 * crate::PARALLEL_MIN_LEN;

impl OptimalWidening {
    /// Chooses the wide tree over `binary` (root at 0, padding at 1, sibling pairs after:
    /// `Bvh::nodes`) under `costs`. Every subtree is priced after its two children's; the
    /// subtrees of the top levels on separate tasks of the current rayon pool, so large
    /// trees are priced on all its threads. Each node's entry depends only on its subtree,
    /// so the choices are the same on any number of threads.
    pub fn new(binary: &[BvhNode], costs: WideCosts) -> OptimalWidening {
        let width = costs.width.clamp(2, MAX_WIDTH);
        // Split only where there are threads to share it: a split pass walks each subtree
        // in pre-order first, which costs a third more than the serial pass's one loop.
        let split = if binary.len() < PARALLEL_MIN_NODES || rayon::current_num_threads() < 2 {
            0
        } else {
            SPLIT_DEPTH
        };
        OptimalWidening {
            width,
            node_cost: costs.node,
            choices: price(binary, costs, width, split),
        }
    }

    /// The least cost of the whole tree (its root a wide node, or a leaf when the root is a
    /// binary leaf).
    pub fn cost(&self, binary: &[BvhNode]) -> f32 {
        match binary.first() {
            None => 0.0,
            Some(root) if root.is_leaf() => self.choices[0].cost[0],
            Some(root) => {
                let (l, r) = (root.first as usize, root.first as usize + 1);
                let children = shared(&self.choices[l].cost, &self.choices[r].cost, self.width).0;
                root.aabb().half_area() * self.node_cost + children
            }
        }
    }

    /// The children of the wide node made from binary node `source`, in slot order (a
    /// binary leaf `source` is its own only child: a leaf root).
    pub fn children(&self, binary: &[BvhNode], source: usize) -> Vec<WideChild> {
        let mut out = Vec::with_capacity(self.width);
        let b = &binary[source];
        if b.is_leaf() {
            self.push(binary, source, 1, &mut out);
            return out;
        }
        let (l, r) = (b.first as usize, b.first as usize + 1);
        let k = shared(&self.choices[l].cost, &self.choices[r].cost, self.width).1;
        self.push(binary, l, k, &mut out);
        self.push(binary, r, self.width - k, &mut out);
        out
    }

    /// Node `i`'s share of a wide node's children when it may fill `slots` of them.
    fn push(&self, binary: &[BvhNode], i: usize, slots: usize, out: &mut Vec<WideChild>) {
        let choice = &self.choices[i];
        let mut j = slots;
        while j > 1 && choice.split[j - 1] == 0 {
            j -= 1;
        }
        if j > 1 {
            let k = choice.split[j - 1] as usize;
            let first = binary[i].first as usize;
            self.push(binary, first, k, out);
            self.push(binary, first + 1, j - k, out);
        } else if let (true, Some((first, count))) = (choice.leaf, choice.slots) {
            out.push(WideChild::Leaf {
                node: i,
                first,
                count,
            });
        } else {
            out.push(WideChild::Node(i));
        }
    }
}

/// Every binary node's entry, the subtrees of the top `split` levels priced on separate
/// tasks (none: every node in one pass from the last up, children being after parents).
fn price(binary: &[BvhNode], costs: WideCosts, width: usize, split: u32) -> Vec<Choice> {
    // Made on the pool: the first writes to fresh pages are a large tree's slowest step.
    let mut choices: Vec<Choice> = (0..binary.len())
        .into_par_iter()
        .with_min_len(crate::PARALLEL_MIN_LEN)
        .map(|_| Choice::NONE)
        .collect();
    if binary.is_empty() {
        return choices;
    }
    let pass = Pricing {
        binary,
        costs,
        width,
        entries: Entries::new(&mut choices),
    };
    if split == 0 {
        // The padding node after the root is no one's child: it keeps `NONE`.
        for i in (0..binary.len()).rev().filter(|&i| i != 1) {
            // SAFETY: one thread; `i`'s children (after it) are priced.
            unsafe { pass.price(i) };
        }
    } else {
        pass.subtree(0, 0, split);
    }
    choices
}

/// The programme's pass over a binary tree: each node's entry is written once, by the task
/// that prices its subtree, after its children's.
struct Pricing<'a> {
    binary: &'a [BvhNode],
    costs: WideCosts,
    width: usize,
    entries: Entries<'a>,
}

impl Pricing<'_> {
    /// Prices the subtree of `i` (at `depth`), its children's subtrees on two tasks above
    /// level `split`.
    fn subtree(&self, i: usize, depth: u32, split: u32) {
        let b = &self.binary[i];
        if depth >= split || b.is_leaf() {
            return self.subtree_serially(i);
        }
        let l = b.first as usize;
        rayon::join(
            || self.subtree(l, depth + 1, split),
            || self.subtree(l + 1, depth + 1, split),
        );
        // SAFETY: this task owns `i`'s subtree, whose two halves the joined tasks priced.
        unsafe { self.price(i) };
    }

    fn subtree_serially(&self, root: usize) {
        let first_child = |i: usize| {
            let b = &self.binary[i];
            (!b.is_leaf()).then_some(b.first as usize)
        };
        for i in crate::children_first(root, first_child) {
            // SAFETY: this task owns `root`'s subtree, and `i`'s children came before it.
            unsafe { self.price(i) };
        }
    }

    /// Writes node `i`'s entry from its children's.
    ///
    /// # Safety
    /// The caller's task owns `i`'s subtree (no other task reads or writes its entries
    /// meanwhile), and `i`'s children are priced.
    unsafe fn price(&self, i: usize) {
        let (b, costs, width) = (&self.binary[i], &self.costs, self.width);
        let area = b.aabb().half_area();
        let choice = if b.is_leaf() {
            Choice {
                cost: [area * (costs.leaf)(b.count).unwrap_or(b.count as f32); MAX_WIDTH],
                split: [0; MAX_WIDTH],
                leaf: true,
                slots: Some((b.first, b.count)),
            }
        } else {
            // SAFETY: the children are in `i`'s subtree and priced (the contract).
            let (l, r) = unsafe {
                (
                    self.entries.get(b.first as usize),
                    self.entries.get(b.first as usize + 1),
                )
            };
            let slots = match (l.slots, r.slots) {
                (Some((lf, lc)), Some((rf, rc))) if lf + lc == rf => Some((lf, lc + rc)),
                (Some((lf, lc)), Some((rf, rc))) if rf + rc == lf => Some((rf, lc + rc)),
                _ => None,
            };
            let as_node = area * costs.node + shared(&l.cost, &r.cost, width).0;
            let as_leaf = slots
                .and_then(|(_, count)| (costs.leaf)(count))
                .map_or(f32::INFINITY, |c| area * c);
            let mut choice = Choice {
                leaf: as_leaf <= as_node,
                slots,
                ..Choice::NONE
            };
            choice.cost[0] = as_leaf.min(as_node);
            for j in 2..=width {
                let (c, k) = shared(&l.cost, &r.cost, j);
                if c < choice.cost[j - 2] {
                    choice.cost[j - 1] = c;
                    choice.split[j - 1] = k as u8;
                } else {
                    choice.cost[j - 1] = choice.cost[j - 2];
                }
            }
            choice
        };
        // SAFETY: `i` is in the caller's subtree (the contract).
        unsafe { self.entries.set(i, choice) };
    }
}

/// The programme's entries, shared by the tasks that price disjoint subtrees: each task
/// writes and reads only its own subtree's nodes (a binary tree's subtrees share no node),
/// and reads a joined task's nodes only after the join (which orders the writes before).
/// Not `split_at_mut`: a subtree's nodes are not one range of the array after reinsertion.
struct Entries<'a> {
    at: *mut Choice,
    len: usize,
    _borrow: std::marker::PhantomData<&'a mut [Choice]>,
}

// SAFETY: the entries are `Choice`s (plain data); concurrent use is limited by the
// contracts of `get` and `set` to disjoint indices.
unsafe impl Sync for Entries<'_> {}

impl<'a> Entries<'a> {
    fn new(entries: &'a mut [Choice]) -> Entries<'a> {
        Entries {
            at: entries.as_mut_ptr(),
            len: entries.len(),
            _borrow: std::marker::PhantomData,
        }
    }

    /// Entry `i`.
    ///
    /// # Safety
    /// No task writes entry `i` meanwhile.
    unsafe fn get(&self, i: usize) -> &Choice {
        assert!(i < self.len, "entry {i} of {}", self.len);
        // SAFETY: in bounds (checked); not written meanwhile (the contract).
        unsafe { &*self.at.add(i) }
    }

    /// Sets entry `i`.
    ///
    /// # Safety
    /// No other task reads or writes entry `i` meanwhile.
    unsafe fn set(&self, i: usize, choice: Choice) {
        assert!(i < self.len, "entry {i} of {}", self.len);
        // SAFETY: in bounds (checked); no one else uses it meanwhile (the contract).
        unsafe { self.at.add(i).write(choice) }
    }
}

/// Two sibling subtrees (their costs by children filled) sharing `j` children of their
/// parent: the least cost, and the children the first takes (the fewest of equal costs).
fn shared(left: &[f32; MAX_WIDTH], right: &[f32; MAX_WIDTH], j: usize) -> (f32, usize) {
    (1..j)
        .map(|k| (left[k - 1] + right[j - k - 1], k))
        .fold(
            (f32::INFINITY, 1),
            |best, c| if c.0 < best.0 { c } else { best },
        )
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

    /// The programme priced on tasks (the subtrees of the top levels apart) and on one
    /// thread chooses alike: every entry bit for bit, for a tree of 30 000 boxes, at every
    /// split depth from none to deeper than the tree, on a pool of four threads.
    #[test]
    fn split_and_serial_pricing_agree() {
        use crate::BuildQuality;
        use crate::aabb::Aabb;
        use crate::bvh::Bvh;
        let mut next = crate::testing::uniform(5);
        let boxes: Vec<Aabb> = (0..30_000)
            .map(|_| {
                let c = [next() * 50.0, next() * 50.0, next() * 50.0];
                Aabb {
                    min: c,
                    max: [c[0] + next(), c[1] + next(), c[2] + next()],
                }
            })
            .collect();
        let (bvh, _) = Bvh::build(&boxes, BuildQuality::Balanced).unwrap();
        let bin = bvh.nodes();
        assert!(bin.len() >= PARALLEL_MIN_NODES, "{} nodes", bin.len());
        let bits = |choices: Vec<Choice>| -> Vec<_> {
            choices
                .iter()
                .map(|c| (c.cost.map(f32::to_bits), c.split, c.leaf, c.slots))
                .collect()
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        for c in [costs(8, 2.0), costs(4, 1.0)] {
            let serial = bits(price(bin, c, c.width, 0));
            assert!(
                serial.iter().any(|e| e.2 && e.3.is_some_and(|s| s.1 > 1)),
                "leaves merge"
            );
            for split in [1, 3, SPLIT_DEPTH, 60] {
                let split_choices = pool.install(|| bits(price(bin, c, c.width, split)));
                assert!(split_choices == serial, "split depth {split}");
            }
            let built = pool.install(|| OptimalWidening::new(bin, c));
            assert!(bits(built.choices) == serial);
        }
    }

    /// Costs of a CPU-like model: a leaf of up to `max` primitives costs its blocks of four.
    fn costs(width: usize, node: f32) -> WideCosts {
        WideCosts {
            width,
            node,
            leaf: |count| (count <= 8).then(|| count.div_ceil(4) as f32),
        }
    }

    /// Binary node `i`'s slots when consecutive (as `OptimalWidening` decides it).
    fn slots(bin: &[BvhNode], i: usize) -> Option<(u32, u32)> {
        let b = &bin[i];
        if b.is_leaf() {
            return Some((b.first, b.count));
        }
        match (
            slots(bin, b.first as usize),
            slots(bin, b.first as usize + 1),
        ) {
            (Some((lf, lc)), Some((rf, rc))) if lf + lc == rf => Some((lf, lc + rc)),
            (Some((lf, lc)), Some((rf, rc))) if rf + rc == lf => Some((rf, lc + rc)),
            _ => None,
        }
    }

    /// Every way to cut the subtree strictly below inner node `i` into at most `most`
    /// nodes.
    fn frontiers(bin: &[BvhNode], i: usize, most: usize) -> Vec<Vec<usize>> {
        let b = &bin[i];
        let options = |c: usize, most: usize| {
            let mut o = vec![vec![c]];
            if !bin[c].is_leaf() && most >= 2 {
                o.extend(frontiers(bin, c, most));
            }
            o
        };
        let mut out = Vec::new();
        for left in options(b.first as usize, most - 1) {
            for right in options(b.first as usize + 1, most - left.len()) {
                if left.len() + right.len() <= most {
                    out.push([left.clone(), right].concat());
                }
            }
        }
        out
    }

    /// The least cost of node `i` as one child, by trying every widening.
    fn brute(bin: &[BvhNode], c: WideCosts, i: usize) -> f32 {
        let b = &bin[i];
        let area = b.aabb().half_area();
        if b.is_leaf() {
            return area * (c.leaf)(b.count).unwrap_or(b.count as f32);
        }
        let as_leaf = slots(bin, i)
            .and_then(|(_, n)| (c.leaf)(n))
            .map_or(f32::INFINITY, |x| area * x);
        let as_node = area * c.node
            + frontiers(bin, i, c.width)
                .iter()
                .map(|f| f.iter().map(|&k| brute(bin, c, k)).sum::<f32>())
                .fold(f32::INFINITY, f32::min);
        as_leaf.min(as_node)
    }

    /// The cost of the wide tree `children` makes from inner node `i` (as a wide node), and
    /// the slots its leaves hold, in order.
    fn chosen(
        o: &OptimalWidening,
        bin: &[BvhNode],
        c: WideCosts,
        i: usize,
        leaves: &mut Vec<(u32, u32)>,
    ) -> f32 {
        let children = o.children(bin, i);
        assert!((1..=c.width).contains(&children.len()));
        let mut cost = bin[i].aabb().half_area() * c.node;
        for child in children {
            cost += match child {
                WideChild::Node(k) => {
                    assert!(!bin[k].is_leaf());
                    chosen(o, bin, c, k, leaves)
                }
                WideChild::Leaf { node, first, count } => {
                    assert_eq!(slots(bin, node), Some((first, count)));
                    leaves.push((first, count));
                    let x = (c.leaf)(count).unwrap_or(count as f32);
                    bin[node].aabb().half_area() * x
                }
            };
        }
        cost
    }

    /// On small random trees the dynamic programme's cost is the least of every widening
    /// (tried one by one), the children it gives make a tree of that cost, and their leaves
    /// hold every slot once.
    #[test]
    fn the_optimal_widening_is_the_cheapest_of_all() {
        let mut rnd = crate::testing::uniform(12345);
        let mut checked = 0;
        for trial in 0..60 {
            let n = 4 + trial % 20;
            let boxes: Vec<crate::Aabb> = (0..n)
                .map(|_| {
                    let (x, y, z) = (rnd() * 10.0, rnd() * 10.0, rnd() * 10.0);
                    let s = rnd() + 0.1;
                    crate::Aabb::from_six([x, y, z, x + s, y + s, z + s])
                })
                .collect();
            let (bvh, _) = crate::Bvh::build(&boxes, crate::BuildQuality::Balanced).unwrap();
            let bin = bvh.nodes();
            if bin[0].is_leaf() {
                continue;
            }
            for (width, node) in [(8, 1.0), (4, 2.0), (3, 0.5), (8, 0.1)] {
                let c = costs(width, node);
                let o = OptimalWidening::new(bin, c);
                let root = bin[0].aabb().half_area();
                let best = root * c.node
                    + frontiers(bin, 0, width)
                        .iter()
                        .map(|f| f.iter().map(|&k| brute(bin, c, k)).sum::<f32>())
                        .fold(f32::INFINITY, f32::min);
                let got = o.cost(bin);
                assert!((got - best).abs() <= 1e-4 * best, "{got} against {best}");
                let mut leaves = Vec::new();
                let built = chosen(&o, bin, c, 0, &mut leaves);
                assert!((built - got).abs() <= 1e-4 * got, "{built} against {got}");
                leaves.sort();
                let mut next = 0;
                for (first, count) in leaves {
                    assert_eq!(first, next);
                    next += count;
                }
                assert_eq!(next as usize, n);
                checked += 1;
            }
        }
        assert!(checked > 150);
    }

    /// Where opening the widest child first is not the cheapest: a large node of two leaves
    /// beside a small one of two small nodes. The widest opens first, and then the small
    /// one, leaving two nodes of two leaves each; the optimum makes the large node one leaf
    /// of its four slots (one block instead of two leaves' areas) and each small node one
    /// leaf.
    #[test]
    fn the_optimal_widening_beats_opening_the_widest() {
        // Root (2, 3); node 2 large, leaves 4 and 5 (two slots each); node 3 small, inner
        // nodes 6 and 7, each two leaves.
        let bin = vec![
            node(2, 0, 10.0),
            node(0, 0, 0.0),
            node(4, 0, 9.0),
            node(6, 0, 2.0),
            node(0, 2, 9.0),
            node(2, 2, 9.0),
            node(8, 0, 1.0),
            node(10, 0, 1.0),
            node(4, 1, 1.0),
            node(5, 1, 1.0),
            node(6, 1, 1.0),
            node(7, 1, 1.0),
        ];
        let c = costs(4, 1.0);
        assert_eq!(children_up_to(&bin, 0, 4), vec![4, 6, 5, 7]);
        let o = OptimalWidening::new(&bin, c);
        assert_eq!(
            o.children(&bin, 0),
            vec![
                WideChild::Leaf {
                    node: 2,
                    first: 0,
                    count: 4
                },
                WideChild::Leaf {
                    node: 6,
                    first: 4,
                    count: 2
                },
                WideChild::Leaf {
                    node: 7,
                    first: 6,
                    count: 2
                },
            ]
        );
        // Half areas: root 300, node 2 and its leaves 243, nodes 6 and 7 and their leaves 3.
        // Opening the widest: the root, leaves 4 and 5, nodes 6 and 7 with two leaves each.
        let greedy = 300.0 * c.node + 2.0 * 243.0 + 2.0 * (3.0 * c.node + 2.0 * 3.0);
        let optimal = 300.0 * c.node + 243.0 + 3.0 + 3.0;
        assert_eq!(greedy, 804.0);
        assert_eq!(o.cost(&bin), optimal);
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
