//! What each function of a module does, transitively: which device calls it makes (so which
//! per-context copies it needs), which private globals it touches, whether a call to it
//! can unwind.

use naga::{AddressSpace, Block, Expression, Function, GlobalVariable, Handle, Module, Statement};
use optik_core::frontend::DeviceFunction;
use std::collections::BTreeSet;

/// Facts about one function, including everything it calls.
#[derive(Clone, Debug, Default)]
pub(crate) struct FnFacts {
    /// The device function this is (a prelude stub), if any; `rt_offset_ray` is a real
    /// function and counts as a helper.
    pub device: Option<DeviceFunction>,
    /// User functions it calls directly.
    pub callees: BTreeSet<Handle<Function>>,
    /// It may trace (directly, or through a continuation callable): copies per trace depth.
    pub traces: bool,
    /// It may call a continuation callable: copies per continuation nesting.
    pub continues: bool,
    /// It may call a direct callable: copies per direct-callable nesting.
    pub calls_direct: bool,
    /// Private globals it (or a callee) reads or writes: copies per owning program.
    pub privates: BTreeSet<Handle<GlobalVariable>>,
    /// A call to it may unwind (ignore, terminate, exception).
    pub unwinds: bool,
}

/// Whether a device function may unwind its caller, given whether exceptions are on.
pub(crate) fn device_unwinds(f: DeviceFunction, exceptions_on: bool, user_throws: bool) -> bool {
    match f {
        DeviceFunction::IgnoreIntersection
        | DeviceFunction::TerminateRay
        | DeviceFunction::ReportIntersection => true,
        DeviceFunction::ThrowException => user_throws,
        DeviceFunction::Trace | DeviceFunction::DirectCall | DeviceFunction::ContinuationCall => {
            exceptions_on
        }
        _ => false,
    }
}

/// Facts for every function of `module`, indexed by handle.
pub(crate) fn analyse(module: &Module, exceptions_on: bool, user_throws: bool) -> Vec<FnFacts> {
    let mut facts: Vec<FnFacts> = Vec::with_capacity(module.functions.len());
    // naga orders functions so that callees come first: one pass suffices.
    for (handle, function) in module.functions.iter() {
        let device = function
            .name
            .as_deref()
            .and_then(DeviceFunction::from_name)
            .filter(|d| *d != DeviceFunction::OffsetRay);
        let mut f = FnFacts {
            device,
            ..FnFacts::default()
        };
        if device.is_none() {
            let mut calls = BTreeSet::new();
            collect_calls(&function.body, &mut calls);
            for callee in calls {
                let c = &facts[callee.index()];
                match c.device {
                    Some(d) => {
                        f.traces |=
                            matches!(d, DeviceFunction::Trace | DeviceFunction::ContinuationCall);
                        f.continues |= d == DeviceFunction::ContinuationCall;
                        f.calls_direct |= d == DeviceFunction::DirectCall;
                        f.unwinds |= device_unwinds(d, exceptions_on, user_throws);
                    }
                    None => {
                        f.callees.insert(callee);
                        f.traces |= c.traces;
                        f.continues |= c.continues;
                        f.calls_direct |= c.calls_direct;
                        f.unwinds |= c.unwinds;
                        f.privates.extend(c.privates.iter().copied());
                    }
                }
            }
            for (_, e) in function.expressions.iter() {
                if let Expression::GlobalVariable(g) = e
                    && module.global_variables[*g].space == AddressSpace::Private
                {
                    f.privates.insert(*g);
                }
            }
        }
        debug_assert_eq!(facts.len(), handle.index());
        facts.push(f);
    }
    facts
}

/// Every function called from `block`.
pub(crate) fn collect_calls(block: &Block, out: &mut BTreeSet<Handle<Function>>) {
    for stmt in block.iter() {
        match stmt {
            Statement::Call { function, .. } => {
                out.insert(*function);
            }
            Statement::Block(b) => collect_calls(b, out),
            Statement::If { accept, reject, .. } => {
                collect_calls(accept, out);
                collect_calls(reject, out);
            }
            Statement::Switch { cases, .. } => {
                for c in cases {
                    collect_calls(&c.body, out);
                }
            }
            Statement::Loop {
                body, continuing, ..
            } => {
                collect_calls(body, out);
                collect_calls(continuing, out);
            }
            _ => {}
        }
    }
}
