//! optik-api: the host API every optik backend implements.
//!
//! - [`Device`]: the object-safe trait of OptiX's device context and its calls;
//! - descriptors for buffers, acceleration structures ([`accel`]), programs ([`program`]),
//!   the shader binding table ([`sbt`]) and launches ([`launch`]);
//! - [`semantics`]: DESIGN.md §4 as pure functions (flag precedence, SBT index math,
//!   facing, motion interpolation, the invalid-ray policy);
//! - [`features`]: what a scene and its programs use, for specialised pipelines;
//! - [`wgsl`]: the WGSL pieces the GPU backends share (traversal, intersection tests).
//!
//! The implementation every backend shares sits above this crate: the WGSL front end, the
//! checks of user input, the SBT record reader, feature resolution, handle tables and the
//! naga passes in `optik-core`; build-input decoding in `optik-accel` (DESIGN.md §1).

// `!(x >= 0.0)` is how this crate says "negative or NaN": the NaN case is the point.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod cache;
pub mod device;
pub mod error;
pub mod features;
pub mod flags;
pub mod handle;
pub mod launch;
pub mod program;
pub mod sbt;
pub mod semantics;
pub mod shapes;
pub mod wgsl;

pub use accel::*;
pub use device::*;
pub use error::{Diagnostic, Error, ErrorKind, Result};
pub use features::{FeatureSet, MotionKinds, ProgramFeatures, SceneFeatures};
pub use flags::*;
pub use handle::{
    Accel, Buffer, DeviceId, Handle, MicromapArray, Module, Pipeline, ProgramGroup, RawHandle,
    Texture,
};
pub use launch::*;
pub use program::*;
pub use sbt::*;
