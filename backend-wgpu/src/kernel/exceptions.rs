//! Exceptions in the megakernel (DESIGN.md §4): `_optik_raise` runs the exception program,
//! when the SBT has its record, and then makes every program on the way back return at once:
//! it sets `_optik_unwind`, which the checks inserted by the unwinding pass every GPU backend
//! shares (`optik_core::unwind`) read after each call that may raise.

use super::KernelConfig;
use super::dispatch::switch;
use crate::program::instance::Site;

/// Writes `_optik_raise`.
pub(super) fn write(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        r#"
// Raises an exception: runs the exception program (if the SBT has its record), then makes
// every program on the way back return at once.
fn _optik_raise(code: i32) {
    if _optik_unwind == 3u {
        return;
    }
    _optik_exception = code;
    let record = _optik_launch.sbt0.y;
    if record != _OPTIK_NONE {
        let saved = _optik_record;
        _optik_record = record;
"#,
    );
    out.push_str(&switch(c, Site::Exception, "        "));
    out.push_str(
        "        _optik_record = saved;\n    }\n    _optik_unwind = 3u;\n    _optik_done = true;\n}\n\n",
    );
}
