//! Lowering one program from naga IR to a Cranelift function.
//!
//! The program and every function it calls become one Cranelift function: calls are
//! inlined at the naga level (naga forbids recursion, so this ends), each inlined call in a
//! fresh [`Frame`] whose `return` jumps to a continuation block. Values are flat lists of
//! scalar leaves ([`types`]); pointers are [`Place`]s ([`place`]). Statements lower in
//! [`stmt`], expressions in [`expr`], numeric built-ins in [`math`], device functions and
//! textures in [`device`].
//!
//! The function's signature is `extern "C" fn(ctx: *mut CallContext)` (see `host.rs`).
//! Its entry block reads the buffer table and the zero page from the context, loads the
//! base and length of every buffer the module declares (unused loads are dead code) and
//! initialises the private globals the program reaches.

mod device;
mod expr;
mod fold;
mod math;
mod place;
mod stmt;
pub(crate) mod types;

use super::abi::DeviceState;
use super::host::{CallContext, HostFn};
use cranelift_codegen::ir::types::I64;
use cranelift_codegen::ir::{
    self, AbiParam, Block, BlockArg, FuncRef, InstBuilder, MemFlagsData, StackSlot, StackSlotData,
    StackSlotKind, Value,
};
use cranelift_codegen::isa::TargetFrontendConfig;
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
pub(crate) use device::{inlinable_closest_hit, state_bits};
use naga::{Expression, Function, GlobalVariable, Handle};
use optik_core::frontend::{CompiledModule, DeviceFunction};
pub(crate) use place::Place;
use std::collections::{HashMap, HashSet};
use types::Types;

/// Why a construct could not be lowered, and where.
#[derive(Debug)]
pub(crate) struct LowerError {
    pub span: naga::Span,
    pub message: String,
}

impl LowerError {
    /// An error whose span a caller fills in.
    pub fn unspanned(message: impl Into<String>) -> Self {
        Self {
            span: naga::Span::UNDEFINED,
            message: message.into(),
        }
    }

    /// This error at `span`, unless it already has a span.
    pub fn or_span(mut self, span: naga::Span) -> Self {
        if !self.span.is_defined() {
            self.span = span;
        }
        self
    }
}

pub(crate) type LResult<T> = Result<T, LowerError>;

/// What the programs of one module share: the IR, its types and where things live.
pub(crate) struct ModuleEnv<'m> {
    pub module: &'m naga::Module,
    pub info: &'m naga::valid::ModuleInfo,
    pub types: Types<'m>,
    /// Prelude stubs by function.
    pub device_fns: HashMap<Handle<Function>, DeviceFunction>,
    /// The slot in the buffer table of each uniform and storage global.
    pub buffer_slots: HashMap<Handle<GlobalVariable>, u32>,
    pub frontend: TargetFrontendConfig,
}

impl<'m> ModuleEnv<'m> {
    pub fn new(compiled: &'m CompiledModule, frontend: TargetFrontendConfig) -> Self {
        let module = &compiled.module;
        let device_fns = DeviceFunction::ALL
            .into_iter()
            .filter(|&f| f != DeviceFunction::OffsetRay)
            .filter_map(|f| compiled.device_function(f).map(|h| (h, f)))
            .collect();
        let mut buffer_slots = HashMap::new();
        for (handle, var) in module.global_variables.iter() {
            if matches!(
                var.space,
                naga::AddressSpace::Uniform | naga::AddressSpace::Storage { .. }
            ) {
                let slot = buffer_slots.len() as u32;
                buffer_slots.insert(handle, slot);
            }
        }
        Self {
            module,
            info: &compiled.info,
            types: Types {
                arena: &module.types,
            },
            device_fns,
            buffer_slots,
            frontend,
        }
    }

    /// The binding number of each buffer slot, in slot order.
    pub fn slot_bindings(&self) -> Vec<Option<u32>> {
        let mut slots = vec![None; self.buffer_slots.len()];
        for (&g, &slot) in &self.buffer_slots {
            slots[slot as usize] = self.module.global_variables[g]
                .binding
                .as_ref()
                .map(|b| b.binding);
        }
        slots
    }
}

/// A lowered expression.
#[derive(Clone)]
pub(crate) enum Lowered {
    /// A value's leaves.
    Value(Vec<Value>),
    /// A pointer.
    Place(Place),
    /// A texture or sampler: its binding number.
    Resource(u32),
}

/// Where `break` and `continue` go.
enum Target {
    Loop {
        continuing: Block,
        exit: Block,
        /// For a copy of an unrolled loop: the nesting of runtime control flow at its start,
        /// and whether a `break` under runtime control flow was seen (the trip count is
        /// then not a constant and unrolling stops).
        unrolled: Option<(u32, bool)>,
    },
    Switch {
        exit: Block,
    },
}

/// One inlined function body.
struct Frame<'m> {
    function: &'m Function,
    info: &'m naga::valid::FunctionInfo,
    args: Vec<Lowered>,
    locals: HashMap<Handle<naga::LocalVariable>, Place>,
    /// Expressions lowered by `Emit` (and call and atomic results), by handle index.
    cache: Vec<Option<Lowered>>,
    /// The continuation a `return` jumps to (with the result leaves); `None` for the
    /// program itself, whose `return` jumps to the exit.
    ret: Option<Block>,
}

/// Lowers one program into a Cranelift function.
pub(crate) struct Lowerer<'m, 'b> {
    env: &'m ModuleEnv<'m>,
    b: FunctionBuilder<'b>,
    import: &'b mut dyn FnMut(HostFn, &mut ir::Function) -> FuncRef,
    imported: HashMap<HostFn, FuncRef>,
    ctx: Value,
    zero_page: Value,
    /// The address of the launch's stop flag (`CallContext::stop`), read at back-edges.
    stop: Value,
    buffers: HashMap<Handle<GlobalVariable>, (Value, Value)>,
    privates: HashMap<Handle<GlobalVariable>, Place>,
    exit: Block,
    targets: Vec<Target>,
    frames: Vec<Frame<'m>>,
    /// Stack memory for host calls' results and arguments passed by pointer.
    scratch: StackSlot,
    /// Whether the current block can be reached (lowering goes on in unreachable blocks
    /// after `break`, `return`, ...; they are dropped by Cranelift).
    live: bool,
    /// Blocks a reachable block jumps to.
    live_blocks: HashSet<Block>,
    /// How many runtime (not constant-folded) branches enclose the current statement.
    runtime_depth: u32,
    /// Expressions lowered so far: bounds the code loop unrolling may add.
    lowered_exprs: usize,
    /// The closest-hit program inlined after each `rt_trace` (see [`InlinedClosestHit`]).
    inlined_closest_hit: Option<InlinedClosestHit>,
    /// The state the code being lowered reads instead of the call's (`CallContext::state`):
    /// an inlined closest hit's.
    state_override: Option<Value>,
    /// The payload registers of the trace whose inlined closest hit is being lowered: the
    /// caller's `RtPayload` (its address and length), the registers the runtime would hand
    /// that program (a trace passes the caller's payload in place), so its payload accesses
    /// address them directly, their bounds known here.
    inlined_payload: Option<(Value, u32)>,
}

/// A closest-hit program compiled into its callers of `rt_trace`: when the runtime's trace
/// entry answers `TRACE_RUN_INLINED`, the caller runs the program's body right there, on
/// the state the entry wrote into `state` (a slot of the caller's frame), instead of the
/// runtime calling the program (docs/cpu-backend.md §8: the call cost more than the body).
#[derive(Clone, Copy)]
pub(crate) struct InlinedClosestHit {
    /// The program.
    pub function: Handle<Function>,
    /// Its own compiled code, by which the runtime recognises it.
    pub entry: FuncRef,
    /// Where the entry writes its state.
    pub state: StackSlot,
}

/// Bytes of the scratch slot: at least the largest host-call result (`rt_object_to_world`,
/// 48 bytes) or argument block (a 32-register payload spilled from registers, 128 bytes);
/// also where out-of-bounds buffer stores of up to this many bytes go.
pub(super) const SCRATCH_BYTES: u32 = 256;

/// Lowers the program `function` of `env` into `func` (whose signature is set here).
pub(crate) fn lower_program<'m>(
    env: &'m ModuleEnv<'m>,
    function: Handle<Function>,
    func: &mut ir::Function,
    fctx: &mut FunctionBuilderContext,
    import: &mut dyn FnMut(HostFn, &mut ir::Function) -> FuncRef,
    inline_closest_hit: Option<(Handle<Function>, FuncRef)>,
) -> LResult<()> {
    func.signature.params.push(AbiParam::new(I64));
    let mut b = FunctionBuilder::new(func, fctx);
    let entry = b.create_block();
    b.append_block_params_for_function_params(entry);
    b.switch_to_block(entry);
    b.seal_block(entry);
    let ctx = b.block_params(entry)[0];
    // Read-only for the call and movable: loads of slots a path does not use disappear.
    let table_flags = MemFlagsData::trusted().with_readonly().with_can_move();
    let table = b
        .ins()
        .load(I64, table_flags, ctx, CallContext::BUFFERS_OFFSET);
    let zero_page = b
        .ins()
        .load(I64, table_flags, ctx, CallContext::ZERO_PAGE_OFFSET);
    let stop = b
        .ins()
        .load(I64, table_flags, ctx, CallContext::STOP_OFFSET);
    let mut buffers = HashMap::new();
    // In slot order: the function's text must not depend on hash order, or the disk
    // cache (keyed by it) would miss.
    let mut slots: Vec<_> = env
        .buffer_slots
        .iter()
        .map(|(&g, &slot)| (slot, g))
        .collect();
    slots.sort_unstable_by_key(|&(slot, _)| slot);
    for (slot, global) in slots {
        let at = (slot * 16) as i32;
        let base = b.ins().load(I64, table_flags, table, at);
        let len = b.ins().load(I64, table_flags, table, at + 8);
        buffers.insert(global, (base, len));
    }
    let scratch = b.create_sized_stack_slot(StackSlotData::new(
        StackSlotKind::ExplicitSlot,
        SCRATCH_BYTES,
        4,
    ));
    let exit = b.create_block();
    let inlined_closest_hit = inline_closest_hit.map(|(function, entry)| InlinedClosestHit {
        function,
        entry,
        state: b.create_sized_stack_slot(StackSlotData::new(
            StackSlotKind::ExplicitSlot,
            std::mem::size_of::<DeviceState>() as u32,
            3,
        )),
    });
    let mut lowerer = Lowerer {
        env,
        b,
        import,
        imported: HashMap::new(),
        ctx,
        zero_page,
        stop,
        buffers,
        privates: HashMap::new(),
        exit,
        targets: Vec::new(),
        frames: Vec::new(),
        scratch,
        live: true,
        live_blocks: HashSet::new(),
        runtime_depth: 0,
        lowered_exprs: 0,
        inlined_closest_hit,
        state_override: None,
        inlined_payload: None,
    };
    lowerer.init_privates(function)?;
    let body = &env.module.functions[function];
    lowerer.push_frame(function, Vec::new(), None)?;
    lowerer.block(&body.body)?;
    lowerer.frames.pop();
    lowerer.goto(exit, &[]);
    lowerer.b.seal_block(exit);
    lowerer.enter(exit);
    lowerer.b.ins().return_(&[]);
    lowerer.b.seal_all_blocks();
    let frontend = env.frontend;
    lowerer.b.finalize(frontend);
    Ok(())
}

impl<'m, 'b> Lowerer<'m, 'b> {
    fn frame(&self) -> &Frame<'m> {
        self.frames.last().expect("lowering always has a frame")
    }

    fn frame_mut(&mut self) -> &mut Frame<'m> {
        self.frames.last_mut().expect("lowering always has a frame")
    }

    /// The function reference of a host function in the function being built.
    fn host(&mut self, f: HostFn) -> FuncRef {
        if let Some(&r) = self.imported.get(&f) {
            return r;
        }
        let r = (self.import)(f, self.b.func);
        self.imported.insert(f, r);
        r
    }

    /// Calls a host function; returns its results.
    fn call_host(&mut self, f: HostFn, args: &[Value]) -> Vec<Value> {
        let r = self.host(f);
        let inst = self.b.ins().call(r, args);
        self.b.inst_results(inst).to_vec()
    }

    /// The address of the scratch slot.
    fn scratch_addr(&mut self) -> Value {
        self.b.ins().stack_addr(I64, self.scratch, 0)
    }

    /// Continues lowering in a block nothing jumps to (after a `return`, `break`, ...).
    fn start_dead_block(&mut self) {
        let dead = self.b.create_block();
        self.b.switch_to_block(dead);
        self.b.seal_block(dead);
        self.live = false;
    }

    /// Jumps to `target`, which is reachable if the current block is. An unreachable block
    /// ends in a trap instead: a jump from it would give `target` a predecessor, and
    /// variables would need block parameters there, hiding constants from folding.
    fn goto(&mut self, target: Block, args: &[BlockArg]) {
        if self.live {
            self.live_blocks.insert(target);
            self.b.ins().jump(target, args);
        } else {
            self.end_dead_block();
        }
    }

    /// Branches on `c` to `then` or `other` (without block arguments).
    fn branch(&mut self, c: Value, then: Block, other: Block) {
        if self.live {
            self.live_blocks.extend([then, other]);
            self.b.ins().brif(c, then, &[], other, &[]);
        } else {
            self.end_dead_block();
        }
    }

    /// Ends an unreachable block.
    fn end_dead_block(&mut self) {
        self.b.ins().trap(ir::TrapCode::unwrap_user(1));
    }

    /// Continues lowering in `block`.
    fn enter(&mut self, block: Block) {
        self.b.switch_to_block(block);
        self.live = self.live_blocks.contains(&block);
    }

    /// The functions a program reaches (itself included).
    fn reachable(&self, program: Handle<Function>) -> Vec<Handle<Function>> {
        let mut seen = HashSet::from([program]);
        let mut stack = vec![program];
        while let Some(f) = stack.pop() {
            let mut calls = Vec::new();
            collect_calls(&self.env.module.functions[f].body, &mut calls);
            for callee in calls {
                if seen.insert(callee) {
                    stack.push(callee);
                }
            }
        }
        seen.into_iter().collect()
    }

    /// Private globals are per invocation: each one the program reaches starts from its
    /// initialiser (or zero) at program entry.
    fn init_privates(&mut self, program: Handle<Function>) -> LResult<()> {
        let reachable = self.reachable(program);
        let module = self.env.module;
        for (handle, var) in module.global_variables.iter() {
            if var.space != naga::AddressSpace::Private {
                continue;
            }
            if !reachable
                .iter()
                .any(|&f| !self.env.info[f][handle].is_empty())
            {
                continue;
            }
            let span = module.global_variables.get_span(handle);
            let inner = &module.types[var.ty].inner;
            let init = match var.init {
                Some(e) => Some(self.global_expr(e).map_err(|e| e.or_span(span))?),
                None => None,
            };
            let place = self
                .new_variable(inner, init)
                .map_err(|e| e.or_span(span))?;
            self.privates.insert(handle, place);
        }
        Ok(())
    }

    /// Enters an inlined function (or the program) with its arguments.
    fn push_frame(
        &mut self,
        function: Handle<Function>,
        args: Vec<Lowered>,
        ret: Option<Block>,
    ) -> LResult<()> {
        let f = &self.env.module.functions[function];
        self.frames.push(Frame {
            function: f,
            info: &self.env.info[function],
            args,
            locals: HashMap::new(),
            cache: vec![None; f.expressions.len()],
            ret,
        });
        for (handle, local) in f.local_variables.iter() {
            let span = f.local_variables.get_span(handle);
            let inner = &self.env.module.types[local.ty].inner;
            let init = match local.init {
                Some(e) => Some(self.values(e).map_err(|e| e.or_span(span))?),
                None => None,
            };
            let place = self
                .new_variable(inner, init)
                .map_err(|e| e.or_span(span))?;
            self.frame_mut().locals.insert(handle, place);
        }
        Ok(())
    }

    /// The naga type of an expression of the current frame.
    fn type_of(&self, expr: Handle<Expression>) -> &'m naga::TypeInner {
        let info: &'m naga::valid::FunctionInfo = self.frame().info;
        info[expr].ty.inner_with(&self.env.module.types)
    }
}

/// Every function a block calls.
fn collect_calls(block: &naga::Block, out: &mut Vec<Handle<Function>>) {
    for stmt in block.iter() {
        match stmt {
            naga::Statement::Call { function, .. } => out.push(*function),
            naga::Statement::Block(b) => collect_calls(b, out),
            naga::Statement::If { accept, reject, .. } => {
                collect_calls(accept, out);
                collect_calls(reject, out);
            }
            naga::Statement::Switch { cases, .. } => {
                for c in cases {
                    collect_calls(&c.body, out);
                }
            }
            naga::Statement::Loop {
                body, continuing, ..
            } => {
                collect_calls(body, out);
                collect_calls(continuing, out);
            }
            _ => {}
        }
    }
}
