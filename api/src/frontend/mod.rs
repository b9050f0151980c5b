//! The WGSL program front end: parse, validate, check the program model, reflect.
//!
//! [`compile`] appends the device-API prelude after the user's source (so naga's line
//! numbers are the user's), parses and validates it with naga, then checks what naga cannot
//! know: program names and signatures, where each device function may be called, and the
//! constructs ray tracing programs forbid. Every error is a [`Diagnostic`] at the user's
//! `file:line:column`. The result, a [`CompiledModule`], is what every backend lowers.

mod device_api;
mod locate;
mod reflect;

pub use device_api::{
    DeviceFunction, OFFSET_RAY_BODY, PRELUDE_CONSTANTS, PRELUDE_EXCEPTION_CODES, PRELUDE_MARKER,
    prelude,
};
pub use reflect::{BindingInfo, BindingKind, ProgramInfo};

use crate::device::ProgramSource;
use crate::error::{Diagnostic, Error, Result};
use crate::program::ProgramKind;
use locate::Locator;

/// A parsed, validated and checked module, ready for a backend to lower.
#[derive(Debug, Clone)]
pub struct CompiledModule {
    /// The file name diagnostics report.
    pub file_name: String,
    /// The user's source as given.
    pub user_source: String,
    /// The user's source followed by the prelude: what naga parsed.
    pub full_source: String,
    /// Byte length of the user part of `full_source` (including the newline optik adds).
    pub user_len: usize,
    /// Payload registers the prelude's `RtPayload` holds.
    pub payload_len: u32,
    /// The naga IR of `full_source`.
    pub module: naga::Module,
    /// naga's validation info for `module`.
    pub info: naga::valid::ModuleInfo,
    /// The programs, in source order.
    pub programs: Vec<ProgramInfo>,
    /// The `@group(0)` bindings the module declares, by binding number.
    pub bindings: Vec<BindingInfo>,
    /// Payload registers the programs use: the largest constant index plus one, or 32 when
    /// an index is dynamic.
    pub payload_values_used: u32,
    /// Attribute registers the programs read or report.
    pub attribute_values_used: u32,
}

impl CompiledModule {
    /// The program named `name`.
    pub fn program(&self, name: &str) -> Option<&ProgramInfo> {
        self.programs.iter().find(|p| p.name == name)
    }

    /// The launch-parameter binding (`@group(0) @binding(0) var<uniform>`), if declared.
    pub fn params(&self) -> Option<&BindingInfo> {
        self.bindings.iter().find(|b| b.binding == 0)
    }

    /// A diagnostic at `span` of `full_source`, located in the user's source as the front
    /// end's own errors are (spans in the prelude are reported against `<optik prelude>`).
    /// Backends use it for constructs they cannot lower.
    pub fn diagnostic(&self, span: naga::Span, message: impl Into<String>) -> Diagnostic {
        Locator::new(&self.file_name, &self.full_source, self.user_len).diagnostic(span, message)
    }

    /// The naga function of a device function (its prelude stub).
    pub fn device_function(&self, f: DeviceFunction) -> Option<naga::Handle<naga::Function>> {
        self.module
            .functions
            .iter()
            .find(|(_, func)| func.name.as_deref() == Some(f.name()))
            .map(|(h, _)| h)
    }
}

/// The capabilities programs may use: what every backend supports.
pub fn capabilities() -> naga::valid::Capabilities {
    naga::valid::Capabilities::default()
}

/// Parses, validates, checks and reflects `source` with a prelude of `payload_len` payload
/// registers.
pub fn compile(source: &ProgramSource, payload_len: u32) -> Result<CompiledModule> {
    let mut full = source.wgsl.clone();
    if !full.ends_with('\n') {
        full.push('\n');
    }
    let user_len = full.len();
    full.push_str(&prelude(payload_len));
    let loc = Locator::new(&source.file_name, &full, user_len);

    let module = naga::front::wgsl::parse_str(&full).map_err(|e| {
        let span = e.labels().next().map(|(s, _)| s).unwrap_or_default();
        let mut message = e.message().to_string();
        for (_, label) in e.labels() {
            if !label.is_empty() && !message.contains(label) {
                message.push_str(&format!(" ({label})"));
            }
        }
        Error::compile(vec![loc.diagnostic(span, message)])
    })?;

    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities())
        .validate(&module)
        .map_err(|e| {
            // naga lists the enclosing function first and the offending expression after it:
            // the narrowest span is the most precise place.
            let span = e
                .spans()
                .map(|(s, _)| *s)
                .filter(|s| s.is_defined())
                .min_by_key(|s| s.to_range().map_or(usize::MAX, |r| r.len()))
                .unwrap_or_default();
            let mut message = e.as_inner().to_string();
            let mut cause = std::error::Error::source(e.as_inner());
            while let Some(c) = cause {
                message.push_str(&format!(": {c}"));
                cause = c.source();
            }
            for (_, label) in e.spans() {
                // naga's labels name IR handles ("naga::ir::Function [0]"), useless to users.
                if !label.is_empty()
                    && !label.contains("naga::")
                    && !message.contains(label.as_str())
                {
                    message.push_str(&format!(" ({label})"));
                }
            }
            Error::compile(vec![loc.diagnostic(span, message)])
        })?;

    let mut diagnostics: Vec<Diagnostic> = Vec::new();
    let reflection = reflect::reflect(&module, &info, &loc, &mut diagnostics);
    if !diagnostics.is_empty() {
        diagnostics.sort_by_key(|d| (d.line, d.column));
        diagnostics.dedup();
        return Err(Error::compile(diagnostics));
    }
    Ok(CompiledModule {
        file_name: source.file_name.clone(),
        user_source: source.wgsl.clone(),
        full_source: full,
        user_len,
        payload_len,
        module,
        info,
        programs: reflection.programs,
        bindings: reflection.bindings,
        payload_values_used: reflection.payload_values_used,
        attribute_values_used: reflection.attribute_values_used,
    })
}

/// The programs of a module kind by kind, for listings.
pub fn programs_of_kind(module: &CompiledModule, kind: ProgramKind) -> Vec<&ProgramInfo> {
    module.programs.iter().filter(|p| p.kind == kind).collect()
}

#[cfg(test)]
mod tests;
