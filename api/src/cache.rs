//! Where optik keeps what it caches on disk (compiled programs, pipeline caches, driver
//! checks): `$OPTIK_CACHE_PATH`, else `$XDG_CACHE_HOME/optik`, else `~/.cache/optik`.
//! `OPTIK_CACHE_DISABLE=1` turns every cache off. Each cache keeps its own file or folder
//! there; losing one only costs the work it saved.
//!
//! Cache files are written with [`write_checked`] and read with [`read_checked`]: a magic
//! word naming the cache, the payload's length and an FNV-1a checksum before the payload,
//! written to a temporary name unique to the process and the write and renamed into place.
//! So concurrent writers (threads or processes) never share a file, and a torn, truncated
//! or corrupted file reads as absent, never as data: a miss costs only time, while damaged
//! data could reach a JIT or a driver (`vkCreatePipelineCache` may assume its initial data
//! is what it once returned).

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The cache folder the environment names (not created here); `None` when none is named.
pub fn root() -> Option<PathBuf> {
    root_in(|name| std::env::var_os(name))
}

/// Whether `OPTIK_CACHE_DISABLE=1` turns the caches off.
pub fn disabled() -> bool {
    disabled_in(|name| std::env::var_os(name))
}

/// Bytes before a checked file's payload: magic, length, checksum.
const CHECKED_HEADER: usize = 8 + 8 + 8;

/// FNV-1a, 64 bits: catches torn writes and bit rot (not an adversary).
fn checksum(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// `payload` framed as a checked file of kind `magic`.
pub fn checked_bytes(magic: &[u8; 8], payload: &[u8]) -> Vec<u8> {
    let mut file = Vec::with_capacity(CHECKED_HEADER + payload.len());
    file.extend_from_slice(magic);
    file.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    file.extend_from_slice(&checksum(payload).to_le_bytes());
    file.extend_from_slice(payload);
    file
}

/// The payload of a checked file's bytes, if they are a whole file of kind `magic`.
pub fn checked_payload<'a>(magic: &[u8; 8], bytes: &'a [u8]) -> Option<&'a [u8]> {
    if bytes.len() < CHECKED_HEADER || &bytes[..8] != magic {
        return None;
    }
    let len = u64::from_le_bytes(bytes[8..16].try_into().ok()?);
    let sum = u64::from_le_bytes(bytes[16..24].try_into().ok()?);
    let payload = &bytes[CHECKED_HEADER..];
    (payload.len() as u64 == len && checksum(payload) == sum).then_some(payload)
}

/// Writes `payload` to `path` as a checked file of kind `magic`: to a temporary name unique
/// to this process and write, then renamed over `path`. Failures only lose the entry.
pub fn write_checked(path: &Path, magic: &[u8; 8], payload: &[u8]) {
    static WRITES: AtomicU64 = AtomicU64::new(0);
    let n = WRITES.fetch_add(1, Ordering::Relaxed);
    let tmp = path.with_extension(format!("tmp{}-{n}", std::process::id()));
    if std::fs::write(&tmp, checked_bytes(magic, payload)).is_ok()
        && std::fs::rename(&tmp, path).is_err()
    {
        let _ = std::fs::remove_file(&tmp);
    }
}

/// The payload of the checked file of kind `magic` at `path`; `None` when it is missing,
/// of another kind, torn or damaged.
pub fn read_checked(path: &Path, magic: &[u8; 8]) -> Option<Vec<u8>> {
    let mut bytes = std::fs::read(path).ok()?;
    checked_payload(magic, &bytes)?;
    // The payload moved to the front in place: no second buffer of the file's size (the
    // Vulkan pipeline cache is megabytes on some drivers).
    bytes.drain(..CHECKED_HEADER);
    Some(bytes)
}

/// [`root`] with the environment given as a lookup (for tests of the rule).
pub fn root_in(var: impl Fn(&str) -> Option<OsString>) -> Option<PathBuf> {
    let env = |name: &str| var(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    env("OPTIK_CACHE_PATH")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("optik")))
        .or_else(|| env("HOME").map(|h| h.join(".cache").join("optik")))
}

/// [`disabled`] with the environment given as a lookup.
pub fn disabled_in(var: impl Fn(&str) -> Option<OsString>) -> bool {
    var("OPTIK_CACHE_DISABLE").is_some_and(|v| v == "1")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checked_bytes_round_trip_and_damage_is_absent() {
        let file = checked_bytes(b"optiktst", b"payload");
        assert_eq!(checked_payload(b"optiktst", &file), Some(&b"payload"[..]));
        assert_eq!(checked_payload(b"otherkin", &file), None, "another kind");
        let mut flipped = file.clone();
        *flipped.last_mut().unwrap() ^= 1;
        assert_eq!(
            checked_payload(b"optiktst", &flipped),
            None,
            "a flipped bit"
        );
        assert_eq!(
            checked_payload(b"optiktst", &file[..file.len() - 1]),
            None,
            "torn"
        );
        assert_eq!(
            checked_payload(b"optiktst", &file[..5]),
            None,
            "shorter than a header"
        );
        let mut longer = file.clone();
        longer.push(0);
        assert_eq!(
            checked_payload(b"optiktst", &longer),
            None,
            "trailing bytes"
        );
        assert_eq!(
            checked_payload(b"optiktst", &checked_bytes(b"optiktst", &[])),
            Some(&[][..])
        );
    }

    /// Threads writing different payloads to one path at once leave one whole payload,
    /// never a mix (each write has its own temporary file).
    #[test]
    fn concurrent_writers_leave_one_whole_file() {
        let dir = std::env::temp_dir().join(format!("optik-checked-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("entry.bin");
        let payloads: Vec<Vec<u8>> = (0..8u8).map(|i| vec![i; 64 * 1024 + i as usize]).collect();
        std::thread::scope(|s| {
            for p in &payloads {
                let path = &path;
                s.spawn(move || {
                    for _ in 0..20 {
                        write_checked(path, b"optiktst", p);
                    }
                });
            }
        });
        let got = read_checked(&path, b"optiktst").expect("a whole file");
        assert!(payloads.contains(&got));
        let leftovers = std::fs::read_dir(&dir).unwrap().count();
        assert_eq!(leftovers, 1, "no temporary file is left behind");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
