//! NumPy arrays: `.npy` files and `.npz` archives (zips of `.npy` members, stored or deflated,
//! zip64 or not), through `npyz` and `zip`. This is the one implementation every optik tool
//! reads and writes arrays with; it reads what numpy 1.x and 2.x write (tests/data/).
//!
//! Every size a header states is checked before use: a shape whose product overflows, or that
//! needs more bytes than the file holds, is an error, never an allocation or a wrapped count.

use crate::IoError;
use crate::output::{write_atomically, write_file_atomically};
use npyz::{AutoSerialize, Deserialize, NpyFile, WriterBuilder};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// An element type optik exchanges arrays of.
pub trait Element: Deserialize + AutoSerialize + Copy + 'static {
    /// NumPy's name for the dtype (`float32`).
    const NAME: &'static str;
}

impl Element for f32 {
    const NAME: &'static str = "float32";
}
impl Element for f64 {
    const NAME: &'static str = "float64";
}
impl Element for u32 {
    const NAME: &'static str = "uint32";
}
impl Element for i32 {
    const NAME: &'static str = "int32";
}

/// A C-order array: its shape and elements.
#[derive(Clone, Debug, PartialEq)]
pub struct Array<T> {
    /// The shape (a 0-d array has an empty shape and one element).
    pub shape: Vec<usize>,
    /// The elements in C order.
    pub data: Vec<T>,
}

/// The magic, version and header text of a `.npy` file, and where its data starts.
fn split_header(bytes: &[u8]) -> Result<(&str, usize), String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a .npy file (it lacks the \\x93NUMPY magic)".into());
    }
    let (len, start): (usize, usize) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => {
            return Err(format!(
                ".npy format version {v} is not supported; expected 1, 2 or 3"
            ));
        }
    };
    let end = start
        .checked_add(len)
        .filter(|&e| e <= bytes.len())
        .ok_or("the .npy header is truncated")?;
    let text = std::str::from_utf8(&bytes[start..end])
        .map_err(|_| "the .npy header is not text".to_string())?;
    Ok((text, end))
}

/// The shape the header states, with every product checked: `npyz` multiplies the dimensions
/// unchecked, so a hostile shape must be refused before it sees the header.
fn checked_shape(header: &str) -> Result<(Vec<usize>, usize), String> {
    let value: py_literal::Value = header
        .trim()
        .parse()
        .map_err(|e| format!("the .npy header is not a Python dict literal: {e}"))?;
    let py_literal::Value::Dict(entries) = value else {
        return Err("the .npy header is not a Python dict".into());
    };
    let shape = entries
        .iter()
        .find(|(k, _)| matches!(k, py_literal::Value::String(s) if s == "shape"))
        .map(|(_, v)| v)
        .ok_or("the .npy header has no 'shape'")?;
    let py_literal::Value::Tuple(dims) = shape else {
        return Err(format!("the .npy shape {shape} is not a tuple"));
    };
    let mut out = Vec::with_capacity(dims.len().min(64));
    // Every partial product must fit (zero dimensions aside), as npyz computes strides from them.
    let mut nonzero: usize = 1;
    for d in dims {
        let n = match d {
            py_literal::Value::Integer(i) => usize::try_from(i).ok(),
            _ => None,
        }
        .ok_or_else(|| format!("the .npy shape {shape} has {d}; expected whole numbers >= 0"))?;
        if n > 0 {
            nonzero = nonzero
                .checked_mul(n)
                .filter(|&p| u64::try_from(p).is_ok())
                .ok_or_else(|| {
                    format!("the .npy shape {shape} has more elements than fit in memory")
                })?;
        }
        out.push(n);
    }
    let count = if out.contains(&0) { 0 } else { nonzero };
    Ok((out, count))
}

/// Parses `.npy` bytes holding an array of `T` (errors without the file name).
pub fn parse_npy<T: Element>(bytes: &[u8]) -> Result<Array<T>, String> {
    let (header, data_start) = split_header(bytes)?;
    let (shape, count) = checked_shape(header)?;
    let file = NpyFile::new(bytes).map_err(|e| format!("not a valid .npy file: {e}"))?;
    // npyz reads the header on its own; a header that names a key twice (a dict literal keeps
    // the last) must not give it another shape than the one checked above.
    if file
        .shape()
        .iter()
        .map(|&d| d as usize)
        .ne(shape.iter().copied())
    {
        return Err(format!(
            "the .npy header gives two shapes ({shape:?} and {:?}); expected one 'shape' key",
            file.shape()
        ));
    }
    let dtype = file.dtype();
    if file.order() != npyz::Order::C {
        return Err(
            "Fortran-order arrays are not supported; save a C-order array (np.ascontiguousarray)"
                .into(),
        );
    }
    let item = dtype.num_bytes().unwrap_or(0);
    let needed = count.checked_mul(item);
    let held = bytes.len() - data_start;
    if needed.is_none_or(|n| n > held) {
        return Err(format!(
            "shape {shape:?} of {} needs {} bytes of data but the file holds {held}",
            dtype.descr(),
            needed.map_or("more than 2^64".to_string(), |n| n.to_string())
        ));
    }
    let reader = file.data::<T>().map_err(|_| {
        format!(
            "dtype is {}; expected {} (for example np.asarray(a, dtype=np.{}))",
            dtype.descr(),
            T::NAME,
            T::NAME
        )
    })?;
    let data = reader
        .collect::<std::io::Result<Vec<T>>>()
        .map_err(|e| format!("cannot read the array data: {e}"))?;
    if data.len() != count {
        return Err(format!(
            "shape {shape:?} needs {count} values but {} were read",
            data.len()
        ));
    }
    Ok(Array { shape, data })
}

/// Reads a `.npy` file holding an array of `T`.
pub fn read_npy<T: Element>(path: &Path) -> Result<Array<T>, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::os(path, "cannot read", e))?;
    parse_npy(&bytes).map_err(|e| IoError::new(path, e))
}

/// `.npy` bytes (format 1.0, little-endian on little-endian machines) for `data` with `shape`.
pub fn npy_bytes<T: Element>(shape: &[usize], data: &[T]) -> Result<Vec<u8>, String> {
    let count = shape
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .filter(|&c| c == data.len())
        .ok_or_else(|| format!("shape {shape:?} does not hold {} elements", data.len()))?;
    let dims: Vec<u64> = shape.iter().map(|&d| d as u64).collect();
    let mut out = Vec::with_capacity(128 + count * std::mem::size_of::<T>());
    let encode = |out: &mut Vec<u8>| -> std::io::Result<()> {
        let mut w = npyz::WriteOptions::new()
            .default_dtype()
            .shape(&dims)
            .writer(out)
            .begin_nd()?;
        w.extend(data.iter().copied())?;
        w.finish()
    };
    encode(&mut out).map_err(|e| format!("cannot encode the array: {e}"))?;
    Ok(out)
}

/// Writes `data` with `shape` as a `.npy` file, atomically.
pub fn write_npy<T: Element>(path: &Path, shape: &[usize], data: &[T]) -> Result<(), IoError> {
    let bytes = npy_bytes(shape, data).map_err(|e| IoError::new(path, e))?;
    write_atomically(path, |w| w.write_all(&bytes))
}

/// A member of an `.npz` archive to write: its name (without `.npy`) and its `.npy` bytes
/// ([`npy_bytes`]).
pub struct Member<'a> {
    /// The array's name: `np.load(path)[name]`.
    pub name: &'a str,
    /// The `.npy` bytes.
    pub npy: Vec<u8>,
}

impl<'a> Member<'a> {
    /// A member holding `data` with `shape`.
    pub fn new<T: Element>(name: &'a str, shape: &[usize], data: &[T]) -> Result<Self, String> {
        Ok(Member {
            name,
            npy: npy_bytes(shape, data)?,
        })
    }
}

/// Writes an uncompressed `.npz` archive (what `np.savez` makes), atomically. Members of 4 GiB
/// or more, and archives past 4 GiB, are written as zip64 entries (numpy reads both).
pub fn write_npz(path: &Path, members: &[Member]) -> Result<(), IoError> {
    write_file_atomically(path, |file| write_npz_to(file, members))
}

fn write_npz_to(file: &mut (impl Write + Seek), members: &[Member]) -> std::io::Result<()> {
    let mut zip = zip::ZipWriter::new(file);
    for m in members {
        let options = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored)
            .large_file(m.npy.len() as u64 >= u64::from(u32::MAX));
        zip.start_file(format!("{}.npy", m.name), options)
            .map_err(std::io::Error::other)?;
        zip.write_all(&m.npy)?;
    }
    zip.finish().map_err(std::io::Error::other)?;
    Ok(())
}

/// An `.npz` archive opened for reading; members are read one at a time.
pub struct Npz {
    path: PathBuf,
    zip: zip::ZipArchive<std::fs::File>,
}

/// Opens an `.npz` archive (stored or deflated members, zip64 or not).
pub fn read_npz(path: &Path) -> Result<Npz, IoError> {
    let file = std::fs::File::open(path).map_err(|e| IoError::os(path, "cannot open", e))?;
    let zip = zip::ZipArchive::new(file).map_err(|e| {
        IoError::new(
            path,
            format!("not a valid .npz (zip) archive: {e}; expected a file written by np.savez"),
        )
    })?;
    Ok(Npz {
        path: path.to_path_buf(),
        zip,
    })
}

impl Npz {
    /// The arrays' names (members without `.npy`), in archive order.
    pub fn names(&self) -> Vec<String> {
        self.zip
            .file_names()
            .filter_map(Result::ok)
            .map(|n| n.strip_suffix(".npy").unwrap_or(&n).to_string())
            .collect()
    }

    /// Reads the array `name` as `T`.
    pub fn array<T: Element>(&mut self, name: &str) -> Result<Array<T>, IoError> {
        let path = &self.path;
        let member = format!("{name}.npy");
        let mut entry = self.zip.by_name(&member).map_err(|e| {
            IoError::new(
                path,
                format!("has no array {name:?} ({e}); expected a member {member}"),
            )
        })?;
        // The stated size bounds the read; the Vec grows only as data actually arrives.
        let stated = entry.size();
        let mut bytes = Vec::new();
        (&mut entry)
            .take(stated)
            .read_to_end(&mut bytes)
            .map_err(|e| IoError::os(path, &format!("cannot read member {member}"), e))?;
        parse_npy(&bytes).map_err(|e| IoError::new(path, format!("{member}: {e}")))
    }
}

#[cfg(test)]
mod tests;
