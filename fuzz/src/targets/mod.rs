//! The fuzz targets. A target is one small function from bytes to an [`Outcome`](crate::Outcome),
//! its seeds and a dictionary; add a module here and an entry in [`ALL`].

pub mod accel;
pub mod exr;
pub mod wgsl;

use crate::Target;

/// Every target, in the order `scripts/fuzz` runs them.
pub const ALL: &[Target] = &[wgsl::TARGET, exr::TARGET, accel::TARGET];
