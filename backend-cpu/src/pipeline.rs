//! Modules, program groups and pipelines (OptiX's objects), and the program seam: a
//! program is JIT-compiled WGSL or a native Rust closure, called the same way.

use crate::program::abi::{Bindings, DeviceCalls};
use crate::traversal::{Spec, Specialised, TraceRay};
use optik_api::features::ProgramFeatures;
use optik_api::{
    Accuracy, BoxTest, Error, ExceptionFlags, FeatureSet, PipelineLinkOptions, ProgramGroupDesc,
    ProgramKind, ProgramRef, Result, TraversableHandle, TriangleTest,
};
use optik_core::frontend::{BindingInfo, CompiledModule};
use std::collections::HashMap;
use std::sync::Arc;

/// A program written in Rust: called with the launch's resources and the device API, like
/// a compiled WGSL program. Like WGSL programs under the JIT, it must return right after
/// calling a terminator (`ignore_intersection`, `terminate_ray`, `throw_exception`) and
/// whenever [`DeviceCalls::unwinding`] turns true after a call that runs other programs.
pub type NativeProgram = Arc<dyn Fn(&Bindings<'_>, &mut dyn DeviceCalls) + Send + Sync>;

/// What [`CpuDeviceExt::create_native_module`] builds a module from.
///
/// [`CpuDeviceExt::create_native_module`]: crate::CpuDeviceExt::create_native_module
#[derive(Clone, Default)]
pub struct NativeModuleDesc {
    /// Programs by full name, prefixed as WGSL programs are (`closesthit__shade`).
    pub programs: Vec<(String, NativeProgram)>,
    /// Payload registers the programs use (for `Auto` pipeline options).
    pub payload_values: u32,
    /// Attribute registers the programs use.
    pub attribute_values: u32,
    /// Whether some program throws user exceptions (`Auto` exception flags then include
    /// `USER`).
    pub throws: bool,
}

impl std::fmt::Debug for NativeModuleDesc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = self.programs.iter().map(|(n, _)| n.as_str()).collect();
        f.debug_struct("NativeModuleDesc")
            .field("programs", &names)
            .finish_non_exhaustive()
    }
}

/// The code of one program.
#[derive(Clone)]
pub enum ProgramCode {
    /// A program of a JIT-compiled module, found by name when a launch starts.
    #[cfg(feature = "jit")]
    Jit {
        /// The compiled module (shared; keeps the code alive).
        module: crate::program::JitModule,
        /// The program's full name.
        name: Arc<str>,
        /// What the module was compiled from, to compile it again for a pipeline's payload
        /// register count.
        source: Arc<CompiledModule>,
        /// The module's optimisation level.
        opt_level: optik_api::OptLevel,
    },
    /// A Rust closure.
    Native(NativeProgram),
}

/// A program ready to call during one launch.
#[derive(Clone, Copy)]
pub enum Callable<'l> {
    /// Compiled code, with the launch's bindings laid out for its module.
    #[cfg(feature = "jit")]
    Jit(
        crate::program::ProgramFn<'l>,
        &'l crate::program::PreparedBindings<'l>,
    ),
    /// A Rust closure.
    Native(&'l NativeProgram),
}

/// A launch's bindings laid out once for each JIT module of its pipeline, so program calls
/// do not lay them out again.
pub(crate) struct PreparedModules<'l> {
    #[cfg(not(feature = "jit"))]
    _bindings: std::marker::PhantomData<&'l Bindings<'l>>,
    #[cfg(feature = "jit")]
    tables: Vec<(
        &'l crate::program::JitModule,
        crate::program::PreparedBindings<'l>,
    )>,
}

impl<'l> PreparedModules<'l> {
    /// Lays `bindings` out for every module of `pipeline`.
    pub fn new(pipeline: &'l PipelineObject, bindings: &'l Bindings<'l>) -> PreparedModules<'l> {
        #[cfg(feature = "jit")]
        {
            use crate::program::JitModule;
            let mut tables: Vec<(&'l JitModule, crate::program::PreparedBindings<'l>)> = Vec::new();
            for (_, g) in &pipeline.groups {
                let p = &g.programs;
                for code in [
                    &p.main,
                    &p.any_hit,
                    &p.intersection,
                    &p.direct,
                    &p.continuation,
                ]
                .into_iter()
                .flatten()
                {
                    if let ProgramCode::Jit { module, .. } = code
                        && !tables.iter().any(|(m, _)| JitModule::same_code(m, module))
                    {
                        tables.push((module, module.prepare(bindings)));
                    }
                }
            }
            PreparedModules { tables }
        }
        #[cfg(not(feature = "jit"))]
        {
            let _ = (pipeline, bindings);
            PreparedModules {
                _bindings: std::marker::PhantomData,
            }
        }
    }
}

impl ProgramCode {
    /// The callable form for a launch whose bindings `prepared` holds.
    pub(crate) fn callable<'l>(
        &'l self,
        prepared: &'l PreparedModules<'l>,
    ) -> Result<Callable<'l>> {
        match self {
            #[cfg(feature = "jit")]
            ProgramCode::Jit { module, name, .. } => {
                let program = module.program(name).ok_or_else(|| {
                    Error::backend(format!("the compiled module lost program `{name}`"))
                })?;
                let table = prepared
                    .tables
                    .iter()
                    .find(|(m, _)| crate::program::JitModule::same_code(m, module))
                    .map(|(_, t)| t)
                    .ok_or_else(|| {
                        Error::backend(format!(
                            "program `{name}`: its module is not one of the pipeline's"
                        ))
                    })?;
                Ok(Callable::Jit(program, table))
            }
            ProgramCode::Native(f) => {
                let _ = prepared;
                Ok(Callable::Native(f))
            }
        }
    }
}

impl<'l> Callable<'l> {
    /// Runs the program with the launch's bindings; `state` is what `calls.state()`
    /// returns (compiled programs read it without asking), `trace` the runtime's own
    /// `rt_trace` for `calls` (compiled programs call it instead of `calls.trace`).
    #[inline]
    pub fn call(
        &self,
        bindings: &Bindings<'_>,
        calls: &mut dyn DeviceCalls,
        state: *const crate::program::abi::DeviceState,
        trace: crate::program::abi::TraceEntry,
    ) {
        match self {
            #[cfg(feature = "jit")]
            Callable::Jit(f, prepared) => {
                let _ = bindings;
                f.call_prepared_with_state(prepared, calls, state, Some(trace))
            }
            Callable::Native(f) => {
                let _ = (state, trace);
                f(bindings, calls)
            }
        }
    }

    /// The program ready for many calls in a row by one invocation with the same
    /// `bindings`, `state`, `stop` flag and `trace` entry (as [`Callable::call`] takes them):
    /// compiled code gets its call context built once. `calls` is the first caller.
    #[inline]
    pub fn repeated(
        self,
        bindings: &'l Bindings<'l>,
        calls: &mut (dyn DeviceCalls + 'l),
        state: *const crate::program::abi::DeviceState,
        stop: *const std::sync::atomic::AtomicU32,
        trace: crate::program::abi::TraceEntry,
    ) -> RepeatedCallable<'l> {
        #[cfg(feature = "jit")]
        if let Callable::Jit(f, prepared) = self
            && let Some(call) = f.repeated(prepared, calls, state, stop, Some(trace))
        {
            return RepeatedCallable::Jit(call);
        }
        let _ = (calls, stop);
        RepeatedCallable::Each {
            program: self,
            bindings,
            state,
            trace,
        }
    }

    /// Whether calling the program has no effect (an empty WGSL program), so it can be
    /// skipped.
    #[inline]
    pub fn does_nothing(&self) -> bool {
        match self {
            #[cfg(feature = "jit")]
            Callable::Jit(f, _) => f.does_nothing(),
            Callable::Native(_) => false,
        }
    }

    /// The address of its compiled code (null for a native program): what a compiled
    /// caller that inlined it names it by ([`abi::TraceEntry`](crate::program::abi::TraceEntry)).
    #[inline]
    pub fn entry_address(&self) -> *const u8 {
        match self {
            #[cfg(feature = "jit")]
            Callable::Jit(f, _) => f.entry_address(),
            Callable::Native(_) => std::ptr::null(),
        }
    }

    /// The `DeviceState` bits the program may read (0: it reads none, or is native and
    /// calls the methods).
    #[inline]
    pub fn state_bits(&self) -> u32 {
        match self {
            #[cfg(feature = "jit")]
            Callable::Jit(f, _) => f.state_bits(),
            Callable::Native(_) => 0,
        }
    }
}

/// A program called many times in a row by one invocation ([`Callable::repeated`]).
pub enum RepeatedCallable<'l> {
    /// Compiled code with its call context built once.
    #[cfg(feature = "jit")]
    Jit(crate::program::RepeatedCall<'l>),
    /// A native program (or compiled code whose bindings are laid out per call): each call
    /// is a [`Callable::call`].
    Each {
        program: Callable<'l>,
        bindings: &'l Bindings<'l>,
        state: *const crate::program::abi::DeviceState,
        trace: crate::program::abi::TraceEntry,
    },
}

impl<'l> RepeatedCallable<'l> {
    /// Runs the program once for `calls` (whose state and stop flag are the ones given to
    /// [`Callable::repeated`]).
    #[inline]
    pub fn call(&mut self, calls: &mut (dyn DeviceCalls + 'l)) {
        match self {
            #[cfg(feature = "jit")]
            RepeatedCallable::Jit(call) => call.call(calls),
            RepeatedCallable::Each {
                program,
                bindings,
                state,
                trace,
            } => program.call(bindings, calls, *state, *trace),
        }
    }

    /// Whether [`RepeatedCallable::run_indices`] can run the program (compiled code with a
    /// launch loop: `RepeatedCall::has_launch_loop`).
    #[inline]
    pub fn has_launch_loop(&self) -> bool {
        match self {
            #[cfg(feature = "jit")]
            RepeatedCallable::Jit(call) => call.has_launch_loop(),
            RepeatedCallable::Each { .. } => false,
        }
    }

    /// `RepeatedCall::run_indices`: the program for up to `count` launch indices of one row;
    /// `None` without a launch loop ([`RepeatedCallable::has_launch_loop`]).
    ///
    /// # Safety
    /// As `RepeatedCall::run_indices`.
    #[inline]
    pub unsafe fn run_indices(
        &mut self,
        calls: &mut (dyn DeviceCalls + 'l),
        count: usize,
        stop: &std::sync::atomic::AtomicU32,
        ended: *const u32,
    ) -> Option<usize> {
        match self {
            #[cfg(feature = "jit")]
            // SAFETY: the caller's contract.
            RepeatedCallable::Jit(call) => unsafe { call.run_indices(calls, count, stop, ended) },
            RepeatedCallable::Each { .. } => {
                let _ = (calls, count, stop, ended);
                None
            }
        }
    }
}

/// A module: its programs by name.
pub struct ModuleObject {
    /// The front end's result, for WGSL modules.
    pub(crate) compiled: Option<Arc<CompiledModule>>,
    /// Programs by full name.
    pub(crate) programs: HashMap<String, (ProgramKind, ProgramCode)>,
    /// Declared features of a native module.
    pub(crate) native: Option<NativeFeatures>,
}

/// What a native module declares about its programs.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct NativeFeatures {
    pub payload_values: u32,
    pub attribute_values: u32,
    pub throws: bool,
}

impl ModuleObject {
    /// A module of native programs; names must carry a program prefix.
    pub fn native(desc: NativeModuleDesc) -> Result<ModuleObject> {
        let mut programs = HashMap::new();
        for (name, code) in desc.programs {
            let Some(kind) = ProgramKind::from_function_name(&name) else {
                return Err(Error::invalid(format!(
                    "native program `{name}` has no program prefix (raygen__, intersection__, anyhit__, closesthit__, miss__, exception__, direct_callable__, continuation_callable__)"
                )));
            };
            if programs
                .insert(name.clone(), (kind, ProgramCode::Native(code)))
                .is_some()
            {
                return Err(Error::invalid(format!(
                    "native program `{name}` is given twice"
                )));
            }
        }
        Ok(ModuleObject {
            compiled: None,
            programs,
            native: Some(NativeFeatures {
                payload_values: desc.payload_values.min(32),
                attribute_values: desc.attribute_values.min(8),
                throws: desc.throws,
            }),
        })
    }
}

/// The programs of a group, resolved from their modules.
#[derive(Clone, Default)]
pub(crate) struct GroupPrograms {
    /// Raygen, miss or exception program (by the group's region), or the closest-hit.
    pub main: Option<ProgramCode>,
    pub any_hit: Option<ProgramCode>,
    pub intersection: Option<ProgramCode>,
    pub direct: Option<ProgramCode>,
    pub continuation: Option<ProgramCode>,
}

/// Finds a module's front-end result and native features by handle.
pub(crate) type ModuleLookup<'a> =
    &'a dyn Fn(optik_api::Module) -> Result<(Option<Arc<CompiledModule>>, Option<NativeFeatures>)>;
/// Finds a program's kind and code.
pub(crate) type ProgramLookup<'a> =
    &'a dyn Fn(&ProgramRef) -> Result<Option<(ProgramKind, ProgramCode)>>;

/// A program group.
#[derive(Clone)]
pub struct GroupObject {
    pub(crate) desc: ProgramGroupDesc,
    pub(crate) programs: GroupPrograms,
    /// The WGSL modules its programs come from (for feature and binding analysis).
    pub(crate) modules: Vec<(optik_api::Module, Arc<CompiledModule>)>,
    /// Declared features of the native modules its programs come from.
    pub(crate) native: Vec<NativeFeatures>,
}

impl GroupObject {
    /// Resolves a group description's programs against the modules.
    pub(crate) fn new(
        index: usize,
        desc: &ProgramGroupDesc,
        module: ModuleLookup<'_>,
        program: ProgramLookup<'_>,
    ) -> Result<GroupObject> {
        let mut programs = GroupPrograms::default();
        let mut modules: Vec<(optik_api::Module, Arc<CompiledModule>)> = Vec::new();
        let mut native = Vec::new();
        for (kind, p) in desc.programs() {
            let what = || {
                format!(
                    "program_groups[{index}] ({} program `{}`)",
                    kind.name(),
                    p.entry
                )
            };
            let (compiled, native_features) = module(p.module).map_err(|e| e.context(what()))?;
            // optik-core has checked that the program exists with this kind.
            let Some((_, code)) = program(p)? else {
                return Err(Error::backend(format!(
                    "{}: the program vanished from its module",
                    what()
                )));
            };
            match kind {
                ProgramKind::AnyHit => programs.any_hit = Some(code),
                ProgramKind::Intersection => programs.intersection = Some(code),
                ProgramKind::DirectCallable => programs.direct = Some(code),
                ProgramKind::ContinuationCallable => programs.continuation = Some(code),
                _ => programs.main = Some(code),
            }
            if let Some(c) = compiled
                && !modules.iter().any(|(m, _)| *m == p.module)
            {
                modules.push((p.module, c));
            }
            native.extend(native_features);
        }
        Ok(GroupObject {
            desc: desc.clone(),
            programs,
            modules,
            native,
        })
    }
}

/// The program features of groups: WGSL modules analysed by the front end, native modules
/// by what they declare.
pub(crate) fn program_features(groups: &[Arc<GroupObject>]) -> ProgramFeatures {
    let descs: Vec<&ProgramGroupDesc> = groups.iter().map(|g| &g.desc).collect();
    let module_of = |p: &ProgramRef| -> Option<&CompiledModule> {
        groups
            .iter()
            .flat_map(|g| g.modules.iter())
            .find(|(m, _)| *m == p.module)
            .map(|(_, c)| c.as_ref())
    };
    let mut f = optik_core::features::program_features(&descs, module_of);
    for n in groups.iter().flat_map(|g| g.native.iter()) {
        f.payload_values_used = f.payload_values_used.max(n.payload_values);
        f.attribute_values_used = f.attribute_values_used.max(n.attribute_values);
        f.throws |= n.throws;
    }
    f
}

/// The groups of a pipeline whose payload has `registers` registers, with every WGSL module
/// compiled again for that count when it was compiled for another (`create_module` with
/// `Auto` compiles for 32): `RtPayload` then holds the registers the pipeline uses, and a
/// trace copies only those. The front end's payload analysis counts every register a
/// program touches, so this changes no result. Should a module not compile again (it
/// compiled once, so it does), the group keeps the module's code, which gives the same
/// results with longer copies.
pub(crate) fn with_payload_registers(
    groups: Vec<(optik_api::ProgramGroup, Arc<GroupObject>)>,
    registers: u32,
) -> Vec<(optik_api::ProgramGroup, Arc<GroupObject>)> {
    #[cfg(feature = "jit")]
    {
        use crate::program::JitModule;
        let registers = registers.max(1);
        // (module as compiled, its code for `registers`) for each module seen.
        let mut recompiled: Vec<(JitModule, Option<ProgramCode>)> = Vec::new();
        let mut again = |code: &ProgramCode| -> Option<ProgramCode> {
            let ProgramCode::Jit {
                module,
                name,
                source,
                opt_level,
            } = code
            else {
                return None;
            };
            if source.payload_len.max(1) == registers {
                return None;
            }
            let known = recompiled
                .iter()
                .position(|(m, _)| JitModule::same_code(m, module));
            let index = known.unwrap_or_else(|| {
                let fresh = crate::jit_glue::recompile(source, *opt_level, registers)
                    .ok()
                    .map(|(module, source)| ProgramCode::Jit {
                        module,
                        name: name.clone(),
                        source,
                        opt_level: *opt_level,
                    });
                recompiled.push((module.clone(), fresh));
                recompiled.len() - 1
            });
            match &recompiled[index].1 {
                Some(ProgramCode::Jit {
                    module,
                    source,
                    opt_level,
                    ..
                }) => Some(ProgramCode::Jit {
                    module: module.clone(),
                    name: name.clone(),
                    source: source.clone(),
                    opt_level: *opt_level,
                }),
                _ => None,
            }
        };
        groups
            .into_iter()
            .map(|(handle, group)| {
                let p = &group.programs;
                let codes = [
                    &p.main,
                    &p.any_hit,
                    &p.intersection,
                    &p.direct,
                    &p.continuation,
                ]
                .map(|c| c.as_ref().and_then(&mut again));
                if codes.iter().all(Option::is_none) {
                    return (handle, group);
                }
                let [main, any_hit, intersection, direct, continuation] = codes;
                let mut copy = GroupObject::clone(&group);
                let slots = [
                    (&mut copy.programs.main, main),
                    (&mut copy.programs.any_hit, any_hit),
                    (&mut copy.programs.intersection, intersection),
                    (&mut copy.programs.direct, direct),
                    (&mut copy.programs.continuation, continuation),
                ];
                for (slot, code) in slots {
                    if let Some(code) = code {
                        *slot = Some(code);
                    }
                }
                (handle, Arc::new(copy))
            })
            .collect()
    }
    #[cfg(not(feature = "jit"))]
    {
        let _ = registers;
        groups
    }
}

/// Traverses for one pipeline: a [`Spec`] chosen from the pipeline's features.
type WalkFn =
    for<'a, 'r, 'l> fn(&'a mut crate::device_api::Invocation<'l>, &'r TraceRay, TraversableHandle);

/// A pipeline's traces, compiled for its [`Spec`]: the walk (for `DeviceCalls::trace`, which
/// native programs call) and the whole `rt_trace` as compiled programs call it, so the
/// arguments reach the walk without a `dyn` call or a fn-pointer hop.
#[derive(Clone, Copy)]
pub(crate) struct TraceFn {
    pub walk: WalkFn,
    pub entry: crate::program::abi::TraceEntry,
}

/// The traces of a pipeline compiled as `S`. Compiled programs' traces may be lean
/// (`device_api::trace_entry` with `LEAN`, docs/cpu-backend.md §5) when the spec has no
/// any-hit programs and no instancing and the pipeline checks no debug exceptions (`debug`);
/// other pipelines keep the whole `rt_trace` in their entry.
fn trace_fn<S: Spec>(debug: bool) -> TraceFn {
    let lean = !S::ANY_HIT && !S::INSTANCING && !debug;
    TraceFn {
        walk: crate::device_api::trace_with::<S>,
        entry: if lean {
            crate::device_api::trace_entry::<S, true>
        } else {
            crate::device_api::trace_entry::<S, false>
        },
    }
}

fn select_c<const M: bool, const I: bool, const A: bool, const W: bool>(
    c: bool,
    debug: bool,
) -> TraceFn {
    if c {
        trace_fn::<Specialised<M, I, A, W, true>>(debug)
    } else {
        trace_fn::<Specialised<M, I, A, W, false>>(debug)
    }
}
fn select_w<const M: bool, const I: bool, const A: bool>(w: bool, c: bool, debug: bool) -> TraceFn {
    if w {
        select_c::<M, I, A, true>(c, debug)
    } else {
        select_c::<M, I, A, false>(c, debug)
    }
}
fn select_a<const M: bool, const I: bool>(a: bool, w: bool, c: bool, debug: bool) -> TraceFn {
    if a {
        select_w::<M, I, true>(w, c, debug)
    } else {
        select_w::<M, I, false>(w, c, debug)
    }
}
fn select_i<const M: bool>(i: bool, a: bool, w: bool, c: bool, debug: bool) -> TraceFn {
    if i {
        select_a::<M, true>(a, w, c, debug)
    } else {
        select_a::<M, false>(a, w, c, debug)
    }
}

/// The traversal compiled for `features` and `accuracy` (DESIGN.md §5 and §6).
pub(crate) fn select_trace(features: &FeatureSet, accuracy: Accuracy) -> TraceFn {
    let (m, i, a) = (features.motion, features.instancing(), features.any_hit);
    let w = accuracy.triangle == TriangleTest::Watertight;
    let c = accuracy.box_test == BoxTest::Conservative;
    let debug = features.exceptions.contains(ExceptionFlags::DEBUG);
    if m {
        select_i::<true>(i, a, w, c, debug)
    } else {
        select_i::<false>(i, a, w, c, debug)
    }
}

/// A linked pipeline.
pub struct PipelineObject {
    /// Its groups by handle.
    pub(crate) groups: Vec<(optik_api::ProgramGroup, Arc<GroupObject>)>,
    pub(crate) features: FeatureSet,
    pub(crate) link: PipelineLinkOptions,
    pub(crate) accuracy: Accuracy,
    pub(crate) trace: TraceFn,
    /// `@group(0)` bindings of its WGSL modules, for launch validation.
    pub(crate) bindings: Vec<BindingInfo>,
}
