//! The one error type every fallible call returns.
//!
//! Messages say what was wrong, which argument, and what was expected, so a user can act on
//! them without reading optik's source. Program compile errors also carry [`Diagnostic`]s that
//! point at the user's file, line and column.

use std::fmt;

/// What kind of failure an [`Error`] reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorKind {
    /// An argument had a wrong value: a size, a count, a stride, an alignment, a flag.
    InvalidArgument,
    /// A handle was destroyed, or belongs to another device.
    InvalidHandle,
    /// WGSL source did not compile; see the error's diagnostics.
    Compile,
    /// The backend or device lacks what was asked for.
    Unsupported,
    /// A device limit was exceeded (launch size, primitives, instances, trace depth).
    LimitExceeded,
    /// The device ran out of memory.
    OutOfMemory,
    /// The device was lost; every object it owned is gone.
    DeviceLost,
    /// A failure inside the backend's driver or runtime that is not the caller's fault.
    Backend,
    /// Reading or writing a file failed.
    Io,
    /// A launch was cancelled (a `CancelToken`, or an interrupt such as Ctrl-C) before it
    /// finished.
    Cancelled,
    /// A launch passed its deadline (`LaunchOptions::deadline`) before it finished.
    TimedOut,
}

/// A located message about a user's WGSL source: `file:line:column: message`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// The file name given with the source.
    pub file: String,
    /// 1-based line in the user's source.
    pub line: u32,
    /// 1-based column (in bytes) in the user's source.
    pub column: u32,
    /// What is wrong.
    pub message: String,
    /// The text of the source line, for display under the message.
    pub source_line: String,
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.file, self.line, self.column, self.message
        )?;
        if !self.source_line.is_empty() {
            let caret_pad = " ".repeat(self.column.saturating_sub(1) as usize);
            write!(f, "\n    {}\n    {}^", self.source_line, caret_pad)?;
        }
        Ok(())
    }
}

/// optik's error: a kind, a message and, for compile errors, located diagnostics.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    kind: ErrorKind,
    message: String,
    diagnostics: Vec<Diagnostic>,
}

/// `Result` with optik's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An error of `kind` with `message`.
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Self {
            kind,
            message: message.into(),
            diagnostics: Vec::new(),
        }
    }

    /// An [`ErrorKind::InvalidArgument`] error.
    pub fn invalid(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::InvalidArgument, message)
    }

    /// An [`ErrorKind::Unsupported`] error.
    pub fn unsupported(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Unsupported, message)
    }

    /// An [`ErrorKind::LimitExceeded`] error.
    pub fn limit(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::LimitExceeded, message)
    }

    /// An [`ErrorKind::Backend`] error.
    pub fn backend(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Backend, message)
    }

    /// A compile error made of located diagnostics.
    pub fn compile(diagnostics: Vec<Diagnostic>) -> Self {
        let message = match diagnostics.as_slice() {
            [] => "WGSL compilation failed".to_string(),
            [one] => one.to_string(),
            [first, rest @ ..] => format!("{first}\n(and {} more errors)", rest.len()),
        };
        Self {
            kind: ErrorKind::Compile,
            message,
            diagnostics,
        }
    }

    /// What kind of failure this is.
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// The message, without diagnostics.
    pub fn message(&self) -> &str {
        &self.message
    }

    /// Located diagnostics of a compile error (empty for other kinds).
    pub fn diagnostics(&self) -> &[Diagnostic] {
        &self.diagnostics
    }

    /// The same error with `context: ` put before its message.
    pub fn context(mut self, context: impl fmt::Display) -> Self {
        self.message = format!("{context}: {}", self.message);
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.kind == ErrorKind::Compile && !self.diagnostics.is_empty() {
            for (i, d) in self.diagnostics.iter().enumerate() {
                if i > 0 {
                    writeln!(f)?;
                }
                write!(f, "{d}")?;
            }
            Ok(())
        } else {
            f.write_str(&self.message)
        }
    }
}

impl std::error::Error for Error {}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::new(ErrorKind::Io, e.to_string())
    }
}

/// Returns `Err(Error::invalid(..))` from the enclosing function when `cond` is false.
#[macro_export]
macro_rules! ensure {
    ($cond:expr, $($fmt:tt)+) => {
        if !$cond {
            return Err($crate::Error::invalid(format!($($fmt)+)));
        }
    };
}
