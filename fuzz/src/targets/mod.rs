//! The fuzz targets. A target is one small function from bytes to an [`Outcome`](crate::Outcome),
//! its seeds and a dictionary; add a module here and an entry in [`ALL`].

pub mod accel;
pub mod exr;
mod file;
pub mod mesh;
pub mod mitsuba;
pub mod npy;
pub mod wgsl;

use crate::Target;

/// Every target, in the order `scripts/fuzz` runs them.
pub const ALL: &[Target] = &[
    wgsl::TARGET,
    exr::TARGET,
    accel::TARGET,
    mesh::OBJ,
    mesh::PLY,
    npy::TARGET,
    mitsuba::TARGET,
];
