//! Exceptions end the launch index (OptiX runs the exception program, then the thread ends).
//! Vulkan cannot end an invocation from inside a function, so the lowering unwinds: after
//! every call that may raise an exception, user functions check the prelude's private flag
//! `_optik_unwound` and return at once. A naga IR pass, so that naga writes the structured
//! control flow. (A flag, not a call: naga needs callees before callers in its function
//! arena, and the prelude's functions come after the user's.)

use naga::{Block, Expression, Function, Handle, Module, Span, Statement};
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
            .filter(|(h, f)| !may_raise.contains(h) && calls_any(&f.body, &may_raise))
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
    for h in user {
        let f = module.functions.get_mut(h);
        let body = std::mem::take(&mut f.body);
        let result_ty = f.result.as_ref().map(|r| r.ty);
        f.body = unwind_block(body, f, result_ty, unwinding, &may_raise, false);
    }
    Ok(())
}

fn calls_any(block: &Block, targets: &HashSet<Handle<Function>>) -> bool {
    block.iter().any(|s| match s {
        Statement::Call { function, .. } => targets.contains(function),
        Statement::Block(b) => calls_any(b, targets),
        Statement::If { accept, reject, .. } => {
            calls_any(accept, targets) || calls_any(reject, targets)
        }
        Statement::Switch { cases, .. } => cases.iter().any(|c| calls_any(&c.body, targets)),
        Statement::Loop {
            body, continuing, ..
        } => calls_any(body, targets) || calls_any(continuing, targets),
        _ => false,
    })
}

/// `block` with a check after every raising call. Inside a loop's `continuing` block WGSL
/// allows no `return`; calls there are left unchecked and caught by the next check outside.
fn unwind_block(
    block: Block,
    f: &mut Function,
    result_ty: Option<Handle<naga::Type>>,
    unwinding: Handle<naga::GlobalVariable>,
    may_raise: &HashSet<Handle<Function>>,
    in_continuing: bool,
) -> Block {
    let mut out = Block::new();
    for (stmt, span) in block.span_into_iter() {
        let recurse = |b: Block, cont: bool, f: &mut Function| {
            unwind_block(b, f, result_ty, unwinding, may_raise, cont)
        };
        let stmt = match stmt {
            Statement::Block(b) => Statement::Block(recurse(b, in_continuing, f)),
            Statement::If {
                condition,
                accept,
                reject,
            } => Statement::If {
                condition,
                accept: recurse(accept, in_continuing, f),
                reject: recurse(reject, in_continuing, f),
            },
            Statement::Switch { selector, cases } => Statement::Switch {
                selector,
                cases: cases
                    .into_iter()
                    .map(|mut c| {
                        c.body = recurse(std::mem::take(&mut c.body), in_continuing, f);
                        c
                    })
                    .collect(),
            },
            Statement::Loop {
                body,
                continuing,
                break_if,
            } => Statement::Loop {
                body: recurse(body, in_continuing, f),
                continuing: recurse(continuing, true, f),
                break_if,
            },
            other => other,
        };
        let raises =
            matches!(&stmt, Statement::Call { function, .. } if may_raise.contains(function));
        out.push(stmt, span);
        if raises && !in_continuing {
            push_check(&mut out, f, result_ty, unwinding, span);
        }
    }
    out
}

/// `if _optik_unwound { return <zero>; }`.
fn push_check(
    out: &mut Block,
    f: &mut Function,
    result_ty: Option<Handle<naga::Type>>,
    unwinding: Handle<naga::GlobalVariable>,
    span: Span,
) {
    let pointer = f
        .expressions
        .append(Expression::GlobalVariable(unwinding), span);
    let flag = f.expressions.append(Expression::Load { pointer }, span);
    out.push(
        Statement::Emit(naga::Range::new_from_bounds(flag, flag)),
        span,
    );
    let value = result_ty.map(|ty| f.expressions.append(Expression::ZeroValue(ty), span));
    let mut accept = Block::new();
    accept.push(Statement::Return { value }, span);
    out.push(
        Statement::If {
            condition: flag,
            accept,
            reject: Block::new(),
        },
        span,
    );
}
