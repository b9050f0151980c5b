//! The renderer's error type.

/// Why a render (or a probe) failed.
#[derive(Debug)]
pub enum RenderError {
    /// The optik device refused a call; the message names the call.
    Device {
        /// What the renderer was doing.
        during: String,
        /// The device's error.
        source: optik::Error,
    },
    /// The scene asks for something this renderer does not simulate yet.
    Unsupported(String),
    /// An option or scene value is out of range.
    Invalid(String),
    /// Writing an output file failed.
    Output(String),
}

impl std::fmt::Display for RenderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RenderError::Device { during, source } => write!(f, "{during}: {source}"),
            RenderError::Unsupported(m) => write!(f, "not supported by the renderer: {m}"),
            RenderError::Invalid(m) => write!(f, "invalid input: {m}"),
            RenderError::Output(m) => write!(f, "cannot write the output: {m}"),
        }
    }
}

impl std::error::Error for RenderError {}

/// Adds what the renderer was doing to a device error.
pub(crate) trait Context<T> {
    fn during(self, what: &str) -> Result<T, RenderError>;
}

impl<T> Context<T> for optik::Result<T> {
    fn during(self, what: &str) -> Result<T, RenderError> {
        self.map_err(|source| RenderError::Device {
            during: what.to_string(),
            source,
        })
    }
}
