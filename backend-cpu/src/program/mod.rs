//! Programs: naga IR compiled to native code with Cranelift.
//!
//! `abi` is the contract with the runtime: a compiled program ([`ProgramFn`]) is called
//! with the launch's resources ([`abi::Bindings`]) and a `&mut dyn` [`abi::DeviceCalls`]
//! that answers the device API. [`JitModule::compile`] compiles every program of a module
//! (each with everything it calls, inlined) and caches the result in memory and, per
//! function, on disk (`cache`).
//!
//! Fast paths for the runtime, both optional: [`JitModule::prepare`] lays a launch's
//! bindings out once for [`ProgramFn::call_prepared`] (instead of at every call), and a
//! `DeviceCalls` that returns an [`abi::DeviceState`] from `state()` has its getters read
//! as memory instead of called (a few nanoseconds each). A runtime may also give
//! [`ProgramFn::call_prepared_with_state`] its own `rt_trace` ([`abi::TraceEntry`]), which
//! compiled code then calls with the trace's arguments as they are, without the trait object.
//!
//! WGSL semantics where the language leaves a choice, the same on every path:
//! - Bounds (naga's policies): indices into arrays, vectors and matrices in function or
//!   private memory are clamped to the last element (`Restrict`); accesses to uniform and
//!   storage buffers out of bounds (an index past its array, or bytes past the bound
//!   length) read zero and drop writes and atomics (`ReadZeroSkipWrite`).
//!   `arrayLength` is `(bound bytes - offset) / stride`.
//! - Integers wrap; `x / 0 = x`, `x % 0 = 0`, `MIN / -1 = MIN`, `MIN % -1 = 0`; shift
//!   amounts are taken modulo 32.
//! - Float to integer conversions saturate, NaN to 0 (Rust's `as`).
//! - `min`, `max`, `clamp`, `select`: see `lower/math.rs`; transcendentals are Rust's `f32`
//!   functions.
//! - Private globals are per invocation: set to their initialiser (or zero) at every
//!   program entry. `override`s take their default values.
//! - Textures: `texture.rs`.
//!
//! Layout: `lower/` turns naga IR into Cranelift IR, `jit.rs` drives Cranelift and calls
//! programs, `host.rs` holds what compiled code calls out to, `math_ref.rs` the built-ins
//! computed in Rust, `texture.rs` the sampler, `cache.rs` the caches, `unwind_tables.rs` the
//! unwind tables that let panics in `DeviceCalls` pass through programs.

pub mod abi;
#[cfg(feature = "jit")]
mod cache;
#[cfg(feature = "jit")]
mod host;
#[cfg(feature = "jit")]
mod jit;
#[cfg(feature = "jit")]
mod lower;
#[cfg(feature = "jit")]
pub mod math_ref;
#[cfg(feature = "jit")]
pub mod texture;
#[cfg(all(feature = "jit", target_os = "linux"))]
mod unwind_tables;

#[cfg(feature = "jit")]
pub use jit::{
    CompileStats, DiskCache, JitModule, JitOptions, PreparedBindings, ProgramFn, RepeatedCall,
};

#[cfg(all(test, feature = "jit"))]
mod tests;
