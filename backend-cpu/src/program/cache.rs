//! Caches of compiled code: in memory per module, on disk per function.
//!
//! - In memory: one [`JitModule`](super::JitModule) per (full source, optimisation level),
//!   held weakly, so compiling a module a second time while the first is alive returns the
//!   same machine code.
//! - On disk: Cranelift's incremental compilation cache (`Context::compile_with_cache`),
//!   keyed by a SHA-256 of the function's CLIF, the target ISA and its flags, and
//!   Cranelift's version. A hit skips instruction selection, register allocation and
//!   emission (most of the compile time); the naga-to-CLIF lowering still runs, since the
//!   key is the CLIF. Relocations to host functions are symbolic, so cached code is valid
//!   in any process. Entries are files named by the hex key in the cache directory,
//!   written and read as `optik_api::cache`'s checked files (a unique temporary name, then a
//!   rename; a length and checksum), so a torn or corrupted file is a miss, never bad code.
//!
//! The directory is `$OPTIK_CACHE_PATH`, else `$XDG_CACHE_HOME/optik`, else
//! `~/.cache/optik` (a `cranelift-<version>` folder inside it); `OPTIK_CACHE_DISABLE=1`
//! turns the disk cache off, as OptiX's `OPTIX_CACHE_*` variables do. Nothing evicts
//! entries yet (entries are a few kilobytes per program version).

use super::jit::{DiskCache, Inner};
use cranelift_codegen::incremental_cache::CacheKvStore;
use optik_api::OptLevel;
use std::borrow::Cow;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, Weak};

/// What identifies a compiled module in memory.
#[derive(Clone, PartialEq, Eq, Hash)]
pub(crate) struct ModuleKey {
    pub source: String,
    pub opt_level: OptLevel,
}

type Modules = HashMap<ModuleKey, Weak<Inner>>;

static MODULES: Mutex<Option<Modules>> = Mutex::new(None);

/// The live module for `key`, or the one `compile` makes (and remembers).
pub(crate) fn memory_cached(
    key: ModuleKey,
    compile: impl FnOnce() -> optik_api::Result<Arc<Inner>>,
) -> optik_api::Result<Arc<Inner>> {
    let lock = || MODULES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(live) = lock()
        .get_or_insert_with(HashMap::new)
        .get(&key)
        .and_then(Weak::upgrade)
    {
        return Ok(live);
    }
    // Compiled outside the lock, so modules compile in parallel; if two threads compiled
    // the same module, the first to finish wins and the other's copy is dropped.
    let compiled = compile()?;
    let mut guard = lock();
    let modules = guard.get_or_insert_with(HashMap::new);
    if let Some(live) = modules.get(&key).and_then(Weak::upgrade) {
        return Ok(live);
    }
    modules.retain(|_, m| m.strong_count() > 0);
    modules.insert(key, Arc::downgrade(&compiled));
    Ok(compiled)
}

/// The disk cache directory `setting` selects, created; `None` when off or unusable.
pub(crate) fn directory(setting: &DiskCache) -> Option<PathBuf> {
    directory_in(setting, |name| std::env::var_os(name))
}

/// [`directory`] with the environment given as a lookup.
fn directory_in(
    setting: &DiskCache,
    var: impl Fn(&str) -> Option<std::ffi::OsString>,
) -> Option<PathBuf> {
    let root = match setting {
        DiskCache::Disabled => return None,
        DiskCache::Directory(dir) => dir.clone(),
        // The rule every optik cache follows (optik_api::cache).
        DiskCache::FromEnvironment => {
            if optik_api::cache::disabled_in(&var) {
                return None;
            }
            optik_api::cache::root_in(&var)?
        }
    };
    let dir = root.join(concat!("cranelift-", env!("CARGO_PKG_VERSION"), "-0.135"));
    std::fs::create_dir_all(&dir).ok()?;
    Some(dir)
}

/// Cranelift's cache store over files in one directory.
pub(crate) struct DiskStore {
    dir: PathBuf,
}

/// The kind of the entries' checked files.
const MAGIC: &[u8; 8] = b"optikjt1";

impl DiskStore {
    pub fn new(dir: PathBuf) -> Self {
        Self { dir }
    }

    fn path(&self, key: &[u8]) -> PathBuf {
        let hex: String = key.iter().map(|b| format!("{b:02x}")).collect();
        self.dir.join(hex)
    }
}

impl CacheKvStore for DiskStore {
    fn get(&self, key: &[u8]) -> Option<Cow<'_, [u8]>> {
        optik_api::cache::read_checked(&self.path(key), MAGIC).map(Cow::Owned)
    }

    fn insert(&mut self, key: &[u8], val: Vec<u8>) {
        // A failed write only loses a cache entry.
        optik_api::cache::write_checked(&self.path(key), MAGIC, &val);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_round_trip_and_damage_is_a_miss() {
        let dir = std::env::temp_dir().join(format!("optik-cache-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut store = DiskStore::new(dir.clone());
        store.insert(&[1, 2, 3], b"compiled".to_vec());
        assert_eq!(store.get(&[1, 2, 3]).as_deref(), Some(&b"compiled"[..]));
        assert!(store.get(&[9]).is_none());
        let path = store.path(&[1, 2, 3]);
        let mut bytes = std::fs::read(&path).unwrap();
        *bytes.last_mut().unwrap() ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        assert!(
            store.get(&[1, 2, 3]).is_none(),
            "a flipped bit must be a miss"
        );
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
        assert!(
            store.get(&[1, 2, 3]).is_none(),
            "a torn file must be a miss"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_environment_chooses_the_directory() {
        assert_eq!(directory(&DiskCache::Disabled), None);
        let dir = std::env::temp_dir().join(format!("optik-cache-dir-{}", std::process::id()));
        let chosen = directory(&DiskCache::Directory(dir.clone())).unwrap();
        assert!(chosen.starts_with(&dir) && chosen.is_dir());

        let base = dir.to_str().unwrap().to_string();
        let from_env = |vars: &[(&str, &str)]| {
            let vars: Vec<(String, String)> = vars
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            directory_in(&DiskCache::FromEnvironment, move |name| {
                vars.iter().find(|(k, _)| k == name).map(|(_, v)| v.into())
            })
        };
        let own = from_env(&[("OPTIK_CACHE_PATH", &base), ("HOME", "/nonexistent")]);
        assert!(
            own.unwrap().starts_with(&dir),
            "OPTIK_CACHE_PATH comes first"
        );
        let xdg = from_env(&[("XDG_CACHE_HOME", &base)]);
        assert!(xdg.unwrap().starts_with(dir.join("optik")));
        let off = from_env(&[("OPTIK_CACHE_DISABLE", "1"), ("OPTIK_CACHE_PATH", &base)]);
        assert_eq!(off, None, "OPTIK_CACHE_DISABLE=1 turns the cache off");
        assert_eq!(from_env(&[]), None, "no directory to use");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
