//! Intel Open Image Denoise, loaded at run time through its small C API.
//!
//! Where the library is looked for, in order ([`candidates`]):
//! 1. `OPTIK_OIDN_LIB`: the library file, or a folder holding it (or holding `lib/` with it);
//! 2. the folder `scripts/oidn-setup` installs the PyPI wheel `pyoidn` into:
//!    `$OPTIK_OIDN_HOME` or `$XDG_DATA_HOME/optik/oidn` (default `~/.local/share/optik/oidn`),
//!    where the wheel puts the library at `pyoidn/oidn/lib/`;
//! 3. the system's library search path (`libOpenImageDenoise.so.2`).
//!
//! The filter is OIDN's `RT` filter on the CPU device with `hdr` on and albedo and normal
//! guides, the configuration OIDN documents for path-traced beauty images. The CPU device is
//! chosen rather than the default one: GPU devices need their own runtimes and device memory,
//! and the images here live in host memory.

use libloading::{Library, Symbol};
use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::path::{Path, PathBuf};

/// The environment variable naming the library file or its folder.
pub const ENV_LIB: &str = "OPTIK_OIDN_LIB";
/// The environment variable naming `scripts/oidn-setup`'s install folder.
pub const ENV_HOME: &str = "OPTIK_OIDN_HOME";

#[cfg(target_os = "linux")]
const LIB_NAMES: &[&str] = &["libOpenImageDenoise.so.2", "libOpenImageDenoise.so"];
#[cfg(target_os = "macos")]
const LIB_NAMES: &[&str] = &["libOpenImageDenoise.2.dylib", "libOpenImageDenoise.dylib"];
#[cfg(target_os = "windows")]
const LIB_NAMES: &[&str] = &["OpenImageDenoise.dll"];
#[cfg(not(any(target_os = "linux", target_os = "macos", target_os = "windows")))]
const LIB_NAMES: &[&str] = &[];

const OIDN_DEVICE_TYPE_CPU: c_int = 1;
const OIDN_FORMAT_FLOAT3: c_int = 3;
const OIDN_ERROR_NONE: c_int = 0;

type Handle = *mut c_void;

/// `scripts/oidn-setup`'s install folder.
pub fn default_home() -> Option<PathBuf> {
    if let Some(home) = std::env::var_os(ENV_HOME) {
        return Some(PathBuf::from(home));
    }
    let data = std::env::var_os("XDG_DATA_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/share")))?;
    Some(data.join("optik/oidn"))
}

/// The library files to try inside `dir`: the library itself, `lib/` below it, and the
/// wheel's `pyoidn/oidn/lib/`.
fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for sub in ["", "lib", "pyoidn/oidn/lib"] {
        for name in LIB_NAMES {
            out.push(dir.join(sub).join(name));
        }
    }
    out
}

/// Where [`Oidn::load`] looks, in order: `OPTIK_OIDN_LIB`, the setup script's folder, then bare
/// names for the system's search path.
pub fn candidates() -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Some(lib) = std::env::var_os(ENV_LIB) {
        let lib = PathBuf::from(lib);
        if lib.is_dir() {
            out.extend(files_in(&lib));
        } else {
            out.push(lib);
        }
        // An explicit choice is the only one tried: falling back silently would hide a typo.
        return out;
    }
    if let Some(home) = default_home() {
        out.extend(files_in(&home).into_iter().filter(|p| p.exists()));
    }
    out.extend(LIB_NAMES.iter().map(PathBuf::from));
    out
}

/// A loaded OIDN library and its version.
pub struct Oidn {
    lib: Library,
    path: PathBuf,
    version: String,
}

/// Runs `f` and turns OIDN's device error, if any, into a message naming `what`.
///
/// # Safety
/// `device` is a live device of `lib`.
unsafe fn check(lib: &Library, device: Handle, what: &str) -> Result<(), String> {
    let get_error: Symbol<unsafe extern "C" fn(Handle, *mut *const c_char) -> c_int> =
        unsafe { lib.get(b"oidnGetDeviceError\0") }.map_err(|e| e.to_string())?;
    let mut message: *const c_char = std::ptr::null();
    let code = unsafe { get_error(device, &mut message) };
    if code == OIDN_ERROR_NONE {
        return Ok(());
    }
    let text = if message.is_null() {
        String::new()
    } else {
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    };
    Err(format!("{what}: OIDN error {code}: {text}"))
}

/// Looks up a symbol, or says which one the library lacks.
macro_rules! sym {
    ($lib:expr, $name:literal, $ty:ty) => {{
        let s: Result<Symbol<$ty>, String> = unsafe { $lib.get(concat!($name, "\0").as_bytes()) }
            .map_err(|e| {
                format!(
                    "the OIDN library has no `{}` (too old? OIDN 2 is needed): {e}",
                    $name
                )
            });
        s
    }};
}

/// Releases a device when dropped, so every early return cleans up.
struct DeviceGuard<'a> {
    lib: &'a Library,
    device: Handle,
}

impl Drop for DeviceGuard<'_> {
    fn drop(&mut self) {
        if let Ok(release) = sym!(self.lib, "oidnReleaseDevice", unsafe extern "C" fn(Handle)) {
            unsafe { release(self.device) };
        }
    }
}

/// Releases a filter when dropped.
struct FilterGuard<'a> {
    lib: &'a Library,
    filter: Handle,
}

impl Drop for FilterGuard<'_> {
    fn drop(&mut self) {
        if let Ok(release) = sym!(self.lib, "oidnReleaseFilter", unsafe extern "C" fn(Handle)) {
            unsafe { release(self.filter) };
        }
    }
}

impl Oidn {
    /// Loads the first library of [`candidates`] that opens and creates a CPU device; the
    /// error lists every place tried and why each failed.
    pub fn load() -> Result<Oidn, String> {
        let mut tried = Vec::new();
        for path in candidates() {
            match Oidn::load_from(&path) {
                Ok(oidn) => return Ok(oidn),
                Err(e) => tried.push(e),
            }
        }
        Err(format!(
            "Intel Open Image Denoise was not found ({}); run scripts/oidn-setup or set {ENV_LIB} \
             to libOpenImageDenoise's path",
            tried.join("; ")
        ))
    }

    /// Loads the library at `path` (a bare file name searches the system's path) and checks
    /// that it can create a CPU device.
    pub fn load_from(path: &Path) -> Result<Oidn, String> {
        // SAFETY: loading runs the library's initialisers; OIDN's have no preconditions.
        let lib = unsafe { Library::new(path) }
            .map_err(|e| format!("{} does not load: {e}", path.display()))?;
        let version = {
            let device = Self::new_device(&lib).map_err(|e| format!("{}: {e}", path.display()))?;
            let get_int = sym!(
                lib,
                "oidnGetDeviceInt",
                unsafe extern "C" fn(Handle, *const c_char) -> c_int
            )?;
            let v = unsafe { get_int(device.device, c"version".as_ptr()) };
            format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
        };
        Ok(Oidn {
            lib,
            path: path.to_path_buf(),
            version,
        })
    }

    fn new_device(lib: &Library) -> Result<DeviceGuard<'_>, String> {
        let new_device = sym!(lib, "oidnNewDevice", unsafe extern "C" fn(c_int) -> Handle)?;
        let commit = sym!(lib, "oidnCommitDevice", unsafe extern "C" fn(Handle))?;
        let device = unsafe { new_device(OIDN_DEVICE_TYPE_CPU) };
        if device.is_null() {
            return Err("OIDN could not create a CPU device (unsupported CPU?)".into());
        }
        let guard = DeviceGuard { lib, device };
        unsafe { commit(device) };
        unsafe { check(lib, device, "committing the CPU device") }?;
        Ok(guard)
    }

    /// The library's version, `major.minor.patch`.
    pub fn version(&self) -> &str {
        &self.version
    }

    /// The file the library was loaded from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Runs the `RT` filter (HDR, albedo and normal guides) over `color`.
    pub fn denoise(
        &self,
        color: &[[f32; 3]],
        albedo: &[[f32; 3]],
        normal: &[[f32; 3]],
        width: u32,
        height: u32,
    ) -> Result<Vec<[f32; 3]>, String> {
        super::check_sizes(color, albedo, normal, width, height).map_err(|e| e.0)?;
        let lib = &self.lib;
        let device = Self::new_device(lib)?;
        let new_filter = sym!(
            lib,
            "oidnNewFilter",
            unsafe extern "C" fn(Handle, *const c_char) -> Handle
        )?;
        type SetImage = unsafe extern "C" fn(
            Handle,
            *const c_char,
            *mut c_void,
            c_int,
            usize,
            usize,
            usize,
            usize,
            usize,
        );
        let set_image = sym!(lib, "oidnSetSharedFilterImage", SetImage)?;
        let set_bool = sym!(
            lib,
            "oidnSetFilterBool",
            unsafe extern "C" fn(Handle, *const c_char, bool)
        )?;
        let commit = sym!(lib, "oidnCommitFilter", unsafe extern "C" fn(Handle))?;
        let execute = sym!(lib, "oidnExecuteFilter", unsafe extern "C" fn(Handle))?;

        let name = CString::new("RT").map_err(|e| e.to_string())?;
        let filter = unsafe { new_filter(device.device, name.as_ptr()) };
        unsafe { check(lib, device.device, "creating the RT filter") }?;
        if filter.is_null() {
            return Err("OIDN returned no RT filter".into());
        }
        let filter = FilterGuard { lib, filter };
        // OIDN reads the inputs and writes the output in place of these host buffers; it
        // never writes the inputs, but its C API takes mutable pointers, so they are copied.
        let mut inputs = [color.to_vec(), albedo.to_vec(), normal.to_vec()];
        let mut output = vec![[0.0f32; 3]; color.len()];
        let (w, h) = (width as usize, height as usize);
        for (label, buffer) in [c"color", c"albedo", c"normal"]
            .into_iter()
            .zip(inputs.iter_mut())
            .chain(std::iter::once((c"output", &mut output)))
        {
            // SAFETY: the buffer holds w × h packed FLOAT3 pixels and outlives the filter's
            // execution below.
            unsafe {
                set_image(
                    filter.filter,
                    label.as_ptr(),
                    buffer.as_mut_ptr().cast(),
                    OIDN_FORMAT_FLOAT3,
                    w,
                    h,
                    0,
                    12,
                    12 * w,
                )
            };
        }
        unsafe { set_bool(filter.filter, c"hdr".as_ptr(), true) };
        unsafe { commit(filter.filter) };
        unsafe { check(lib, device.device, "committing the RT filter") }?;
        unsafe { execute(filter.filter) };
        unsafe { check(lib, device.device, "running the RT filter") }?;
        drop(filter);
        drop(device);
        Ok(output)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::denoise::testimage::{TestImage, mse};
    use crate::denoise::{Denoiser, denoise};

    #[test]
    fn a_missing_library_is_named_in_the_message() {
        let err = match Oidn::load_from(Path::new("/nonexistent/libOpenImageDenoise.so.2")) {
            Ok(_) => panic!("a missing file cannot load"),
            Err(e) => e,
        };
        assert!(
            err.contains("/nonexistent/libOpenImageDenoise.so.2 does not load"),
            "{err}"
        );
    }

    #[test]
    fn denoise_names_the_denoiser_that_ran() {
        let img = TestImage::new(64, 48, 4);
        let (out, which) = denoise(&img.noisy, &img.albedo, &img.normal, 64, 48).unwrap();
        println!("denoiser: {which}");
        match (&which, Oidn::load()) {
            (Denoiser::Oidn { .. }, Ok(_)) => {}
            (Denoiser::ATrous { reason }, Err(_)) => {
                assert!(reason.contains("oidn-setup"), "{reason}")
            }
            (which, loaded) => panic!(
                "denoise ran {which} while OIDN {}",
                if loaded.is_ok() { "loads" } else { "does not" }
            ),
        }
        assert!(mse(&out, &img.converged) < 0.25 * mse(&img.noisy, &img.converged));
    }

    #[test]
    fn oidn_reduces_error_against_the_converged_image() {
        let oidn = match Oidn::load() {
            Ok(o) => o,
            Err(reason) => {
                println!("skipped: OIDN is not installed here ({reason})");
                return;
            }
        };
        let img = TestImage::new(64, 48, 4);
        let out = oidn
            .denoise(&img.noisy, &img.albedo, &img.normal, 64, 48)
            .unwrap_or_else(|e| panic!("OIDN {} failed: {e}", oidn.version()));
        let (before, after) = (mse(&img.noisy, &img.converged), mse(&out, &img.converged));
        println!(
            "OIDN {} from {}: MSE {before:.5} -> {after:.5}",
            oidn.version(),
            oidn.path().display()
        );
        assert!(after < 0.25 * before, "MSE {before} -> {after}");
        let err = oidn.denoise(&img.noisy[1..], &img.albedo, &img.normal, 64, 48);
        assert!(err.is_err());
    }
}
