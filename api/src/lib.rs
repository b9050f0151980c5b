//! optik-api: the host API every optik backend implements.
//!
//! - [`Device`]: the object-safe trait of OptiX's device context and its calls;
//! - descriptors for buffers, acceleration structures ([`accel`]), programs ([`program`]),
//!   the shader binding table ([`sbt`]) and launches ([`launch`]);
//! - [`validate`]: checks shared by all backends, with errors that name what was wrong;
//! - [`semantics`]: DESIGN.md §4 as pure functions (flag precedence, SBT index math,
//!   facing, motion interpolation, the invalid-ray policy);
//! - [`frontend`]: the WGSL program front end (prelude, parse, checks, reflection);
//! - [`features`]: what a scene and its programs use, for specialised pipelines.

// `!(x >= 0.0)` is how this crate says "negative or NaN": the NaN case is the point.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod decode;
pub mod device;
pub mod error;
pub mod features;
pub mod flags;
pub mod frontend;
pub mod handle;
pub mod launch;
pub mod program;
pub mod sbt;
pub mod semantics;
pub mod shapes;
pub mod unwind;
pub mod validate;
pub mod wgsl;

pub use accel::*;
pub use device::*;
pub use error::{Diagnostic, Error, ErrorKind, Result};
pub use features::{FeatureSet, MotionKinds, ProgramFeatures, SceneFeatures};
pub use flags::*;
pub use handle::{
    Accel, Buffer, DeviceId, Handle, HandleTable, MicromapArray, Module, Pipeline, ProgramGroup,
    RawHandle, Texture,
};
pub use launch::*;
pub use program::*;
pub use sbt::*;

/// naga, re-exported so backends lower the same IR version the front end produces.
pub use naga;
