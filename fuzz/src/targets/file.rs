//! Readers that take a path get each input as a file: one per thread (cargo test runs targets
//! side by side), rewritten for every input, in the system's temporary folder.

use std::path::PathBuf;

/// Writes `bytes` to this thread's file with extension `ext` and runs `read` on its path;
/// `None` when the file cannot be written (the input is then not run).
pub fn with_file<R>(
    ext: &str,
    bytes: &[u8],
    read: impl FnOnce(&std::path::Path) -> R,
) -> Option<R> {
    let path = thread_file(ext);
    std::fs::write(&path, bytes).ok()?;
    Some(read(&path))
}

fn thread_file(ext: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("optik-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let thread = format!("{:?}", std::thread::current().id());
    let thread: String = thread.chars().filter(char::is_ascii_digit).collect();
    dir.join(format!("input-{thread}.{ext}"))
}
