//! Readers that take a path get each input as a file: one per thread (cargo test runs targets
//! side by side), rewritten for every input, in a RAM file system where there is one.
//!
//! On a disk file system rewriting the same file is slow: ext4 flushes a file truncated and
//! written again when it is closed (`auto_da_alloc`), so each input waited for the disk and
//! the Mitsuba target ran ~350 inputs/s where tmpfs gives ~15,000. The readers still open,
//! read and resolve paths next to a real file; only where it lives changes.

use std::path::{Path, PathBuf};

/// Writes `bytes` to this thread's file with extension `ext` and runs `read` on its path;
/// `None` when the file cannot be written (the input is then not run). The file and its
/// folder are removed afterwards, so a run leaves nothing behind (tmpfs is memory).
pub fn with_file<R>(ext: &str, bytes: &[u8], read: impl FnOnce(&Path) -> R) -> Option<R> {
    // One folder per thread: relative paths in an input resolve next to its own file only,
    // and removing the folder cannot race another thread.
    let thread = format!("{:?}", std::thread::current().id());
    let thread: String = thread.chars().filter(char::is_ascii_digit).collect();
    let dir = scratch_root().join(format!("optik-fuzz-{}-{thread}", std::process::id()));
    std::fs::create_dir_all(&dir).ok()?;
    let path = dir.join(format!("input.{ext}"));
    let result = std::fs::write(&path, bytes).ok().map(|()| read(&path));
    let _ = std::fs::remove_file(&path);
    let _ = std::fs::remove_dir(&dir);
    result
}

/// `/dev/shm` (tmpfs on Linux) when it can be written to, else the system's temporary
/// folder; `OPTIK_FUZZ_DIR` overrides both.
fn scratch_root() -> PathBuf {
    static ROOT: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    ROOT.get_or_init(|| {
        if let Some(dir) = std::env::var_os("OPTIK_FUZZ_DIR") {
            return PathBuf::from(dir);
        }
        let shm = Path::new("/dev/shm");
        let probe = shm.join(format!("optik-fuzz-probe-{}", std::process::id()));
        if std::fs::write(&probe, b"").is_ok() {
            let _ = std::fs::remove_file(&probe);
            return shm.to_path_buf();
        }
        std::env::temp_dir()
    })
    .clone()
}
