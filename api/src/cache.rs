//! Where optik keeps what it caches on disk (compiled programs, pipeline caches, driver
//! checks): `$OPTIK_CACHE_PATH`, else `$XDG_CACHE_HOME/optik`, else `~/.cache/optik`.
//! `OPTIK_CACHE_DISABLE=1` turns every cache off. Each cache keeps its own file or folder
//! there; losing one only costs the work it saved.

use std::ffi::OsString;
use std::path::PathBuf;

/// The cache folder the environment names (not created here); `None` when none is named.
pub fn root() -> Option<PathBuf> {
    root_in(|name| std::env::var_os(name))
}

/// Whether `OPTIK_CACHE_DISABLE=1` turns the caches off.
pub fn disabled() -> bool {
    disabled_in(|name| std::env::var_os(name))
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
