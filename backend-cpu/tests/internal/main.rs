//! optik-cpu's own tests: what only this backend has. The rules every backend keeps are
//! tested once, on every backend, in optik-conformance (its catalog, `tests/misuse.rs` and
//! `tests/rules/`; conformance/README.md, "Where the backend tests live").
//!
//! - `jit`: WGSL programs through the Cranelift JIT, end to end, and its unwinding;
//! - `cancel`: deadlines, cancel tokens and the process-wide interrupt stopping JIT'd loops;
//! - `determinism`: results do not depend on the number of launch threads;
//! - `features`: pipelines compile what their scene and programs use;
//! - `handles`: structures checked at trace time (foreign, destroyed, reused slots);
//! - `inlined`: a module's closest-hit program compiled into its ray generation programs;
//! - `launch_loop`: ray generation programs compiled with their launch loop;
//! - `lean`: compiled programs' traces without the invocation's trace state, against the full
//!   trace;
//! - `native`: native (Rust closure) programs, this backend's own program API, and the
//!   helpers the tests above share.

mod cancel;
mod determinism;
mod features;
mod handles;
#[cfg(feature = "jit")]
mod inlined;
#[cfg(feature = "jit")]
mod jit;
#[cfg(feature = "jit")]
mod launch_loop;
#[cfg(feature = "jit")]
mod lean;
mod native;

use std::sync::{RwLock, RwLockReadGuard, RwLockWriteGuard};

/// The process-wide interrupt (`interrupt_launches`) stops every launch in the process, so
/// the test that sets it holds this lock alone ([`exclusive`]) while every other test that
/// launches holds it shared ([`shared`]).
static LAUNCHES: RwLock<()> = RwLock::new(());

pub fn shared() -> RwLockReadGuard<'static, ()> {
    LAUNCHES.read().unwrap_or_else(|e| e.into_inner())
}

pub fn exclusive() -> RwLockWriteGuard<'static, ()> {
    LAUNCHES.write().unwrap_or_else(|e| e.into_inner())
}
