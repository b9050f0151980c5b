//! optik-benches: criterion benches, the one-process benchmark report, and the data tools they
//! share with the `optik` command (meshes, NumPy arrays, ray casting through the public API).

pub mod mesh;
pub mod npy;
pub mod raycast;
pub mod rays;
pub mod report;
pub mod scenes;
