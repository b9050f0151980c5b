//! Direct callables called from intersection and any-hit programs. Vulkan runs callables
//! only from raygen, closest-hit, miss and callable stages, so optik compiles the direct
//! callables of the pipeline into those stages instead (as the wgpu megakernel does for
//! every program): `rt_direct_call` there goes to a generated dispatcher, which reads the
//! called record's program and data from the callable table of the launch (`@group(1)
//! @binding(5)`, sbt.rs) and switches over the module's direct callables. Inside, the
//! device functions of a callable read the inlined call's arguments and record
//! (device_api.rs).
//!
//! WGSL has no recursion, so a direct callable that calls direct callables (through any
//! helper) gets one copy per nesting level: level `k`'s copies call the dispatcher of level
//! `k + 1`, and the dispatcher past `max_direct_callable_depth` raises `STACK_OVERFLOW`.
//! Copies are the callable's source text with the names of the functions copied renamed
//! (naga gives every function's source span).

use super::config::LoweringConfig;
use super::device_api::raise_if;
use naga::{Block, Function, Handle, Statement};
use optik_api::ExceptionFlags;
use optik_core::frontend::CompiledModule;
use std::collections::{BTreeSet, HashMap};

/// The direct callables of a pipeline a module holds: their program id in the pipeline's
/// callable table and their function name.
pub type ModuleCallables = [(u32, String)];

/// The WGSL appended to a module for the inlined calls: copies of its direct callables per
/// nesting level and the dispatchers. `module` is `None` for optik's own module (no
/// callables).
pub fn inline_source(
    config: &LoweringConfig,
    module: Option<&CompiledModule>,
    callables: &ModuleCallables,
) -> String {
    let max = config.max_direct_callable_depth;
    let copied = match module {
        Some(m) => reaching_direct_calls(m, callables),
        None => Vec::new(),
    };
    // Without nested calls, level 1 calls the callables themselves.
    let levels = if copied.is_empty() { max.min(1) } else { max };
    let mut s = String::from(
        "\n// ---- direct callables inlined into intersection and any-hit stages (program/inline.rs) ----\n",
    );
    let names: BTreeSet<&str> = copied.iter().map(|(n, _)| n.as_str()).collect();
    for level in 1..=levels {
        for (_, text) in &copied {
            s.push_str(&renamed(text, &names, level));
            s.push('\n');
        }
    }
    for level in 1..=levels {
        s.push_str(&dispatcher(config, callables, &names, level));
    }
    s.push_str(&format!(
        "\nfn _optik_inline_call_{}(index: u32, args: ptr<function, RtPayload>) {{\n    {}\n}}\n",
        levels + 1,
        raise_if(
            config,
            ExceptionFlags::STACK_OVERFLOW,
            "RT_EXCEPTION_CODE_STACK_OVERFLOW"
        )
    ));
    s
}

/// The dispatcher of nesting level `level`.
fn dispatcher(
    config: &LoweringConfig,
    callables: &ModuleCallables,
    copied: &BTreeSet<&str>,
    level: u32,
) -> String {
    let invalid = raise_if(
        config,
        ExceptionFlags::DEBUG,
        "RT_EXCEPTION_CODE_CALLABLE_INVALID_SBT",
    );
    let mut cases = String::new();
    for (id, name) in callables {
        let target = if copied.contains(name.as_str()) {
            copy_name(name, level)
        } else {
            name.clone()
        };
        cases.push_str(&format!(
            "        case {id}u: {{\n            {target}();\n        }}\n"
        ));
    }
    let refresh = if config.unwinds() {
        "\n    _optik_unwound = _optik_unwinding();"
    } else {
        ""
    };
    format!(
        r#"
// Level {level}: record `index` of the callable table (program id, data offset).
fn _optik_inline_call_{level}(index: u32, args: ptr<function, RtPayload>) {{
    if index >= _optik_launch.callable_count {{
        {invalid}
        return;
    }}
    let program = _optik_callables[2u * index];
    let data = _optik_callables[2u * index + 1u];
    let saved_args = _optik_args;
    let saved_data = _optik_inline_data;
    let saved_depth = _optik_inline_depth;
    _optik_args = *args;
    _optik_inline_data = data;
    _optik_inline_depth = {level}u;
    switch program {{
{cases}        default: {{
            {invalid}
        }}
    }}
    *args = _optik_args;
    _optik_args = saved_args;
    _optik_inline_data = saved_data;
    _optik_inline_depth = saved_depth;{refresh}
}}
"#
    )
}

/// The name of `name`'s copy at `level`.
fn copy_name(name: &str, level: u32) -> String {
    format!("{name}__optik_inline{level}")
}

/// The functions reachable from `callables` that call `rt_direct_call` (through any
/// helper), with their source text: they need a copy per level.
fn reaching_direct_calls(m: &CompiledModule, callables: &ModuleCallables) -> Vec<(String, String)> {
    let module = &m.module;
    let name_of = |h: Handle<Function>| module.functions[h].name.clone().unwrap_or_default();
    let user = |h: Handle<Function>| {
        module
            .functions
            .get_span(h)
            .to_range()
            .is_some_and(|r| r.end <= m.user_len)
    };
    let callees: HashMap<Handle<Function>, Vec<Handle<Function>>> = module
        .functions
        .iter()
        .map(|(h, f)| {
            let mut out = Vec::new();
            calls(&f.body, &mut out);
            (h, out)
        })
        .collect();
    let direct_call = module
        .functions
        .iter()
        .find(|(_, f)| f.name.as_deref() == Some("rt_direct_call"))
        .map(|(h, _)| h);
    // Functions that reach rt_direct_call.
    let mut reaching: BTreeSet<Handle<Function>> = direct_call.into_iter().collect();
    loop {
        let more: Vec<Handle<Function>> = callees
            .iter()
            .filter(|(h, c)| !reaching.contains(h) && c.iter().any(|x| reaching.contains(x)))
            .map(|(h, _)| *h)
            .collect();
        if more.is_empty() {
            break;
        }
        reaching.extend(more);
    }
    // Functions reachable from the callables.
    let mut stack: Vec<Handle<Function>> = module
        .functions
        .iter()
        .filter(|(_, f)| {
            callables
                .iter()
                .any(|(_, n)| f.name.as_deref() == Some(n.as_str()))
        })
        .map(|(h, _)| h)
        .collect();
    let mut reachable: BTreeSet<Handle<Function>> = stack.iter().copied().collect();
    while let Some(h) = stack.pop() {
        for c in callees.get(&h).into_iter().flatten() {
            if reachable.insert(*c) {
                stack.push(*c);
            }
        }
    }
    reachable
        .into_iter()
        .filter(|h| reaching.contains(h) && user(*h))
        .filter_map(|h| {
            let range = module.functions.get_span(h).to_range()?;
            Some((name_of(h), m.full_source.get(range)?.to_string()))
        })
        .collect()
}

/// The functions `block` calls.
fn calls(block: &Block, out: &mut Vec<Handle<Function>>) {
    for s in block.iter() {
        match s {
            Statement::Call { function, .. } => out.push(*function),
            Statement::Block(b) => calls(b, out),
            Statement::If { accept, reject, .. } => {
                calls(accept, out);
                calls(reject, out);
            }
            Statement::Switch { cases, .. } => cases.iter().for_each(|c| calls(&c.body, out)),
            Statement::Loop {
                body, continuing, ..
            } => {
                calls(body, out);
                calls(continuing, out);
            }
            _ => {}
        }
    }
}

/// A function's text at `level`: the names of `copied` functions renamed to their copies of
/// that level, `rt_direct_call` to the next level's dispatcher. Identifiers after a `.`
/// (member accesses and swizzles) and inside comments stay.
fn renamed(text: &str, copied: &BTreeSet<&str>, level: u32) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    let bytes = text.as_bytes();
    let mut i = 0;
    let mut after_dot = false;
    while i < bytes.len() {
        let c = bytes[i];
        if text[i..].starts_with("//") {
            let end = text[i..].find('\n').map_or(text.len(), |e| i + e);
            out.push_str(&text[i..end]);
            i = end;
            continue;
        }
        if text[i..].starts_with("/*") {
            let end = block_comment_end(text, i);
            out.push_str(&text[i..end]);
            i = end;
            continue;
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            let end = text[i..]
                .find(|ch: char| !(ch.is_ascii_alphanumeric() || ch == '_'))
                .map_or(text.len(), |e| i + e);
            let word = &text[i..end];
            if !after_dot && copied.contains(word) {
                out.push_str(&copy_name(word, level));
            } else if !after_dot && word == "rt_direct_call" {
                out.push_str(&format!("_optik_inline_call_{}", level + 1));
            } else {
                out.push_str(word);
            }
            after_dot = false;
            i = end;
            continue;
        }
        if c.is_ascii_digit() {
            // Numbers with their suffixes (`1u`, `0x1Fu`, `1e5f`).
            let end = text[i..]
                .find(|ch: char| !(ch.is_ascii_alphanumeric() || ch == '_' || ch == '.'))
                .map_or(text.len(), |e| i + e);
            out.push_str(&text[i..end]);
            after_dot = false;
            i = end;
            continue;
        }
        if !c.is_ascii_whitespace() {
            after_dot = c == b'.';
        }
        let ch = text[i..].chars().next().unwrap_or(' ');
        out.push(ch);
        i += ch.len_utf8();
    }
    out
}

/// The end of the (nested) block comment starting at `start`.
fn block_comment_end(text: &str, start: usize) -> usize {
    let mut depth = 0;
    let mut i = start;
    while i < text.len() {
        if text[i..].starts_with("/*") {
            depth += 1;
            i += 2;
        } else if text[i..].starts_with("*/") {
            depth -= 1;
            i += 2;
            if depth == 0 {
                return i;
            }
        } else {
            i += text[i..].chars().next().map_or(1, char::len_utf8);
        }
    }
    text.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copies_rename_calls_but_not_members_or_comments() {
        let copied: BTreeSet<&str> = ["helper", "direct_callable__a"].into_iter().collect();
        let text = "fn direct_callable__a() {\n    // helper() in a comment\n    let v = p.helper + helper(1u, 0x1Fu);\n    rt_direct_call(0u, &args); /* rt_direct_call */\n}";
        let out = renamed(text, &copied, 2);
        assert_eq!(
            out,
            "fn direct_callable__a__optik_inline2() {\n    // helper() in a comment\n    let v = p.helper + helper__optik_inline2(1u, 0x1Fu);\n    _optik_inline_call_3(0u, &args); /* rt_direct_call */\n}"
        );
    }
}
