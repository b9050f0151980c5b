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
pub(crate) mod scan;

pub use device_api::{
    DeviceFunction, OFFSET_RAY_BODY, PRELUDE_CONSTANTS, PRELUDE_EXCEPTION_CODES, PRELUDE_MARKER,
    prelude,
};
pub use reflect::{BindingInfo, BindingKind, ProgramInfo};

use locate::Locator;
use optik_api::device::ProgramSource;
use optik_api::error::{Diagnostic, Error, Result};
use optik_api::program::ProgramKind;

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
    /// end's own errors are (spans in the prelude are reported at the end of the user's source).
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
/// registers. A leading UTF-8 byte order mark is ignored.
pub fn compile(source: &ProgramSource, payload_len: u32) -> Result<CompiledModule> {
    // Editors on Windows start files with a byte order mark; it is not WGSL.
    let user = source.wgsl.strip_prefix('\u{FEFF}').unwrap_or(&source.wgsl);
    let mut full = user.to_string();
    if !full.ends_with('\n') {
        full.push('\n');
    }
    let user_len = full.len();
    let prelude_text = prelude(payload_len);
    full.push_str(&prelude_text);
    let loc = Locator::new(&source.file_name, &full, user_len);
    check_user_text(&loc, &full[..user_len], &prelude_text)?;

    let module = naga::front::wgsl::parse_str(&full)
        .map_err(|e| Error::compile(vec![parse_diagnostic(&e, &loc, &full[..user_len])]))?;

    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities())
        .validate(&module)
        .map_err(|e| {
            // naga lists the enclosing function first and the offending expression after it:
            // the narrowest span is the most precise place, the user's own text first.
            let defined: Vec<naga::Span> = e
                .spans()
                .map(|(s, _)| *s)
                .filter(|s| s.is_defined())
                .collect();
            let narrowest = |spans: &mut dyn Iterator<Item = naga::Span>| {
                spans.min_by_key(|s| s.to_range().map_or(usize::MAX, |r| r.len()))
            };
            let mut message = e.as_inner().to_string();
            let mut cause = std::error::Error::source(e.as_inner());
            while let Some(c) = cause {
                message.push_str(&format!(": {c}"));
                cause = c.source();
            }
            let span = narrowest(&mut defined.iter().copied().filter(|s| loc.is_user(*s)))
                .or_else(|| narrowest(&mut defined.iter().copied()))
                .unwrap_or_else(|| fallback_span(&message, &full[..user_len]));
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
        user_source: user.to_string(),
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

/// A naga parse error as a diagnostic in the user's text: its notes kept, its position the
/// first label in the user's text (naga's first label may fall in the prelude), or for
/// errors naga gives no position, the likeliest place.
fn parse_diagnostic(e: &naga::front::wgsl::ParseError, loc: &Locator, user: &str) -> Diagnostic {
    let notes: Vec<&str> = e.notes().filter(|n| !n.is_empty()).collect();
    // naga's "internal" errors say what happened only in their notes (the recursion limit).
    let internal = e.message() == "internal WGSL front end error";
    let mut message = match (internal, notes.first()) {
        (true, Some(first)) => format!("WGSL front end error: {first}"),
        _ => e.message().to_string(),
    };
    for (_, label) in e.labels() {
        if !label.is_empty() && !message.contains(label) {
            message.push_str(&format!(" ({label})"));
        }
    }
    for note in notes.iter().skip(usize::from(internal)) {
        message.push_str(&format!("; note: {note}"));
    }
    let labels: Vec<naga::Span> = e
        .labels()
        .map(|(s, _)| s)
        .filter(|s| s.is_defined())
        .collect();
    let span = labels
        .iter()
        .copied()
        .find(|s| loc.is_user(*s))
        .or_else(|| labels.first().copied())
        .unwrap_or_else(|| fallback_span(&message, user));
    if internal && message.contains("recursion limit") {
        message.push_str(
            "; the code nests too deeply for naga's WGSL parser (fewer than 200 levels of brackets, blocks and expressions); the deepest nesting starts here",
        );
    }
    loc.diagnostic(span, message)
}

/// Where to report an error naga gives no position: the deepest nesting for a recursion
/// limit, the largest array for a type too large; else the start of the file.
fn fallback_span(message: &str, user: &str) -> naga::Span {
    let at = if message.contains("recursion limit") {
        scan::deepest_nesting(user).map(|(start, _)| (start, start + 1))
    } else if message.contains("too large") {
        scan::largest_array(user)
    } else {
        None
    };
    at.map_or_else(naga::Span::default, |(s, e)| {
        naga::Span::new(s as u32, e as u32)
    })
}

/// What naga cannot report in the user's text because it only notices it in the prelude
/// that follows: a bracket or comment left open, module-scope names that would hide a name
/// the prelude declares or relies on, and names with the prefix of the WGSL the backends add
/// (`optik_api::wgsl::INTERNAL_PREFIX`), which would clash there.
fn check_user_text(loc: &Locator, user: &str, prelude_text: &str) -> Result<()> {
    let one = |start: usize, end: usize, message: String| {
        Err(Error::compile(vec![loc.diagnostic(
            naga::Span::new(start as u32, end as u32),
            message,
        )]))
    };
    if let Some(at) = scan::unclosed_comment(user) {
        return one(at, at + 2, "this `/*` comment is never closed".into());
    }
    if let Some((at, open)) = scan::unclosed_bracket(user) {
        let close = match open {
            '{' => '}',
            '(' => ')',
            _ => ']',
        };
        return one(
            at,
            at + 1,
            format!(
                "this `{open}` is never closed: a `{close}` is missing before the end of the file"
            ),
        );
    }
    let reserved = scan::prelude_names(prelude_text);
    let mut diagnostics = Vec::new();
    for d in scan::module_scope_names(user) {
        let what = match d.keyword {
            "fn" => "a function",
            "struct" => "a struct",
            "alias" => "a type alias",
            "const" => "a constant",
            "override" => "an override",
            _ => "a variable",
        };
        if optik_api::wgsl::is_internal_name(&d.name) {
            diagnostics.push(loc.diagnostic(
                naga::Span::new(d.start as u32, d.end as u32),
                format!(
                    "{what} named `{}`: names starting with `{}` (in any letter case) are reserved for the WGSL optik adds to your programs; rename it",
                    d.name,
                    optik_api::wgsl::INTERNAL_PREFIX
                ),
            ));
            continue;
        }
        let Some((_, declared_by_prelude)) = reserved.iter().find(|(n, _)| *n == d.name) else {
            continue;
        };
        let message = if *declared_by_prelude {
            format!(
                "`{}` is a name of optik's device API, declared by the prelude optik adds after your source; {what} cannot take it: rename it",
                d.name
            )
        } else {
            format!(
                "{what} named `{}` would hide WGSL's own `{}`, which optik's device-API prelude uses; rename it",
                d.name, d.name
            )
        };
        diagnostics.push(loc.diagnostic(naga::Span::new(d.start as u32, d.end as u32), message));
    }
    if diagnostics.is_empty() {
        Ok(())
    } else {
        Err(Error::compile(diagnostics))
    }
}

/// Turns a WGSL file's bytes into a [`ProgramSource`]: a byte order mark is dropped, and
/// bytes that are not UTF-8 are a compile error naming their byte offset, line and column.
pub fn source_from_bytes(file_name: &str, bytes: &[u8]) -> Result<ProgramSource> {
    match std::str::from_utf8(bytes) {
        Ok(text) => Ok(ProgramSource::new(
            file_name,
            text.strip_prefix('\u{FEFF}').unwrap_or(text),
        )),
        Err(e) => {
            let at = e.valid_up_to();
            // Everything before `at` is valid UTF-8, so lines and columns can be counted.
            let before = String::from_utf8_lossy(&bytes[..at]);
            let line = before.matches('\n').count() as u32 + 1;
            let line_start = before.rfind('\n').map_or(0, |p| p + 1);
            let bad: Vec<String> = bytes[at..]
                .iter()
                .take(e.error_len().unwrap_or(bytes.len() - at).max(1))
                .map(|b| format!("{b:#04x}"))
                .collect();
            Err(Error::compile(vec![Diagnostic {
                file: file_name.to_string(),
                line,
                column: (at - line_start) as u32 + 1,
                message: format!(
                    "the file is not UTF-8: byte offset {at} holds {} (WGSL source must be UTF-8 text)",
                    bad.join(" ")
                ),
                source_line: String::new(),
            }]))
        }
    }
}

/// The programs of a module kind by kind, for listings.
pub fn programs_of_kind(module: &CompiledModule, kind: ProgramKind) -> Vec<&ProgramInfo> {
    module.programs.iter().filter(|p| p.kind == kind).collect()
}

/// The module-scope names `generated` declares (functions, structs, aliases, constants,
/// overrides, variables) that are neither declared by `user` nor device-API names of the
/// front end's prelude, and do not start with `optik_api::wgsl::INTERNAL_PREFIX`: what a backend's
/// generated WGSL must not have. Backends test their generated sources with it.
pub fn unprefixed_internal_names(generated: &str, user: &str) -> Vec<String> {
    let user: Vec<String> = scan::module_scope_names(user)
        .into_iter()
        .map(|d| d.name)
        .collect();
    let api: Vec<String> = scan::module_scope_names(&prelude(32))
        .into_iter()
        .map(|d| d.name)
        .collect();
    scan::module_scope_names(generated)
        .into_iter()
        .map(|d| d.name)
        .filter(|n| !optik_api::wgsl::is_internal_name(n) && !user.contains(n) && !api.contains(n))
        .collect()
}

#[cfg(test)]
mod tests;
