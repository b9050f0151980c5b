//! Launches: every launch index of a launch on the device's rayon threads, each run by an
//! [`Invocation`] (the device API, `device_api`) from its ray generation program.

use crate::accel::SceneTable;
use crate::device_api::Invocation;
use crate::pipeline::TraceFn;
use crate::program::abi::Bindings;
use crate::sbt::ResolvedSbt;
use crate::traversal::TraceConfig;
use optik_api::{FeatureSet, PipelineLinkOptions};
use std::sync::atomic::AtomicU32;

/// Launch indices one rayon task runs: enough to make scheduling cheap per ray, few enough
/// to balance rays of very different cost over the threads.
const INDICES_PER_TASK: usize = 64;

/// What every invocation of a launch shares.
pub(crate) struct LaunchShared<'l> {
    pub sbt: ResolvedSbt<'l>,
    pub scene: &'l SceneTable,
    pub bindings: &'l Bindings<'l>,
    pub size: [u32; 3],
    pub config: TraceConfig,
    pub features: FeatureSet,
    pub link: PipelineLinkOptions,
    pub trace: TraceFn,
    /// Non-zero once the launch must stop (`optik_api::LaunchWatch::flag`): checked before
    /// each launch index and, by compiled programs, at every loop back-edge.
    pub stop: &'l AtomicU32,
}

/// Runs every launch index on `pool`. Invocations share nothing mutable but the user's
/// buffers, so results do not depend on the thread count.
pub(crate) fn run(shared: &LaunchShared<'_>, pool: &rayon::ThreadPool) {
    use rayon::prelude::*;
    let [w, h, d] = shared.size;
    // The device limits launches to 2^32 invocations, which fit `usize` on 64-bit hosts.
    let count = (w as u64 * h as u64 * d as u64).min(usize::MAX as u64) as usize;
    let Some(raygen) = shared.sbt.raygen.programs.main else {
        return;
    };
    let (w, h) = (w as u64, h as u64);
    pool.install(|| {
        (0..count.div_ceil(INDICES_PER_TASK))
            .into_par_iter()
            .for_each(|task| {
                let first = task * INDICES_PER_TASK;
                // Divisions once per task; the index then steps along x (three 64-bit
                // divisions per invocation cost more than the rest of a missed ray's launch
                // bookkeeping).
                let f = first as u64;
                let index = [(f % w) as u32, ((f / w) % h) as u32, (f / (w * h)) as u32];
                let indices = (first + INDICES_PER_TASK).min(count) - first;
                Invocation::new(shared).run_raygens(raygen, index, indices, [w as u32, h as u32]);
            })
    });
}

/// The launch index after `index` in x-major order over a launch `w` wide and `h` high.
#[inline]
pub(crate) fn next_index([x, y, z]: [u32; 3], w: u32, h: u32) -> [u32; 3] {
    if x + 1 < w {
        [x + 1, y, z]
    } else if y + 1 < h {
        [0, y + 1, z]
    } else {
        [0, 0, z + 1]
    }
}

#[cfg(test)]
mod tests {
    use super::next_index;

    #[test]
    fn stepping_the_launch_index_matches_dividing_the_linear_one() {
        for (w, h, d) in [
            (1u64, 1u64, 3u64),
            (5, 3, 2),
            (1, 7, 2),
            (4096, 2, 1),
            (3, 1, 4),
        ] {
            let mut index = [0u32; 3];
            for i in 0..w * h * d {
                let want = [(i % w) as u32, ((i / w) % h) as u32, (i / (w * h)) as u32];
                assert_eq!(index, want, "{w}x{h}x{d} at {i}");
                index = next_index(index, w as u32, h as u32);
            }
        }
    }
}
