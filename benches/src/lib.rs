//! optik-benches: criterion benches and the one-process benchmark report. Meshes and arrays are
//! read and written with `optik-io`, rays cast with `optik::raycast`, as `optik trace` does.

pub mod mesh;
pub mod rays;
pub mod report;
pub mod rounds;
pub mod scenes;
pub mod walk;
