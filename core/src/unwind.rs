//! The exception-unwinding pass on naga IR, shared by the backends that lower WGSL for a GPU.
//!
//! An exception (and, on wgpu, ignore and terminate) ends the program that raised it and
//! every caller up to the program's entry, but WGSL has no way to leave several functions at
//! once. So after every call that may unwind, a caller checks an "unwinding" flag and
//! returns at once (a zero value for functions with a result). Inside a loop's `continuing`
//! block WGSL forbids `return`, so calls there are not checked in place: the check moves to
//! the start of the loop body, which runs next (DESIGN.md §3, "Lowering per backend").
//!
//! Backends differ only in where the flag lives ([`UnwoundFlag`]) and in calls they
//! redirect while rewriting (wgpu calls per-depth copies of functions).

use naga::{Arena, Block, Expression, Function, GlobalVariable, Handle, Span, Statement, Type};

/// Where a caller reads whether it must unwind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnwoundFlag {
    /// A private `bool` global variable (the Vulkan prelude's).
    Global(Handle<GlobalVariable>),
    /// A function without arguments returning `bool` (the wgpu megakernel's stub).
    Call(Handle<Function>),
}

/// How one backend unwinds.
pub struct Unwinding<'a> {
    /// The flag checked after calls that may unwind; `None`: no call unwinds, no checks.
    pub flag: Option<UnwoundFlag>,
    /// Whether a call to this function may unwind.
    pub may_unwind: &'a dyn Fn(Handle<Function>) -> bool,
    /// The function a call is rewritten to call (the same one when nothing is redirected).
    pub redirect: &'a dyn Fn(Handle<Function>) -> Handle<Function>,
}

/// `block` (a body of a function whose expressions are `exprs` and result type
/// `result_ty`) with calls redirected and an unwinding check after every call that may
/// unwind.
pub fn insert_checks(
    block: Block,
    exprs: &mut Arena<Expression>,
    result_ty: Option<Handle<Type>>,
    unwinding: &Unwinding<'_>,
) -> Block {
    rewrite(block, exprs, result_ty, unwinding, false)
}

fn rewrite(
    block: Block,
    exprs: &mut Arena<Expression>,
    result_ty: Option<Handle<Type>>,
    u: &Unwinding<'_>,
    in_continuing: bool,
) -> Block {
    let mut out = Block::with_capacity(block.len());
    for (stmt, span) in block.span_into_iter() {
        let rec = |b: Block, exprs: &mut Arena<Expression>, cont: bool| {
            rewrite(b, exprs, result_ty, u, cont)
        };
        match stmt {
            Statement::Call {
                function,
                arguments,
                result,
            } => {
                out.push(
                    Statement::Call {
                        function: (u.redirect)(function),
                        arguments,
                        result,
                    },
                    span,
                );
                if (u.may_unwind)(function) && !in_continuing {
                    push_check(&mut out, exprs, result_ty, u.flag, span);
                }
            }
            Statement::Block(b) => out.push(Statement::Block(rec(b, exprs, in_continuing)), span),
            Statement::If {
                condition,
                accept,
                reject,
            } => {
                let accept = rec(accept, exprs, in_continuing);
                let reject = rec(reject, exprs, in_continuing);
                out.push(
                    Statement::If {
                        condition,
                        accept,
                        reject,
                    },
                    span,
                );
            }
            Statement::Switch { selector, cases } => {
                let cases = cases
                    .into_iter()
                    .map(|c| naga::SwitchCase {
                        body: rec(c.body, exprs, in_continuing),
                        ..c
                    })
                    .collect();
                out.push(Statement::Switch { selector, cases }, span);
            }
            Statement::Loop {
                body,
                continuing,
                break_if,
            } => {
                let mut new_body = Block::new();
                if calls_any(&continuing, u.may_unwind) {
                    push_check(&mut new_body, exprs, result_ty, u.flag, span);
                }
                new_body.extend_block(rec(body, exprs, in_continuing));
                let continuing = rec(continuing, exprs, true);
                out.push(
                    Statement::Loop {
                        body: new_body,
                        continuing,
                        break_if,
                    },
                    span,
                );
            }
            other => out.push(other, span),
        }
    }
    out
}

/// Whether `block` calls a function for which `pred` holds.
pub fn calls_any(block: &Block, pred: &dyn Fn(Handle<Function>) -> bool) -> bool {
    block.iter().any(|s| match s {
        Statement::Call { function, .. } => pred(*function),
        Statement::Block(b) => calls_any(b, pred),
        Statement::If { accept, reject, .. } => calls_any(accept, pred) || calls_any(reject, pred),
        Statement::Switch { cases, .. } => cases.iter().any(|c| calls_any(&c.body, pred)),
        Statement::Loop {
            body, continuing, ..
        } => calls_any(body, pred) || calls_any(continuing, pred),
        _ => false,
    })
}

/// `if <flag> { return <zero>; }`.
fn push_check(
    out: &mut Block,
    exprs: &mut Arena<Expression>,
    result_ty: Option<Handle<Type>>,
    flag: Option<UnwoundFlag>,
    span: Span,
) {
    let condition = match flag {
        None => return,
        Some(UnwoundFlag::Global(g)) => {
            let pointer = exprs.append(Expression::GlobalVariable(g), span);
            let value = exprs.append(Expression::Load { pointer }, span);
            out.push(
                Statement::Emit(naga::Range::new_from_bounds(value, value)),
                span,
            );
            value
        }
        Some(UnwoundFlag::Call(stub)) => {
            let value = exprs.append(Expression::CallResult(stub), span);
            out.push(
                Statement::Call {
                    function: stub,
                    arguments: Vec::new(),
                    result: Some(value),
                },
                span,
            );
            value
        }
    };
    let value = result_ty.map(|ty| exprs.append(Expression::ZeroValue(ty), span));
    let mut accept = Block::new();
    accept.push(Statement::Return { value }, span);
    out.push(
        Statement::If {
            condition,
            accept,
            reject: Block::new(),
        },
        span,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOURCE: &str = "
var<private> unwound: bool;
fn raise() {}
fn quiet() {}
fn flag() -> bool { return unwound; }
fn f() -> f32 {
    raise();
    quiet();
    loop {
        if unwound { break; }
        continuing {
            raise();
            break if true;
        }
    }
    return 1.0;
}
";

    fn function(m: &naga::Module, name: &str) -> Handle<Function> {
        m.functions
            .iter()
            .find(|(_, f)| f.name.as_deref() == Some(name))
            .map(|(h, _)| h)
            .unwrap_or_else(|| panic!("no function {name}"))
    }

    /// Whether statement `i` of `block` is `if <flag> { return <zero>; }`.
    fn is_check(block: &Block, i: usize) -> bool {
        matches!(
            block.get(i),
            Some(Statement::If { accept, reject, .. })
                if reject.is_empty()
                    && matches!(accept.iter().next(), Some(Statement::Return { value: Some(_) }))
        )
    }

    #[test]
    fn checks_follow_unwinding_calls_and_open_loops_whose_continuing_unwinds() {
        for use_call in [false, true] {
            let mut m = naga::front::wgsl::parse_str(SOURCE).unwrap();
            let raise = function(&m, "raise");
            let flag = if use_call {
                UnwoundFlag::Call(function(&m, "flag"))
            } else {
                let g = m.global_variables.iter().next().map(|(h, _)| h).unwrap();
                UnwoundFlag::Global(g)
            };
            let f = m.functions.get_mut(function(&m, "f"));
            let body = std::mem::take(&mut f.body);
            let how = Unwinding {
                flag: Some(flag),
                may_unwind: &|c| c == raise,
                redirect: &|c| c,
            };
            let ty = f.result.as_ref().map(|r| r.ty);
            f.body = insert_checks(body, &mut f.expressions, ty, &how);
            let stmts: Vec<&Statement> = f.body.iter().collect();
            // raise(); the flag's load or call; the check; quiet(); loop ...
            assert!(is_check(&f.body, 2), "{stmts:#?}");
            assert!(!is_check(&f.body, 4), "no check after quiet(): {stmts:#?}");
            let Some(Statement::Loop {
                body, continuing, ..
            }) = f.body.iter().find(|s| matches!(s, Statement::Loop { .. }))
            else {
                panic!("no loop: {stmts:#?}")
            };
            assert!(is_check(body, 1), "a check opens the loop body: {body:#?}");
            assert!(
                !continuing.iter().any(|s| matches!(s, Statement::If { .. })),
                "no return inside continuing"
            );
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&m)
            .unwrap_or_else(|e| panic!("invalid IR after the pass: {e:?}"));
        }
    }
}
