//! Exceptions end the launch index (OptiX runs the exception program, then the thread ends).
//! Vulkan cannot end an invocation from inside a function, so the lowering unwinds: after
//! every call that may raise an exception, user functions check the prelude's private flag
//! `_optik_unwound` and return at once, by the pass every GPU backend shares
//! (`optik_core::unwind`). (A flag, not a call: naga needs callees before callers in its
//! function arena, and the prelude's functions come after the user's.)

use naga::{Function, Handle, Module};
use optik_core::unwind::{self, Unwinding, UnwoundFlag};
use std::collections::{HashMap, HashSet};

/// The device functions that may raise: the traces and calls (whose callees may raise, and
/// which check their arguments) and the throw.
pub const RAISING: &[&str] = &[
    "rt_trace",
    "rt_direct_call",
    "rt_continuation_call",
    "rt_throw_exception",
];

/// The device functions that may end the calling intersection program: a report accepted
/// under TERMINATE_ON_FIRST_HIT ends the ray, and the CPU backend unwinds the program there,
/// while Vulkan's OpReportIntersectionKHR returns to it (the prelude sets `_optik_unwound`).
pub const ENDING_REPORTS: &[&str] = &["rt_report_intersection"];

/// Inserts the unwinding checks after every call to one of `raising` (or to a function
/// that reaches one) into the user's functions of `module`, which holds the Vulkan prelude
/// (and so `_optik_unwound`).
pub fn insert_unwinding(module: &mut Module, raising: &[&str]) -> Result<(), String> {
    let by_name: HashMap<&str, Handle<Function>> = module
        .functions
        .iter()
        .filter_map(|(h, f)| Some((f.name.as_deref()?, h)))
        .collect();
    let unwinding = module
        .global_variables
        .iter()
        .find(|(_, g)| g.name.as_deref() == Some("_optik_unwound"))
        .map(|(h, _)| h)
        .ok_or("the prelude lacks _optik_unwound")?;
    let mut may_raise: HashSet<Handle<Function>> = raising
        .iter()
        .filter_map(|n| by_name.get(n).copied())
        .collect();
    loop {
        let more: Vec<Handle<Function>> = module
            .functions
            .iter()
            .filter(|(h, f)| {
                !may_raise.contains(h) && unwind::calls_any(&f.body, &|c| may_raise.contains(&c))
            })
            .map(|(h, _)| h)
            .collect();
        if more.is_empty() {
            break;
        }
        may_raise.extend(more);
    }
    let user: Vec<Handle<Function>> = module
        .functions
        .iter()
        .filter(|(_, f)| {
            f.name
                .as_deref()
                .is_some_and(|n| !n.starts_with("rt_") && !n.starts_with("_optik_"))
        })
        .map(|(h, _)| h)
        .collect();
    let may_unwind = |c: Handle<Function>| may_raise.contains(&c);
    let how = Unwinding {
        flag: Some(UnwoundFlag::Global(unwinding)),
        may_unwind: &may_unwind,
        redirect: &|c| c,
    };
    for h in user {
        let f = module.functions.get_mut(h);
        let body = std::mem::take(&mut f.body);
        let result_ty = f.result.as_ref().map(|r| r.ty);
        f.body = unwind::insert_checks(body, &mut f.expressions, result_ty, &how);
    }
    Ok(())
}
