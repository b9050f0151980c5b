//! Exceptions (DESIGN.md §4): an exception runs the pipeline's exception program, when the
//! SBT has one, and ends the launch index: every program on the stack returns (see
//! `DeviceCalls::unwinding`) and later device calls do nothing.

use super::{Invocation, View};
use optik_api::ProgramKind;

impl Invocation<'_> {
    /// Raises an exception: runs the exception program, then ends the launch index.
    pub(super) fn raise(&mut self, exception_code: i32) {
        if self.ending {
            return;
        }
        if let Some(rec) = &self.shared.sbt.exception
            && let Some(p) = rec.programs.main
        {
            let view = View {
                kind: ProgramKind::Exception,
                record: Some(rec),
                exception_code,
                ..*self.view()
            };
            self.run(p, view);
        }
        self.ending = true;
        if !self.index_ended.is_null() {
            // SAFETY: set while a compiled launch loop runs this index (`run_rows`), whose
            // word it is; the loop reads it only after the index returns.
            unsafe { self.index_ended.write(1) };
        }
    }
}
