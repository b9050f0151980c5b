//! NumPy `.npy` and `.npz` files: reading float32 arrays, writing float32 and uint32 arrays.
//!
//! Only what optik's tools exchange: little-endian, C-order arrays. Anything else is a clear
//! error naming what was found and what is expected.

use optik::{Error, Result};
use std::io::Write;

/// A C-order array read from a `.npy` file.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    /// The shape.
    pub shape: Vec<usize>,
    /// The elements in C order.
    pub data: Vec<f32>,
}

fn header_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let at = header.find(&format!("'{key}'"))?;
    let rest = header[at + key.len() + 2..]
        .trim_start()
        .strip_prefix(':')?
        .trim_start();
    if let Some(r) = rest.strip_prefix('(') {
        return r.find(')').map(|end| &r[..end]);
    }
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    Some(rest[..end].trim())
}

/// Parses a `.npy` file holding a little-endian float32 array.
pub fn read_f32(bytes: &[u8], what: &str) -> Result<NpyArray> {
    let (shape, data) = read::<f32>(bytes, what)?;
    Ok(NpyArray { shape, data })
}

/// Parses a `.npy` file holding a little-endian uint32 array: its shape and elements.
pub fn read_u32(bytes: &[u8], what: &str) -> Result<(Vec<usize>, Vec<u32>)> {
    read::<u32>(bytes, what)
}

/// Parses a `.npy` file holding a little-endian array of `T`.
fn read<T: NpyElement>(bytes: &[u8], what: &str) -> Result<(Vec<usize>, Vec<T>)> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(Error::invalid(format!(
            "{what}: not a .npy file (it lacks the \\x93NUMPY magic)"
        )));
    }
    let (header_len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => {
            return Err(Error::invalid(format!(
                "{what}: .npy format version {v} is not supported (expected 1, 2 or 3)"
            )));
        }
    };
    let header = bytes
        .get(start..start + header_len)
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or_else(|| Error::invalid(format!("{what}: truncated or non-text .npy header")))?;
    let descr = header_value(header, "descr")
        .unwrap_or("?")
        .trim_matches(['\'', '"']);
    if descr != T::DESCR && descr != &T::DESCR[1..] {
        return Err(Error::invalid(format!(
            "{what}: dtype is {descr}; expected {} ('{}'), for example np.asarray(rays, dtype=np.{})",
            T::NAME,
            T::DESCR,
            T::NAME
        )));
    }
    if header_value(header, "fortran_order") != Some("False") {
        return Err(Error::invalid(format!(
            "{what}: Fortran-order arrays are not supported; save a C-order array"
        )));
    }
    let shape: Vec<usize> = header_value(header, "shape")
        .ok_or_else(|| Error::invalid(format!("{what}: the .npy header has no shape")))?
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<usize>()
                .map_err(|_| Error::invalid(format!("{what}: bad shape entry {s:?}")))
        })
        .collect::<Result<_>>()?;
    let count: usize = shape.iter().product();
    let body = &bytes[start + header_len..];
    if body.len() < count * 4 {
        return Err(Error::invalid(format!(
            "{what}: shape {shape:?} needs {} bytes of data but the file holds {}",
            count * 4,
            body.len()
        )));
    }
    let data = body[..count * 4]
        .chunks_exact(4)
        .map(|c| T::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Ok((shape, data))
}

/// Elements an array can be written and read with.
pub trait NpyElement: Copy {
    /// NumPy's dtype string.
    const DESCR: &'static str;
    /// NumPy's dtype name.
    const NAME: &'static str;
    /// Little-endian bytes.
    fn le_bytes(self) -> [u8; 4];
    /// The element of little-endian bytes.
    fn from_le_bytes(bytes: [u8; 4]) -> Self;
}

impl NpyElement for f32 {
    const DESCR: &'static str = "<f4";
    const NAME: &'static str = "float32";
    fn le_bytes(self) -> [u8; 4] {
        self.to_le_bytes()
    }
    fn from_le_bytes(bytes: [u8; 4]) -> f32 {
        f32::from_le_bytes(bytes)
    }
}

impl NpyElement for u32 {
    const DESCR: &'static str = "<u4";
    const NAME: &'static str = "uint32";
    fn le_bytes(self) -> [u8; 4] {
        self.to_le_bytes()
    }
    fn from_le_bytes(bytes: [u8; 4]) -> u32 {
        u32::from_le_bytes(bytes)
    }
}

/// A `.npy` file (format 1.0) holding `data` with `shape`.
pub fn encode<T: NpyElement>(shape: &[usize], data: &[T]) -> Vec<u8> {
    let shape_text = match shape {
        [one] => format!("({one},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut header = format!(
        "{{'descr': '{}', 'fortran_order': False, 'shape': {shape_text}, }}",
        T::DESCR
    );
    // The data starts on a 64-byte boundary: magic (6) + version (2) + length (2) + header + '\n'.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat(total.next_multiple_of(64) - total));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len() * 4);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in data {
        out.extend_from_slice(&v.le_bytes());
    }
    out
}

/// Writes a `.npz` archive (an uncompressed zip of `.npy` members, as `np.savez` makes).
pub fn write_npz(path: &std::path::Path, members: &[(&str, Vec<u8>)]) -> Result<()> {
    let mut out: Vec<u8> = Vec::new();
    let mut central: Vec<u8> = Vec::new();
    for (name, data) in members {
        let file_name = format!("{name}.npy");
        let mut crc = flate2::Crc::new();
        crc.update(data);
        let crc = crc.sum();
        let offset = out.len() as u32;
        let size = u32::try_from(data.len()).map_err(|_| {
            Error::invalid(format!(
                "{name}: {} bytes is too large for a zip member",
                data.len()
            ))
        })?;
        // Local file header.
        out.extend_from_slice(&0x0403_4b50u32.to_le_bytes());
        out.extend_from_slice(&[20, 0, 0, 0, 0, 0, 0, 0, 0x21, 0]); // version, flags, stored, time, date
        out.extend_from_slice(&crc.to_le_bytes());
        out.extend_from_slice(&size.to_le_bytes());
        out.extend_from_slice(&size.to_le_bytes());
        out.extend_from_slice(&(file_name.len() as u16).to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        out.extend_from_slice(file_name.as_bytes());
        out.extend_from_slice(data);
        // Central directory entry.
        central.extend_from_slice(&0x0201_4b50u32.to_le_bytes());
        central.extend_from_slice(&[20, 0, 20, 0, 0, 0, 0, 0, 0, 0, 0x21, 0]);
        central.extend_from_slice(&crc.to_le_bytes());
        central.extend_from_slice(&size.to_le_bytes());
        central.extend_from_slice(&size.to_le_bytes());
        central.extend_from_slice(&(file_name.len() as u16).to_le_bytes());
        central.extend_from_slice(&[0; 12]); // extra, comment, disk, internal attrs, external attrs
        central.extend_from_slice(&offset.to_le_bytes());
        central.extend_from_slice(file_name.as_bytes());
    }
    let central_offset = out.len() as u32;
    out.extend_from_slice(&central);
    out.extend_from_slice(&0x0605_4b50u32.to_le_bytes());
    out.extend_from_slice(&[0, 0, 0, 0]);
    out.extend_from_slice(&(members.len() as u16).to_le_bytes());
    out.extend_from_slice(&(members.len() as u16).to_le_bytes());
    out.extend_from_slice(&(central.len() as u32).to_le_bytes());
    out.extend_from_slice(&central_offset.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    let mut f = std::fs::File::create(path).map_err(|e| Error::from(e).context(path.display()))?;
    f.write_all(&out)
        .map_err(|e| Error::from(e).context(path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_f32() {
        let data: Vec<f32> = (0..16).map(|i| i as f32 * 0.5).collect();
        let bytes = encode(&[2, 8], &data);
        assert_eq!(
            (10 + u16::from_le_bytes([bytes[8], bytes[9]]) as usize) % 64,
            0
        );
        let a = read_f32(&bytes, "t").unwrap();
        assert_eq!(a.shape, vec![2, 8]);
        assert_eq!(a.data, data);
    }

    #[test]
    fn round_trip_u32() {
        let data: Vec<u32> = vec![0, 7, u32::MAX];
        let (shape, back) = read_u32(&encode(&[3], &data), "prim.npy").unwrap();
        assert_eq!((shape, back), (vec![3], data));
        let e = read_u32(&encode(&[1], &[1.0f32]), "prim.npy").unwrap_err();
        assert!(e.message().contains("expected uint32"), "{e}");
    }

    #[test]
    fn wrong_dtype_and_truncation_are_errors() {
        let bytes = encode(&[3], &[1u32, 2, 3]);
        let e = read_f32(&bytes, "rays.npy").unwrap_err();
        assert!(
            e.message().contains("dtype is <u4; expected float32"),
            "{e}"
        );
        let mut short = encode(&[4, 8], &[0f32; 32]);
        short.truncate(short.len() - 4);
        let e = read_f32(&short, "rays.npy").unwrap_err();
        assert!(e.message().contains("needs 128 bytes"), "{e}");
        assert!(
            read_f32(b"not numpy at all", "x")
                .unwrap_err()
                .message()
                .contains("magic")
        );
    }
}
