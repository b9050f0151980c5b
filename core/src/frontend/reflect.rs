//! Program-model checks and reflection over naga IR.
//!
//! naga validates WGSL; this pass knows the ray tracing program model: which functions are
//! programs, where each device function may be called (checked transitively through the
//! user's helper functions), which constructs are forbidden, which bindings each program
//! uses, and how many payload and attribute registers the programs touch.

use super::device_api::DeviceFunction;
use super::locate::Locator;
use naga::{AddressSpace, Block, Expression, Function, Handle, Module, Span, Statement, TypeInner};
use optik_api::error::Diagnostic;
use optik_api::program::ProgramKind;
use std::collections::{BTreeSet, HashMap, VecDeque};

/// One program of a module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgramInfo {
    /// Its kind, from the name's prefix.
    pub kind: ProgramKind,
    /// The full function name (`closesthit__radiance`).
    pub name: String,
    /// The naga function.
    pub function: Handle<Function>,
    /// Device functions it calls, directly or through helpers.
    pub device_functions: BTreeSet<DeviceFunction>,
    /// The user helper functions it reaches.
    pub helpers: BTreeSet<String>,
    /// `@group(0)` binding numbers it uses, directly or through helpers.
    pub bindings_used: BTreeSet<u32>,
    /// 1-based line of its declaration.
    pub line: u32,
    /// 1-based column of its name.
    pub column: u32,
}

impl ProgramInfo {
    /// Whether the program (or a helper it calls) calls `f`.
    pub fn calls(&self, f: DeviceFunction) -> bool {
        self.device_functions.contains(&f)
    }
}

/// What a `@group(0)` binding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BindingKind {
    /// Binding 0: the launch parameters, `var<uniform>` of `size` bytes.
    Params {
        /// Bytes of the parameter type.
        size: u32,
    },
    /// A storage buffer.
    StorageBuffer {
        /// Declared `read` (not `read_write`).
        read_only: bool,
        /// Bytes of the type's fixed part (for a runtime array, the bytes before it).
        min_size: u32,
    },
    /// A `texture_2d<f32>`.
    Texture2d,
    /// A `sampler`.
    Sampler,
}

/// One `@group(0)` binding.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BindingInfo {
    /// The binding number.
    pub binding: u32,
    /// The variable's name.
    pub name: String,
    /// What it is.
    pub kind: BindingKind,
    /// The naga global variable.
    pub global: Handle<naga::GlobalVariable>,
}

pub(crate) struct Reflection {
    pub programs: Vec<ProgramInfo>,
    pub bindings: Vec<BindingInfo>,
    pub payload_values_used: u32,
    pub attribute_values_used: u32,
}

/// Largest register counts, used when an index is not a constant.
const MAX_PAYLOAD: u32 = optik_api::MAX_PAYLOAD_VALUES;
const MAX_ATTRIBUTES: u32 = optik_api::MAX_ATTRIBUTE_VALUES;

/// What one function does, collected in one walk.
#[derive(Default)]
struct FunctionFacts {
    /// Calls to user functions and device functions, with the call's span.
    calls: Vec<(Handle<Function>, Span)>,
    /// Register indices touched: `None` for a dynamic index.
    payload_indices: Vec<Option<u32>>,
    attribute_indices: Vec<Option<u32>>,
}

pub(crate) fn reflect(
    module: &Module,
    info: &naga::valid::ModuleInfo,
    loc: &Locator,
    diags: &mut Vec<Diagnostic>,
) -> Reflection {
    let device_fns: HashMap<Handle<Function>, DeviceFunction> = module
        .functions
        .iter()
        .filter(|(h, _)| !loc.is_user(module.functions.get_span(*h)))
        .filter_map(|(h, f)| {
            f.name
                .as_deref()
                .and_then(DeviceFunction::from_name)
                .map(|d| (h, d))
        })
        .collect();

    let bindings = check_globals(module, loc, diags);

    for ep in &module.entry_points {
        diags.push(loc.diagnostic(
            loc.function_name_span(&ep.name),
            format!(
                "entry point `{}` is not allowed: ray tracing programs are plain functions named by prefix ({})",
                ep.name,
                prefixes_text()
            ),
        ));
    }

    let payload_ty = payload_type(module);
    let mut facts: HashMap<Handle<Function>, FunctionFacts> = HashMap::new();
    let mut programs = Vec::new();
    for (handle, function) in module.functions.iter() {
        if device_fns.contains_key(&handle) {
            continue;
        }
        let name = function.name.clone().unwrap_or_default();
        let decl_span = loc.function_name_span(&name);
        let span = if decl_span.is_defined() {
            decl_span
        } else {
            module.functions.get_span(handle)
        };
        if let Some(kind) = check_function_name(&name, span, loc, diags) {
            if !function.arguments.is_empty() {
                diags.push(loc.diagnostic(
                    span,
                    format!(
                        "{} program `{name}` takes parameters; programs take none and read their inputs through the device API (rt_launch_index, rt_get_payload, ...)",
                        kind.name()
                    ),
                ));
            }
            if function.result.is_some() {
                diags.push(loc.diagnostic(
                    span,
                    format!(
                        "{} program `{name}` returns a value; programs return nothing and write results through the payload or buffers",
                        kind.name()
                    ),
                ));
            }
            let d = loc.diagnostic(span, "");
            programs.push(ProgramInfo {
                kind,
                name: name.clone(),
                function: handle,
                device_functions: BTreeSet::new(),
                helpers: BTreeSet::new(),
                bindings_used: BTreeSet::new(),
                line: d.line,
                column: d.column,
            });
        }
        let mut f = FunctionFacts::default();
        walk_block(
            &function.body,
            module,
            function,
            &device_fns,
            &mut f,
            loc,
            diags,
        );
        check_expressions(
            module, function, handle, info, payload_ty, &mut f, loc, diags,
        );
        facts.insert(handle, f);
    }

    let binding_of: HashMap<Handle<naga::GlobalVariable>, u32> =
        bindings.iter().map(|b| (b.global, b.binding)).collect();
    for program in &mut programs {
        analyse_program(
            program,
            module,
            info,
            &facts,
            &device_fns,
            &binding_of,
            loc,
            diags,
        );
    }

    let mut payload_values_used = 0;
    let mut attribute_values_used = 0;
    for f in facts.values() {
        for i in &f.payload_indices {
            payload_values_used = payload_values_used
                .max(i.map_or(MAX_PAYLOAD, |i| i.saturating_add(1).min(MAX_PAYLOAD)));
        }
        for i in &f.attribute_indices {
            attribute_values_used = attribute_values_used
                .max(i.map_or(MAX_ATTRIBUTES, |i| i.saturating_add(1).min(MAX_ATTRIBUTES)));
        }
    }
    let reports = programs
        .iter()
        .any(|p| p.calls(DeviceFunction::ReportIntersection))
        || programs
            .iter()
            .any(|p| p.calls(DeviceFunction::TriangleBarycentrics));
    if reports || attribute_values_used > 0 {
        // OptiX raises attribute counts below 2 to 2 (the triangle barycentrics).
        attribute_values_used = attribute_values_used.max(2);
    }
    Reflection {
        programs,
        bindings,
        payload_values_used,
        attribute_values_used,
    }
}

fn prefixes_text() -> String {
    ProgramKind::ALL
        .iter()
        .map(|k| k.prefix())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Checks a function's name; returns its program kind when it is a program.
fn check_function_name(
    name: &str,
    span: Span,
    loc: &Locator,
    diags: &mut Vec<Diagnostic>,
) -> Option<ProgramKind> {
    if let Some(kind) = ProgramKind::from_function_name(name) {
        if name.len() == kind.prefix().len() {
            diags.push(loc.diagnostic(
                span,
                format!(
                    "program `{name}` has no name after its prefix `{}`",
                    kind.prefix()
                ),
            ));
        }
        return Some(kind);
    }
    if name.starts_with("rt_") {
        diags.push(loc.diagnostic(
            span,
            format!(
                "function name `{name}`: names starting with `rt_` are reserved for the device API"
            ),
        ));
        return None;
    }
    if let Some(at) = name.find("__").filter(|&at| at > 0) {
        let prefix = &name[..at + 2];
        let closest = ProgramKind::ALL
            .iter()
            .min_by_key(|k| edit_distance(k.prefix(), prefix))
            .map(|k| k.prefix())
            .unwrap_or("raygen__");
        diags.push(loc.diagnostic(
            span,
            format!(
                "unknown program prefix `{prefix}` in `{name}` (did you mean `{closest}`?); program names start with one of {}, and `__` is reserved for them",
                prefixes_text()
            ),
        ));
    }
    None
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur.push(sub.min(prev[j + 1] + 1).min(cur[j] + 1));
        }
        prev = cur;
    }
    prev[b.len()]
}

/// Checks global variables and collects the `@group(0)` bindings.
fn check_globals(module: &Module, loc: &Locator, diags: &mut Vec<Diagnostic>) -> Vec<BindingInfo> {
    let mut bindings = Vec::new();
    let gctx = module.to_ctx();
    for (handle, var) in module.global_variables.iter() {
        let span = module.global_variables.get_span(handle);
        let name = var.name.clone().unwrap_or_default();
        match var.space {
            AddressSpace::WorkGroup => {
                diags.push(loc.diagnostic(
                    span,
                    format!("`var<workgroup> {name}`: workgroup memory is not available to ray tracing programs, which run one ray at a time (as in OptiX)"),
                ));
                continue;
            }
            AddressSpace::Immediate | AddressSpace::TaskPayload => {
                diags.push(loc.diagnostic(
                    span,
                    format!("`{name}`: this address space is not available to ray tracing programs; pass data through `params` (binding 0) or storage buffers"),
                ));
                continue;
            }
            AddressSpace::RayPayload | AddressSpace::IncomingRayPayload => {
                diags.push(loc.diagnostic(
                    span,
                    format!("`{name}`: naga's ray payload address spaces are not used by optik; payloads are `RtPayload` registers passed to rt_trace"),
                ));
                continue;
            }
            _ => {}
        }
        let Some(rb) = &var.binding else { continue };
        if rb.group != 0 {
            diags.push(loc.diagnostic(
                span,
                format!("`{name}` is in @group({}); programs use @group(0) only (groups 1 and up belong to the backends)", rb.group),
            ));
            continue;
        }
        let inner = &module.types[var.ty].inner;
        let kind = match (rb.binding, var.space) {
            (0, AddressSpace::Uniform) => BindingKind::Params {
                size: inner.size(gctx),
            },
            (0, _) => {
                diags.push(loc.diagnostic(
                    span,
                    format!("`{name}` at @binding(0): binding 0 is the launch parameters and must be `var<uniform> params: T`"),
                ));
                continue;
            }
            (_, AddressSpace::Uniform) => {
                diags.push(loc.diagnostic(
                    span,
                    format!("`{name}` at @binding({}): only binding 0 (the launch parameters) is a uniform; declare buffers from binding 1 up as `var<storage, read>` or `var<storage, read_write>`", rb.binding),
                ));
                continue;
            }
            (_, AddressSpace::Storage { access }) => BindingKind::StorageBuffer {
                read_only: !access.contains(naga::StorageAccess::STORE),
                min_size: storage_min_size(module, var.ty),
            },
            (_, AddressSpace::Handle) => match inner {
                TypeInner::Image {
                    dim: naga::ImageDimension::D2,
                    arrayed: false,
                    class:
                        naga::ImageClass::Sampled {
                            kind: naga::ScalarKind::Float,
                            multi: false,
                        },
                } => BindingKind::Texture2d,
                TypeInner::Sampler { comparison: false } => BindingKind::Sampler,
                _ => {
                    diags.push(loc.diagnostic(
                        span,
                        format!("`{name}`: unsupported resource type; programs may bind `texture_2d<f32>` and `sampler` (and storage buffers)"),
                    ));
                    continue;
                }
            },
            _ => continue,
        };
        if let Some(prev) = bindings
            .iter()
            .find(|b: &&BindingInfo| b.binding == rb.binding)
        {
            diags.push(loc.diagnostic(
                span,
                format!(
                    "`{name}` reuses @binding({}) of `{}`",
                    rb.binding, prev.name
                ),
            ));
            continue;
        }
        bindings.push(BindingInfo {
            binding: rb.binding,
            name,
            kind,
            global: handle,
        });
    }
    bindings.sort_by_key(|b| b.binding);
    bindings
}

/// Bytes of a storage type's fixed part.
fn storage_min_size(module: &Module, ty: Handle<naga::Type>) -> u32 {
    match &module.types[ty].inner {
        TypeInner::Array {
            size: naga::ArraySize::Dynamic,
            stride,
            ..
        } => *stride,
        TypeInner::Struct { members, span } => match members.last() {
            Some(last) => match module.types[last.ty].inner {
                TypeInner::Array {
                    size: naga::ArraySize::Dynamic,
                    stride,
                    ..
                } => last.offset + stride,
                _ => *span,
            },
            None => *span,
        },
        other => other.size(module.to_ctx()),
    }
}

/// The type of `RtPayload` (`array<u32, N>`): what the prelude's `rt_trace` points to.
/// naga does not keep alias names, so the type is found through the prelude's signature.
fn payload_type(module: &Module) -> Option<Handle<naga::Type>> {
    let (_, trace) = module
        .functions
        .iter()
        .find(|(_, f)| f.name.as_deref() == Some("rt_trace"))?;
    match module.types[trace.arguments.last()?.ty].inner {
        TypeInner::Pointer { base, .. } => Some(base),
        _ => None,
    }
}

/// Walks statements: collects calls, rejects forbidden statements.
fn walk_block(
    block: &Block,
    module: &Module,
    function: &Function,
    device_fns: &HashMap<Handle<Function>, DeviceFunction>,
    facts: &mut FunctionFacts,
    loc: &Locator,
    diags: &mut Vec<Diagnostic>,
) {
    for (stmt, span) in block.span_iter() {
        let span = *span;
        match stmt {
            Statement::Block(b) => walk_block(b, module, function, device_fns, facts, loc, diags),
            Statement::If { accept, reject, .. } => {
                walk_block(accept, module, function, device_fns, facts, loc, diags);
                walk_block(reject, module, function, device_fns, facts, loc, diags);
            }
            Statement::Switch { cases, .. } => {
                for case in cases {
                    walk_block(&case.body, module, function, device_fns, facts, loc, diags);
                }
            }
            Statement::Loop {
                body, continuing, ..
            } => {
                walk_block(body, module, function, device_fns, facts, loc, diags);
                walk_block(continuing, module, function, device_fns, facts, loc, diags);
            }
            Statement::Call {
                function: callee,
                arguments,
                ..
            } => {
                facts.calls.push((*callee, span));
                match device_fns.get(callee) {
                    Some(DeviceFunction::GetPayload | DeviceFunction::SetPayload) => {
                        facts
                            .payload_indices
                            .push(const_u32(module, function, arguments[0]));
                    }
                    Some(DeviceFunction::GetAttribute) => {
                        facts
                            .attribute_indices
                            .push(const_u32(module, function, arguments[0]));
                    }
                    _ => {}
                }
            }
            Statement::ControlBarrier(_)
            | Statement::MemoryBarrier(_)
            | Statement::WorkGroupUniformLoad { .. } => {
                diags.push(loc.diagnostic(
                    span,
                    "barriers are not available in ray tracing programs: each ray runs alone, with no workgroup to synchronise (as in OptiX)",
                ));
            }
            Statement::Kill => {
                diags.push(loc.diagnostic(
                    span,
                    "`discard` is for fragment shaders; ray tracing programs cannot use it",
                ));
            }
            Statement::RayQuery { .. } | Statement::RayPipelineFunction(_) => {
                diags.push(loc.diagnostic(
                    span,
                    "naga's ray query and ray pipeline built-ins are not part of optik's device API: trace rays with rt_trace",
                ));
            }
            Statement::SubgroupBallot { .. }
            | Statement::SubgroupGather { .. }
            | Statement::SubgroupCollectiveOperation { .. } => {
                diags.push(loc.diagnostic(
                    span,
                    "subgroup operations are not available in ray tracing programs",
                ));
            }
            Statement::ImageStore { .. } | Statement::ImageAtomic { .. } => {
                diags.push(loc.diagnostic(
                    span,
                    "storage textures are not supported: write results to a storage buffer",
                ));
            }
            Statement::CooperativeStore { .. } => {
                diags.push(loc.diagnostic(
                    span,
                    "cooperative matrix operations are not available in ray tracing programs",
                ));
            }
            _ => {}
        }
    }
}

/// The value of a constant `u32`/`i32` expression, or `None` when it is dynamic.
fn const_u32(module: &Module, function: &Function, expr: Handle<Expression>) -> Option<u32> {
    fn literal(l: &naga::Literal) -> Option<u32> {
        match *l {
            naga::Literal::U32(v) => Some(v),
            naga::Literal::I32(v) => u32::try_from(v).ok(),
            naga::Literal::AbstractInt(v) => u32::try_from(v).ok(),
            _ => None,
        }
    }
    match &function.expressions[expr] {
        Expression::Literal(l) => literal(l),
        Expression::ZeroValue(_) => Some(0),
        Expression::Constant(c) => match &module.global_expressions[module.constants[*c].init] {
            Expression::Literal(l) => literal(l),
            Expression::ZeroValue(_) => Some(0),
            _ => None,
        },
        _ => None,
    }
}

/// Rejects forbidden expressions and records indices into payload arrays.
#[allow(clippy::too_many_arguments)]
fn check_expressions(
    module: &Module,
    function: &Function,
    handle: Handle<Function>,
    info: &naga::valid::ModuleInfo,
    payload_ty: Option<Handle<naga::Type>>,
    facts: &mut FunctionFacts,
    loc: &Locator,
    diags: &mut Vec<Diagnostic>,
) {
    let finfo = &info[handle];
    let is_payload = |base: Handle<Expression>| -> bool {
        let Some(pty) = payload_ty else { return false };
        match finfo[base].ty.inner_with(&module.types) {
            TypeInner::Pointer { base, .. } => *base == pty,
            _ => finfo[base].ty.handle() == Some(pty),
        }
    };
    for (expr, e) in function.expressions.iter() {
        let span = function.expressions.get_span(expr);
        match e {
            Expression::ImageSample {
                level: naga::SampleLevel::Auto | naga::SampleLevel::Bias(_) | naga::SampleLevel::Gradient { .. },
                ..
            } => diags.push(loc.diagnostic(
                span,
                "textureSample and textureSampleBias need screen-space derivatives, which ray tracing programs do not have: use textureSampleLevel",
            )),
            Expression::Derivative { .. } => diags.push(loc.diagnostic(
                span,
                "derivatives (dpdx, dpdy, fwidth) are not available in ray tracing programs",
            )),
            Expression::RayQueryGetIntersection { .. }
            | Expression::RayQueryProceedResult
            | Expression::RayQueryVertexPositions { .. } => diags.push(loc.diagnostic(
                span,
                "ray queries are not part of optik's device API: trace rays with rt_trace",
            )),
            Expression::AccessIndex { base, index } if is_payload(*base) => {
                facts.payload_indices.push(Some(*index));
            }
            Expression::Access { base, index } if is_payload(*base) => {
                facts.payload_indices.push(const_u32(module, function, *index));
            }
            _ => {}
        }
    }
}

/// Follows the program's calls through the user's helpers: records the device functions and
/// bindings it reaches and checks each device call is legal in this kind of program.
#[allow(clippy::too_many_arguments)]
fn analyse_program(
    program: &mut ProgramInfo,
    module: &Module,
    info: &naga::valid::ModuleInfo,
    facts: &HashMap<Handle<Function>, FunctionFacts>,
    device_fns: &HashMap<Handle<Function>, DeviceFunction>,
    binding_of: &HashMap<Handle<naga::GlobalVariable>, u32>,
    loc: &Locator,
    diags: &mut Vec<Diagnostic>,
) {
    // Breadth-first, remembering through which function each was reached, for the message.
    let mut via: HashMap<Handle<Function>, Option<Handle<Function>>> = HashMap::new();
    let mut queue = VecDeque::from([program.function]);
    via.insert(program.function, None);
    while let Some(f) = queue.pop_front() {
        for (global, _) in module.global_variables.iter() {
            if !info[f][global].is_empty()
                && let Some(b) = binding_of.get(&global)
            {
                program.bindings_used.insert(*b);
            }
        }
        let Some(ff) = facts.get(&f) else { continue };
        for &(callee, span) in &ff.calls {
            if let Some(&df) = device_fns.get(&callee) {
                program.device_functions.insert(df);
                if !df.is_allowed_in(program.kind) {
                    let mut message = format!(
                        "`{}` cannot be used in a {} program (`{}`); it is available in {}",
                        df.name(),
                        program.kind.name(),
                        program.name,
                        df.allowed_in_text()
                    );
                    if f != program.function {
                        message.push_str(&format!(
                            " (reached through {})",
                            call_chain(module, &via, f)
                        ));
                    }
                    diags.push(loc.diagnostic(span, message));
                }
            } else if let std::collections::hash_map::Entry::Vacant(e) = via.entry(callee) {
                e.insert(Some(f));
                if let Some(name) = &module.functions[callee].name {
                    program.helpers.insert(name.clone());
                }
                queue.push_back(callee);
            }
        }
    }
}

fn call_chain(
    module: &Module,
    via: &HashMap<Handle<Function>, Option<Handle<Function>>>,
    mut f: Handle<Function>,
) -> String {
    let mut names = vec![];
    loop {
        names.push(module.functions[f].name.clone().unwrap_or_default());
        match via.get(&f) {
            Some(Some(parent)) => f = *parent,
            _ => break,
        }
    }
    names.reverse();
    names.join(" -> ")
}
