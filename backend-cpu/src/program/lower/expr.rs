//! Expressions: naga's expression arena to leaves and places.
//!
//! An expression's value is fixed where its `Emit` range is, so `Emit` lowers and caches;
//! every use reads the cache. Expressions naga never emits (literals, constants, variables,
//! arguments, and constant-folded composites) are lowered again at each use and never
//! cached: a value first built inside an `if` arm would not dominate a later use.

use super::place::{Index, MemPlace, Place};
use super::types::Leaf;
use super::{LResult, LowerError, Lowered, Lowerer};
use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::types::{F32, I8, I32, I64};
use cranelift_codegen::ir::{InstBuilder, MemFlagsData, StackSlotData, StackSlotKind, Value};
use naga::{BinaryOperator as B, Expression, Handle, ScalarKind, TypeInner, UnaryOperator};

/// The leaf kind of a scalar, vector or matrix type.
pub(super) fn leaf_of(inner: &TypeInner) -> LResult<Leaf> {
    match *inner {
        TypeInner::Scalar(s) | TypeInner::Atomic(s) => Leaf::of(s),
        TypeInner::Vector { scalar, .. } | TypeInner::Matrix { scalar, .. } => Leaf::of(scalar),
        TypeInner::ValuePointer { scalar, .. } => Leaf::of(scalar),
        _ => Err(LowerError::unspanned(format!(
            "expected a scalar, vector or matrix, found {inner:?}"
        ))),
    }
}

impl<'m> Lowerer<'m, '_> {
    /// The lowered expression: cached if emitted, else lowered now.
    pub(super) fn expr(&mut self, h: Handle<Expression>) -> LResult<Lowered> {
        if let Some(l) = &self.frame().cache[h.index()] {
            return Ok(l.clone());
        }
        let span = self.frame().function.expressions.get_span(h);
        self.lower_expr(h).map_err(|e| e.or_span(span))
    }

    /// Lowers and caches an emitted expression.
    pub(super) fn emit(&mut self, h: Handle<Expression>) -> LResult<()> {
        let span = self.frame().function.expressions.get_span(h);
        let l = self.lower_expr(h).map_err(|e| e.or_span(span))?;
        self.frame_mut().cache[h.index()] = Some(l);
        self.lowered_exprs += 1;
        Ok(())
    }

    /// The leaves of a value expression.
    pub(super) fn values(&mut self, h: Handle<Expression>) -> LResult<Vec<Value>> {
        match self.expr(h)? {
            Lowered::Value(v) => Ok(v),
            _ => Err(LowerError::unspanned(
                "expected a value, found a pointer or resource",
            )),
        }
    }

    /// The place of a pointer expression.
    pub(super) fn place(&mut self, h: Handle<Expression>) -> LResult<Place> {
        match self.expr(h)? {
            Lowered::Place(p) => Ok(p),
            _ => Err(LowerError::unspanned("expected a pointer")),
        }
    }

    /// The one leaf of a scalar expression.
    pub(super) fn scalar(&mut self, h: Handle<Expression>) -> LResult<Value> {
        let v = self.values(h)?;
        v.first()
            .copied()
            .ok_or_else(|| LowerError::unspanned("expected a scalar"))
    }

    /// The type a pointer expression points to.
    pub(super) fn pointee(&self, pointer: Handle<Expression>) -> LResult<TypeInner> {
        match self.type_of(pointer) {
            TypeInner::Pointer { base, .. } => Ok(self.env.module.types[*base].inner.clone()),
            TypeInner::ValuePointer {
                size: Some(size),
                scalar,
                ..
            } => Ok(TypeInner::Vector {
                size: *size,
                scalar: *scalar,
            }),
            TypeInner::ValuePointer {
                size: None, scalar, ..
            } => Ok(TypeInner::Scalar(*scalar)),
            other => Err(LowerError::unspanned(format!(
                "expected a pointer type, found {other:?}"
            ))),
        }
    }

    fn is_pointer(&self, h: Handle<Expression>) -> bool {
        matches!(
            self.type_of(h),
            TypeInner::Pointer { .. } | TypeInner::ValuePointer { .. }
        )
    }

    fn lower_expr(&mut self, h: Handle<Expression>) -> LResult<Lowered> {
        let function = self.frame().function;
        let value = |v: Vec<Value>| Ok(Lowered::Value(v));
        match function.expressions[h] {
            Expression::Literal(lit) => value(vec![self.literal(lit)?]),
            Expression::Constant(c) => {
                let init = self.env.module.constants[c].init;
                value(self.global_expr(init)?)
            }
            Expression::Override(o) => value(self.override_value(o)?),
            Expression::ZeroValue(ty) => {
                let layout = self.env.types.layout(&self.env.module.types[ty].inner)?;
                value(self.zeros(&layout))
            }
            Expression::Compose { ref components, .. } => {
                let mut leaves = Vec::new();
                for &c in components {
                    leaves.extend(self.values(c)?);
                }
                value(leaves)
            }
            Expression::Splat { size, value: v } => {
                let x = self.scalar(v)?;
                value(vec![x; size as usize])
            }
            Expression::Swizzle {
                size,
                vector,
                pattern,
            } => {
                let v = self.values(vector)?;
                value(
                    pattern[..size as usize]
                        .iter()
                        .map(|&c| v[c as usize])
                        .collect(),
                )
            }
            Expression::FunctionArgument(i) => Ok(self.frame().args[i as usize].clone()),
            Expression::GlobalVariable(g) => self.global_variable(g),
            Expression::LocalVariable(l) => Ok(Lowered::Place(self.frame().locals[&l].clone())),
            Expression::Load { pointer } => {
                let place = self.place(pointer)?;
                let pointee = self.pointee(pointer)?;
                value(self.load(&place, &pointee)?)
            }
            Expression::Access { base, index } => {
                let i = self.scalar(index)?;
                self.access(base, Index::Dynamic(i))
            }
            Expression::AccessIndex { base, index } => self.access(base, Index::Const(index)),
            Expression::Unary { op, expr } => {
                let leaf = leaf_of(self.type_of(expr))?;
                let v = self.values(expr)?;
                value(v.into_iter().map(|x| self.unary(op, leaf, x)).collect())
            }
            Expression::Binary { op, left, right } => value(self.binary(op, left, right)?),
            Expression::Select {
                condition,
                accept,
                reject,
            } => {
                let c = self.values(condition)?;
                let a = self.values(accept)?;
                let r = self.values(reject)?;
                value(
                    a.iter()
                        .zip(&r)
                        .enumerate()
                        .map(|(i, (&a, &r))| {
                            let c = if c.len() == 1 { c[0] } else { c[i] };
                            self.select(c, a, r)
                        })
                        .collect(),
                )
            }
            Expression::Relational { fun, argument } => {
                let v = self.values(argument)?;
                value(vec![self.relational(fun, &v)])
            }
            Expression::Math {
                fun,
                arg,
                arg1,
                arg2,
                arg3,
            } => value(self.math(fun, arg, arg1, arg2, arg3)?),
            Expression::As {
                expr,
                kind,
                convert,
            } => {
                let from = leaf_of(self.type_of(expr))?;
                let v = self.values(expr)?;
                let to = match (kind, convert) {
                    (ScalarKind::Bool, _) => Leaf::Bool,
                    (ScalarKind::Float, Some(4) | None) => Leaf::F32,
                    (ScalarKind::Sint, Some(4) | None) => Leaf::I32,
                    (ScalarKind::Uint, Some(4) | None) => Leaf::U32,
                    _ => {
                        return Err(LowerError::unspanned(format!(
                            "conversion to {kind:?} of width {convert:?} is not supported by the CPU JIT"
                        )));
                    }
                };
                value(
                    v.into_iter()
                        .map(|x| self.convert(x, from, to, convert.is_some()))
                        .collect(),
                )
            }
            Expression::CallResult(_) | Expression::AtomicResult { .. } => {
                Err(LowerError::unspanned(
                    "internal: a call or atomic result used before its statement",
                ))
            }
            Expression::ArrayLength(pointer) => value(vec![self.array_length(pointer)?]),
            Expression::ImageSample { .. }
            | Expression::ImageLoad { .. }
            | Expression::ImageQuery { .. } => value(self.image(&function.expressions[h])?),
            ref other => Err(LowerError::unspanned(format!(
                "the CPU JIT cannot lower the expression `{}`",
                expression_name(other)
            ))),
        }
    }

    fn literal(&mut self, lit: naga::Literal) -> LResult<Value> {
        use naga::Literal as L;
        Ok(match lit {
            L::F32(f) => self.b.ins().f32const(f),
            // Zero-extended: the verifier rejects sign-extended i32 immediates.
            L::I32(i) => self.b.ins().iconst(I32, i as u32 as i64),
            L::U32(u) => self.b.ins().iconst(I32, u as i64),
            L::Bool(b) => self.b.ins().iconst(I8, b as i64),
            other => {
                return Err(LowerError::unspanned(format!(
                    "the literal {other:?} is outside the types the CPU JIT supports (f32, i32, u32, bool)"
                )));
            }
        })
    }

    /// A constant expression of the module (constant, override or global initialiser).
    pub(super) fn global_expr(&mut self, h: Handle<Expression>) -> LResult<Vec<Value>> {
        let module = self.env.module;
        Ok(match module.global_expressions[h] {
            Expression::Literal(lit) => vec![self.literal(lit)?],
            Expression::Constant(c) => self.global_expr(module.constants[c].init)?,
            Expression::Override(o) => self.override_value(o)?,
            Expression::ZeroValue(ty) => {
                let layout = self.env.types.layout(&module.types[ty].inner)?;
                self.zeros(&layout)
            }
            Expression::Compose { ref components, .. } => {
                let mut leaves = Vec::new();
                for &c in components {
                    leaves.extend(self.global_expr(c)?);
                }
                leaves
            }
            Expression::Splat { size, value } => {
                let x = self.global_expr(value)?;
                vec![x[0]; size as usize]
            }
            // Overrides' initialisers are not folded by the front end (their inputs are
            // not known there): the operators they may use, component-wise.
            Expression::Unary { op, expr } => {
                let leaf = leaf_of(self.env.info[expr].inner_with(&module.types))?;
                let v = self.global_expr(expr)?;
                v.into_iter().map(|x| self.unary(op, leaf, x)).collect()
            }
            Expression::Binary { op, left, right } => {
                let leaf = leaf_of(self.env.info[left].inner_with(&module.types))?;
                let (a, c) = (self.global_expr(left)?, self.global_expr(right)?);
                let n = a.len().max(c.len());
                (0..n)
                    .map(|i| {
                        let x = if a.len() == 1 { a[0] } else { a[i] };
                        let y = if c.len() == 1 { c[0] } else { c[i] };
                        self.scalar_binary(op, leaf, x, y)
                    })
                    .collect()
            }
            Expression::Select {
                condition,
                accept,
                reject,
            } => {
                let c = self.global_expr(condition)?;
                let (a, r) = (self.global_expr(accept)?, self.global_expr(reject)?);
                (0..a.len())
                    .map(|i| {
                        self.b
                            .ins()
                            .select(if c.len() == 1 { c[0] } else { c[i] }, a[i], r[i])
                    })
                    .collect()
            }
            Expression::As {
                expr,
                kind,
                convert,
            } => {
                let from = leaf_of(self.env.info[expr].inner_with(&module.types))?;
                let to = match kind {
                    ScalarKind::Bool => Leaf::Bool,
                    ScalarKind::Float => Leaf::F32,
                    ScalarKind::Sint => Leaf::I32,
                    _ => Leaf::U32,
                };
                let v = self.global_expr(expr)?;
                v.into_iter()
                    .map(|x| self.convert(x, from, to, convert.is_some()))
                    .collect()
            }
            ref other => {
                let span = module.global_expressions.get_span(h);
                return Err(LowerError {
                    span,
                    message: format!(
                        "the CPU JIT cannot evaluate `{}` in a module-scope expression",
                        expression_name(other)
                    ),
                });
            }
        })
    }

    /// An override: its default (pipeline constants are not part of optik's API).
    fn override_value(&mut self, o: Handle<naga::Override>) -> LResult<Vec<Value>> {
        let module = self.env.module;
        let ov = &module.overrides[o];
        match ov.init {
            Some(init) => self.global_expr(init),
            None => Err(LowerError {
                span: module.overrides.get_span(o),
                message: format!(
                    "override `{}` has no default value; optik sets no pipeline constants, so every override needs one",
                    ov.name.as_deref().unwrap_or("?")
                ),
            }),
        }
    }

    fn global_variable(&mut self, g: Handle<naga::GlobalVariable>) -> LResult<Lowered> {
        let var = &self.env.module.global_variables[g];
        match var.space {
            naga::AddressSpace::Handle => match &var.binding {
                Some(b) => Ok(Lowered::Resource(b.binding)),
                None => Err(LowerError::unspanned(
                    "a texture or sampler without a binding",
                )),
            },
            naga::AddressSpace::Uniform | naga::AddressSpace::Storage { .. } => {
                let (base, len) = self.buffers[&g];
                Ok(Lowered::Place(Place::Memory(MemPlace {
                    base,
                    offset: 0,
                    dynamic: None,
                    checked: Some(super::place::Checked {
                        len,
                        guard: None,
                        proven: false,
                        given: self.env.given_bytes(g),
                    }),
                })))
            }
            naga::AddressSpace::Private => self
                .privates
                .get(&g)
                .cloned()
                .map(Lowered::Place)
                .ok_or_else(|| {
                    LowerError::unspanned(
                        "internal: a private global the program was not found to use",
                    )
                }),
            space => Err(LowerError::unspanned(format!(
                "global `{}` in address space {space:?} is not supported by the CPU JIT",
                var.name.as_deref().unwrap_or("?")
            ))),
        }
    }

    /// `base[index]` on a pointer (a place) or a value.
    fn access(&mut self, base: Handle<Expression>, index: Index) -> LResult<Lowered> {
        if self.is_pointer(base) {
            let place = self.place(base)?;
            let pointee = self.pointee(base)?;
            return Ok(Lowered::Place(self.step_place(&place, &pointee, index)?));
        }
        let ty = self.type_of(base).clone();
        let leaves = self.values(base)?;
        let types = self.env.types;
        let step = types.step(
            &ty,
            match index {
                Index::Const(k) => Some(k),
                Index::Dynamic(_) => None,
            },
        )?;
        let width = types.leaf_count(&step.child)? as usize;
        let i = match (step.member, index) {
            (Some((leaf, _)), _) => {
                return Ok(Lowered::Value(leaves[leaf as usize..][..width].to_vec()));
            }
            (None, Index::Const(k)) => {
                return Ok(Lowered::Value(
                    leaves[k as usize * width..][..width].to_vec(),
                ));
            }
            (None, Index::Dynamic(i)) => match self.int_konst(i) {
                Some(k) => {
                    let k = k.min(step.count.unwrap_or(1).saturating_sub(1)) as usize;
                    return Ok(Lowered::Value(leaves[k * width..][..width].to_vec()));
                }
                None => i,
            },
        };
        let count = step.count.unwrap_or(1);
        if count <= 16 {
            // A select chain over the elements, index clamped (naga's `Restrict`).
            let last = self.b.ins().iconst(I32, count as i64 - 1);
            let i = self.umin(i, last);
            let hits: Vec<Value> = (1..count)
                .map(|j| self.b.ins().icmp_imm_u(IntCC::Equal, i, j as i64))
                .collect();
            let out = (0..width)
                .map(|k| {
                    let mut acc = leaves[k];
                    for (j, &hit) in hits.iter().enumerate() {
                        acc = self.b.ins().select(hit, leaves[(j + 1) * width + k], acc);
                    }
                    acc
                })
                .collect();
            return Ok(Lowered::Value(out));
        }
        // A large array value: spill it to the stack and index the copy.
        let size = types.size(&ty);
        let slot = self.b.create_sized_stack_slot(StackSlotData::new(
            StackSlotKind::ExplicitSlot,
            size,
            4,
        ));
        let addr = self.b.ins().stack_addr(I64, slot, 0);
        let spilled = Place::Memory(MemPlace {
            base: addr,
            offset: 0,
            dynamic: None,
            checked: None,
        });
        self.store(&spilled, &ty, &leaves)?;
        let element = self.step_place(&spilled, &ty, Index::Dynamic(i))?;
        Ok(Lowered::Value(self.load(&element, &step.child)?))
    }

    fn unary(&mut self, op: UnaryOperator, leaf: Leaf, x: Value) -> Value {
        match (self.konst(x), op, leaf) {
            (Some(super::fold::Konst::Float(f)), UnaryOperator::Negate, _) => {
                return self.b.ins().f32const(-f);
            }
            (Some(super::fold::Konst::Int(i)), UnaryOperator::Negate, _) => {
                return self.int(i.wrapping_neg());
            }
            (Some(super::fold::Konst::Int(i)), UnaryOperator::LogicalNot, _)
            | (Some(super::fold::Konst::Int(i)), UnaryOperator::BitwiseNot, Leaf::Bool) => {
                return self.boolean(i == 0);
            }
            (Some(super::fold::Konst::Int(i)), UnaryOperator::BitwiseNot, _) => {
                return self.int(!i);
            }
            _ => {}
        }
        match (op, leaf) {
            (UnaryOperator::Negate, Leaf::F32) => self.b.ins().fneg(x),
            (UnaryOperator::Negate, _) => self.b.ins().ineg(x),
            (UnaryOperator::LogicalNot, _) => self.b.ins().bxor_imm_u(x, 1),
            (UnaryOperator::BitwiseNot, Leaf::Bool) => self.b.ins().bxor_imm_u(x, 1),
            (UnaryOperator::BitwiseNot, _) => self.b.ins().bnot(x),
        }
    }

    fn binary(
        &mut self,
        op: B,
        left: Handle<Expression>,
        right: Handle<Expression>,
    ) -> LResult<Vec<Value>> {
        let lt = self.type_of(left).clone();
        let rt = self.type_of(right).clone();
        let a = self.values(left)?;
        let c = self.values(right)?;
        if op == B::Multiply {
            match (&lt, &rt) {
                (TypeInner::Matrix { columns, rows, .. }, TypeInner::Vector { .. }) => {
                    return Ok(self.mat_vec(&a, *columns as usize, *rows as usize, &c));
                }
                (TypeInner::Vector { .. }, TypeInner::Matrix { columns, rows, .. }) => {
                    return Ok(self.vec_mat(&a, &c, *columns as usize, *rows as usize));
                }
                (
                    TypeInner::Matrix {
                        columns: k, rows, ..
                    },
                    TypeInner::Matrix { columns, .. },
                ) => {
                    return Ok(self.mat_mat(
                        &a,
                        *k as usize,
                        *rows as usize,
                        &c,
                        *columns as usize,
                    ));
                }
                _ => {}
            }
        }
        let leaf = leaf_of(&lt)?;
        let n = a.len().max(c.len());
        Ok((0..n)
            .map(|i| {
                let x = if a.len() == 1 { a[0] } else { a[i] };
                let y = if c.len() == 1 { c[0] } else { c[i] };
                self.scalar_binary(op, leaf, x, y)
            })
            .collect())
    }

    /// One WGSL binary operation on scalars of kind `leaf`.
    pub(super) fn scalar_binary(&mut self, op: B, leaf: Leaf, x: Value, y: Value) -> Value {
        if let Some(folded) = self.fold_binary(op, leaf, x, y) {
            return folded;
        }
        let ins = self.b.ins();
        match (op, leaf) {
            (B::Add, Leaf::F32) => ins.fadd(x, y),
            (B::Add, _) => ins.iadd(x, y),
            (B::Subtract, Leaf::F32) => ins.fsub(x, y),
            (B::Subtract, _) => ins.isub(x, y),
            (B::Multiply, Leaf::F32) => ins.fmul(x, y),
            (B::Multiply, _) => ins.imul(x, y),
            (B::Divide, Leaf::F32) => ins.fdiv(x, y),
            (B::Divide, _) => {
                let d = self.safe_divisor(leaf, x, y);
                if leaf.is_signed() {
                    self.b.ins().sdiv(x, d)
                } else {
                    self.b.ins().udiv(x, d)
                }
            }
            (B::Modulo, Leaf::F32) => {
                // WGSL's float `%` truncates: x - y * trunc(x / y).
                let q = ins.fdiv(x, y);
                let t = self.b.ins().trunc(q);
                let p = self.b.ins().fmul(y, t);
                self.b.ins().fsub(x, p)
            }
            (B::Modulo, _) => {
                let d = self.safe_divisor(leaf, x, y);
                if leaf.is_signed() {
                    self.b.ins().srem(x, d)
                } else {
                    self.b.ins().urem(x, d)
                }
            }
            (B::Equal, Leaf::F32) => ins.fcmp(FloatCC::Equal, x, y),
            (B::NotEqual, Leaf::F32) => ins.fcmp(FloatCC::NotEqual, x, y),
            (B::Less, Leaf::F32) => ins.fcmp(FloatCC::LessThan, x, y),
            (B::LessEqual, Leaf::F32) => ins.fcmp(FloatCC::LessThanOrEqual, x, y),
            (B::Greater, Leaf::F32) => ins.fcmp(FloatCC::GreaterThan, x, y),
            (B::GreaterEqual, Leaf::F32) => ins.fcmp(FloatCC::GreaterThanOrEqual, x, y),
            (B::Equal, _) => ins.icmp(IntCC::Equal, x, y),
            (B::NotEqual, _) => ins.icmp(IntCC::NotEqual, x, y),
            (B::Less, Leaf::I32) => ins.icmp(IntCC::SignedLessThan, x, y),
            (B::LessEqual, Leaf::I32) => ins.icmp(IntCC::SignedLessThanOrEqual, x, y),
            (B::Greater, Leaf::I32) => ins.icmp(IntCC::SignedGreaterThan, x, y),
            (B::GreaterEqual, Leaf::I32) => ins.icmp(IntCC::SignedGreaterThanOrEqual, x, y),
            (B::Less, _) => ins.icmp(IntCC::UnsignedLessThan, x, y),
            (B::LessEqual, _) => ins.icmp(IntCC::UnsignedLessThanOrEqual, x, y),
            (B::Greater, _) => ins.icmp(IntCC::UnsignedGreaterThan, x, y),
            (B::GreaterEqual, _) => ins.icmp(IntCC::UnsignedGreaterThanOrEqual, x, y),
            (B::And | B::LogicalAnd, _) => ins.band(x, y),
            (B::InclusiveOr | B::LogicalOr, _) => ins.bor(x, y),
            (B::ExclusiveOr, _) => ins.bxor(x, y),
            // Cranelift masks shift amounts to the width, as WGSL requires.
            (B::ShiftLeft, _) => ins.ishl(x, y),
            (B::ShiftRight, Leaf::I32) => ins.sshr(x, y),
            (B::ShiftRight, _) => ins.ushr(x, y),
        }
    }

    /// The divisor WGSL's integer `/` and `%` use: 1 where Cranelift would trap (zero, and
    /// `MIN / -1`), which gives `x / 0 = x`, `x % 0 = 0` and `MIN / -1 = MIN`.
    fn safe_divisor(&mut self, leaf: Leaf, x: Value, y: Value) -> Value {
        let one = self.b.ins().iconst(I32, 1);
        let zero = self.b.ins().icmp_imm_u(IntCC::Equal, y, 0);
        let bad = if leaf.is_signed() {
            let min = self
                .b
                .ins()
                .icmp_imm_u(IntCC::Equal, x, i32::MIN as u32 as i64);
            let minus_one = self.b.ins().icmp_imm_u(IntCC::Equal, y, u32::MAX as i64);
            let overflow = self.b.ins().band(min, minus_one);
            self.b.ins().bor(zero, overflow)
        } else {
            zero
        };
        self.b.ins().select(bad, one, y)
    }

    /// `m * v`: `r[row] = sum over c of m[c][row] * v[c]`, summed left to right.
    fn mat_vec(&mut self, m: &[Value], columns: usize, rows: usize, v: &[Value]) -> Vec<Value> {
        (0..rows)
            .map(|r| {
                let mut acc = self.b.ins().fmul(m[r], v[0]);
                for c in 1..columns {
                    let p = self.b.ins().fmul(m[c * rows + r], v[c]);
                    acc = self.b.ins().fadd(acc, p);
                }
                acc
            })
            .collect()
    }

    /// `v * m`: `r[c] = dot(v, m[c])`.
    fn vec_mat(&mut self, v: &[Value], m: &[Value], columns: usize, rows: usize) -> Vec<Value> {
        (0..columns)
            .map(|c| self.dot(v, &m[c * rows..][..rows], Leaf::F32))
            .collect()
    }

    /// `a * b` for `a` with `k` columns of `rows` and `b` with `columns` columns of `k`.
    fn mat_mat(
        &mut self,
        a: &[Value],
        k: usize,
        rows: usize,
        b: &[Value],
        columns: usize,
    ) -> Vec<Value> {
        (0..columns)
            .flat_map(|c| self.mat_vec(a, k, rows, &b[c * k..][..k]))
            .collect()
    }

    /// `dot(a, b)` summed left to right.
    pub(super) fn dot(&mut self, a: &[Value], b: &[Value], leaf: Leaf) -> Value {
        let mut acc = self.scalar_binary(B::Multiply, leaf, a[0], b[0]);
        for i in 1..a.len() {
            let p = self.scalar_binary(B::Multiply, leaf, a[i], b[i]);
            acc = self.scalar_binary(B::Add, leaf, acc, p);
        }
        acc
    }

    fn relational(&mut self, fun: naga::RelationalFunction, v: &[Value]) -> Value {
        use naga::RelationalFunction as R;
        match fun {
            R::All => v[1..]
                .iter()
                .fold(v[0], |acc, &x| self.b.ins().band(acc, x)),
            R::Any => v[1..].iter().fold(v[0], |acc, &x| self.b.ins().bor(acc, x)),
            R::IsNan => self.b.ins().fcmp(FloatCC::Unordered, v[0], v[0]),
            R::IsInf => {
                let a = self.b.ins().fabs(v[0]);
                let inf = self.b.ins().f32const(f32::INFINITY);
                self.b.ins().fcmp(FloatCC::Equal, a, inf)
            }
        }
    }

    /// A WGSL conversion (`convert`) or bitcast of one leaf.
    fn convert(&mut self, x: Value, from: Leaf, to: Leaf, convert: bool) -> Value {
        if from != to
            && let Some(folded) = self.fold_convert(x, from, to, convert)
        {
            return folded;
        }
        let ins = self.b.ins();
        match (from, to, convert) {
            (a, b, _) if a == b => x,
            (Leaf::F32, Leaf::I32 | Leaf::U32, false) => ins.bitcast(I32, MemFlagsData::new(), x),
            (Leaf::I32 | Leaf::U32, Leaf::F32, false) => ins.bitcast(F32, MemFlagsData::new(), x),
            (Leaf::I32 | Leaf::U32, Leaf::I32 | Leaf::U32, _) => x,
            // Saturating, NaN to 0: Rust's `as`.
            (Leaf::F32, Leaf::I32, true) => ins.fcvt_to_sint_sat(I32, x),
            (Leaf::F32, Leaf::U32, true) => ins.fcvt_to_uint_sat(I32, x),
            (Leaf::I32, Leaf::F32, true) => ins.fcvt_from_sint(F32, x),
            (Leaf::U32, Leaf::F32, true) => ins.fcvt_from_uint(F32, x),
            (Leaf::F32, Leaf::Bool, _) => {
                let zero = ins.f32const(0.0);
                self.b.ins().fcmp(FloatCC::NotEqual, x, zero)
            }
            (_, Leaf::Bool, _) => ins.icmp_imm_u(IntCC::NotEqual, x, 0),
            (Leaf::Bool, Leaf::F32, _) => {
                let one = ins.f32const(1.0);
                let zero = self.b.ins().f32const(0.0);
                self.b.ins().select(x, one, zero)
            }
            (Leaf::Bool, _, _) => ins.uextend(I32, x),
            (Leaf::F32, Leaf::F32, _) => x,
        }
    }

    /// `arrayLength(p)`: whole elements of the runtime-sized array in the bound bytes.
    fn array_length(&mut self, pointer: Handle<Expression>) -> LResult<Value> {
        let Place::Memory(m) = self.place(pointer)? else {
            return Err(LowerError::unspanned(
                "arrayLength of a value held in registers",
            ));
        };
        let (TypeInner::Array { stride, .. }, Some(checked)) = (self.pointee(pointer)?, m.checked)
        else {
            return Err(LowerError::unspanned(
                "arrayLength of something other than a buffer's runtime-sized array",
            ));
        };
        let count = self.runtime_count(checked.len, m.offset, stride);
        // Clamped to u32 (a bound length over 4 GiB of elements).
        let max = self.b.ins().iconst(I64, u32::MAX as i64);
        let count = self.b.ins().umin(count, max);
        Ok(self.b.ins().ireduce(I32, count))
    }
}

/// The name of an expression kind for error messages.
pub(super) fn expression_name(e: &Expression) -> String {
    let debug = format!("{e:?}");
    debug
        .split([' ', '(', '{'])
        .next()
        .unwrap_or("?")
        .to_string()
}
