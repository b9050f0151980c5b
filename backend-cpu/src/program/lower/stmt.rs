//! Statements and structured control flow.
//!
//! - `if`: a branch to two arms that meet again.
//! - `loop`: header, body, `continuing` block, back edge (or `break if`); the header is
//!   sealed only after the back edge exists. Body values reach `continuing` because WGSL
//!   forbids a `continue` that skips a declaration `continuing` uses.
//! - `switch`: Cranelift's `Switch` dispatch to one block per case; a case that falls
//!   through jumps to the next case's block (naga writes `case 1, 2:` as an empty case
//!   falling through).
//! - `break` leaves the innermost loop or switch, `continue` the innermost loop.
//! - After `return`, `break`, `continue` or a terminator, lowering goes on in a block
//!   nothing jumps to, so the rest of a naga block needs no special case.
//! - Calls of user functions are inlined; their `return` jumps to a continuation block
//!   whose parameters are the result's leaves.

use super::expr::leaf_of;
use super::{LResult, LowerError, Lowered, Lowerer, Target};
use cranelift_codegen::ir::{BlockArg, InstBuilder, Value};
use cranelift_frontend::Switch;
use naga::{Expression, Handle, Statement};

impl<'m> Lowerer<'m, '_> {
    /// Lowers a block of statements.
    pub(super) fn block(&mut self, block: &'m naga::Block) -> LResult<()> {
        for (stmt, span) in block.span_iter() {
            self.statement(stmt, *span).map_err(|e| e.or_span(*span))?;
        }
        Ok(())
    }

    fn statement(&mut self, stmt: &'m Statement, span: naga::Span) -> LResult<()> {
        let _ = span;
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
                let (then, other, merge) = (
                    self.b.create_block(),
                    self.b.create_block(),
                    self.b.create_block(),
                );
                self.b.ins().brif(c, then, &[], other, &[]);
                self.b.seal_block(then);
                self.b.seal_block(other);
                self.b.switch_to_block(then);
                self.block(accept)?;
                self.b.ins().jump(merge, &[]);
                self.b.switch_to_block(other);
                self.block(reject)?;
                self.b.ins().jump(merge, &[]);
                self.b.seal_block(merge);
                self.b.switch_to_block(merge);
            }
            Statement::Switch { selector, cases } => self.switch(*selector, cases)?,
            Statement::Loop {
                body,
                continuing,
                break_if,
            } => {
                let (header, cont, exit) = (
                    self.b.create_block(),
                    self.b.create_block(),
                    self.b.create_block(),
                );
                self.b.ins().jump(header, &[]);
                self.b.switch_to_block(header);
                self.targets.push(Target::Loop {
                    continuing: cont,
                    exit,
                });
                self.block(body)?;
                self.b.ins().jump(cont, &[]);
                self.b.seal_block(cont);
                self.b.switch_to_block(cont);
                self.block(continuing)?;
                match break_if {
                    Some(c) => {
                        let c = self.scalar(*c)?;
                        self.b.ins().brif(c, exit, &[], header, &[]);
                    }
                    None => {
                        self.b.ins().jump(header, &[]);
                    }
                }
                self.targets.pop();
                self.b.seal_block(header);
                self.b.seal_block(exit);
                self.b.switch_to_block(exit);
            }
            Statement::Break => {
                let exit = match self.targets.last() {
                    Some(Target::Loop { exit, .. } | Target::Switch { exit }) => *exit,
                    None => return Err(LowerError::unspanned("`break` outside a loop or switch")),
                };
                self.b.ins().jump(exit, &[]);
                self.start_dead_block();
            }
            Statement::Continue => {
                let cont = self.targets.iter().rev().find_map(|t| match t {
                    Target::Loop { continuing, .. } => Some(*continuing),
                    Target::Switch { .. } => None,
                });
                let cont =
                    cont.ok_or_else(|| LowerError::unspanned("`continue` outside a loop"))?;
                self.b.ins().jump(cont, &[]);
                self.start_dead_block();
            }
            Statement::Return { value } => {
                let values = match value {
                    Some(v) => self.values(*v)?,
                    None => Vec::new(),
                };
                match self.frame().ret {
                    Some(cont) => {
                        let args: Vec<BlockArg> = values.into_iter().map(BlockArg::from).collect();
                        self.b.ins().jump(cont, &args);
                    }
                    None => {
                        let exit = self.exit;
                        self.b.ins().jump(exit, &[]);
                    }
                }
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
        dispatch.emit(&mut self.b, value, default);
        self.targets.push(Target::Switch { exit });
        for (i, case) in cases.iter().enumerate() {
            // Every jump into this case (dispatch, the previous case falling through) exists.
            self.b.seal_block(blocks[i]);
            self.b.switch_to_block(blocks[i]);
            self.block(&case.body)?;
            let next = if case.fall_through {
                blocks.get(i + 1).copied().unwrap_or(exit)
            } else {
                exit
            };
            self.b.ins().jump(next, &[]);
        }
        self.targets.pop();
        self.b.seal_block(exit);
        self.b.switch_to_block(exit);
        Ok(())
    }

    /// Inlines a call of a user function (or the prelude's `rt_offset_ray`).
    fn inline_call(
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
        self.b.ins().jump(cont, &zeros);
        self.b.seal_block(cont);
        self.b.switch_to_block(cont);
        if let Some(r) = result {
            let values: Vec<Value> = self.b.block_params(cont).to_vec();
            self.frame_mut().cache[r.index()] = Some(Lowered::Value(values));
        }
        Ok(())
    }

    fn zero_of(&mut self, t: cranelift_codegen::ir::Type) -> Value {
        if t.is_float() {
            self.b.ins().f32const(0.0)
        } else {
            self.b.ins().iconst(t, 0)
        }
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
