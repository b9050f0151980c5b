//! The lean trace (issue 14 item 1, docs/cpu-backend.md §5): `rt_trace` of compiled programs
//! for pipelines without any-hit programs, instancing or debug exceptions, from a root of
//! static triangle blocks (`traversal::blocks_root`), which holds no custom primitive and no
//! instance.
//!
//! Under those conditions a candidate's fate is fixed: it is committed when it is nearer
//! (`Invocation::candidate` with `S::ANY_HIT` false, its record looked up only to be kept), so
//! the walk reports to a [`Closest`] on the stack instead of the invocation: no trace state,
//! no record per candidate, no payload or depth saved around the walk. The record is looked
//! up once, for the hit that stays; the invocation's frame (trace state, payload registers,
//! depth) is set up only when a program runs inside the trace. What programs see and the
//! results are those of `Invocation::trace_ray`, bit for bit.

use super::{HitState, Inlined, Invocation, MAX_PAYLOAD, TraceState, View};
use crate::accel::Gas;
use crate::sbt::Record;
use crate::traversal::{self, Candidate, CustomPrimitive, Handler, Path, Spec, TraceRay};
use optik_api::semantics::opacity::CandidateFate;
use optik_api::semantics::sbt_index;
use optik_api::{ExceptionFlags, RayFlags};

/// The nearest candidate of a lean trace so far.
struct Closest {
    /// The end of the interval: the ray's `tmax`, then the nearest candidate's distance.
    tmax: f32,
    /// The ray ends at its first hit (`RayFlags::TERMINATE_ON_FIRST_HIT`).
    terminate_on_first: bool,
    terminated: bool,
    /// Whether `hit` holds a candidate.
    found: bool,
    /// The nearest candidate as programs see it (`HitState::of`), but for its attributes:
    /// made once from its data, for the hit that stays (`Closest::hit_state`), and only
    /// for a program that may read them.
    hit: std::mem::MaybeUninit<HitState>,
}

impl Closest {
    /// The hit that stays, as programs see it; with `attributes` false, its attribute
    /// registers zero instead of made from its data: for an inlined closest hit, which
    /// cannot read them (`lower::inlinable_closest_hit`: no `rt_get_attribute`) and whose
    /// state holds everything it reads but them.
    #[inline(always)]
    fn hit_state(&mut self, attributes: bool) -> &HitState {
        debug_assert!(self.found);
        let hit = self.hit.as_mut_ptr();
        // SAFETY: every field but the attributes was written with `found` (`candidate`),
        // and the attributes are written here.
        unsafe {
            (*hit).attributes = if attributes {
                HitState::attributes_of((*hit).data)
            } else {
                [0; 8]
            };
            &*hit
        }
    }

    /// The SBT geometry index of the nearest candidate (there is one).
    #[inline(always)]
    fn sbt_gas_index(&self) -> u32 {
        debug_assert!(self.found);
        // SAFETY: written with `found` (`candidate`); read through the pointer, as the hit's
        // attributes may not be written yet.
        unsafe { (*self.hit.as_ptr()).sbt_gas_index }
    }
}

impl Handler for Closest {
    #[inline(always)]
    fn t_max(&self) -> f32 {
        self.tmax
    }

    #[inline(always)]
    fn done(&self) -> bool {
        self.terminated
    }

    #[inline(always)]
    fn candidate<S: Spec>(&mut self, c: &Candidate<'_>, _path: &Path, _fate: CandidateFate) {
        // Without any-hit programs every candidate the walk reports (nearer than `tmax`,
        // culled already) is committed, whatever its fate (`Invocation::candidate`).
        self.tmax = c.t;
        let hit = self.hit.as_mut_ptr();
        // SAFETY: plain fields of the handler's own slot, written through its pointer.
        unsafe {
            (*hit).t = c.t;
            (*hit).primitive_index = c.info.primitive_index;
            (*hit).sbt_gas_index = c.info.sbt_gas_index;
            (*hit).hit_kind = c.hit_kind;
            (*hit).data = Some(c.data);
        }
        self.found = true;
        self.terminated = self.terminate_on_first;
    }

    fn custom<S: Spec>(&mut self, _: &CustomPrimitive<'_>, _: &Path, _: CandidateFate) {
        // A root of triangle blocks holds triangles only: the walk never reports custom
        // primitives to this handler.
        debug_assert!(false, "a lean trace met a custom primitive");
    }

    fn traversal_exception(&mut self, _code: i32) {
        // The walk reports these only under debug exceptions, which keep a pipeline off the
        // lean trace (`pipeline::trace_fn`): a candidate's record is then checked per
        // candidate, as `Invocation::candidate` does.
        debug_assert!(false, "a lean trace was asked to raise an exception");
    }
}

impl<'l> Invocation<'l> {
    /// `Invocation::trace_ray` of a compiled program's `rt_trace` (payload used in place)
    /// from the root `g` that `Invocation::blocks_root` gave, in a pipeline compiled as `S`
    /// that may trace lean (`pipeline::trace_fn`: without any-hit programs, instancing or
    /// debug exceptions): the same checks, the same walk, the same programs with the same
    /// views and state. Returns whether the caller runs its inlined closest hit.
    ///
    /// # Safety
    /// As `trace_ray`: `payload` holds `payload_len` registers of the caller.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) unsafe fn trace_lean<S: Spec>(
        &mut self,
        g: &'l Gas,
        handle: [u32; 2],
        origin: [f32; 3],
        direction: [f32; 3],
        [tmin, tmax, time]: [f32; 3],
        [mask, flags, sbt_offset, sbt_stride, miss_index]: [u32; 5],
        payload: *mut u32,
        payload_len: usize,
        inlined: Inlined,
    ) -> bool {
        debug_assert!(
            !S::ANY_HIT
                && !S::INSTANCING
                && !self
                    .shared
                    .features
                    .exceptions
                    .contains(ExceptionFlags::DEBUG)
        );
        // `trace_ray`'s start, step for step.
        if self.trace_refused(origin, direction, tmin, tmax) {
            return false;
        }
        let world = self.world_ray(origin, direction, [tmin, tmax, time], mask, flags);
        if self.root_check_ends(handle, &world, miss_index, super::misses_root_with::<S>) {
            return false;
        }
        let mut closest = Closest {
            tmax,
            terminate_on_first: world.flags.contains(RayFlags::TERMINATE_ON_FIRST_HIT),
            terminated: false,
            found: false,
            hit: std::mem::MaybeUninit::uninit(),
        };
        let shared = self.shared;
        traversal::trace_blocks::<S, _>(shared.scene, g, &world, &shared.config, &mut closest);
        let registers = (payload, payload_len.min(MAX_PAYLOAD));
        if closest.found {
            self.root_check_armed = false;
            let record = self.lean_hit_record(sbt_offset, sbt_stride, closest.sbt_gas_index());
            self.lean_closest_hit(
                &world,
                [sbt_offset, sbt_stride],
                record,
                &mut closest,
                registers,
                inlined,
            )
        } else {
            self.found_nothing();
            // A miss index past the records runs nothing (no debug exceptions here).
            if let Some(record) = self.miss_record(miss_index)
                && record.main_runs
            {
                self.in_trace_frame(&world, [sbt_offset, sbt_stride], registers, |inv| {
                    inv.miss(record, &world)
                });
            }
            false
        }
    }

    /// The hit group record of a lean trace's hit (`Invocation::hit_record` at the root,
    /// whose path adds no SBT offset): past the records, the record without programs.
    #[inline(always)]
    fn lean_hit_record(
        &self,
        sbt_offset: u32,
        sbt_stride: u32,
        sbt_gas_index: u32,
    ) -> &'l Record<'l> {
        let shared = self.shared;
        let i = sbt_index::hit_record_index(0, sbt_gas_index, sbt_offset, sbt_stride);
        shared
            .sbt
            .hitgroup
            .get(i as usize)
            .unwrap_or(&shared.sbt.null_hit)
    }

    /// The closest hit of a lean trace (`Invocation::closest_hit_of` inside the trace's
    /// frame). An inlined closest hit only needs its state written, which reads the depth
    /// (its payload is the caller's, addressed in place by its code): that alone is set
    /// for it.
    #[inline(always)]
    fn lean_closest_hit(
        &mut self,
        world: &TraceRay,
        sbt: [u32; 2],
        record: &'l Record<'l>,
        closest: &mut Closest,
        registers: (*mut u32, usize),
        inlined: Inlined,
    ) -> bool {
        let Some(ch) = super::closest_hit_program(world, record) else {
            return false;
        };
        let inlined_here = inlined.is(ch);
        let hit = closest.hit_state(!inlined_here);
        let path = std::ptr::null();
        if inlined_here {
            // What `run_program` would write for the program, in the caller's memory, one
            // level deeper (the depth the program reads).
            self.depth += 1;
            let view = View::closest_hit(world, record, hit, path);
            self.fill_inlined_state(inlined.state, ch.state_bits(), &view);
            self.depth -= 1;
            true
        } else {
            self.in_trace_frame(world, sbt, registers, |inv| {
                inv.run_closest_hit(world, record, ch, hit, path, inlined)
            })
        }
    }

    /// Runs `f` (a program of the trace of `world`) in the frame `trace_ray` keeps while its
    /// programs run: the innermost trace's state, its payload registers, one level deeper.
    #[inline(never)]
    fn in_trace_frame<R>(
        &mut self,
        world: &TraceRay,
        [sbt_offset, sbt_stride]: [u32; 2],
        registers: (*mut u32, usize),
        f: impl FnOnce(&mut Self) -> R,
    ) -> R {
        let mut state = TraceState {
            ray: world,
            tmax: world.tmax,
            sbt_offset,
            sbt_stride,
            committed_record: None,
            committed_hit: std::mem::MaybeUninit::uninit(),
            committed_path: std::mem::MaybeUninit::uninit(),
            committed_has_path: false,
            terminated: false,
            any_hit: super::AnyHitOutcome::Accept,
            intersection: std::ptr::null(),
            intersection_exit: false,
        };
        let saved_trace = std::mem::replace(&mut self.trace, &mut state);
        let saved_payload = (self.payload, self.payload_len);
        (self.payload, self.payload_len) = registers;
        self.depth += 1;
        let r = f(self);
        self.depth -= 1;
        self.trace = saved_trace;
        (self.payload, self.payload_len) = saved_payload;
        r
    }
}
