//! The JIT driver: a module's programs to machine code, and calling them.

use super::abi::{Bindings, DeviceCalls, DeviceState, TraceEntry};
use super::cache::{self, DiskStore, ModuleKey};
use super::host::{BufferSlot, CallContext, HostFn, NEVER_STOP, SlotLayout, ZERO_PAGE};
use super::lower::{self, LowerError, ModuleEnv};
use cranelift_codegen::control::ControlPlane;
use cranelift_codegen::settings::{self, Configurable};
use cranelift_codegen::{Context, ir, isa::OwnedTargetIsa};
use cranelift_frontend::FunctionBuilderContext;
use cranelift_jit::{ArenaMemoryProvider, JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module, ModuleReloc, default_libcall_names};
use optik_api::{Error, OptLevel, ProgramKind, Result};
use optik_core::frontend::{CompiledModule, DeviceFunction};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::AtomicU32;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Where compiled functions are cached on disk.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum DiskCache {
    /// `$OPTIK_CACHE_PATH`, `$XDG_CACHE_HOME/optik` or `~/.cache/optik`; off when
    /// `OPTIK_CACHE_DISABLE=1`.
    #[default]
    FromEnvironment,
    /// No disk cache.
    Disabled,
    /// This directory.
    Directory(PathBuf),
}

/// How to compile a module.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct JitOptions {
    /// Cranelift's optimisation level: `None` is Cranelift's `none`, the others `speed`.
    pub opt_level: OptLevel,
    /// The disk cache. It changes compile time only: code is the same with it on or off.
    pub disk_cache: DiskCache,
}

/// What compiling a module did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CompileStats {
    /// Programs compiled.
    pub functions: usize,
    /// Of those, how many came from the disk cache.
    pub disk_cache_hits: usize,
    /// Ray generation programs with the module's closest-hit program compiled in after
    /// their traces (`InlinedClosestHit`; docs/cpu-backend.md §5).
    pub closest_hits_inlined: usize,
    /// Ray generation programs also compiled with their launch loop (`RepeatedCall::run_indices`;
    /// docs/cpu-backend.md §5), which the disk cache holds as well.
    pub launch_loops: usize,
    /// Buffer accesses compiled with a bounds check, over every function compiled. Reads
    /// of the params at constant offsets need none (`host::SlotLayout`).
    pub bounds_checks: usize,
    /// Wall time of the whole compile.
    pub time: Duration,
}

/// A program's entry point. `C-unwind`: a panic in a `DeviceCalls` method unwinds through the
/// program (on Linux, see `unwind_tables.rs`).
type EntryFn = unsafe extern "C-unwind" fn(*mut CallContext<'_>);

/// A ray generation program's launch loop (`lower::LaunchLoop`): context, count, stop flag,
/// the index's ended flag; returns the indices it ran.
type LaunchLoopFn =
    unsafe extern "C-unwind" fn(*mut CallContext<'_>, u64, *const AtomicU32, *const u32) -> u64;

/// The name of a ray generation program's launch loop in the compiled module.
fn launch_loop_name(program: &str) -> String {
    format!("{program}__launch_loop")
}

/// One compiled program.
#[derive(Clone, Copy)]
struct CompiledProgram {
    entry: EntryFn,
    /// The `DeviceState` bits it reads.
    state_bits: u32,
    /// Whether it does nothing ([`ProgramFn::does_nothing`]).
    empty: bool,
    /// Whether it (or a helper) has a loop.
    loops: bool,
    /// A ray generation program's launch loop, where one was compiled.
    launch_loop: Option<LaunchLoopFn>,
}

/// The compiled programs of one module and the memory holding their code.
pub(crate) struct Inner {
    /// The programs by name.
    programs: HashMap<String, CompiledProgram>,
    /// Where each buffer-table slot comes from.
    slots: SlotLayout,
    stats: CompileStats,
    /// The unwind tables of the code; dropped (deregistered) before the code is freed.
    #[cfg(target_os = "linux")]
    unwind: Option<super::unwind_tables::UnwindRegistration>,
    /// Owns the executable memory; only touched again to free it.
    code: Mutex<Option<JITModule>>,
}

impl Drop for Inner {
    fn drop(&mut self) {
        #[cfg(target_os = "linux")]
        drop(self.unwind.take());
        if let Some(module) = self
            .code
            .get_mut()
            .unwrap_or_else(|e| e.into_inner())
            .take()
        {
            // SAFETY: the last `JitModule` is gone, and every `ProgramFn` borrows one, so
            // no code of this module can run any more.
            unsafe { module.free_memory() };
        }
    }
}

/// The programs of a module, compiled to native code. Cheap to clone; shared by threads.
#[derive(Clone)]
pub struct JitModule {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for JitModule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut names: Vec<&String> = self.inner.programs.keys().collect();
        names.sort();
        f.debug_struct("JitModule")
            .field("programs", &names)
            .field("stats", &self.inner.stats)
            .finish()
    }
}

/// One compiled program. Borrows its [`JitModule`], which keeps the code alive.
#[derive(Clone, Copy)]
pub struct ProgramFn<'m> {
    entry: EntryFn,
    /// The `DeviceState` bits of the getters the program (or a helper) calls; only when
    /// there are some is `DeviceCalls::state` asked for.
    state_bits: u32,
    /// The program's body has no statement with an effect (see
    /// [`ProgramFn::does_nothing`]).
    empty: bool,
    /// The program (or a helper) has a loop, so its code may read the stop flag
    /// (`DeviceCalls::stop_flag`); only then is the flag asked for.
    loops: bool,
    /// A ray generation program's launch loop ([`RepeatedCall::run_indices`]).
    launch_loop: Option<LaunchLoopFn>,
    slots: &'m SlotLayout,
}

impl std::fmt::Debug for ProgramFn<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProgramFn")
            .field("entry", &(self.entry as *const u8))
            .finish()
    }
}

/// Buffers a program call binds without allocating.
const INLINE_SLOTS: usize = 16;

/// A launch's bindings laid out for one module's code: the buffer table programs read.
/// Preparing once per launch (or per thread) and calling with
/// [`ProgramFn::call_prepared`] saves rebuilding it at every program call.
pub struct PreparedBindings<'a> {
    bindings: &'a Bindings<'a>,
    table: Vec<BufferSlot>,
    /// The params' zero-padded copy the table may point to ([`SlotLayout::fill`]).
    _padded: Vec<u8>,
    /// The slot layout the table was built for (borrowed from its module), to catch a
    /// mix-up of modules.
    layout: &'a SlotLayout,
}

// The table holds the same raw buffer pointers as `Bindings`, shared the same way.
unsafe impl Send for PreparedBindings<'_> {}
unsafe impl Sync for PreparedBindings<'_> {}

impl ProgramFn<'_> {
    /// The [`DeviceState`] bits (`DeviceState::RAY`, ...) of the values this program may
    /// read from the state: a runtime that fills the state per call only needs these.
    #[inline]
    pub fn state_bits(&self) -> u32 {
        self.state_bits
    }

    /// The address of the compiled code.
    #[inline]
    pub fn entry_address(&self) -> *const u8 {
        self.entry as *const u8
    }

    /// Whether calling the program can have no effect: its body is empty (expressions
    /// evaluated for nothing at most), as a miss program that leaves the payload alone
    /// often is. A runtime may skip the call.
    #[inline]
    pub fn does_nothing(&self) -> bool {
        self.empty
    }

    /// Runs the program once with `bindings`, answering device-API calls with `calls`.
    ///
    /// Buffer accesses are bounds-checked against the bound lengths; the runtime's part of
    /// the contract (`abi.rs`) is that every bound pointer is valid for its length for the
    /// duration of the call. A panic inside `calls` propagates to the caller.
    pub fn call(&self, bindings: &Bindings<'_>, calls: &mut dyn DeviceCalls) {
        let slots = self.slots.bindings.len();
        let mut padded = Vec::new();
        if slots <= INLINE_SLOTS {
            let mut inline = [BufferSlot::EMPTY; INLINE_SLOTS];
            self.slots.fill(&mut inline[..slots], bindings, &mut padded);
            self.run(inline.as_ptr(), bindings, calls);
        } else {
            let table = self.slots.table(bindings, &mut padded);
            self.run(table.as_ptr(), bindings, calls);
        }
    }

    /// Runs the program once with bindings prepared by [`JitModule::prepare`] (of this
    /// program's module; bindings prepared for another module are laid out again here).
    #[inline]
    pub fn call_prepared(&self, prepared: &PreparedBindings<'_>, calls: &mut dyn DeviceCalls) {
        if std::ptr::eq(prepared.layout, self.slots) {
            self.run(prepared.table.as_ptr(), prepared.bindings, calls);
        } else {
            self.call(prepared.bindings, calls);
        }
    }

    /// [`ProgramFn::call_prepared`] given what `calls.state()` returns, which saves asking
    /// for it (a runtime that keeps its state at hand calls this), and optionally the
    /// runtime's own `rt_trace` for `calls` ([`TraceEntry`]: its contract is the caller's
    /// to keep).
    #[inline]
    pub fn call_prepared_with_state(
        &self,
        prepared: &PreparedBindings<'_>,
        calls: &mut dyn DeviceCalls,
        state: *const DeviceState,
        trace: Option<TraceEntry>,
    ) {
        if std::ptr::eq(prepared.layout, self.slots) {
            self.run_with_state(
                prepared.table.as_ptr(),
                prepared.bindings,
                calls,
                state,
                trace,
            );
        } else {
            self.call(prepared.bindings, calls);
        }
    }

    /// The context of a call.
    fn context<'a>(
        &self,
        table: *const BufferSlot,
        bindings: &Bindings<'a>,
        calls: &mut (dyn DeviceCalls + 'a),
        state: *const DeviceState,
        stop: *const AtomicU32,
        trace: Option<TraceEntry>,
    ) -> CallContext<'a> {
        CallContext {
            buffers: table,
            zero_page: ZERO_PAGE.as_ptr(),
            state: if state.is_null() {
                &DeviceState::EMPTY
            } else {
                state
            },
            stop: if !self.loops || stop.is_null() {
                &NEVER_STOP
            } else {
                stop
            },
            calls: calls as *mut (dyn DeviceCalls + 'a),
            trace,
            bindings: bindings as *const Bindings<'a>,
            panic: None,
        }
    }

    fn run(&self, table: *const BufferSlot, bindings: &Bindings<'_>, calls: &mut dyn DeviceCalls) {
        let state = if self.state_bits != 0 {
            calls.state()
        } else {
            std::ptr::null()
        };
        self.run_with_state(table, bindings, calls, state, None);
    }

    fn run_with_state(
        &self,
        table: *const BufferSlot,
        bindings: &Bindings<'_>,
        calls: &mut dyn DeviceCalls,
        state: *const DeviceState,
        trace: Option<TraceEntry>,
    ) {
        let stop = if self.loops {
            calls.stop_flag()
        } else {
            std::ptr::null()
        };
        let ctx = self.context(table, bindings, calls, state, stop, trace);
        RepeatedCall {
            entry: self.entry,
            launch_loop: None,
            ctx,
        }
        .call(calls);
    }
}

impl<'m> ProgramFn<'m> {
    /// The program's call context for many calls in a row by one caller, built once
    /// ([`RepeatedCall`]): a launch task runs its ray generation program once per launch
    /// index with the same bindings, state, stop flag and trace entry. `None` when
    /// `prepared` was laid out for another module (then [`ProgramFn::call_prepared`] lays
    /// the bindings out per call).
    ///
    /// `state` and `stop` are what `calls.state()` and `calls.stop_flag()` return for every
    /// call made through the result (null: none), and `trace`, if any, is the runtime's own
    /// `rt_trace` for those calls ([`TraceEntry`]: its contract is the caller's to keep).
    /// `calls` is the first caller's; [`RepeatedCall::call`] takes each call's.
    pub fn repeated<'a>(
        &self,
        prepared: &'a PreparedBindings<'a>,
        calls: &mut (dyn DeviceCalls + 'a),
        state: *const DeviceState,
        stop: *const AtomicU32,
        trace: Option<TraceEntry>,
    ) -> Option<RepeatedCall<'a>>
    where
        'm: 'a,
    {
        if !std::ptr::eq(prepared.layout, self.slots) {
            return None;
        }
        Some(RepeatedCall {
            entry: self.entry,
            launch_loop: self.launch_loop,
            ctx: self.context(
                prepared.table.as_ptr(),
                prepared.bindings,
                calls,
                state,
                stop,
                trace,
            ),
        })
    }
}

/// A program's call context built once for many calls ([`ProgramFn::repeated`]).
pub struct RepeatedCall<'a> {
    entry: EntryFn,
    launch_loop: Option<LaunchLoopFn>,
    ctx: CallContext<'a>,
}

impl<'a> RepeatedCall<'a> {
    /// Runs the program once, answering device-API calls with `calls` (whose `state()` and
    /// `stop_flag()` are the ones the context was built with). A panic inside `calls`
    /// propagates to the caller.
    #[inline]
    pub fn call(&mut self, calls: &mut (dyn DeviceCalls + 'a)) {
        // Set per call: the caller uses `calls` itself between calls.
        self.ctx.calls = calls;
        // SAFETY: `entry` is finalized code of a live module (borrowed by the `ProgramFn`
        // that built this call, for as long as its bindings) with the signature
        // `extern "C-unwind" fn(*mut CallContext)`; the context, the buffer table (as long as
        // the module's slots), the state and the stop flag outlive the call.
        unsafe { (self.entry)(&mut self.ctx) };
        // Only where compiled code has no unwind tables does a panic wait in the context
        // (`host::with_calls`); on Linux it has unwound through the program already. The
        // check stays there too: without it the jit bench's calls as launched measured
        // slower, not faster (51 against 43 ns a `closest_hit` call, Xeon, stop 61; why is
        // not known), and a launch's ray generation programs run through `run_indices` there.
        if let Some(payload) = self.ctx.panic.take() {
            std::panic::resume_unwind(payload);
        }
    }

    /// Whether [`RepeatedCall::run_indices`] can run the program: a ray generation program
    /// compiled with its launch loop.
    #[inline]
    pub fn has_launch_loop(&self) -> bool {
        self.launch_loop.is_some()
    }

    /// Runs the program for up to `count` launch indices of one row, as `count` calls of
    /// [`RepeatedCall::call`] with the state's `launch_index` x stepped between them would
    /// (the caller writes the first index into the state, which must be the context's and
    /// writable). Stops before an index when `*stop` is nonzero, and after an index that set
    /// `*ended` (the caller's exception flag, which it clears before it calls again);
    /// returns the indices run (an ended one included), or `None` without a launch loop
    /// ([`RepeatedCall::has_launch_loop`]). A panic inside `calls` propagates.
    ///
    /// # Safety
    /// `ended` points to a word that only the caller and `calls` write, valid for the call;
    /// the context's state is writable.
    #[inline]
    pub unsafe fn run_indices(
        &mut self,
        calls: &mut (dyn DeviceCalls + 'a),
        count: usize,
        stop: &AtomicU32,
        ended: *const u32,
    ) -> Option<usize> {
        let launch_loop = self.launch_loop?;
        self.ctx.calls = calls;
        // SAFETY: `launch_loop` is finalized code of a live module with `LaunchLoopFn`'s
        // signature; the context, stop flag and ended word outlive the call (the caller's
        // contract), and the state it steps is the caller's (writable by the contract).
        Some(unsafe { launch_loop(&mut self.ctx, count as u64, stop, ended) as usize })
    }
}

impl JitModule {
    /// Compiles every program of `module` (with every function it reaches), or returns
    /// the live module already compiled from the same source and optimisation level.
    pub fn compile(module: &CompiledModule, options: &JitOptions) -> Result<JitModule> {
        let key = ModuleKey {
            source: module.full_source.clone(),
            opt_level: options.opt_level,
        };
        let inner = cache::memory_cached(key, || compile_module(module, options).map(Arc::new))?;
        Ok(JitModule { inner })
    }

    /// [`JitModule::compile_uncached`] with `arena_bytes` of address space for the code
    /// (tests of the reservation).
    #[cfg(test)]
    pub(super) fn compile_in_arena(
        module: &CompiledModule,
        options: &JitOptions,
        arena_bytes: usize,
    ) -> Result<JitModule> {
        Ok(JitModule {
            inner: Arc::new(compile_module_in(module, options, arena_bytes)?),
        })
    }

    /// The entry addresses of the module's programs.
    #[cfg(test)]
    pub(super) fn entry_addresses(&self) -> Vec<usize> {
        self.inner
            .programs
            .values()
            .map(|p| p.entry as usize)
            .collect()
    }

    /// Compiles without looking in (or adding to) the in-memory cache.
    pub fn compile_uncached(module: &CompiledModule, options: &JitOptions) -> Result<JitModule> {
        Ok(JitModule {
            inner: Arc::new(compile_module(module, options)?),
        })
    }

    /// The program named `name` (with its prefix, e.g. `closesthit__radiance`).
    pub fn program(&self, name: &str) -> Option<ProgramFn<'_>> {
        let p = *self.inner.programs.get(name)?;
        Some(ProgramFn {
            entry: p.entry,
            state_bits: p.state_bits,
            empty: p.empty,
            loops: p.loops,
            launch_loop: p.launch_loop,
            slots: &self.inner.slots,
        })
    }

    /// `bindings` laid out for this module's programs (see [`PreparedBindings`]).
    pub fn prepare<'a>(&'a self, bindings: &'a Bindings<'a>) -> PreparedBindings<'a> {
        let layout = &self.inner.slots;
        let mut padded = Vec::new();
        PreparedBindings {
            bindings,
            table: layout.table(bindings, &mut padded),
            _padded: padded,
            layout,
        }
    }

    /// What compiling this module did.
    pub fn stats(&self) -> CompileStats {
        self.inner.stats
    }

    /// Whether `a` and `b` share their machine code (the in-memory cache's doing).
    pub fn same_code(a: &JitModule, b: &JitModule) -> bool {
        Arc::ptr_eq(&a.inner, &b.inner)
    }
}

/// Whether `function` or a function it calls has a `loop` statement (the only construct
/// that can run forever: WGSL has no recursion).
fn has_loops(module: &naga::Module, function: naga::Handle<naga::Function>) -> bool {
    fn block(
        module: &naga::Module,
        b: &naga::Block,
        seen: &mut Vec<naga::Handle<naga::Function>>,
    ) -> bool {
        b.iter().any(|s| match s {
            naga::Statement::Loop { .. } => true,
            naga::Statement::Block(inner) => block(module, inner, seen),
            naga::Statement::If { accept, reject, .. } => {
                block(module, accept, seen) || block(module, reject, seen)
            }
            naga::Statement::Switch { cases, .. } => {
                cases.iter().any(|c| block(module, &c.body, seen))
            }
            naga::Statement::Call { function, .. } => {
                if seen.contains(function) {
                    return false;
                }
                seen.push(*function);
                block(module, &module.functions[*function].body, seen)
            }
            _ => false,
        })
    }
    block(
        module,
        &module.functions[function].body,
        &mut vec![function],
    )
}

fn build_isa(opt_level: OptLevel) -> Result<OwnedTargetIsa> {
    let mut flags = settings::builder();
    let level = if opt_level == OptLevel::None {
        "none"
    } else {
        "speed"
    };
    let set = |flags: &mut settings::Builder, name: &str, value: &str| {
        flags
            .set(name, value)
            .map_err(|e| Error::backend(format!("Cranelift setting {name}={value}: {e}")))
    };
    set(&mut flags, "opt_level", level)?;
    set(&mut flags, "use_colocated_libcalls", "false")?;
    set(&mut flags, "is_pic", "false")?;
    set(
        &mut flags,
        "enable_verifier",
        if cfg!(debug_assertions) {
            "true"
        } else {
            "false"
        },
    )?;
    let native = cranelift_native::builder().map_err(|e| {
        Error::unsupported(format!("the CPU JIT does not support this machine: {e}"))
    })?;
    native
        .finish(settings::Flags::new(flags))
        .map_err(|e| Error::backend(format!("Cranelift could not target this machine: {e}")))
}

/// The address space reserved for one module's code and data (reserved, not committed:
/// pages are mapped as the code fills them).
///
/// A module's programs refer to one another with 32-bit PC-relative displacements (a ray
/// generation program passes its inlined closest hit's address to the trace, and calls
/// between the module's own functions are direct), which reach ±2 GiB. cranelift-jit's
/// default memory provider maps each function's pages wherever the kernel puts them, so two
/// functions of one module could land more than 2 GiB apart, and finalising the module then
/// panicked on the relocation (seen under AddressSanitizer, whose mappings spread out; a
/// process with many large mappings could see it too). All of a module's memory comes from
/// one reservation of this size instead, well under 2 GiB, so every such reference fits;
/// calls to the runtime's host functions use absolute addresses and may be anywhere.
pub(super) const CODE_ARENA_BYTES: usize = 256 << 20;

fn compile_module(module: &CompiledModule, options: &JitOptions) -> Result<Inner> {
    compile_module_in(module, options, CODE_ARENA_BYTES)
}

/// [`compile_module`] with `arena_bytes` of address space for the module's code.
fn compile_module_in(
    module: &CompiledModule,
    options: &JitOptions,
    arena_bytes: usize,
) -> Result<Inner> {
    let start = Instant::now();
    let isa = build_isa(options.opt_level)?;
    let mut builder = JITBuilder::with_isa(isa.clone(), default_libcall_names());
    for &f in HostFn::ALL {
        builder.symbol(f.symbol(), f.address());
    }
    let arena = ArenaMemoryProvider::new_with_size(arena_bytes).map_err(|e| {
        Error::backend(format!(
            "the CPU JIT could not reserve {arena_bytes} bytes of address space for a module's code: {e}"
        ))
    })?;
    builder.memory_provider(Box::new(arena));
    let mut jit = JITModule::new(builder);
    let call_conv = isa.default_call_conv();
    let module_err = |e: cranelift_module::ModuleError| match e {
        cranelift_module::ModuleError::Allocation { err } => Error::backend(format!(
            "the CPU JIT could not place the module's code in the {arena_bytes} bytes reserved for it: {err}"
        )),
        e => Error::backend(format!("the CPU JIT failed: {e}")),
    };
    let mut host_ids: HashMap<HostFn, FuncId> = HashMap::new();
    for &f in HostFn::ALL {
        let id = jit
            .declare_function(f.symbol(), Linkage::Import, &f.signature(call_conv))
            .map_err(module_err)?;
        host_ids.insert(f, id);
    }
    let env = ModuleEnv::new(module, jit.target_config());
    let mut store = cache::directory(&options.disk_cache).map(DiskStore::new);
    let mut stats = CompileStats::default();
    let mut fctx = FunctionBuilderContext::new();
    let mut ctx = jit.make_context();
    let mut ids = Vec::new();
    let mut sig = ir::Signature::new(call_conv);
    sig.params.push(ir::AbiParam::new(ir::types::I64));
    let mut program_ids = HashMap::new();
    for program in &module.programs {
        let id = jit
            .declare_function(&program.name, Linkage::Local, &sig)
            .map_err(module_err)?;
        program_ids.insert(program.function, id);
    }
    // Ray generation programs also get their launch loop (`lower::LaunchLoop`), where a
    // panic unwinds through compiled code (the loop could not see a parked one).
    let mut loop_ids = HashMap::new();
    if cfg!(target_os = "linux") {
        let mut loop_sig = sig.clone();
        lower::LaunchLoop::signature(&mut loop_sig);
        for program in module
            .programs
            .iter()
            .filter(|p| p.kind == ProgramKind::Raygen)
        {
            let id = jit
                .declare_function(&launch_loop_name(&program.name), Linkage::Local, &loop_sig)
                .map_err(module_err)?;
            loop_ids.insert(program.function, id);
        }
    }
    let inlined_closest_hit = lower::inlinable_closest_hit(module);
    let variants = module.programs.iter().flat_map(|p| {
        let looped = loop_ids.get(&p.function).map(|&id| (p, id, true));
        std::iter::once((p, program_ids[&p.function], false)).chain(looped)
    });
    let mut loops_of = HashMap::new();
    for (program, id, launch_loop) in variants {
        let name = if launch_loop {
            launch_loop_name(&program.name)
        } else {
            program.name.clone()
        };
        ctx.func.signature.call_conv = call_conv;
        let inline = inlined_closest_hit
            .filter(|_| program.kind == ProgramKind::Raygen && program.calls(DeviceFunction::Trace))
            .map(|ch| {
                (
                    ch,
                    jit.declare_func_in_func(program_ids[&ch], &mut ctx.func),
                )
            });
        stats.closest_hits_inlined += (inline.is_some() && !launch_loop) as usize;
        {
            let jit = &mut jit;
            let host_ids = &host_ids;
            let mut import =
                |f: HostFn, func: &mut ir::Function| jit.declare_func_in_func(host_ids[&f], func);
            stats.bounds_checks += lower::lower_program(
                &env,
                program.function,
                &mut ctx.func,
                &mut fctx,
                &mut import,
                inline,
                launch_loop,
            )
            .map_err(|e| lowering_error(module, &program.name, e))?;
        }
        let dump = std::env::var_os("OPTIK_JIT_DUMP").map(PathBuf::from);
        if let Some(dir) = &dump {
            // A debugging aid: the CLIF of every program, and its machine code after.
            let _ = std::fs::write(
                dir.join(format!("{name}.clif")),
                ctx.func.display().to_string(),
            );
            ctx.set_disasm(true);
        }
        let hit = compile_function(&mut ctx, &*isa, store.as_mut(), &name)?;
        if let (Some(dir), Some(vcode)) = (&dump, ctx.compiled_code().and_then(|c| c.vcode.clone()))
        {
            let _ = std::fs::write(dir.join(format!("{name}.s")), vcode);
        }
        let code = ctx.compiled_code().expect("compiled above");
        let unwind_info = code
            .create_unwind_info(&*isa)
            .map_err(|e| Error::backend(format!("unwind information for `{name}`: {e}")))?;
        let relocs: Vec<ModuleReloc> = code
            .buffer
            .relocs()
            .iter()
            .map(|r| ModuleReloc::from_mach_reloc(r, &ctx.func, id))
            .collect();
        let alignment = code.buffer.alignment as u64;
        jit.define_function_bytes(id, alignment, code.code_buffer(), &relocs)
            .map_err(module_err)?;
        jit.clear_context(&mut ctx);
        if launch_loop {
            stats.launch_loops += 1;
            loops_of.insert(program.name.clone(), (id, unwind_info));
            continue;
        }
        stats.functions += 1;
        stats.disk_cache_hits += hit as usize;
        let state_bits = program
            .device_functions
            .iter()
            .fold(0, |bits, &f| bits | lower::state_bits(f));
        let empty = module.module.functions[program.function]
            .body
            .iter()
            .all(|s| {
                matches!(
                    s,
                    naga::Statement::Emit(_) | naga::Statement::Return { value: None }
                )
            });
        let loops = has_loops(&module.module, program.function);
        ids.push((
            program.name.clone(),
            id,
            unwind_info,
            state_bits,
            empty,
            loops,
        ));
    }
    jit.finalize_definitions().map_err(module_err)?;
    let mut programs = HashMap::new();
    let mut frames = Vec::new();
    for (name, id, unwind_info, state_bits, empty, loops) in ids {
        let ptr = jit.get_finalized_function(id);
        // SAFETY: the function was compiled with exactly this signature.
        let entry: EntryFn = unsafe { std::mem::transmute::<*const u8, EntryFn>(ptr) };
        frames.extend(unwind_info.map(|info| (ptr as usize, info)));
        let launch_loop = loops_of.remove(&name).map(|(id, unwind_info)| {
            let ptr = jit.get_finalized_function(id);
            frames.extend(unwind_info.map(|info| (ptr as usize, info)));
            // SAFETY: compiled with `lower::LaunchLoop`'s signature, which this is.
            unsafe { std::mem::transmute::<*const u8, LaunchLoopFn>(ptr) }
        });
        programs.insert(
            name,
            CompiledProgram {
                entry,
                state_bits,
                empty,
                loops,
                launch_loop,
            },
        );
    }
    #[cfg(target_os = "linux")]
    let unwind = match super::unwind_tables::UnwindRegistration::new(&*isa, &frames) {
        Ok(registration) => Some(registration),
        Err(e) => {
            // SAFETY: none of the module's code has run or been handed out. (Dropped
            // without this, a finalised module's memory is leaked.)
            unsafe { jit.free_memory() };
            return Err(Error::backend(format!(
                "the CPU JIT could not register unwind tables: {e}"
            )));
        }
    };
    #[cfg(not(target_os = "linux"))]
    let _ = frames;
    stats.time = start.elapsed();
    Ok(Inner {
        programs,
        slots: env.slot_layout(),
        stats,
        #[cfg(target_os = "linux")]
        unwind,
        code: Mutex::new(Some(jit)),
    })
}

/// Compiles `ctx.func`, through the disk cache when there is one; returns whether the
/// cache had it.
fn compile_function(
    ctx: &mut Context,
    isa: &dyn cranelift_codegen::isa::TargetIsa,
    store: Option<&mut DiskStore>,
    name: &str,
) -> Result<bool> {
    let mut ctrl = ControlPlane::default();
    let failed =
        |e: String| Error::backend(format!("Cranelift could not compile program `{name}`: {e}"));
    match store {
        Some(store) => match ctx.compile_with_cache(isa, store, &mut ctrl) {
            Ok((_, hit)) => Ok(hit),
            Err(e) => Err(failed(format!("{:?}", e.inner))),
        },
        None => match ctx.compile(isa, &mut ctrl) {
            Ok(_) => Ok(false),
            Err(e) => Err(failed(format!("{:?}", e.inner))),
        },
    }
}

/// A lowering failure as a compile error at the user's line.
fn lowering_error(module: &CompiledModule, program: &str, e: LowerError) -> Error {
    let message = format!(
        "{} (while compiling program `{program}` for the CPU backend)",
        e.message
    );
    Error::compile(vec![module.diagnostic(e.span, message)])
}
