//! Statements and structured control flow.
//!
//! - `if`: a branch to two arms that meet again; on a constant condition, just the arm
//!   taken.
//! - `loop`: header, body, `continuing` block, back edge (or `break if`); the header is
//!   sealed only after the back edge exists. Body values reach `continuing` because WGSL
//!   forbids a `continue` that skips a declaration `continuing` uses.
//! - Unrolling: a loop whose exit test reads only constants and local variables (a
//!   counted `for`) is first lowered as copies of one iteration, each continuing into the
//!   next. Loop counters are constants in each copy (`fold.rs`), so the exit tests fold,
//!   indices into local arrays become constant and those arrays stay in registers. Copying
//!   stops when the loop has exited in every copy, when an exit depends on a runtime value,
//!   or at a size limit; a real loop then runs whatever iterations remain, so unrolling
//!   never changes what a program does.
//! - `switch`: Cranelift's `Switch` dispatch to one block per case; a case that falls
//!   through jumps to the next case's block (naga writes `case 1, 2:` as an empty case
//!   falling through).
//! - Every back-edge of a real loop reads the launch's stop flag and returns from the program
//!   when it is set (`DeviceCalls::stop_flag`), so a program that never ends can be
//!   cancelled; unrolled copies need no check (they are finite).
//! - `break` leaves the innermost loop or switch, `continue` the innermost loop.
//! - After `return`, `break`, `continue` or a terminator, lowering goes on in a block
//!   nothing jumps to, so the rest of a naga block needs no special case.
//! - Calls of user functions are inlined; their `return` jumps to a continuation block
//!   whose parameters are the result's leaves.

use super::expr::leaf_of;
use super::{LResult, LowerError, Lowered, Lowerer, Target};
use cranelift_codegen::ir::types::I32;
use cranelift_codegen::ir::{BlockArg, InstBuilder, MemFlagsData, Value};
use cranelift_frontend::Switch;
use naga::{Expression, Handle, Statement};

impl<'m> Lowerer<'m, '_> {
    /// Lowers a block of statements.
    pub(super) fn block(&mut self, block: &'m naga::Block) -> LResult<()> {
        for (stmt, span) in block.span_iter() {
            self.statement(stmt).map_err(|e| e.or_span(*span))?;
        }
        Ok(())
    }

    fn statement(&mut self, stmt: &'m Statement) -> LResult<()> {
        match stmt {
            Statement::Emit(range) => {
                for h in range.clone() {
                    self.emit(h)?;
                }
            }
            Statement::Block(b) => self.block(b)?,
            Statement::If {
                condition,
                accept,
                reject,
            } => {
                let c = self.scalar(*condition)?;
                if let Some(k) = self.int_konst(c) {
                    return self.block(if k != 0 { accept } else { reject });
                }
                let (then, other, merge) = (
                    self.b.create_block(),
                    self.b.create_block(),
                    self.b.create_block(),
                );
                self.branch(c, then, other);
                self.b.seal_block(then);
                self.b.seal_block(other);
                self.runtime_depth += 1;
                self.enter(then);
                self.block(accept)?;
                self.goto(merge, &[]);
                self.enter(other);
                self.block(reject)?;
                self.goto(merge, &[]);
                self.runtime_depth -= 1;
                self.b.seal_block(merge);
                self.enter(merge);
            }
            Statement::Switch { selector, cases } => self.switch(*selector, cases)?,
            Statement::Loop {
                body,
                continuing,
                break_if,
            } => self.lower_loop(body, continuing, *break_if)?,
            Statement::Break => {
                let depth = self.runtime_depth;
                let live = self.live;
                let exit = match self.targets.last_mut() {
                    Some(Target::Loop { exit, unrolled, .. }) => {
                        if let Some((start, runtime_exit)) = unrolled {
                            *runtime_exit |= live && depth > *start;
                        }
                        *exit
                    }
                    Some(Target::Switch { exit }) => *exit,
                    None => {
                        return Err(LowerError::unspanned("`break` outside a loop or switch"));
                    }
                };
                self.goto(exit, &[]);
                self.start_dead_block();
            }
            Statement::Continue => {
                let cont = self.targets.iter().rev().find_map(|t| match t {
                    Target::Loop { continuing, .. } => Some(*continuing),
                    Target::Switch { .. } => None,
                });
                let cont =
                    cont.ok_or_else(|| LowerError::unspanned("`continue` outside a loop"))?;
                self.goto(cont, &[]);
                self.start_dead_block();
            }
            Statement::Return { value } => {
                let values = match value {
                    Some(v) => self.values(*v)?,
                    None => Vec::new(),
                };
                let target = self.frame().ret.unwrap_or(self.exit);
                let args: Vec<BlockArg> = values.into_iter().map(BlockArg::from).collect();
                self.goto(target, &args);
                self.start_dead_block();
            }
            Statement::Store { pointer, value } => {
                let place = self.place(*pointer)?;
                let pointee = self.pointee(*pointer)?;
                let values = self.values(*value)?;
                self.store(&place, &pointee, &values)?;
            }
            Statement::Call {
                function,
                arguments,
                result,
            } => {
                if let Some(&df) = self.env.device_fns.get(function) {
                    self.device_call(df, arguments, *result)?;
                } else {
                    self.inline_call(*function, arguments, *result)?;
                }
            }
            Statement::Atomic {
                pointer,
                fun,
                value,
                result,
            } => {
                let place = self.place(*pointer)?;
                let signed = leaf_of(&self.pointee(*pointer)?)?.is_signed();
                let v = self.scalar(*value)?;
                let compare = match fun {
                    naga::AtomicFunction::Exchange { compare: Some(c) } => Some(self.scalar(*c)?),
                    _ => None,
                };
                let old = self.atomic(&place, fun, signed, v, compare)?;
                if let Some(r) = result {
                    self.frame_mut().cache[r.index()] = Some(Lowered::Value(old));
                }
            }
            other => {
                return Err(LowerError::unspanned(format!(
                    "the CPU JIT cannot lower the statement `{}`",
                    statement_name(other)
                )));
            }
        }
        Ok(())
    }

    fn switch(
        &mut self,
        selector: Handle<Expression>,
        cases: &'m [naga::SwitchCase],
    ) -> LResult<()> {
        let value = self.scalar(selector)?;
        let blocks: Vec<_> = cases.iter().map(|_| self.b.create_block()).collect();
        let exit = self.b.create_block();
        let mut dispatch = Switch::new();
        let mut default = exit;
        for (case, &block) in cases.iter().zip(&blocks) {
            match case.value {
                naga::SwitchValue::I32(v) => dispatch.set_entry(v as u32 as u128, block),
                naga::SwitchValue::U32(v) => dispatch.set_entry(v as u128, block),
                naga::SwitchValue::Default => default = block,
            }
        }
        if self.live {
            dispatch.emit(&mut self.b, value, default);
            self.live_blocks
                .extend(blocks.iter().copied().chain([default]));
        } else {
            self.end_dead_block();
        }
        self.targets.push(Target::Switch { exit });
        self.runtime_depth += 1;
        for (i, case) in cases.iter().enumerate() {
            // Every jump into this case (dispatch, the previous case falling through) exists.
            self.b.seal_block(blocks[i]);
            self.enter(blocks[i]);
            self.block(&case.body)?;
            let next = if case.fall_through {
                blocks.get(i + 1).copied().unwrap_or(exit)
            } else {
                exit
            };
            self.goto(next, &[]);
        }
        self.runtime_depth -= 1;
        self.targets.pop();
        self.b.seal_block(exit);
        self.enter(exit);
        Ok(())
    }

    /// Inlines a call of a user function (or the prelude's `rt_offset_ray`).
    pub(super) fn inline_call(
        &mut self,
        callee: Handle<naga::Function>,
        arguments: &[Handle<Expression>],
        result: Option<Handle<Expression>>,
    ) -> LResult<()> {
        let function = &self.env.module.functions[callee];
        let mut args = Vec::with_capacity(arguments.len());
        for &a in arguments {
            args.push(self.expr(a)?);
        }
        let result_types = match &function.result {
            Some(r) => self
                .env
                .types
                .layout(&self.env.module.types[r.ty].inner)?
                .clif_types(),
            None => Vec::new(),
        };
        let cont = self.b.create_block();
        for &t in &result_types {
            self.b.append_block_param(cont, t);
        }
        self.push_frame(callee, args, Some(cont))?;
        let lowered = self.block(&function.body);
        self.frames.pop();
        lowered?;
        // Falling off the end: a function without a result returns; one with a result
        // cannot get here (every path returned), so this block is unreachable.
        let zeros: Vec<BlockArg> = result_types
            .iter()
            .map(|&t| self.zero_of(t))
            .map(BlockArg::from)
            .collect();
        self.goto(cont, &zeros);
        self.b.seal_block(cont);
        self.enter(cont);
        if let Some(r) = result {
            let values: Vec<Value> = self.b.block_params(cont).to_vec();
            self.frame_mut().cache[r.index()] = Some(Lowered::Value(values));
        }
        Ok(())
    }

    /// A `loop`: unrolled while that folds (see the module doc), then a real loop for
    /// whatever remains.
    fn lower_loop(
        &mut self,
        body: &'m naga::Block,
        continuing: &'m naga::Block,
        break_if: Option<Handle<Expression>>,
    ) -> LResult<()> {
        let exit = self.b.create_block();
        if self.counted(body, break_if) {
            let mut copies = 0;
            while self.live && copies < MAX_UNROLL && self.lowered_exprs < UNROLL_BUDGET {
                let cont = self.b.create_block();
                self.targets.push(Target::Loop {
                    continuing: cont,
                    exit,
                    unrolled: Some((self.runtime_depth, false)),
                });
                let lowered = self.one_iteration(body, continuing, break_if, cont, exit);
                let Some(Target::Loop { unrolled, .. }) = self.targets.pop() else {
                    unreachable!("the loop's own target")
                };
                lowered?;
                copies += 1;
                if unrolled.is_some_and(|(_, runtime_exit)| runtime_exit) {
                    break;
                }
            }
        }
        if self.live {
            let (header, cont) = (self.b.create_block(), self.b.create_block());
            self.goto(header, &[]);
            self.enter(header);
            self.targets.push(Target::Loop {
                continuing: cont,
                exit,
                unrolled: None,
            });
            self.runtime_depth += 1;
            let lowered = self.one_iteration(body, continuing, break_if, cont, exit);
            self.runtime_depth -= 1;
            self.targets.pop();
            lowered?;
            self.stop_check();
            self.goto(header, &[]);
            self.b.seal_block(header);
        } else {
            // Every copy has left the loop; this block is unreachable but must end.
            self.goto(exit, &[]);
        }
        self.b.seal_block(exit);
        self.enter(exit);
        Ok(())
    }

    /// Returns from the program when the launch's stop flag is set: at each back-edge, so
    /// a loop that never ends can be cancelled (a deadline, a token, Ctrl-C). The load is
    /// not marked read-only, so it stays in the loop; it hits L1 and the branch predicts,
    /// which keeps the check to about a cycle an iteration.
    fn stop_check(&mut self) {
        if !self.live || !stop_checks() {
            return;
        }
        let flag = self
            .b
            .ins()
            .load(I32, MemFlagsData::trusted(), self.stop, 0);
        let go_on = self.b.create_block();
        let exit = self.exit;
        self.branch(flag, exit, go_on);
        self.b.seal_block(go_on);
        self.enter(go_on);
    }

    /// One iteration: body, `continuing`, `break if`. Ends in the block that goes on to the
    /// next iteration (the caller jumps back or lowers the next copy there).
    fn one_iteration(
        &mut self,
        body: &'m naga::Block,
        continuing: &'m naga::Block,
        break_if: Option<Handle<Expression>>,
        cont: cranelift_codegen::ir::Block,
        exit: cranelift_codegen::ir::Block,
    ) -> LResult<()> {
        self.block(body)?;
        self.goto(cont, &[]);
        self.b.seal_block(cont);
        self.enter(cont);
        self.block(continuing)?;
        if let Some(c) = break_if {
            let c = self.scalar(c)?;
            match self.int_konst(c) {
                Some(0) => {}
                Some(_) => {
                    self.goto(exit, &[]);
                    self.start_dead_block();
                }
                None => {
                    if let Some(Target::Loop {
                        unrolled: Some((_, runtime_exit)),
                        ..
                    }) = self.targets.last_mut()
                    {
                        *runtime_exit = true;
                    }
                    let next = self.b.create_block();
                    self.branch(c, exit, next);
                    self.b.seal_block(next);
                    self.enter(next);
                }
            }
        }
        Ok(())
    }

    /// Whether a loop looks counted: its exit test (the `if ... { break; }` that starts
    /// the body, or `break if`) reads only constants and local variables.
    fn counted(&self, body: &naga::Block, break_if: Option<Handle<Expression>>) -> bool {
        let function = self.frame().function;
        let first = body.iter().find(|s| !matches!(s, Statement::Emit(_)));
        let test = match first {
            Some(Statement::If {
                condition,
                accept,
                reject,
            }) if is_break(accept) || is_break(reject) => Some(*condition),
            _ => break_if,
        };
        test.is_some_and(|t| local_only(function, t, 0))
    }

    fn zero_of(&mut self, t: cranelift_codegen::ir::Type) -> Value {
        if t.is_float() {
            self.b.ins().f32const(0.0)
        } else {
            self.b.ins().iconst(t, 0)
        }
    }
}

/// Whether back-edges check the stop flag: always, unless `OPTIK_JIT_STOP_CHECKS=0` turns
/// them off to measure what they cost (launches then cannot stop a program that loops
/// forever). Read once per process.
fn stop_checks() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("OPTIK_JIT_STOP_CHECKS").is_none_or(|v| v != "0"))
}

/// Copies of one loop's iteration at most.
const MAX_UNROLL: usize = 32;

/// No loop is unrolled further once a program has this many expressions lowered.
const UNROLL_BUDGET: usize = 8000;

/// Whether a block is just `break`.
fn is_break(block: &naga::Block) -> bool {
    matches!(block.iter().next(), Some(Statement::Break)) && block.len() == 1
}

/// Whether an expression reads only constants and local variables (no buffers, arguments,
/// calls or device values).
fn local_only(function: &naga::Function, e: Handle<Expression>, depth: u32) -> bool {
    if depth > 32 {
        return false;
    }
    let go = |e: Handle<Expression>| local_only(function, e, depth + 1);
    match function.expressions[e] {
        Expression::Literal(_) | Expression::Constant(_) | Expression::ZeroValue(_) => true,
        Expression::LocalVariable(_) => true,
        Expression::Load { pointer } => go(pointer),
        Expression::Access { base, index } => go(base) && go(index),
        Expression::AccessIndex { base, .. } => go(base),
        Expression::Unary { expr, .. } | Expression::As { expr, .. } => go(expr),
        Expression::Splat { value, .. } => go(value),
        Expression::Binary { left, right, .. } => go(left) && go(right),
        Expression::Select {
            condition,
            accept,
            reject,
        } => go(condition) && go(accept) && go(reject),
        _ => false,
    }
}

/// The name of a statement kind for error messages.
fn statement_name(s: &Statement) -> String {
    let debug = format!("{s:?}");
    debug
        .split([' ', '(', '{'])
        .next()
        .unwrap_or("?")
        .to_string()
}
