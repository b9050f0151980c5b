//! Places: what a pointer expression lowers to, and loads, stores and atomics through them.
//!
//! - Variables whose type holds no array (scalars, vectors, matrices, structs of those), or
//!   only small arrays, live in Cranelift `Variable`s, one per leaf, which gives register allocation for free
//!   (Cranelift has no mem2reg). A runtime index into one (a vector component, a matrix
//!   column, `m[i][j]`) is an absolute leaf index with the list of leaves it may name;
//!   loads and stores through it become `select` chains.
//! - Everything else is memory: stack slots (arrays in function or private memory) and
//!   buffers, as base + static offset + dynamic offset.
//!
//! Bounds (WGSL leaves the choice to the implementation; these are naga's policies):
//! - function and private memory: `Restrict`: a runtime index is clamped to the last
//!   element, so every access stays inside the variable;
//! - uniform and storage buffers: `ReadZeroSkipWrite`: an index past its array (or vector)
//!   or an access past the bound length makes a load read zero and a store or atomic do
//!   nothing (an atomic then returns zero). Out of bounds, a load reads a static zero page
//!   and a store writes a scratch slot instead, their address chosen in a cold block (the
//!   access itself is not branched around); atomics branch around the access.

use super::types::{Layout, Leaf};
use super::{LResult, LowerError, Lowerer};
use crate::program::host::ZERO_PAGE_BYTES;
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::types::{I8, I32, I64};
use cranelift_codegen::ir::{
    AtomicRmwOp, InstBuilder, MemFlagsData, StackSlotData, StackSlotKind, Value,
};
use cranelift_frontend::Variable;
use naga::TypeInner;
use std::rc::Rc;

/// Where a pointer points.
#[derive(Clone)]
pub(crate) enum Place {
    Vars(VarPlace),
    Memory(MemPlace),
}

/// Leaves of a variable held in Cranelift variables.
#[derive(Clone)]
pub(crate) struct VarPlace {
    pub vars: Rc<[Variable]>,
    /// First leaf pointed to (when `dynamic` is `None`).
    pub leaf: u32,
    pub dynamic: Option<DynLeaf>,
}

/// A leaf index known only at run time.
#[derive(Clone)]
pub(crate) struct DynLeaf {
    /// The absolute first leaf (i32).
    pub index: Value,
    /// Every value `index` may have.
    pub candidates: Rc<[u32]>,
}

/// Memory at `base + offset + dynamic`.
#[derive(Clone)]
pub(crate) struct MemPlace {
    pub base: Value,
    pub offset: i64,
    /// Extra byte offset (i64).
    pub dynamic: Option<Value>,
    /// For buffers: the bound length and the in-bounds condition of runtime indices.
    pub checked: Option<Checked>,
}

/// The bounds of a buffer access.
#[derive(Clone, Copy)]
pub(crate) struct Checked {
    /// Bytes bound (i64).
    pub len: Value,
    /// Whether every runtime index so far is inside its array (i8), if any was checked.
    pub guard: Option<Value>,
    /// Whether `guard` already proves the whole access lies inside the buffer (it checked
    /// an element of a runtime-sized array, and everything deeper lies inside that element).
    pub proven: bool,
    /// Bytes at the buffer's start that every call binds and nothing changes during it
    /// (`ModuleEnv::given_bytes`: the params'): an access at a constant offset inside them
    /// is not checked, and its loads may be merged and hoisted out of loops.
    pub given: u32,
}

/// One level of indexing.
#[derive(Clone, Copy)]
pub(crate) enum Index {
    Const(u32),
    /// A runtime index (i32 or u32 bits; negative i32 counts as huge).
    Dynamic(Value),
}

/// Variables with arrays of up to this many leaves in all are held in registers too: with
/// constant indices (unrolled loops) they cost nothing; a runtime index costs a `select`
/// per candidate element, still cheaper than a stack round trip at this size.
const MAX_ARRAY_LEAVES: u32 = 16;

fn stack_flags() -> MemFlagsData {
    MemFlagsData::trusted()
}

fn buffer_flags() -> MemFlagsData {
    // Every access is bounds-checked or redirected to the zero page, so none traps; user
    // buffers carry no alignment promise.
    MemFlagsData::new().with_notrap()
}

impl Lowerer<'_, '_> {
    /// A new function or private variable of type `inner`, set to `init` or zero.
    pub(super) fn new_variable(
        &mut self,
        inner: &TypeInner,
        init: Option<Vec<Value>>,
    ) -> LResult<Place> {
        let types = self.env.types;
        let layout = types.layout(inner)?;
        if types.is_register_type(inner)
            || types.leaf_count(inner).is_ok_and(|n| n <= MAX_ARRAY_LEAVES)
        {
            let vars: Vec<Variable> = layout
                .leaves
                .iter()
                .map(|(_, l)| self.b.declare_var(l.clif()))
                .collect();
            let values = match init {
                Some(v) => v,
                None => self.zeros(&layout),
            };
            for (var, v) in vars.iter().zip(values) {
                self.b.def_var(*var, v);
            }
            return Ok(Place::Vars(VarPlace {
                vars: vars.into(),
                leaf: 0,
                dynamic: None,
            }));
        }
        let size = types.size(inner).max(4);
        let slot = self.b.create_sized_stack_slot(StackSlotData::new(
            StackSlotKind::ExplicitSlot,
            size,
            4,
        ));
        let base = self.b.ins().stack_addr(I64, slot, 0);
        let place = MemPlace {
            base,
            offset: 0,
            dynamic: None,
            checked: None,
        };
        match init {
            Some(values) => self.store_memory(&place, &layout, &values),
            None => self.zero_memory(base, size),
        }
        Ok(Place::Memory(place))
    }

    /// Zero leaves of a layout.
    pub(super) fn zeros(&mut self, layout: &Layout) -> Vec<Value> {
        layout.leaves.iter().map(|(_, l)| self.zero(*l)).collect()
    }

    pub(super) fn zero(&mut self, leaf: Leaf) -> Value {
        match leaf {
            Leaf::F32 => self.b.ins().f32const(0.0),
            other => self.b.ins().iconst(other.clif(), 0),
        }
    }

    fn zero_memory(&mut self, base: Value, size: u32) {
        if size <= 256 {
            let zero = self.b.ins().iconst(I32, 0);
            for at in (0..size).step_by(4) {
                self.b.ins().store(stack_flags(), zero, base, at as i32);
            }
        } else {
            let zero = self.b.ins().iconst(I8, 0);
            let len = self.b.ins().iconst(I64, size as i64);
            let frontend = self.env.frontend;
            self.b.call_memset(frontend, base, zero, len);
        }
    }

    /// The place one index further into `place`, which points to a `pointee`.
    pub(super) fn step_place(
        &mut self,
        place: &Place,
        pointee: &TypeInner,
        index: Index,
    ) -> LResult<Place> {
        let types = self.env.types;
        let index = self.constant_index(place, pointee, index);
        let step = types.step(
            pointee,
            match index {
                Index::Const(k) => Some(k),
                Index::Dynamic(_) => None,
            },
        )?;
        match place {
            Place::Vars(v) => {
                let mut v = v.clone();
                let delta = match (step.member, index) {
                    (Some((leaf, _)), _) => Some(leaf),
                    (None, Index::Const(k)) => Some(k * step.leaf_stride),
                    (None, Index::Dynamic(_)) => None,
                };
                if let Some(delta) = delta {
                    v.leaf += delta;
                    if let Some(d) = &mut v.dynamic {
                        d.index = self.b.ins().iadd_imm_u(d.index, delta as i64);
                        d.candidates = d.candidates.iter().map(|c| c + delta).collect();
                    }
                    return Ok(Place::Vars(v));
                }
                let Index::Dynamic(i) = index else {
                    unreachable!("constant indices handled above")
                };
                let count = step
                    .count
                    .ok_or_else(|| LowerError::unspanned("a runtime-sized array in a variable"))?;
                let clamped = self.clamp_index(i, count);
                let scaled = self.b.ins().imul_imm_u(clamped, step.leaf_stride as i64);
                let (start, starts): (Value, Vec<u32>) = match &v.dynamic {
                    Some(d) => (d.index, d.candidates.to_vec()),
                    None => (self.b.ins().iconst(I32, v.leaf as i64), vec![v.leaf]),
                };
                let index = self.b.ins().iadd(start, scaled);
                let candidates = starts
                    .iter()
                    .flat_map(|s| (0..count).map(move |j| s + j * step.leaf_stride))
                    .collect();
                v.dynamic = Some(DynLeaf { index, candidates });
                Ok(Place::Vars(v))
            }
            Place::Memory(m) => {
                let mut m = m.clone();
                match (step.member, index) {
                    (Some((_, bytes)), _) => m.offset += bytes as i64,
                    (None, Index::Const(k)) => {
                        m.offset += k as i64 * step.byte_stride as i64;
                        if step.count.is_none() {
                            self.check_runtime_element(&mut m, step.byte_stride);
                        }
                    }
                    (None, Index::Dynamic(i)) => {
                        let i = match (&m.checked, step.count) {
                            (Some(_), _) => i,
                            (None, Some(count)) => self.clamp_index(i, count),
                            (None, None) => {
                                return Err(LowerError::unspanned(
                                    "a runtime-sized array outside a buffer",
                                ));
                            }
                        };
                        let wide = self.b.ins().uextend(I64, i);
                        let bytes = self.b.ins().imul_imm_u(wide, step.byte_stride as i64);
                        if let (None, None, Some(checked)) = (step.count, m.dynamic, m.checked) {
                            // An element of a runtime-sized array at a fixed offset (the usual
                            // case): `i < arrayLength`, whose count is computed once per
                            // function (Cranelift merges the equal computations).
                            let count = self.runtime_count(checked.len, m.offset, step.byte_stride);
                            let inside = self.b.ins().icmp(IntCC::UnsignedLessThan, wide, count);
                            m.dynamic = Some(bytes);
                            self.add_guard(&mut m, inside);
                            if let Some(checked) = &mut m.checked {
                                checked.proven = true;
                            }
                            return Ok(Place::Memory(m));
                        }
                        m.dynamic = Some(match m.dynamic {
                            Some(d) => self.b.ins().iadd(d, bytes),
                            None => bytes,
                        });
                        match step.count {
                            Some(count) if m.checked.is_some() => {
                                let inside = self.b.ins().icmp_imm_u(
                                    IntCC::UnsignedLessThan,
                                    i,
                                    count as i64,
                                );
                                self.add_guard(&mut m, inside);
                            }
                            None => self.check_runtime_element(&mut m, step.byte_stride),
                            Some(_) => {}
                        }
                    }
                }
                Ok(Place::Memory(m))
            }
        }
    }

    /// `min(i, count - 1)` as u32: naga's `Restrict` policy.
    fn clamp_index(&mut self, i: Value, count: u32) -> Value {
        let last = self.b.ins().iconst(I32, count.saturating_sub(1) as i64);
        self.umin(i, last)
    }

    /// A runtime index that folded to a constant, as a constant index where that means
    /// the same: clamped in function and private memory; in buffers, only when in bounds
    /// (an out-of-bounds constant keeps the runtime path, whose guard is then false).
    fn constant_index(&self, place: &Place, pointee: &TypeInner, index: Index) -> Index {
        let Index::Dynamic(v) = index else {
            return index;
        };
        let Some(k) = self.int_konst(v) else {
            return index;
        };
        let count = match *pointee {
            TypeInner::Vector { size, .. } => Some(size as u32),
            TypeInner::Matrix { columns, .. } => Some(columns as u32),
            TypeInner::Array {
                size: naga::ArraySize::Constant(n),
                ..
            } => Some(n.get()),
            TypeInner::Array { .. } => None,
            _ => return index,
        };
        let checked = matches!(
            place,
            Place::Memory(MemPlace {
                checked: Some(_),
                ..
            })
        );
        match (count, checked) {
            (Some(n), false) => Index::Const(k.min(n.saturating_sub(1))),
            (Some(n), true) if k < n => Index::Const(k),
            (None, true) => Index::Const(k),
            _ => index,
        }
    }

    /// Guards an element of a runtime-sized array: it must end inside the buffer (the
    /// same as `index < arrayLength`).
    fn check_runtime_element(&mut self, m: &mut MemPlace, stride: u32) {
        let Some(checked) = m.checked else { return };
        let end = self.end_offset(m, stride);
        let inside = self
            .b
            .ins()
            .icmp(IntCC::UnsignedLessThanOrEqual, end, checked.len);
        self.add_guard(m, inside);
    }

    /// Whole elements of `stride` bytes between byte `offset` and the bound length `len`
    /// (i64): `arrayLength` of a runtime-sized array at `offset`.
    pub(super) fn runtime_count(&mut self, len: Value, offset: i64, stride: u32) -> Value {
        let offset = self.b.ins().iconst(I64, offset);
        let after = self.b.ins().icmp(IntCC::UnsignedGreaterThan, len, offset);
        let rest = self.b.ins().isub(len, offset);
        let none = self.b.ins().iconst(I64, 0);
        let past = self.b.ins().select(after, rest, none);
        self.b.ins().udiv_imm_u(past, stride as i64)
    }

    fn add_guard(&mut self, m: &mut MemPlace, inside: Value) {
        if let Some(checked) = &mut m.checked {
            checked.guard = Some(match checked.guard {
                Some(g) => self.b.ins().band(g, inside),
                None => inside,
            });
        }
    }

    /// Whether an access of `size` bytes at `m` lies at a constant offset inside its
    /// buffer's given bytes ([`Checked::given`]).
    fn inside_given(m: &MemPlace, size: u32) -> bool {
        m.checked.is_some_and(|c| {
            c.guard.is_none() && m.dynamic.is_none() && m.offset + size as i64 <= c.given as i64
        })
    }

    /// `offset + dynamic + size` (i64).
    fn end_offset(&mut self, m: &MemPlace, size: u32) -> Value {
        let fixed = m.offset + size as i64;
        match m.dynamic {
            Some(d) => self.b.ins().iadd_imm_u(d, fixed),
            None => self.b.ins().iconst(I64, fixed),
        }
    }

    /// Whether an access of `size` bytes at `m` is in bounds (i8), for checked places that
    /// may not be.
    fn in_bounds(&mut self, m: &MemPlace, size: u32) -> Option<Value> {
        let checked = m.checked?;
        if Self::inside_given(m, size) {
            return None;
        }
        self.bounds_checks += self.live as usize;
        if let (true, Some(guard)) = (checked.proven, checked.guard) {
            return Some(guard);
        }
        let end = self.end_offset(m, size);
        let fits = self
            .b
            .ins()
            .icmp(IntCC::UnsignedLessThanOrEqual, end, checked.len);
        Some(match checked.guard {
            Some(g) => self.b.ins().band(g, fits),
            None => fits,
        })
    }

    /// `base + dynamic` (the static offset stays in the instructions' immediates).
    fn base_plus_dynamic(&mut self, m: &MemPlace) -> Value {
        match m.dynamic {
            Some(d) => self.b.ins().iadd(m.base, d),
            None => m.base,
        }
    }

    /// `m` with its static offset small enough for instruction immediates (a constant index
    /// far into a runtime-sized array moves it to the dynamic part).
    fn small_offset(&mut self, m: &MemPlace) -> MemPlace {
        if m.offset < (1 << 30) {
            return m.clone();
        }
        let offset = self.b.ins().iconst(I64, m.offset);
        let dynamic = match m.dynamic {
            Some(d) => self.b.ins().iadd(d, offset),
            None => offset,
        };
        MemPlace {
            dynamic: Some(dynamic),
            offset: 0,
            ..m.clone()
        }
    }

    /// The full address of a memory place.
    pub(super) fn address(&mut self, m: &MemPlace) -> Value {
        let base = self.base_plus_dynamic(m);
        self.b.ins().iadd_imm_u(base, m.offset)
    }

    /// Loads the value of type `pointee` at `place`.
    pub(super) fn load(&mut self, place: &Place, pointee: &TypeInner) -> LResult<Vec<Value>> {
        let layout = self.env.types.layout(pointee)?;
        match place {
            Place::Vars(v) => Ok(self.load_vars(v, layout.len())),
            Place::Memory(m) => {
                let m = &self.small_offset(m);
                let size = self.env.types.size(pointee);
                let mut addr = self.base_plus_dynamic(m);
                let flags = if Self::inside_given(m, size) {
                    // Bound and unchanged for the call: a pure value.
                    buffer_flags().with_readonly().with_can_move()
                } else if m.checked.is_some() {
                    buffer_flags()
                } else {
                    stack_flags()
                };
                if let Some(ok) = self.in_bounds(m, size) {
                    if size > ZERO_PAGE_BYTES {
                        return Err(LowerError::unspanned(format!(
                            "loading {size} bytes from a buffer at once (at most {ZERO_PAGE_BYTES} can be)"
                        )));
                    }
                    // Out of bounds: read the zero page, at the same static offsets.
                    addr = self
                        .in_bounds_or(ok, addr, |s| s.b.ins().iadd_imm_s(s.zero_page, -m.offset));
                }
                Ok(layout
                    .leaves
                    .iter()
                    .map(|&(off, leaf)| {
                        let at = m.offset + off as i64;
                        if layout.atomic {
                            let p = self.b.ins().iadd_imm_s(addr, at);
                            self.b.ins().atomic_load(leaf.clif(), flags, p)
                        } else {
                            self.b.ins().load(leaf.clif(), flags, addr, at as i32)
                        }
                    })
                    .collect())
            }
        }
    }

    /// `addr` when `ok`, else the address `outside` makes (the zero page for loads, the
    /// scratch slot for stores). A branch to a cold block rather than a `select`: the
    /// access's address then does not wait for the bounds check (the CPU predicts it),
    /// which made compiled programs 8–13 % faster (docs/cpu-backend.md §8, "JIT'd programs
    /// against Rust").
    fn in_bounds_or(
        &mut self,
        ok: Value,
        addr: Value,
        outside: impl FnOnce(&mut Self) -> Value,
    ) -> Value {
        if !self.live {
            // Unreachable code: the access never runs.
            return addr;
        }
        let (cold, after) = (self.b.create_block(), self.b.create_block());
        let chosen = self.b.append_block_param(after, I64);
        self.live_blocks.extend([cold, after]);
        self.b.set_cold_block(cold);
        self.b.ins().brif(ok, after, &[addr.into()], cold, &[]);
        self.b.seal_block(cold);
        self.enter(cold);
        let other = outside(self);
        self.goto(after, &[other.into()]);
        self.b.seal_block(after);
        self.enter(after);
        chosen
    }

    fn load_vars(&mut self, v: &VarPlace, n: usize) -> Vec<Value> {
        match &v.dynamic {
            None => (0..n)
                .map(|k| self.b.use_var(v.vars[v.leaf as usize + k]))
                .collect(),
            Some(d) => {
                let hits: Vec<(u32, Value)> = d
                    .candidates
                    .iter()
                    .map(|&c| (c, self.b.ins().icmp_imm_u(IntCC::Equal, d.index, c as i64)))
                    .collect();
                (0..n)
                    .map(|k| {
                        let mut acc = self.b.use_var(v.vars[hits[0].0 as usize + k]);
                        for &(c, hit) in &hits[1..] {
                            let x = self.b.use_var(v.vars[c as usize + k]);
                            acc = self.b.ins().select(hit, x, acc);
                        }
                        acc
                    })
                    .collect()
            }
        }
    }

    /// Stores `values` (of type `pointee`) at `place`.
    pub(super) fn store(
        &mut self,
        place: &Place,
        pointee: &TypeInner,
        values: &[Value],
    ) -> LResult<()> {
        let layout = self.env.types.layout(pointee)?;
        match place {
            Place::Vars(v) => {
                match &v.dynamic {
                    None => {
                        for (k, &x) in values.iter().enumerate() {
                            self.b.def_var(v.vars[v.leaf as usize + k], x);
                        }
                    }
                    Some(d) => {
                        for &c in d.candidates.iter() {
                            let hit = self.b.ins().icmp_imm_u(IntCC::Equal, d.index, c as i64);
                            for (k, &x) in values.iter().enumerate() {
                                let var = v.vars[c as usize + k];
                                let old = self.b.use_var(var);
                                let new = self.b.ins().select(hit, x, old);
                                self.b.def_var(var, new);
                            }
                        }
                    }
                }
                Ok(())
            }
            Place::Memory(m) => {
                let m = &self.small_offset(m);
                let size = self.env.types.size(pointee);
                match self.in_bounds(m, size) {
                    None => self.store_memory(m, &layout, values),
                    Some(ok) if size <= super::SCRATCH_BYTES && !layout.atomic => {
                        // Out of bounds: write the scratch slot instead. The store itself
                        // is not branched around, so Cranelift does not duplicate the stored
                        // value's computation into both paths.
                        let addr = self.base_plus_dynamic(m);
                        let addr = self.in_bounds_or(ok, addr, |s| {
                            let scratch = s.scratch_addr();
                            s.b.ins().iadd_imm_s(scratch, -m.offset)
                        });
                        for (&(off, _), &x) in layout.leaves.iter().zip(values) {
                            self.b.ins().store(
                                buffer_flags(),
                                x,
                                addr,
                                (m.offset + off as i64) as i32,
                            );
                        }
                    }
                    Some(ok) => {
                        let store = self.b.create_block();
                        let after = self.b.create_block();
                        self.branch(ok, store, after);
                        self.b.seal_block(store);
                        self.enter(store);
                        self.store_memory(m, &layout, values);
                        self.goto(after, &[]);
                        self.b.seal_block(after);
                        self.enter(after);
                    }
                }
                Ok(())
            }
        }
    }

    fn store_memory(&mut self, m: &MemPlace, layout: &Layout, values: &[Value]) {
        let addr = self.base_plus_dynamic(m);
        let flags = if m.checked.is_some() {
            buffer_flags()
        } else {
            stack_flags()
        };
        for (&(off, _), &x) in layout.leaves.iter().zip(values) {
            let at = m.offset + off as i64;
            if layout.atomic {
                let p = self.b.ins().iadd_imm_s(addr, at);
                self.b.ins().atomic_store(flags, x, p);
            } else {
                self.b.ins().store(flags, x, addr, at as i32);
            }
        }
    }

    /// An atomic read-modify-write (or compare-exchange when `compare` is given) on the
    /// 32-bit integer at `place`; returns the old value (and whether it exchanged). Out of
    /// bounds it does nothing and returns zero (and false).
    pub(super) fn atomic(
        &mut self,
        place: &Place,
        fun: &naga::AtomicFunction,
        signed: bool,
        value: Value,
        compare: Option<Value>,
    ) -> LResult<Vec<Value>> {
        let Place::Memory(m) = place else {
            return Err(LowerError::unspanned("an atomic outside a buffer"));
        };
        let ok = self.in_bounds(m, 4);
        let (body, after) = (self.b.create_block(), self.b.create_block());
        let old = self.b.append_block_param(after, I32);
        let exchanged = self.b.append_block_param(after, I8);
        if !self.live {
            self.end_dead_block();
        } else if let Some(ok) = ok {
            self.live_blocks.extend([body, after]);
            let zero = self.b.ins().iconst(I32, 0);
            let no = self.b.ins().iconst(I8, 0);
            self.b
                .ins()
                .brif(ok, body, &[], after, &[zero.into(), no.into()]);
        } else {
            self.live_blocks.insert(body);
            self.b.ins().jump(body, &[]);
        }
        self.b.seal_block(body);
        self.enter(body);
        let addr = self.address(m);
        let flags = buffer_flags();
        let (result, did) = match (fun, compare) {
            (naga::AtomicFunction::Exchange { compare: Some(_) }, Some(expected)) => {
                let old = self.b.ins().atomic_cas(flags, addr, expected, value);
                let did = self.b.ins().icmp(IntCC::Equal, old, expected);
                (old, did)
            }
            _ => {
                use naga::AtomicFunction as A;
                let op = match fun {
                    A::Add => AtomicRmwOp::Add,
                    A::Subtract => AtomicRmwOp::Sub,
                    A::And => AtomicRmwOp::And,
                    A::ExclusiveOr => AtomicRmwOp::Xor,
                    A::InclusiveOr => AtomicRmwOp::Or,
                    A::Min if signed => AtomicRmwOp::Smin,
                    A::Min => AtomicRmwOp::Umin,
                    A::Max if signed => AtomicRmwOp::Smax,
                    A::Max => AtomicRmwOp::Umax,
                    A::Exchange { .. } => AtomicRmwOp::Xchg,
                };
                let old = self.b.ins().atomic_rmw(I32, flags, op, addr, value);
                (old, self.b.ins().iconst(I8, 0))
            }
        };
        self.goto(after, &[result.into(), did.into()]);
        self.b.seal_block(after);
        self.enter(after);
        Ok(match compare {
            Some(_) => vec![old, exchanged],
            None => vec![old],
        })
    }
}
