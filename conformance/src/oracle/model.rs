//! Rust models of a case's WGSL programs, run by the oracle.
//!
//! Each model mirrors its WGSL program statement by statement, through a [`Ctx`] whose
//! methods are the device API (`ctx.trace`, `ctx.get_payload`, `ctx.report_intersection`,
//! ...). Terminators return an [`Unwind`]: `return ctx.ignore_intersection();` ends the
//! any-hit model as `rt_ignore_intersection()` ends the WGSL program.

use super::exec::Ctx;
use std::collections::HashMap;
use std::sync::Arc;

/// Why a program ended early.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unwind {
    /// `rt_ignore_intersection()` in an any-hit program.
    Ignore,
    /// `rt_terminate_ray()` in an any-hit program (or a terminating report).
    Terminate,
    /// An exception with this code.
    Throw(i32),
}

/// How a program model ends: normally, or unwinding.
pub type Flow = Result<(), Unwind>;

/// A program model.
pub type ProgramFn = Arc<dyn Fn(&mut Ctx<'_, '_>) -> Flow + Send + Sync>;

/// The models of a case's programs, by WGSL function name.
#[derive(Clone, Default)]
pub struct Models {
    programs: HashMap<String, ProgramFn>,
}

impl Models {
    /// No models.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the model of the WGSL function `name`.
    pub fn add(
        &mut self,
        name: &str,
        f: impl Fn(&mut Ctx<'_, '_>) -> Flow + Send + Sync + 'static,
    ) -> &mut Self {
        self.programs.insert(name.to_string(), Arc::new(f));
        self
    }

    /// Adds every model of `other`.
    pub fn extend(&mut self, other: &Models) -> &mut Self {
        for (k, v) in &other.programs {
            self.programs.insert(k.clone(), v.clone());
        }
        self
    }

    /// The model of `name`.
    pub fn get(&self, name: &str) -> Option<&ProgramFn> {
        self.programs.get(name)
    }

    /// The names modelled.
    pub fn names(&self) -> Vec<&str> {
        let mut v: Vec<&str> = self.programs.keys().map(String::as_str).collect();
        v.sort();
        v
    }
}

impl std::fmt::Debug for Models {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Models({:?})", self.names())
    }
}
