//! Programs: naga IR compiled to native code with Cranelift.
//!
//! `abi` is the contract with the runtime. The JIT itself is being written (issue 3).

pub mod abi;
