//! A small WGSL tokenizer for what naga's errors cannot say about the user's own text: an
//! unclosed bracket (which naga only notices inside the prelude that follows), module-scope
//! names that would hide what the prelude relies on, the deepest nesting (naga's recursion
//! limit has no position) and the largest array (naga's "type is too large" often has none).

/// One token: an identifier, a number, or one punctuation character.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Ident,
    Number,
    Punct(char),
}

/// A token and its byte range in the text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Token {
    pub kind: Kind,
    pub start: usize,
    pub end: usize,
}

/// The tokens of `text`, without whitespace and comments (line comments and nested block
/// comments, as WGSL has them). Unknown characters become punctuation; an unterminated
/// block comment ends the text.
pub(crate) fn tokens(text: &str) -> Vec<Token> {
    lex(text).0
}

/// The byte offset of a block comment that `text` never closes.
pub(crate) fn unclosed_comment(text: &str) -> Option<usize> {
    lex(text).1
}

fn lex(text: &str) -> (Vec<Token>, Option<usize>) {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut unclosed = None;
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        if c.is_ascii_whitespace() {
            i += 1;
        } else if text[i..].starts_with("//") {
            i = text[i..].find('\n').map_or(bytes.len(), |n| i + n);
        } else if text[i..].starts_with("/*") {
            unclosed = Some(i);
            let mut depth = 0usize;
            while i < bytes.len() {
                if text[i..].starts_with("/*") {
                    depth += 1;
                    i += 2;
                } else if text[i..].starts_with("*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        unclosed = None;
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if c.is_ascii_digit()
            || (c == b'.' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit))
        {
            let start = i;
            while i < bytes.len()
                && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'.' || bytes[i] == b'_')
            {
                i += 1;
            }
            out.push(Token {
                kind: Kind::Number,
                start,
                end: i,
            });
        } else if c == b'_' || c.is_ascii_alphabetic() || c >= 0x80 {
            let start = i;
            let rest = &text[i..];
            let len = rest
                .char_indices()
                .find(|(_, ch)| !(ch.is_alphanumeric() || *ch == '_'))
                .map_or(rest.len(), |(n, _)| n);
            // A non-alphanumeric non-ASCII character on its own is punctuation.
            if len == 0 {
                let ch = rest.chars().next().unwrap_or('\u{FFFD}');
                i += ch.len_utf8();
                out.push(Token {
                    kind: Kind::Punct(ch),
                    start,
                    end: i,
                });
            } else {
                i += len;
                out.push(Token {
                    kind: Kind::Ident,
                    start,
                    end: i,
                });
            }
        } else {
            out.push(Token {
                kind: Kind::Punct(c as char),
                start: i,
                end: i + 1,
            });
            i += 1;
        }
    }
    (out, unclosed)
}

/// The innermost `{`, `(` or `[` still open at the end of `text`, if any: its byte offset
/// and character. Mismatched closers are left to naga, which reports them in place.
pub(crate) fn unclosed_bracket(text: &str) -> Option<(usize, char)> {
    let mut open: Vec<(usize, char)> = Vec::new();
    for t in tokens(text) {
        match t.kind {
            Kind::Punct(c @ ('{' | '(' | '[')) => open.push((t.start, c)),
            Kind::Punct(c @ ('}' | ')' | ']')) => {
                let opener = match c {
                    '}' => '{',
                    ')' => '(',
                    _ => '[',
                };
                if open.last().is_some_and(|(_, o)| *o == opener) {
                    open.pop();
                } else {
                    return None;
                }
            }
            _ => {}
        }
    }
    open.last().copied()
}

/// The first bracket at the deepest nesting of `text`, with that depth.
pub(crate) fn deepest_nesting(text: &str) -> Option<(usize, usize)> {
    let mut depth = 0usize;
    let mut best: Option<(usize, usize)> = None;
    for t in tokens(text) {
        match t.kind {
            Kind::Punct('{' | '(' | '[') => {
                depth += 1;
                if best.is_none_or(|(_, d)| depth > d) {
                    best = Some((t.start, depth));
                }
            }
            Kind::Punct('}' | ')' | ']') => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    best
}

/// The `array<T, N>` of `text` with the largest constant element count: the byte range of
/// its `array` keyword. The usual cause of a type too large to lay out.
pub(crate) fn largest_array(text: &str) -> Option<(usize, usize)> {
    let toks = tokens(text);
    let mut best: Option<(u128, (usize, usize))> = None;
    for (i, t) in toks.iter().enumerate() {
        if t.kind != Kind::Ident || &text[t.start..t.end] != "array" {
            continue;
        }
        if toks.get(i + 1).map(|n| n.kind) != Some(Kind::Punct('<')) {
            continue;
        }
        // The last number at the template's own level, before its closing `>`.
        let mut depth = 0usize;
        let mut count = None;
        for n in &toks[i + 1..] {
            match n.kind {
                Kind::Punct('<') => depth += 1,
                Kind::Punct('>') => {
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        break;
                    }
                }
                Kind::Number if depth == 1 => count = parse_count(&text[n.start..n.end]),
                _ => {}
            }
        }
        if let Some(c) = count
            && best.is_none_or(|(b, _)| c > b)
        {
            best = Some((c, (t.start, t.end)));
        }
    }
    best.map(|(_, range)| range)
}

fn parse_count(literal: &str) -> Option<u128> {
    let digits = literal.trim_end_matches(['u', 'i']);
    match digits
        .strip_prefix("0x")
        .or_else(|| digits.strip_prefix("0X"))
    {
        Some(hex) => u128::from_str_radix(hex, 16).ok(),
        None => digits.parse().ok(),
    }
}

/// A name declared at module scope.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Declared {
    /// `fn`, `struct`, `alias`, `const`, `override` or `var`.
    pub keyword: &'static str,
    pub name: String,
    pub start: usize,
    pub end: usize,
}

/// The names `text` declares at module scope, in order.
pub(crate) fn module_scope_names(text: &str) -> Vec<Declared> {
    let toks = tokens(text);
    let mut out = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    while i < toks.len() {
        let t = toks[i];
        match t.kind {
            Kind::Punct('{' | '(' | '[') => depth += 1,
            Kind::Punct('}' | ')' | ']') => depth = depth.saturating_sub(1),
            Kind::Ident if depth == 0 => {
                let word = &text[t.start..t.end];
                let keyword = ["fn", "struct", "alias", "const", "override", "var"]
                    .into_iter()
                    .find(|k| *k == word);
                if let Some(keyword) = keyword {
                    let mut j = i + 1;
                    // `var<storage, read_write> name`: skip the template.
                    if keyword == "var" && toks.get(j).map(|n| n.kind) == Some(Kind::Punct('<')) {
                        while j < toks.len() && toks[j].kind != Kind::Punct('>') {
                            j += 1;
                        }
                        j += 1;
                    }
                    if let Some(n) = toks.get(j).filter(|n| n.kind == Kind::Ident) {
                        out.push(Declared {
                            keyword,
                            name: text[n.start..n.end].to_string(),
                            start: n.start,
                            end: n.end,
                        });
                    }
                    i = j;
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// WGSL keywords and context-dependent names (address spaces, access modes, attribute
/// arguments): words a declaration cannot hide from the prelude.
const NOT_HIDEABLE: &[&str] = &[
    "fn",
    "let",
    "var",
    "const",
    "return",
    "if",
    "else",
    "for",
    "while",
    "loop",
    "break",
    "continue",
    "continuing",
    "switch",
    "case",
    "default",
    "struct",
    "alias",
    "true",
    "false",
    "override",
    "discard",
    "enable",
    "requires",
    "diagnostic",
    "function",
    "private",
    "workgroup",
    "uniform",
    "storage",
    "handle",
    "read",
    "write",
    "read_write",
];

/// The names a user's module-scope declaration must not take, because `prelude` declares
/// them or uses them as WGSL's predeclared types and functions (`f32`, `vec3`, `select`):
/// each with whether the prelude declares it (`true`) or relies on WGSL's own (`false`).
pub(crate) fn prelude_names(prelude: &str) -> Vec<(String, bool)> {
    let declared: Vec<String> = module_scope_names(prelude)
        .into_iter()
        .map(|d| d.name)
        .collect();
    let toks = tokens(prelude);
    // Parameters, struct members and local `let`/`var`/`const` names: local to the prelude,
    // so a user's module-scope name does not disturb them.
    let mut local = std::collections::BTreeSet::new();
    for (i, t) in toks.iter().enumerate() {
        if t.kind != Kind::Ident {
            continue;
        }
        let next = toks.get(i + 1).map(|n| n.kind);
        let prev = i
            .checked_sub(1)
            .map(|p| &prelude[toks[p].start..toks[p].end]);
        if next == Some(Kind::Punct(':')) || matches!(prev, Some("let" | "var" | "const")) {
            local.insert(&prelude[t.start..t.end]);
        }
    }
    let mut out: Vec<(String, bool)> = declared.iter().map(|n| (n.clone(), true)).collect();
    for (i, t) in toks.iter().enumerate() {
        let word = &prelude[t.start..t.end];
        let after_dot = i > 0 && toks[i - 1].kind == Kind::Punct('.');
        let after_at = i > 0 && toks[i - 1].kind == Kind::Punct('@');
        if t.kind != Kind::Ident
            || after_dot
            || after_at
            || local.contains(word)
            || NOT_HIDEABLE.contains(&word)
            || out.iter().any(|(n, _)| n == word)
        {
            continue;
        }
        out.push((word.to_string(), false));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_and_nesting_are_skipped() {
        let text = "/* a /* nested */ { */ fn f() { // {\n let x = (1); }";
        assert_eq!(unclosed_bracket(text), None);
        assert_eq!(
            unclosed_bracket("fn f() {\n  if x {\n  }\n"),
            Some((7, '{'))
        );
        assert_eq!(unclosed_bracket("fn f() { ) }"), None, "left to naga");
        assert_eq!(unclosed_comment("a /* b /* c */ d"), Some(2));
        assert_eq!(unclosed_comment("a /* b /* c */ d */"), None);
    }

    #[test]
    fn module_scope_declarations_only() {
        let text = "@group(0) @binding(1) var<storage, read_write> out: array<u32>;\n\
                    struct S { a: f32 }\nfn f32() { let inner = 1; }\nconst K = 1u;";
        let names: Vec<(&str, String)> = module_scope_names(text)
            .into_iter()
            .map(|d| (d.keyword, d.name))
            .collect();
        assert_eq!(
            names,
            vec![
                ("var", "out".to_string()),
                ("struct", "S".to_string()),
                ("fn", "f32".to_string()),
                ("const", "K".to_string()),
            ]
        );
    }

    #[test]
    fn prelude_names_are_its_declarations_and_the_builtins_it_uses() {
        let prelude = "alias RtHandle = vec2<u32>;\nconst RT_X: u32 = 1u;\n\
                       fn rt_f(p: vec3<f32>, n: ptr<function, RtHandle>) -> f32 { let of_i = abs(p.x); return of_i; }";
        let names = prelude_names(prelude);
        let get = |n: &str| names.iter().find(|(m, _)| m == n).map(|(_, d)| *d);
        assert_eq!(get("RtHandle"), Some(true));
        assert_eq!(get("RT_X"), Some(true));
        assert_eq!(get("rt_f"), Some(true));
        assert_eq!(get("f32"), Some(false));
        assert_eq!(get("vec2"), Some(false));
        assert_eq!(get("abs"), Some(false));
        for local in ["p", "n", "of_i", "x", "function", "ptr_never"] {
            assert_eq!(get(local), None, "{local}");
        }
    }

    #[test]
    fn largest_array_and_deepest_nesting() {
        let text = "var<private> a: array<f32, 4>;\nvar<private> b: array<vec4<f32>, 0x10000000u>;";
        let (s, e) = largest_array(text).unwrap();
        assert_eq!(&text[s..e], "array");
        assert!(s > 30);
        let nested = format!("fn f() {{ let x = {}1{}; }}", "(".repeat(5), ")".repeat(5));
        let fifth = nested.find("(((").unwrap() + 4;
        assert_eq!(deepest_nesting(&nested), Some((fifth, 6)));
    }
}
