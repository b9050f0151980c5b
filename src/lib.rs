//! optik: an OptiX-7-style ray tracing API for Rust (facade; being written, issue 2).
pub use optik_api::*;
