//! Constant folding while lowering.
//!
//! Cranelift folds constants too, but only after the function is built; folding here lets
//! lowering itself see constants: an `if` on a constant lowers one arm, an index that is a
//! constant addresses a leaf or a byte offset directly, and a loop whose exit test is
//! constant is unrolled (`stmt.rs`). Loop counters of unrolled loops are constants in each
//! copy (cranelift-frontend resolves a variable to the one definition reaching it), so
//! everything computed from them folds.
//!
//! Folding computes exactly what the emitted instructions would (WGSL integer semantics,
//! IEEE f32 arithmetic without contraction), so results do not depend on it.

use super::Lowerer;
use super::types::Leaf;
use cranelift_codegen::ir::types::{I8, I32};
use cranelift_codegen::ir::{InstBuilder, InstructionData, Opcode, Value};
use naga::BinaryOperator as B;

/// A constant leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Konst {
    Int(u32),
    Float(f32),
}

impl Lowerer<'_, '_> {
    /// The constant `v` holds, if it is one.
    pub(super) fn konst(&self, v: Value) -> Option<Konst> {
        let dfg = &self.b.func.dfg;
        let inst = dfg.value_def(v).inst()?;
        match dfg.insts[inst] {
            InstructionData::UnaryImm {
                opcode: Opcode::Iconst,
                imm,
            } => Some(Konst::Int(imm.bits() as u32)),
            InstructionData::UnaryIeee32 {
                opcode: Opcode::F32const,
                imm,
            } => Some(Konst::Float(f32::from_bits(imm.bits()))),
            _ => None,
        }
    }

    /// The integer (or bool) constant `v` holds.
    pub(super) fn int_konst(&self, v: Value) -> Option<u32> {
        match self.konst(v)? {
            Konst::Int(i) => Some(i),
            Konst::Float(_) => None,
        }
    }

    pub(super) fn int(&mut self, x: u32) -> Value {
        self.b.ins().iconst(I32, x as i64)
    }

    pub(super) fn boolean(&mut self, x: bool) -> Value {
        self.b.ins().iconst(I8, x as i64)
    }

    /// `op` on two constant leaves, or `None` when either is not constant.
    pub(super) fn fold_binary(&mut self, op: B, leaf: Leaf, x: Value, y: Value) -> Option<Value> {
        match (self.konst(x)?, self.konst(y)?) {
            (Konst::Int(a), Konst::Int(b)) if leaf != Leaf::F32 => {
                Some(self.fold_int(op, leaf, a, b))
            }
            (Konst::Float(a), Konst::Float(b)) => Some(self.fold_float(op, a, b)),
            _ => None,
        }
    }

    fn fold_int(&mut self, op: B, leaf: Leaf, a: u32, b: u32) -> Value {
        let (sa, sb) = (a as i32, b as i32);
        let signed = leaf.is_signed();
        let trap = b == 0 || (signed && sa == i32::MIN && sb == -1);
        let value = match op {
            B::Add => a.wrapping_add(b),
            B::Subtract => a.wrapping_sub(b),
            B::Multiply => a.wrapping_mul(b),
            B::Divide if trap => a,
            B::Divide if signed => (sa / sb) as u32,
            B::Divide => a / b,
            B::Modulo if trap => 0,
            B::Modulo if signed => (sa % sb) as u32,
            B::Modulo => a % b,
            B::And | B::LogicalAnd => a & b,
            B::InclusiveOr | B::LogicalOr => a | b,
            B::ExclusiveOr => a ^ b,
            B::ShiftLeft => a.wrapping_shl(b),
            B::ShiftRight if signed => sa.wrapping_shr(b) as u32,
            B::ShiftRight => a.wrapping_shr(b),
            B::Equal => return self.boolean(a == b),
            B::NotEqual => return self.boolean(a != b),
            B::Less => return self.boolean(if signed { sa < sb } else { a < b }),
            B::LessEqual => return self.boolean(if signed { sa <= sb } else { a <= b }),
            B::Greater => return self.boolean(if signed { sa > sb } else { a > b }),
            B::GreaterEqual => return self.boolean(if signed { sa >= sb } else { a >= b }),
        };
        if leaf == Leaf::Bool {
            self.b.ins().iconst(I8, (value & 1) as i64)
        } else {
            self.int(value)
        }
    }

    fn fold_float(&mut self, op: B, a: f32, b: f32) -> Value {
        let value = match op {
            B::Add => a + b,
            B::Subtract => a - b,
            B::Multiply => a * b,
            B::Divide => a / b,
            B::Modulo => a - b * (a / b).trunc(),
            B::Equal => return self.boolean(a == b),
            B::NotEqual => return self.boolean(a != b),
            B::Less => return self.boolean(a < b),
            B::LessEqual => return self.boolean(a <= b),
            B::Greater => return self.boolean(a > b),
            B::GreaterEqual => return self.boolean(a >= b),
            // Not float operators; never reached from a validated module.
            _ => return self.b.ins().f32const(f32::NAN),
        };
        self.b.ins().f32const(value)
    }

    /// `select(c, a, b)`, picking at compile time when `c` is constant.
    pub(super) fn select(&mut self, c: Value, a: Value, b: Value) -> Value {
        match self.int_konst(c) {
            Some(0) => b,
            Some(_) => a,
            None => self.b.ins().select(c, a, b),
        }
    }

    /// `min(a, b)` on u32, folded when both are constant.
    pub(super) fn umin(&mut self, a: Value, b: Value) -> Value {
        match (self.int_konst(a), self.int_konst(b)) {
            (Some(x), Some(y)) => self.int(x.min(y)),
            _ => self.b.ins().umin(a, b),
        }
    }

    /// A WGSL conversion of a constant leaf, if it is one.
    pub(super) fn fold_convert(
        &mut self,
        x: Value,
        from: Leaf,
        to: Leaf,
        convert: bool,
    ) -> Option<Value> {
        let k = self.konst(x)?;
        Some(match (k, to, convert) {
            (Konst::Int(i), Leaf::F32, true) => {
                let f = if from == Leaf::I32 {
                    i as i32 as f32
                } else {
                    i as f32
                };
                self.b.ins().f32const(f)
            }
            (Konst::Int(i), Leaf::F32, false) => self.b.ins().f32const(f32::from_bits(i)),
            (Konst::Int(i), Leaf::Bool, _) => self.boolean(i != 0),
            (Konst::Int(i), _, _) => self.int(i),
            (Konst::Float(f), Leaf::I32, true) => self.int(f as i32 as u32),
            (Konst::Float(f), Leaf::U32, true) => self.int(f as u32),
            (Konst::Float(f), Leaf::Bool, _) => self.boolean(f != 0.0),
            (Konst::Float(f), Leaf::I32 | Leaf::U32, false) => self.int(f.to_bits()),
            (Konst::Float(f), Leaf::F32, _) => self.b.ins().f32const(f),
        })
    }
}
