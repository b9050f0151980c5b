//! optik-io: reading and writing the files optik's command, renderer and benches share.
//!
//! - [`mesh`]: triangle meshes from OBJ (through `tobj`) and PLY (through `ply-rs-bw`), mapped to
//!   one [`mesh::MeshData`].
//! - [`mod@array`]: NumPy `.npy` and `.npz` files (through `npyz` and `zip`, zip64 included): the
//!   one implementation every optik tool reads and writes arrays with.
//! - [`output`]: outputs written to a temporary file beside the target and renamed over it, so a
//!   failed write never destroys a previous good file.
//!
//! The crate depends on no optik crate: everything is plain arrays, so every crate may use it.
//! Sizes read from a file's header never size an allocation before the data proves they exist.

pub mod array;
mod error;
pub mod mesh;
pub mod output;

pub use error::IoError;
