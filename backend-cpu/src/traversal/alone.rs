//! The walk alone: rays traced one by one straight into the traversal, without a launch, for
//! tools that time the traversal apart from the launch around it (`bench-cpu`'s walk-alone
//! table, docs/cpu-backend.md §8).
//!
//! Compiled here, in the backend, so that its walk is the launch's own: a generic walk
//! instantiated in another crate could not inline this crate's non-generic helpers and would
//! run other machine code (the bunny's incoherent rays 3.9 % slower, measured when a first
//! version lived in `optik-benches`).

use super::{
    Candidate, CustomPrimitive, Handler, Path, Spec, Specialised, TraceConfig, TraceRay,
    blocks_root, trace_blocks,
};
use crate::accel::SceneTable;
use optik_api::semantics::opacity::CandidateFate;
use optik_api::{PrimitiveTypeFlags, RayFlags, TraversableHandle};

/// The switches of a pipeline without motion, instancing or any-hit programs at the default
/// accuracy (watertight triangles, conservative boxes): `optik::raycast`'s.
type Closest = Specialised<false, false, false, true, true>;

/// What such a pipeline traces: triangles, nothing else looked up or reported.
const TRIANGLES: TraceConfig = TraceConfig {
    primitive_types: PrimitiveTypeFlags::TRIANGLE,
    intersection: false,
    micromaps: false,
    debug_exceptions: false,
    max_graph_depth: 2,
};

/// The nearest triangle hit of each of `rays` from `root` (a geometry structure of static
/// triangles in `scene`), traced one by one on this thread as a pipeline without motion,
/// instancing or any-hit programs traces them at the default accuracy, with the ray flag
/// `DISABLE_ANYHIT`: written to `hits` (ray `i`'s to `hits[i]`, for as many rays as both
/// hold), the hit's primitive index and distance, `None` for a miss. The caller keeps the
/// output, as a launch writes into a buffer made before it: a timed pass allocates nothing.
/// Each ray is `[origin x, y, z, tmin, direction x, y, z, tmax]` and must be valid (finite,
/// `0 <= tmin <= tmax`: the validity check belongs to the launch). Returns false, writing
/// nothing, when `root` is not such a structure.
pub fn nearest_triangle_hits(
    scene: &SceneTable,
    root: TraversableHandle,
    rays: &[[f32; 8]],
    hits: &mut [Option<(u32, f32)>],
) -> bool {
    let Some(g) = blocks_root::<Closest>(scene, root, &TRIANGLES) else {
        return false;
    };
    for (r, hit) in rays.iter().zip(hits) {
        let ray = TraceRay {
            origin: [r[0], r[1], r[2]],
            direction: [r[4], r[5], r[6]],
            tmin: r[3],
            tmax: r[7],
            time: 0.0,
            mask: 0xFF,
            flags: RayFlags::DISABLE_ANYHIT,
        };
        let mut nearest = Nearest {
            tmax: ray.tmax,
            hit: None,
        };
        trace_blocks::<Closest, _>(scene, g, &ray, &TRIANGLES, &mut nearest);
        *hit = nearest.hit;
    }
    true
}

/// The nearest candidate so far: every candidate the walk reports lies before the interval's
/// end and is committed, as a pipeline without any-hit programs commits it.
struct Nearest {
    tmax: f32,
    /// Primitive index and distance.
    hit: Option<(u32, f32)>,
}

impl Handler for Nearest {
    #[inline(always)]
    fn t_max(&self) -> f32 {
        self.tmax
    }

    #[inline(always)]
    fn done(&self) -> bool {
        false
    }

    #[inline(always)]
    fn candidate<S: Spec>(&mut self, c: &Candidate<'_>, _: &Path, _: CandidateFate) {
        self.tmax = c.t;
        self.hit = Some((c.info.primitive_index, c.t));
    }

    fn custom<S: Spec>(&mut self, _: &CustomPrimitive<'_>, _: &Path, _: CandidateFate) {
        // A root of triangle blocks holds no custom primitive.
    }

    fn traversal_exception(&mut self, _: i32) {
        // Reported only under debug exceptions, which `TRIANGLES` leaves off.
    }
}
