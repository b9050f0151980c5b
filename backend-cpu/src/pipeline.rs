//! Modules, program groups and pipelines (OptiX's objects), and the program seam: a
//! program is JIT-compiled WGSL or a native Rust closure, called the same way.

use crate::program::abi::{Bindings, DeviceCalls};
use crate::traverse::{Spec, Specialised, TraceRay};
use optik_api::features::ProgramFeatures;
use optik_api::frontend::{BindingInfo, CompiledModule};
use optik_api::{
    Accuracy, BoxTest, Error, FeatureSet, PipelineLinkOptions, ProgramGroupDesc, ProgramKind,
    ProgramRef, Result, TraversableHandle, TriangleTest,
};
use std::collections::HashMap;
use std::sync::Arc;

/// A program written in Rust: called with the launch's resources and the device API, like
/// a compiled WGSL program. Like WGSL programs under the JIT, it must return right after
/// calling a terminator (`ignore_intersection`, `terminate_ray`, `throw_exception`) and
/// whenever [`DeviceCalls::unwinding`] turns true after a call that runs other programs.
pub type NativeProgram = Arc<dyn Fn(&Bindings<'_>, &mut dyn DeviceCalls) + Send + Sync>;

/// What [`crate::CpuDevice::create_native_module`] builds a module from.
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
    },
    /// A Rust closure.
    Native(NativeProgram),
}

/// A program ready to call during one launch.
#[derive(Clone, Copy)]
pub enum Callable<'l> {
    /// Compiled code.
    #[cfg(feature = "jit")]
    Jit(crate::program::ProgramFn<'l>),
    /// A Rust closure.
    Native(&'l NativeProgram),
}

impl ProgramCode {
    /// The callable form, borrowing the code for a launch.
    pub fn callable(&self) -> Result<Callable<'_>> {
        match self {
            #[cfg(feature = "jit")]
            ProgramCode::Jit { module, name } => {
                module.program(name).map(Callable::Jit).ok_or_else(|| {
                    Error::backend(format!("the compiled module lost program `{name}`"))
                })
            }
            ProgramCode::Native(f) => Ok(Callable::Native(f)),
        }
    }
}

impl Callable<'_> {
    /// Runs the program.
    #[inline]
    pub fn call(&self, bindings: &Bindings<'_>, calls: &mut dyn DeviceCalls) {
        match self {
            #[cfg(feature = "jit")]
            Callable::Jit(f) => f.call(bindings, calls),
            Callable::Native(f) => f(bindings, calls),
        }
    }
}

/// A module: its programs by name.
pub(crate) struct ModuleObject {
    /// The front end's result, for WGSL modules.
    pub compiled: Option<Arc<CompiledModule>>,
    /// Programs by full name.
    pub programs: HashMap<String, (ProgramKind, ProgramCode)>,
    /// Declared features of a native module.
    pub native: Option<NativeFeatures>,
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
pub(crate) struct GroupObject {
    pub desc: ProgramGroupDesc,
    pub programs: GroupPrograms,
    /// The WGSL modules its programs come from (for feature and binding analysis).
    pub modules: Vec<(optik_api::Module, Arc<CompiledModule>)>,
    /// Declared features of the native modules its programs come from.
    pub native: Vec<NativeFeatures>,
}

impl GroupObject {
    /// Resolves a group description's programs against the modules.
    pub fn new(
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
            let Some((found, code)) = program(p)? else {
                return Err(Error::invalid(format!(
                    "{}: the module has no program of that name",
                    what()
                )));
            };
            if found != kind {
                return Err(Error::invalid(format!(
                    "{}: `{}` is a {} program (by its prefix), but the group uses it as its {} program",
                    what(),
                    p.entry,
                    found.name(),
                    kind.name()
                )));
            }
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
    let mut f = ProgramFeatures::of_groups(&descs, module_of);
    for n in groups.iter().flat_map(|g| g.native.iter()) {
        f.payload_values_used = f.payload_values_used.max(n.payload_values);
        f.attribute_values_used = f.attribute_values_used.max(n.attribute_values);
        f.throws |= n.throws;
    }
    f
}

/// Traverses for one pipeline: a [`Spec`] chosen from the pipeline's features.
pub(crate) type TraceFn =
    for<'a, 'l> fn(&'a mut crate::launch::Invocation<'l>, &'a TraceRay, TraversableHandle);

fn trace_fn<S: Spec>() -> TraceFn {
    crate::launch::trace_with::<S>
}

fn select_c<const M: bool, const I: bool, const A: bool, const W: bool>(c: bool) -> TraceFn {
    if c {
        trace_fn::<Specialised<M, I, A, W, true>>()
    } else {
        trace_fn::<Specialised<M, I, A, W, false>>()
    }
}
fn select_w<const M: bool, const I: bool, const A: bool>(w: bool, c: bool) -> TraceFn {
    if w {
        select_c::<M, I, A, true>(c)
    } else {
        select_c::<M, I, A, false>(c)
    }
}
fn select_a<const M: bool, const I: bool>(a: bool, w: bool, c: bool) -> TraceFn {
    if a {
        select_w::<M, I, true>(w, c)
    } else {
        select_w::<M, I, false>(w, c)
    }
}
fn select_i<const M: bool>(i: bool, a: bool, w: bool, c: bool) -> TraceFn {
    if i {
        select_a::<M, true>(a, w, c)
    } else {
        select_a::<M, false>(a, w, c)
    }
}

/// The traversal compiled for `features` and `accuracy` (DESIGN.md §5 and §6).
pub(crate) fn select_trace(features: &FeatureSet, accuracy: Accuracy) -> TraceFn {
    let (m, i, a) = (features.motion, features.instancing(), features.any_hit);
    let w = accuracy.triangle == TriangleTest::Watertight;
    let c = accuracy.box_test == BoxTest::Conservative;
    if m {
        select_i::<true>(i, a, w, c)
    } else {
        select_i::<false>(i, a, w, c)
    }
}

/// A linked pipeline.
pub(crate) struct PipelineObject {
    /// Its groups by handle.
    pub groups: Vec<(optik_api::ProgramGroup, Arc<GroupObject>)>,
    pub features: FeatureSet,
    pub link: PipelineLinkOptions,
    pub accuracy: Accuracy,
    pub trace: TraceFn,
    /// `@group(0)` bindings of its WGSL modules, for launch validation.
    pub bindings: Vec<BindingInfo>,
}
