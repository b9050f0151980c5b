//! Turning naga spans into diagnostics at the user's `file:line:column`.

use optik_api::error::Diagnostic;

/// Maps byte spans of the parsed source (user source + prelude) to diagnostics.
pub(crate) struct Locator<'a> {
    file: &'a str,
    full: &'a str,
    user_len: usize,
}

impl<'a> Locator<'a> {
    pub(crate) fn new(file: &'a str, full: &'a str, user_len: usize) -> Self {
        Self {
            file,
            full,
            user_len,
        }
    }

    /// A diagnostic at `span`. A span inside the prelude (which the front end's own checks
    /// keep user code from reaching) is reported at the end of the user's source, where the
    /// prelude begins, naming the prelude line: every diagnostic points at the user's file.
    pub(crate) fn diagnostic(&self, span: naga::Span, message: impl Into<String>) -> Diagnostic {
        let mut message = message.into();
        let Some(range) = span.to_range().filter(|r| r.start <= self.full.len()) else {
            return Diagnostic {
                file: self.file.to_string(),
                line: 1,
                column: 1,
                message,
                source_line: String::new(),
            };
        };
        let user = &self.full[..self.user_len];
        let offset = if range.start >= self.user_len {
            let prelude = &self.full[self.user_len..];
            let at = range.start - self.user_len;
            let line_start = prelude[..at].rfind('\n').map_or(0, |p| p + 1);
            let text = prelude[line_start..].lines().next().unwrap_or("").trim();
            message.push_str(&format!(
                " (found in optik's device-API prelude, which follows your source: `{text}`)"
            ));
            // The newline that ends the user's text: just past its last character.
            self.user_len.saturating_sub(1)
        } else {
            range.start
        };
        let prefix = &user[..offset];
        let line = prefix.matches('\n').count() as u32 + 1;
        let line_start = prefix.rfind('\n').map(|p| p + 1).unwrap_or(0);
        let column = (offset - line_start) as u32 + 1;
        let source_line = user[line_start..].lines().next().unwrap_or("").to_string();
        Diagnostic {
            file: self.file.to_string(),
            line,
            column,
            message,
            source_line,
        }
    }

    /// The byte offset of `fn name` in the user's source, as a one-byte span at the name.
    pub(crate) fn function_name_span(&self, name: &str) -> naga::Span {
        let user = &self.full[..self.user_len];
        let mut from = 0;
        while let Some(found) = user[from..].find(name) {
            let at = from + found;
            let before = user[..at].trim_end();
            let after = user[at + name.len()..].chars().next();
            if before.ends_with("fn") && !after.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                return naga::Span::new(at as u32, (at + name.len()) as u32);
            }
            from = at + name.len();
        }
        naga::Span::default()
    }

    /// Whether `span` lies in the user's part of the source.
    pub(crate) fn is_user(&self, span: naga::Span) -> bool {
        span.to_range().is_some_and(|r| r.start < self.user_len)
    }
}
