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
use super::host::{CallContext, HostFn, SlotLayout};
use cranelift_codegen::ir::types::I64;
use cranelift_codegen::ir::{
    self, AbiParam, Block, BlockArg, FuncRef, InstBuilder, MemFlagsData, StackSlot, StackSlotData,
    StackSlotKind, Value,
};
use cranelift_codegen::isa::TargetFrontendConfig;
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
pub(crate) use device::{inlinable_closest_hit, state_bits};
use naga::{Expression, Function, GlobalVariable, Handle};
use optik_core::frontend::{BindingKind, CompiledModule, DeviceFunction};
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
    /// The params uniform (binding 0) and the bytes of its type, which every buffer table
    /// gives it (`host::SlotLayout`): reads of it at constant offsets need no bounds check.
    pub params: Option<(Handle<GlobalVariable>, u32)>,
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
        let params = compiled.bindings.iter().find_map(|b| match b.kind {
            BindingKind::Params { size } if buffer_slots.contains_key(&b.global) => {
                Some((b.global, size))
            }
            _ => None,
        });
        Self {
            module,
            info: &compiled.info,
            types: Types {
                arena: &module.types,
            },
            device_fns,
            buffer_slots,
            params,
            frontend,
        }
    }

    /// Where each buffer slot comes from: its binding number, in slot order, and the
    /// params' slot with the bytes the code takes as given.
    pub fn slot_layout(&self) -> SlotLayout {
        let mut bindings = vec![None; self.buffer_slots.len()];
        for (&g, &slot) in &self.buffer_slots {
            bindings[slot as usize] = self.module.global_variables[g]
                .binding
                .as_ref()
                .map(|b| b.binding);
        }
        let params = self
            .params
            .map(|(g, bytes)| (self.buffer_slots[&g] as usize, bytes as usize));
        SlotLayout { bindings, params }
    }

    /// Bytes at the start of buffer global `g` that every call binds and that stay
    /// unchanged for the call (`host::SlotLayout`), so that reads there need no bounds
    /// check and may move: the params' type's size; 0 for storage buffers.
    pub fn given_bytes(&self, g: Handle<GlobalVariable>) -> u32 {
        match self.params {
            Some((params, bytes)) if params == g => bytes,
            _ => 0,
        }
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
    /// In a launch loop (`LaunchLoop`): the launch index, which the program's own
    /// `rt_launch_index` reads from here instead of the state.
    loop_index: Option<[Value; 3]>,
    /// The payload registers of the trace whose inlined closest hit is being lowered: the
    /// caller's `RtPayload` (its address and length), the registers the runtime would hand
    /// that program (a trace passes the caller's payload in place), so its payload accesses
    /// address them directly, their bounds known here.
    inlined_payload: Option<(Value, u32)>,
    /// Buffer accesses lowered with a bounds check so far (`CompileStats::bounds_checks`).
    bounds_checks: usize,
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
///
/// With `launch_loop`, a ray generation program's launch loop instead ([`LaunchLoop`]): the
/// function runs the program for up to `count` launch indices in a row, as the runtime's
/// loop would call it once per index.
///
/// Returns how many buffer accesses it compiled with a bounds check.
pub(crate) fn lower_program<'m>(
    env: &'m ModuleEnv<'m>,
    function: Handle<Function>,
    func: &mut ir::Function,
    fctx: &mut FunctionBuilderContext,
    import: &mut dyn FnMut(HostFn, &mut ir::Function) -> FuncRef,
    inline_closest_hit: Option<(Handle<Function>, FuncRef)>,
    launch_loop: bool,
) -> LResult<usize> {
    func.signature.params.push(AbiParam::new(I64));
    if launch_loop {
        LaunchLoop::signature(&mut func.signature);
    }
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
        loop_index: None,
        inlined_payload: None,
        bounds_checks: 0,
    };
    // The launch loop's next index, entered before the program's body (whose private and
    // local variables are initialised afresh for each index).
    let looped = launch_loop.then(|| LaunchLoop::enter(&mut lowerer, entry));
    lowerer.init_privates(function)?;
    let body = &env.module.functions[function];
    lowerer.push_frame(function, Vec::new(), None)?;
    lowerer.block(&body.body)?;
    lowerer.frames.pop();
    lowerer.goto(exit, &[]);
    lowerer.b.seal_block(exit);
    lowerer.enter(exit);
    match looped {
        Some(l) => l.next_index(&mut lowerer),
        None => {
            lowerer.b.ins().return_(&[]);
        }
    }
    lowerer.b.seal_all_blocks();
    let bounds_checks = lowerer.bounds_checks;
    let frontend = env.frontend;
    lowerer.b.finalize(frontend);
    Ok(bounds_checks)
}

/// A ray generation program compiled with its launch loop (`lower_program`'s
/// `launch_loop`): `extern "C-unwind" fn(ctx, count: u64, stop: *const u32, ended: *const
/// u32) -> u64` runs the program for launch index after launch index of one row, the state's
/// `launch_index` x stepped after each (the runtime writes the first), and returns how many
/// it ran: `count`, or fewer when the launch's stop flag (`stop`) was raised before an index
/// (that index not run), or when an index ended early (`*ended` nonzero after it: an
/// exception, which the runtime handles before it goes on; that index counted as run).
///
/// What it saves against the runtime calling the program per index: the runtime's loop (the
/// stop flag, the index's copies, the call and its checks, ~40 instructions) and the
/// program's entry and exit (the context's and the buffers' loads, its frame), which it pays
/// once for the row (docs/cpu-backend.md §5, "the launch loop compiled with the ray generation program").
#[derive(Clone, Copy)]
pub(crate) struct LaunchLoop {
    /// Block of the next index: parameters `k`, the indices run so far, and `x`, the launch
    /// index's.
    header: Block,
    /// Its `k`.
    k: Value,
    /// Its `x`.
    x: Value,
    /// Block that returns its parameter (the indices run).
    done: Block,
    /// The `ended` flag's address.
    ended: Value,
}

impl LaunchLoop {
    /// Adds the loop's parameters and result to a program's signature (after `ctx`): the
    /// one place that says what `jit::LaunchLoopFn` is in Cranelift's terms, for the
    /// declaration (`jit.rs`) and the definition (`lower_program`) alike.
    pub(crate) fn signature(sig: &mut ir::Signature) {
        sig.params.push(AbiParam::new(I64)); // count
        sig.params.push(AbiParam::new(I64)); // stop
        sig.params.push(AbiParam::new(I64)); // ended
        sig.returns.push(AbiParam::new(I64));
    }

    /// From the entry block (its loads made): the loop's header, which returns once
    /// `count` indices ran or the stop flag is up, else goes on into the body, where the
    /// lowerer is left.
    fn enter(l: &mut Lowerer<'_, '_>, entry: Block) -> LaunchLoop {
        let params = l.b.block_params(entry).to_vec();
        let (count, stop, ended) = (params[1], params[2], params[3]);
        // The first index, which the runtime wrote; the loop carries x in a register (the
        // program's first loads wait on it at every index: read back from the state after
        // the loop's store, it came through a store-to-load forwarding).
        let state = l.state_pointer();
        let at = std::mem::offset_of!(DeviceState, launch_index) as i32;
        let index = [0, 4, 8].map(|o| {
            l.b.ins()
                .load(ir::types::I32, MemFlagsData::trusted(), state, at + o)
        });
        let header = l.b.create_block();
        let k = l.b.append_block_param(header, I64);
        let x = l.b.append_block_param(header, ir::types::I32);
        let done = l.b.create_block();
        l.b.append_block_param(done, I64);
        let check_stop = l.b.create_block();
        let body = l.b.create_block();
        let zero = l.b.ins().iconst(I64, 0);
        l.goto(header, &[zero.into(), index[0].into()]);
        l.enter(header);
        let all_ran =
            l.b.ins()
                .icmp(ir::condcodes::IntCC::UnsignedGreaterThanOrEqual, k, count);
        l.live_blocks.extend([done, check_stop]);
        l.b.ins().brif(all_ran, done, &[k.into()], check_stop, &[]);
        l.b.seal_block(check_stop);
        l.enter(check_stop);
        // Not read-only: another thread raises it.
        let flag =
            l.b.ins()
                .load(ir::types::I32, MemFlagsData::trusted(), stop, 0);
        l.live_blocks.extend([done, body]);
        l.b.ins().brif(flag, done, &[k.into()], body, &[]);
        l.b.seal_block(body);
        l.enter(body);
        l.loop_index = Some([x, index[1], index[2]]);
        LaunchLoop {
            header,
            k,
            x,
            done,
            ended,
        }
    }

    /// At the program's exit: returns when the index ended early, else steps the state's
    /// launch index along x and goes to the next.
    fn next_index(self, l: &mut Lowerer<'_, '_>) {
        let ran = l.b.ins().iadd_imm_u(self.k, 1);
        let step = l.b.create_block();
        let ended =
            l.b.ins()
                .load(ir::types::I32, MemFlagsData::trusted(), self.ended, 0);
        l.live_blocks.extend([self.done, step]);
        l.b.ins().brif(ended, self.done, &[ran.into()], step, &[]);
        l.b.seal_block(step);
        l.enter(step);
        // The next x, carried to the next index and stored where the runtime's readers of
        // the launch index find it (`Invocation::current_index`).
        let state = l.state_pointer();
        let at = std::mem::offset_of!(DeviceState, launch_index) as i32;
        let x = l.b.ins().iadd_imm_u(self.x, 1);
        l.b.ins().store(MemFlagsData::trusted(), x, state, at);
        l.goto(self.header, &[ran.into(), x.into()]);
        l.b.seal_block(self.header);
        l.b.seal_block(self.done);
        l.enter(self.done);
        let n = l.b.block_params(self.done)[0];
        l.b.ins().return_(&[n]);
    }
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
