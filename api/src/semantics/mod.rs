//! Semantics every backend implements the same way (DESIGN.md §4), as pure functions.
//!
//! Backends call these rather than re-deriving the rules, so flag precedence, SBT index math,
//! facing, motion interpolation and the invalid-ray policy live in one place.

pub mod affine;
pub mod exception;
pub mod facing;
pub mod motion;
pub mod opacity;
pub mod primitive;
pub mod ray;
pub mod sbt_index;
