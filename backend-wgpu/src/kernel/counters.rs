//! The instrumented kernel: per-invocation traffic counters for bytes-per-ray figures.
//!
//! Only kernels generated with `KernelConfig::counters` (the benchmark's counting launch)
//! contain any of this; pipelines made through the `Device` trait never do, which
//! `tests/internal/bench.rs` asserts. Each invocation counts in private variables (no memory
//! traffic of its own while tracing) and adds its totals once, at the end of the entry
//! point, to 64-bit counters (two `u32` words each, carry propagated) in one extra
//! read-write binding after the scene chunks.

use super::KernelConfig;

/// What is counted; the index of each counter in `_optik_count` and (times two) in the
/// counter buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Counter {
    /// Traversals started (`_optik_traverse` calls).
    Traces = 0,
    /// 16-byte reads of the scene arena (every `_optik_fetch`): nodes, primitive records,
    /// instance records, headers and transforms alike.
    ArenaFetches = 1,
    /// BVH4 nodes tested (128 bytes each).
    Nodes = 2,
    /// Primitives tested in geometry leaves.
    Primitives = 3,
    /// Instance records entered (80 bytes each): the mask passed and the child is alive.
    Instances = 4,
    /// Handle-table entries read (16 bytes each).
    HandleReads = 5,
    /// Traversal stack pushes (8 bytes each).
    StackPushes = 6,
    /// Traversal stack pops (8 bytes each).
    StackPops = 7,
}

/// Number of counters.
pub(crate) const COUNTERS: usize = 8;

/// Bytes of the counter buffer (a `u32` pair per counter).
pub(crate) const BUFFER_BYTES: u64 = (COUNTERS * 8) as u64;

/// The statement adding `amount` to `counter`, or nothing in a normal kernel.
pub(crate) fn count(c: &KernelConfig<'_>, counter: Counter, amount: &str) -> String {
    if c.counters {
        format!("_optik_count[{}] += {amount}; ", counter as u32)
    } else {
        String::new()
    }
}

/// Where the traversal is counted: a counter statement goes before every line equal to
/// the anchor (leaf loops share theirs). Anchoring on the lines of the normal kernel keeps
/// its text exactly as written; `counts_match_the_layout` in `tests/internal/bench.rs` fails if an
/// anchor stops matching.
const HOOKS: &[(&str, Counter, &str)] = &[
    (
        "    var root = _optik_resolve_handle(handle);",
        Counter::Traces,
        "1u",
    ),
    (
        "    let e = _optik_handles[slot];",
        Counter::HandleReads,
        "1u",
    ),
    ("            e = stack[sp];", Counter::StackPops, "1u"),
    ("            var n: _OptikNode4;", Counter::Nodes, "1u"),
    (
        "        (*stack)[*sp] = vec2<u32>(r, bitcast<u32>(key));",
        Counter::StackPushes,
        "1u",
    ),
    (
        "                stack[sp] = vec2<u32>((2u << 30u) | ((count - 2u) << 27u) | (slot + 1u), e.y);",
        Counter::StackPushes,
        "1u",
    ),
    // An instance entered: its two markers, then its structure's root entry when the first
    // marker has built its level.
    (
        "            stack[sp] = vec2<u32>(3u << 30u, 0xFF800000u);",
        Counter::StackPushes,
        "2u",
    ),
    (
        "                stack[sp] = vec2<u32>(0u, bitcast<u32>(_optik_ray.tmin));",
        Counter::StackPushes,
        "1u",
    ),
    (
        "            _optik_path[lvl] = rec;",
        Counter::Instances,
        "1u",
    ),
    ("        let slot = first + i;", Counter::Primitives, "1u"),
];

/// The traversal text with the counting statements of [`HOOKS`] inserted.
pub(crate) fn instrument(traversal: &str) -> String {
    let mut out = String::with_capacity(traversal.len() + 1024);
    for line in traversal.split_inclusive('\n') {
        let bare = line.trim_end_matches('\n');
        for (anchor, counter, amount) in HOOKS {
            if bare == *anchor {
                let indent = &bare[..bare.len() - bare.trim_start().len()];
                out.push_str(&format!(
                    "{indent}_optik_count[{}] += {amount};\n",
                    *counter as u32
                ));
            }
        }
        out.push_str(line);
    }
    out
}

/// The counter binding and private totals (after the scene chunks' bindings).
pub(crate) fn declare(c: &KernelConfig<'_>, out: &mut String) {
    if !c.counters {
        return;
    }
    out.push_str(&format!(
        "// Traffic counters (instrumented benchmark kernel only).\n@group(1) @binding({}) var<storage, read_write> _optik_counters: array<atomic<u32>, {}>;\nvar<private> _optik_count: array<u32, {COUNTERS}>;\n\n",
        binding(c.sizes.chunks),
        2 * COUNTERS
    ));
}

/// The binding of the counter buffer for a kernel of `chunks` scene chunks.
pub(crate) fn binding(chunks: u32) -> u32 {
    3 + chunks
}

/// The end of the entry point: adds this invocation's totals to the 64-bit counters.
pub(crate) fn flush(c: &KernelConfig<'_>, out: &mut String) {
    if !c.counters {
        return;
    }
    out.push_str(&format!(
        r#"    for (var k = 0u; k < {COUNTERS}u; k = k + 1u) {{
        let v = _optik_count[k];
        if v != 0u {{
            let old = atomicAdd(&_optik_counters[2u * k], v);
            if old > 0xFFFFFFFFu - v {{
                atomicAdd(&_optik_counters[2u * k + 1u], 1u);
            }}
        }}
    }}
"#
    ));
}

/// Totals read back from the counter buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TrafficCounts {
    /// Traversals started.
    pub traces: u64,
    /// 16-byte scene arena reads (all kinds of records).
    pub arena_fetches: u64,
    /// BVH4 nodes tested.
    pub nodes: u64,
    /// Primitives tested.
    pub primitives: u64,
    /// Instance records read whole (mask passed, child alive).
    pub instances: u64,
    /// Handle-table entries read.
    pub handle_reads: u64,
    /// Stack pushes.
    pub stack_pushes: u64,
    /// Stack pops.
    pub stack_pops: u64,
}

impl TrafficCounts {
    /// Decodes the counter buffer's words.
    pub(crate) fn from_words(words: &[u32]) -> TrafficCounts {
        let at = |c: Counter| {
            let k = 2 * c as usize;
            match (words.get(k), words.get(k + 1)) {
                (Some(&lo), Some(&hi)) => (hi as u64) << 32 | lo as u64,
                _ => 0,
            }
        };
        TrafficCounts {
            traces: at(Counter::Traces),
            arena_fetches: at(Counter::ArenaFetches),
            nodes: at(Counter::Nodes),
            primitives: at(Counter::Primitives),
            instances: at(Counter::Instances),
            handle_reads: at(Counter::HandleReads),
            stack_pushes: at(Counter::StackPushes),
            stack_pops: at(Counter::StackPops),
        }
    }

    /// Bytes read from device memory: every arena fetch (16 bytes: nodes, primitive and
    /// instance records, headers) and every handle-table entry (16 bytes).
    pub fn memory_bytes(&self) -> u64 {
        16 * (self.arena_fetches + self.handle_reads)
    }

    /// Bytes of traversal stack traffic (8 bytes a push or pop; the stack is per-invocation
    /// memory, which the driver keeps in registers or spills to local memory).
    pub fn stack_bytes(&self) -> u64 {
        8 * (self.stack_pushes + self.stack_pops)
    }

    /// Bytes of BVH4 nodes (128 each).
    pub fn node_bytes(&self) -> u64 {
        128 * self.nodes
    }

    /// Bytes of the instance records entered (80 each: the world-to-object rows, the
    /// id/offset/mask/flags word and the child link; the object-to-world rows are read only
    /// when a program asks for a hit's object space).
    pub fn instance_bytes(&self) -> u64 {
        80 * self.instances
    }

    /// Arena bytes that are neither nodes nor entered instance records: primitive records,
    /// structure headers, transforms and the first words of masked-out instances.
    pub fn other_arena_bytes(&self) -> u64 {
        (16 * self.arena_fetches).saturating_sub(self.node_bytes() + self.instance_bytes())
    }
}
