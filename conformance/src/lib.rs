//! optik-conformance: the conformance suite (DESIGN.md §7; its rules in README.md).
//!
//! - [`catalog`]: the cases, each a scene, WGSL programs, pipeline options, launches, what is
//!   recorded, a tolerance class and a Rust model of its programs;
//! - [`oracle`]: the independent brute-force `f64` tracer with exact orientation predicates
//!   that runs those models and says which results are admissible (ambiguous rays included);
//! - [`image`], [`exrio`]: hit records and images as EXR;
//! - [`compare`]: OpenImageIO `idiff`'s semantics plus the NaN/Inf gate;
//! - [`runner`], [`report`], [`cli`]: running cases on backends, tables, JSON, HTML, `bless`.

pub mod case;
pub mod catalog;
pub mod cli;
pub mod compare;
pub mod device_run;
pub mod exrio;
pub mod image;
pub mod judge;
pub mod kit;
pub mod oracle;
pub mod report;
pub mod runner;
pub mod scene;
pub mod tolerance;
