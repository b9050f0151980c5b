//! The fate of the candidates a trace finds (DESIGN.md §4): the hit group record a candidate
//! selects, its any-hit program (accept, ignore, terminate), a custom primitive's intersection
//! program, and the commit of the closest hit so far.

use super::{AnyHitOutcome, HitState, IntersectionContext, Invocation, View};
use crate::pipeline::Callable;
use crate::sbt::Record;
use crate::traversal::{Candidate, CustomPrimitive, Handler, Path, Spec};
use optik_api::semantics::exception as code;
use optik_api::semantics::opacity::CandidateFate;
use optik_api::semantics::sbt_index;
use optik_api::{ExceptionFlags, ProgramKind, RayFlags};

impl<'l> Invocation<'l> {
    /// The hit group record of a candidate. An index past the records selects a record
    /// without programs (the hit counts, nothing runs; custom primitives, which need an
    /// intersection program, cannot be hit), or raises `INVALID_HIT_SBT` under debug
    /// exceptions (`None`).
    #[inline]
    fn hit_record(&mut self, path: &Path, sbt_gas_index: u32) -> Option<&'l Record<'l>> {
        let shared = self.shared;
        let tr = self.tr();
        let i = sbt_index::hit_record_index(
            path.sbt_offset,
            sbt_gas_index,
            tr.sbt_offset,
            tr.sbt_stride,
        );
        match shared.sbt.hitgroup.get(i as usize) {
            Some(rec) => Some(rec),
            None if self.exceptions().contains(ExceptionFlags::DEBUG) => {
                self.raise(code::INVALID_HIT_SBT);
                None
            }
            None => Some(&shared.sbt.null_hit),
        }
    }

    /// Runs the any-hit program on a candidate below `path` (null: no instances); `None`
    /// when the invocation ended.
    pub(super) fn any_hit(
        &mut self,
        program: Callable<'l>,
        record: &'l Record<'l>,
        hit: &HitState,
        path: *const Path,
    ) -> Option<AnyHitOutcome> {
        let saved = std::mem::replace(&mut self.tr_mut().any_hit, AnyHitOutcome::Accept);
        let ray = self.tr().ray;
        self.run(
            program,
            View {
                kind: ProgramKind::AnyHit,
                record: Some(record),
                ray,
                tmax: hit.t,
                hit,
                path,
                exception_code: 0,
            },
        );
        let outcome = std::mem::replace(&mut self.tr_mut().any_hit, saved);
        (!self.ending).then_some(outcome)
    }

    /// Commits a hit below `path` (null: no instances); `terminate` ends the traversal.
    #[inline(always)]
    pub(super) fn commit(
        &mut self,
        hit: HitState,
        path: *const Path,
        record: &'l Record<'l>,
        terminate: bool,
    ) {
        let tr = self.tr_mut();
        tr.tmax = hit.t;
        tr.committed_hit.write(hit);
        tr.committed_record = Some(record);
        tr.committed_has_path = !path.is_null();
        if !path.is_null() {
            // SAFETY: a non-null path points to the traversal's live path for this call.
            tr.committed_path.write(unsafe { *path });
        }
        // SAFETY: the trace in progress keeps its ray (`TraceState::ray`).
        let flags = unsafe { (*tr.ray).flags };
        if terminate || flags.contains(RayFlags::TERMINATE_ON_FIRST_HIT) {
            tr.terminated = true;
        }
    }
}

impl Handler for Invocation<'_> {
    #[inline]
    fn t_max(&self) -> f32 {
        self.tr().tmax
    }

    #[inline]
    fn done(&self) -> bool {
        self.tr().terminated || self.ending
    }

    #[inline]
    fn candidate<S: Spec>(&mut self, c: &Candidate<'_>, path: &Path, fate: CandidateFate) {
        let Some(record) = self.hit_record(path, c.info.sbt_gas_index) else {
            return;
        };
        // Without instancing the path is the ray's own: programs need not see it.
        let path: *const Path = if S::INSTANCING {
            path
        } else {
            std::ptr::null()
        };
        let any_hit = match record.programs.any_hit {
            Some(ah) if S::ANY_HIT && fate == CandidateFate::NonOpaque => ah,
            _ => return self.commit(HitState::of(c), path, record, false),
        };
        let hit = HitState::of(c);
        let terminate = match self.any_hit(any_hit, record, &hit, path) {
            None | Some(AnyHitOutcome::Ignore) => return,
            Some(AnyHitOutcome::Terminate) => true,
            Some(AnyHitOutcome::Accept) => false,
        };
        self.commit(hit, path, record, terminate);
    }

    fn custom<S: Spec>(&mut self, p: &CustomPrimitive<'_>, path: &Path, fate: CandidateFate) {
        let Some(record) = self.hit_record(path, p.info.sbt_gas_index) else {
            return;
        };
        let Some(is) = record.programs.intersection else {
            return;
        };
        let path: *const Path = if S::INSTANCING {
            path
        } else {
            std::ptr::null()
        };
        let base = HitState::at(p.info);
        let context = IntersectionContext {
            base,
            path,
            record,
            fate,
        };
        let tr = self.tr_mut();
        let saved = std::mem::replace(&mut tr.intersection, &context);
        tr.intersection_exit = false;
        let view = View {
            kind: ProgramKind::Intersection,
            record: Some(record),
            ray: tr.ray,
            tmax: tr.tmax,
            hit: &base,
            path,
            exception_code: 0,
        };
        self.run(is, view);
        let tr = self.tr_mut();
        tr.intersection = saved;
        tr.intersection_exit = false;
    }

    fn traversal_exception(&mut self, exception_code: i32) {
        self.raise(exception_code);
    }
}
