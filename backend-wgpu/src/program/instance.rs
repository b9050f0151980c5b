//! Lowering the user's programs into the megakernel, at the naga IR level.
//!
//! WGSL has no recursion, but ray tracing programs recurse through the device API: raygen
//! traces, the closest-hit program it reaches traces again, and so on. Every function that
//! can (transitively) trace, call a continuation callable or call a direct callable gets one
//! copy per call context: the trace depth `d`, the continuation-callable nesting `c` and the
//! direct-callable nesting `k`, each only where the function depends on it. A copy's calls
//! go to the copies of the next context, ending at stubs that raise the depth exceptions.
//!
//! Each program invocation owns its `var<private>` globals: every program copy (a *root*)
//! gets its own set, helpers that touch private globals are copied per root, and a root
//! starts by resetting its set from the pristine originals. So a suspended program (raygen
//! during a trace, an intersection program during the any-hit its report triggers) keeps its
//! values, and each program starts fresh.
//!
//! Device-API calls become calls to stubs named `_optik_*_fn`; after naga writes the module
//! with `wgsl-out`, the stubs' bodies are cut out and `crate::kernel` supplies real ones.
//! After every call that may unwind (ignore, terminate, an exception), the copy checks
//! `_optik_unwinding_fn()` and returns (the shared pass of `optik_core::unwind`), which is how
//! "does not return" is expressed in WGSL.

use super::analysis::{self, FnFacts};
use naga::{
    AddressSpace, Block, Expression, Function, FunctionResult, GlobalVariable, Handle, Module,
    Scalar, Span, Statement, Type, TypeInner,
};
use optik_api::{Error, Result};
use optik_core::frontend::{CompiledModule, DeviceFunction};
use optik_core::unwind::{self, Unwinding, UnwoundFlag};
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// Where a program is: a module (index into the pipeline's modules) and a function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ProgramLoc {
    pub module: usize,
    pub function: Handle<Function>,
}

/// The programs of one pipeline group.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct GroupPrograms {
    pub raygen: Option<ProgramLoc>,
    pub miss: Option<ProgramLoc>,
    pub closest_hit: Option<ProgramLoc>,
    pub any_hit: Option<ProgramLoc>,
    pub intersection: Option<ProgramLoc>,
    pub direct: Option<ProgramLoc>,
    pub continuation: Option<ProgramLoc>,
    pub exception: Option<ProgramLoc>,
}

/// A place in the megakernel that calls programs by group.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) enum Site {
    Raygen,
    /// Closest-hit programs run at trace depth `p` (1 = traced from raygen).
    ClosestHit(u32),
    Miss(u32),
    Intersection,
    AnyHit,
    /// Direct callables at nesting `k` (1 = called from a non-callable program).
    Direct(u32),
    /// Continuation callables at trace depth `d` and nesting `c`.
    Continuation(u32, u32),
    Exception,
}

/// What is lowered.
pub(crate) struct LowerInput<'a> {
    pub modules: Vec<&'a CompiledModule>,
    pub groups: Vec<GroupPrograms>,
    pub max_trace_depth: u32,
    pub max_direct_depth: u32,
    pub max_continuation_depth: u32,
    /// Any exception can be raised (so traces and callables may unwind).
    pub exceptions_on: bool,
    /// `rt_throw_exception` raises (the USER flag).
    pub user_throws: bool,
    pub any_hit: bool,
    pub intersection: bool,
}

/// The lowered programs.
pub(crate) struct Lowered {
    /// Each module as WGSL, stubs removed; user bindings of module `i > 0` moved up by
    /// `i * BINDING_STRIDE`.
    pub module_wgsl: Vec<String>,
    /// Per site, the program copy each group runs there.
    pub dispatch: BTreeMap<Site, Vec<(u32, String)>>,
    /// Trace depths `d` whose `_optik_trace_{d}_fn` is called (d = max_trace_depth: the
    /// depth-exceeded stub).
    pub traces: BTreeSet<u32>,
    /// Trace depths `d` below max_trace_depth whose `_optik_trace_{d}_nch_fn` is called: call
    /// sites whose flags have the `DISABLE_CLOSESTHIT` bit whatever their other operands are
    /// (shadow rays). Every driver inlines a trace's closest-hit dispatch, usually the
    /// largest part of a kernel, at each call site; these sites go without it.
    pub traces_without_closest_hit: BTreeSet<u32>,
    /// Direct-callable levels `k` whose `_optik_direct_{k}_fn` is called.
    pub directs: BTreeSet<u32>,
    /// `(d, c)` of the `_optik_cont_{d}_{c}_fn` called.
    pub continuations: BTreeSet<(u32, u32)>,
    /// The other device functions called.
    pub device_functions: BTreeSet<DeviceFunction>,
}

/// Binding numbers of module `i` of a pipeline start at `i * BINDING_STRIDE`.
pub(crate) const BINDING_STRIDE: u32 = 128;

/// The stub name of a plain device function.
pub(crate) fn device_stub_name(f: DeviceFunction) -> String {
    format!("_optik_{}_fn", f.name().trim_start_matches("rt_"))
}

/// The stub name of `rt_trace` at trace depth `d`.
pub(crate) fn trace_stub_name(d: u32) -> String {
    format!("_optik_trace_{d}_fn")
}

/// The stub name of `rt_trace` at trace depth `d` for call sites whose ray flags always
/// include `DISABLE_CLOSESTHIT`: a trace without the closest-hit dispatch.
pub(crate) fn trace_without_closest_hit_stub_name(d: u32) -> String {
    format!("_optik_trace_{d}_nch_fn")
}

/// The stub name of `rt_direct_call` calling nesting level `k`.
pub(crate) fn direct_stub_name(k: u32) -> String {
    format!("_optik_direct_{k}_fn")
}

/// The stub name of `rt_continuation_call` at depth `d` calling nesting level `c`.
pub(crate) fn continuation_stub_name(d: u32, c: u32) -> String {
    format!("_optik_cont_{d}_{c}_fn")
}

/// The stub that says whether the current program must return at once.
pub(crate) const UNWINDING_STUB: &str = "_optik_unwinding_fn";

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Ctx {
    d: u32,
    c: u32,
    k: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct FnKey {
    function: Handle<Function>,
    d: Option<u32>,
    c: Option<u32>,
    k: Option<u32>,
    root: Option<u32>,
    is_root: bool,
}

struct ModuleWork<'a> {
    src: &'a CompiledModule,
    out: Module,
    facts: Vec<FnFacts>,
    prefix: String,
    memo: HashMap<FnKey, Handle<Function>>,
    stubs: HashMap<String, Handle<Function>>,
    private_copies: HashMap<(u32, Handle<GlobalVariable>), Handle<GlobalVariable>>,
    names: HashMap<Handle<Function>, String>,
    count: u32,
}

struct Lowering<'a> {
    input: &'a LowerInput<'a>,
    work: Vec<ModuleWork<'a>>,
    pending: Vec<Site>,
    sites: BTreeSet<Site>,
    roots: HashMap<(usize, FnKey), u32>,
    out: Lowered,
}

/// Lowers the programs of a pipeline.
pub(crate) fn lower(input: &LowerInput<'_>) -> Result<Lowered> {
    let mut work = Vec::new();
    for (mi, src) in input.modules.iter().enumerate() {
        let mut out = src.module.clone();
        out.functions = naga::Arena::new();
        out.entry_points.clear();
        out.doc_comments = None;
        let prefix = unique_prefix(&out, mi);
        rename_module_items(&mut out, &prefix);
        if mi > 0 {
            for (_, g) in out.global_variables.iter_mut() {
                if let Some(b) = &mut g.binding {
                    if b.binding >= BINDING_STRIDE {
                        return Err(Error::unsupported(format!(
                            "module `{}` uses @binding({}); when a pipeline's programs come from several modules, bindings must be below {BINDING_STRIDE}",
                            src.file_name, b.binding
                        )));
                    }
                    b.binding += mi as u32 * BINDING_STRIDE;
                }
            }
        }
        work.push(ModuleWork {
            src,
            facts: analysis::analyse(&src.module, input.exceptions_on, input.user_throws),
            out,
            prefix,
            memo: HashMap::new(),
            stubs: HashMap::new(),
            private_copies: HashMap::new(),
            names: HashMap::new(),
            count: 0,
        });
    }
    let mut l = Lowering {
        input,
        work,
        pending: Vec::new(),
        sites: BTreeSet::new(),
        roots: HashMap::new(),
        out: Lowered {
            module_wgsl: Vec::new(),
            dispatch: BTreeMap::new(),
            traces: BTreeSet::new(),
            traces_without_closest_hit: BTreeSet::new(),
            directs: BTreeSet::new(),
            continuations: BTreeSet::new(),
            device_functions: BTreeSet::new(),
        },
    };
    l.request(Site::Raygen);
    if input.exceptions_on {
        l.request(Site::Exception);
    }
    while let Some(site) = l.pending.pop() {
        l.process(site)?;
    }
    for w in &mut l.work {
        l.out.module_wgsl.push(finish(w)?);
    }
    Ok(l.out)
}

/// A prefix no name in the module starts with, so prefixed names never collide.
fn unique_prefix(m: &Module, mi: usize) -> String {
    let names: Vec<&str> = m
        .types
        .iter()
        .filter_map(|(_, t)| t.name.as_deref())
        .chain(m.constants.iter().filter_map(|(_, c)| c.name.as_deref()))
        .chain(m.overrides.iter().filter_map(|(_, o)| o.name.as_deref()))
        .chain(
            m.global_variables
                .iter()
                .filter_map(|(_, g)| g.name.as_deref()),
        )
        .collect();
    let mut attempt = 0u32;
    loop {
        let p = if attempt == 0 {
            format!("m{mi}_")
        } else {
            format!("m{mi}q{attempt}_")
        };
        if !names.iter().any(|n| n.starts_with(&p)) {
            return p;
        }
        attempt += 1;
    }
}

/// Prefixes the names of types, constants, overrides and globals.
fn rename_module_items(m: &mut Module, prefix: &str) {
    let named: Vec<(Handle<Type>, Type)> = m
        .types
        .iter()
        .filter(|(_, t)| t.name.is_some())
        .map(|(h, t)| (h, t.clone()))
        .collect();
    for (h, t) in named {
        let renamed = Type {
            name: t.name.as_ref().map(|n| format!("{prefix}{n}")),
            inner: t.inner.clone(),
        };
        m.types.replace(h, renamed);
    }
    for (_, c) in m.constants.iter_mut() {
        if let Some(n) = &mut c.name {
            *n = format!("{prefix}{n}");
        }
    }
    for (_, o) in m.overrides.iter_mut() {
        if let Some(n) = &mut o.name {
            *n = format!("{prefix}{n}");
        }
    }
    for (_, g) in m.global_variables.iter_mut() {
        if let Some(n) = &mut g.name {
            *n = format!("{prefix}{n}");
        }
    }
}

/// A function name naga's namer keeps as it is: no `__`, no trailing `_` or digit.
fn stable_name(prefix: &str, original: &str, n: u32) -> String {
    let mut stem = String::new();
    for ch in original.chars() {
        if ch == '_' && (stem.is_empty() || stem.ends_with('_')) {
            continue;
        }
        if ch.is_ascii_alphanumeric() || ch == '_' {
            stem.push(ch);
        }
    }
    let stem = stem.trim_end_matches('_');
    format!("{prefix}{stem}_{n}x")
}

impl<'a> Lowering<'a> {
    fn request(&mut self, site: Site) {
        if self.sites.insert(site) {
            self.pending.push(site);
        }
    }

    fn request_trace(&mut self, d: u32) {
        if self.out.traces.insert(d) && d < self.input.max_trace_depth {
            self.request(Site::ClosestHit(d + 1));
            self.request(Site::Miss(d + 1));
            if self.input.any_hit {
                self.request(Site::AnyHit);
            }
            if self.input.intersection {
                self.request(Site::Intersection);
            }
        }
    }

    fn process(&mut self, site: Site) -> Result<()> {
        let ctx = match site {
            Site::Raygen | Site::Exception => Ctx { d: 0, c: 0, k: 0 },
            Site::ClosestHit(p) | Site::Miss(p) => Ctx { d: p, c: 0, k: 0 },
            Site::Intersection | Site::AnyHit => Ctx { d: 1, c: 0, k: 0 },
            Site::Direct(k) => Ctx { d: 0, c: 0, k },
            Site::Continuation(d, c) => Ctx { d, c, k: 0 },
        };
        let mut entries = Vec::new();
        for (gi, g) in self.input.groups.iter().enumerate() {
            let loc = match site {
                Site::Raygen => g.raygen,
                Site::ClosestHit(_) => g.closest_hit,
                Site::Miss(_) => g.miss,
                Site::Intersection => g.intersection,
                Site::AnyHit => g.any_hit,
                Site::Direct(_) => g.direct,
                Site::Continuation(..) => g.continuation,
                Site::Exception => g.exception,
            };
            let Some(loc) = loc else { continue };
            let key = self.key(loc.module, loc.function, ctx, None, true);
            let next = self.roots.len() as u32;
            let root = *self.roots.entry((loc.module, key)).or_insert(next);
            let h = self.instance(loc.module, loc.function, ctx, Some(root), true)?;
            entries.push((gi as u32, self.work[loc.module].names[&h].clone()));
        }
        self.out.dispatch.insert(site, entries);
        Ok(())
    }

    fn key(
        &self,
        mi: usize,
        f: Handle<Function>,
        ctx: Ctx,
        root: Option<u32>,
        is_root: bool,
    ) -> FnKey {
        let facts = &self.work[mi].facts[f.index()];
        FnKey {
            function: f,
            d: facts.traces.then_some(ctx.d),
            c: facts.continues.then_some(ctx.c),
            k: facts.calls_direct.then_some(ctx.k),
            root: if facts.privates.is_empty() {
                None
            } else {
                root
            },
            is_root,
        }
    }

    /// The copy of `f` for `ctx` (and `root`'s private globals), made on first use.
    fn instance(
        &mut self,
        mi: usize,
        f: Handle<Function>,
        ctx: Ctx,
        root: Option<u32>,
        is_root: bool,
    ) -> Result<Handle<Function>> {
        let key = self.key(mi, f, ctx, root, is_root);
        if let Some(h) = self.work[mi].memo.get(&key) {
            return Ok(*h);
        }
        let src = &self.work[mi].src.module.functions[f];
        let mut callees = BTreeSet::new();
        analysis::collect_calls(&src.body, &mut callees);
        // Callees first: naga wants a function's callees earlier in the arena.
        let mut target: HashMap<Handle<Function>, Handle<Function>> = HashMap::new();
        let mut unwinds: BTreeSet<Handle<Function>> = BTreeSet::new();
        let mut trace_stub = None;
        for callee in callees {
            let facts = self.work[mi].facts[callee.index()].clone();
            let mapped = match facts.device {
                Some(df) => {
                    if analysis::device_unwinds(
                        df,
                        self.input.exceptions_on,
                        self.input.user_throws,
                    ) {
                        unwinds.insert(callee);
                    }
                    let name = self.device_stub(df, ctx);
                    let stub = self.stub(mi, &name, callee);
                    if df == DeviceFunction::Trace && ctx.d < self.input.max_trace_depth {
                        trace_stub = Some((callee, stub));
                    }
                    stub
                }
                None => {
                    if facts.unwinds {
                        unwinds.insert(callee);
                    }
                    self.instance(mi, callee, ctx, root, false)?
                }
            };
            target.insert(callee, mapped);
        }
        let unwinding = if unwinds.is_empty() {
            None
        } else {
            Some(self.unwinding_stub(mi))
        };
        let w = &mut self.work[mi];
        let mut func = w.src.module.functions[f].clone();
        for (_, e) in func.expressions.iter_mut() {
            if let Expression::CallResult(callee) = e {
                *callee = target[callee];
            }
        }
        // Private globals: this root's copies.
        let facts = w.facts[f.index()].clone();
        if let (Some(root), false) = (root, facts.privates.is_empty()) {
            let mut copies = HashMap::new();
            for g in &facts.privates {
                let copy = *w.private_copies.entry((root, *g)).or_insert_with(|| {
                    let original = &w.out.global_variables[*g];
                    let var = GlobalVariable {
                        name: original.name.as_ref().map(|n| format!("{n}_r{root}")),
                        ..original.clone()
                    };
                    w.out.global_variables.append(var, Span::UNDEFINED)
                });
                copies.insert(*g, copy);
            }
            for (_, e) in func.expressions.iter_mut() {
                if let Expression::GlobalVariable(g) = e
                    && let Some(c) = copies.get(g)
                {
                    *g = *c;
                }
            }
            if is_root {
                let mut reset = Block::new();
                for g in &facts.privates {
                    let pristine = func
                        .expressions
                        .append(Expression::GlobalVariable(*g), Span::UNDEFINED);
                    let value = func
                        .expressions
                        .append(Expression::Load { pointer: pristine }, Span::UNDEFINED);
                    reset.push(
                        Statement::Emit(naga::Range::new_from_bounds(value, value)),
                        Span::UNDEFINED,
                    );
                    let own = func
                        .expressions
                        .append(Expression::GlobalVariable(copies[g]), Span::UNDEFINED);
                    reset.push(
                        Statement::Store {
                            pointer: own,
                            value,
                        },
                        Span::UNDEFINED,
                    );
                }
                let body = std::mem::take(&mut func.body);
                reset.extend_block(body);
                func.body = reset;
            }
        }
        let body = std::mem::take(&mut func.body);
        let result_ty = func.result.as_ref().map(|r| r.ty);
        let how = Unwinding {
            flag: unwinding.map(UnwoundFlag::Call),
            may_unwind: &|c| unwinds.contains(&c),
            redirect: &|c| target.get(&c).copied().unwrap_or(c),
        };
        func.body = unwind::insert_checks(body, &mut func.expressions, result_ty, &how);
        if let Some((template, with)) = trace_stub {
            // The stub costs nothing when no site uses it: `finish` cuts every stub out.
            let without = self.stub(mi, &trace_without_closest_hit_stub_name(ctx.d), template);
            let bits = KnownBits {
                module: &self.work[mi].out,
                exprs: &func.expressions,
            };
            let mut redirected = false;
            for_each_call(&mut func.body, &mut |callee, args| {
                if *callee == with && closest_hit_disabled(&bits, args) {
                    *callee = without;
                    redirected = true;
                }
            });
            if redirected {
                self.out.traces_without_closest_hit.insert(ctx.d);
            }
        }
        let w = &mut self.work[mi];
        let original = func.name.clone().unwrap_or_else(|| "f".into());
        let name = stable_name(&w.prefix, &original, w.count);
        w.count += 1;
        func.name = Some(name.clone());
        let h = w.out.functions.append(func, Span::UNDEFINED);
        w.memo.insert(key, h);
        w.names.insert(h, name);
        Ok(h)
    }

    /// The stub a device call becomes in context `ctx`, requesting what it needs.
    fn device_stub(&mut self, df: DeviceFunction, ctx: Ctx) -> String {
        match df {
            DeviceFunction::Trace => {
                self.request_trace(ctx.d);
                trace_stub_name(ctx.d)
            }
            DeviceFunction::DirectCall => {
                let k = ctx.k + 1;
                if self.out.directs.insert(k) && k <= self.input.max_direct_depth {
                    self.request(Site::Direct(k));
                }
                direct_stub_name(k)
            }
            DeviceFunction::ContinuationCall => {
                let c = ctx.c + 1;
                if self.out.continuations.insert((ctx.d, c))
                    && c <= self.input.max_continuation_depth
                {
                    self.request(Site::Continuation(ctx.d, c));
                }
                continuation_stub_name(ctx.d, c)
            }
            other => {
                self.out.device_functions.insert(other);
                device_stub_name(other)
            }
        }
    }

    /// A stub named `name` with the signature of the prelude function `template`.
    fn stub(&mut self, mi: usize, name: &str, template: Handle<Function>) -> Handle<Function> {
        let w = &mut self.work[mi];
        if let Some(h) = w.stubs.get(name) {
            return *h;
        }
        let mut f = w.src.module.functions[template].clone();
        f.name = Some(name.to_string());
        let h = w.out.functions.append(f, Span::UNDEFINED);
        w.stubs.insert(name.to_string(), h);
        h
    }

    fn unwinding_stub(&mut self, mi: usize) -> Handle<Function> {
        let w = &mut self.work[mi];
        if let Some(h) = w.stubs.get(UNWINDING_STUB) {
            return *h;
        }
        let bool_ty = w.out.types.insert(
            Type {
                name: None,
                inner: TypeInner::Scalar(Scalar::BOOL),
            },
            Span::UNDEFINED,
        );
        let mut f = Function {
            name: Some(UNWINDING_STUB.to_string()),
            result: Some(FunctionResult {
                ty: bool_ty,
                binding: None,
            }),
            ..Function::default()
        };
        let value = f.expressions.append(
            Expression::Literal(naga::Literal::Bool(false)),
            Span::UNDEFINED,
        );
        f.body
            .push(Statement::Return { value: Some(value) }, Span::UNDEFINED);
        let h = w.out.functions.append(f, Span::UNDEFINED);
        w.stubs.insert(UNWINDING_STUB.to_string(), h);
        h
    }
}

/// Bits of `u32` expressions that are set whatever the values of non-constant operands.
struct KnownBits<'a> {
    module: &'a Module,
    exprs: &'a naga::Arena<Expression>,
}

impl KnownBits<'_> {
    /// The bits of `e` known to be set (0 where nothing is known).
    fn of(&self, e: Handle<Expression>) -> u32 {
        self.in_arena(self.exprs, e, 0)
    }

    fn in_arena(&self, arena: &naga::Arena<Expression>, e: Handle<Expression>, depth: u32) -> u32 {
        if depth > 16 {
            return 0;
        }
        match arena[e] {
            Expression::Literal(naga::Literal::U32(v)) => v,
            Expression::Constant(c) => {
                let init = self.module.constants[c].init;
                self.in_arena(&self.module.global_expressions, init, depth + 1)
            }
            Expression::Binary {
                op: naga::BinaryOperator::InclusiveOr,
                left,
                right,
            } => self.in_arena(arena, left, depth + 1) | self.in_arena(arena, right, depth + 1),
            _ => 0,
        }
    }
}

/// `RT_RAY_FLAG_DISABLE_CLOSESTHIT`.
const DISABLE_CLOSESTHIT: u32 = 8;

/// Whether the flags argument (the eighth) of a call of `rt_trace` always disables closest-hit.
fn closest_hit_disabled(bits: &KnownBits<'_>, args: &[Handle<Expression>]) -> bool {
    args.get(7)
        .is_some_and(|&flags| bits.of(flags) & DISABLE_CLOSESTHIT != 0)
}

/// What [`for_each_call`] calls: the callee (to rewrite) and the arguments of one call.
type CallVisitor<'a> = dyn FnMut(&mut Handle<Function>, &[Handle<Expression>]) + 'a;

/// Calls `f` with the callee and arguments of every call statement in `block`, nested
/// blocks included.
fn for_each_call(block: &mut Block, f: &mut CallVisitor<'_>) {
    for statement in block.iter_mut() {
        match statement {
            Statement::Call {
                function,
                arguments,
                ..
            } => f(function, arguments),
            Statement::Block(b) => for_each_call(b, f),
            Statement::If { accept, reject, .. } => {
                for_each_call(accept, f);
                for_each_call(reject, f);
            }
            Statement::Switch { cases, .. } => {
                for case in cases {
                    for_each_call(&mut case.body, f);
                }
            }
            Statement::Loop {
                body, continuing, ..
            } => {
                for_each_call(body, f);
                for_each_call(continuing, f);
            }
            _ => {}
        }
    }
}

/// Validates a lowered module, writes it as WGSL and cuts out the stubs' bodies.
fn finish(w: &mut ModuleWork<'_>) -> Result<String> {
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        optik_core::frontend::capabilities(),
    )
    .validate(&w.out)
    .map_err(|e| {
        Error::backend(format!(
            "lowering `{}` for the wgpu megakernel produced invalid IR: {}",
            w.src.file_name,
            e.as_inner()
        ))
    })?;
    let mut text =
        naga::back::wgsl::write_string(&w.out, &info, naga::back::wgsl::WriterFlags::empty())
            .map_err(|e| {
                Error::backend(format!("writing `{}` as WGSL failed: {e}", w.src.file_name))
            })?;
    for name in w.stubs.keys() {
        text = remove_function(&text, name).ok_or_else(|| {
            Error::backend(format!(
                "the WGSL written for `{}` has no function `{name}` (naga renamed it)",
                w.src.file_name
            ))
        })?;
    }
    for name in w.names.values() {
        if !text.contains(&format!("fn {name}(")) {
            return Err(Error::backend(format!(
                "the WGSL written for `{}` has no function `{name}` (naga renamed it)",
                w.src.file_name
            )));
        }
    }
    // Private globals are per program copy; the originals keep the initial values.
    let _ = AddressSpace::Private;
    Ok(text)
}

/// `text` without the definition of function `name` (naga writes `fn name(...) ... {` and
/// the body's braces balance; stubs hold no strings or comments).
pub(crate) fn remove_function(text: &str, name: &str) -> Option<String> {
    let start = text.find(&format!("fn {name}("))?;
    let open = start + text[start..].find('{')?;
    let mut depth = 0usize;
    let mut end = None;
    for (i, ch) in text[open..].char_indices() {
        match ch {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    end = Some(open + i + 1);
                    break;
                }
            }
            _ => {}
        }
    }
    let end = end?;
    let end = if text[end..].starts_with('\n') {
        end + 1
    } else {
        end
    };
    Some(format!("{}{}", &text[..start], &text[end..]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stable_names_survive_nagas_namer() {
        assert_eq!(stable_name("m0_", "raygen__main", 3), "m0_raygen_main_3x");
        assert_eq!(stable_name("m1_", "f2", 0), "m1_f2_0x");
        assert_eq!(stable_name("m0_", "_x__", 1), "m0_x_1x");
    }

    #[test]
    fn remove_function_cuts_balanced_bodies() {
        let text = "fn a() {\n    if true { }\n}\nfn b() -> u32 {\n    return 0u;\n}\n";
        assert_eq!(
            remove_function(text, "a").unwrap(),
            "fn b() -> u32 {\n    return 0u;\n}\n"
        );
        assert_eq!(
            remove_function(text, "b").unwrap(),
            "fn a() {\n    if true { }\n}\n"
        );
        assert!(remove_function(text, "c").is_none());
    }
}
