//! optik: an OptiX-7-style ray tracing API for Rust.
//!
//! One host API ([`Device`] and the types of [`optik_api`]) and one program language (WGSL
//! with an OptiX-style device API) on three backends: CPU (`optik-cpu`), wgpu compute
//! (`optik-wgpu`) and Vulkan ray tracing (`optik-vulkan`). This facade re-exports the API
//! and opens devices: a named backend, or the best one available (Vulkan ray tracing on a
//! GPU, else wgpu on a GPU, else CPU; software GPU drivers only when named).

pub use optik_api::*;

/// The WGSL program front end every backend compiles through: parse, check and reflect a
/// module without a device (`optik compile` uses it).
pub use optik_core::frontend;

mod auto;
pub use auto::{AutoChoice, FoundDevice, auto_choice, decide_auto};
pub mod raycast;
pub mod triangle_check;

/// Which backend [`open`] should use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BackendChoice {
    /// The fastest real device here: Vulkan ray tracing on a GPU, else wgpu on a GPU, else
    /// the CPU backend. Software Vulkan or wgpu devices (lavapipe, llvmpipe) are never chosen
    /// automatically: they are correct but hundreds of times slower than the CPU backend.
    Auto,
    /// Exactly this backend, or an error saying why it cannot run.
    Named(BackendKind),
}

impl BackendChoice {
    /// Parses `auto`, `cpu`, `wgpu` or `vulkan`.
    pub fn parse(s: &str) -> Option<BackendChoice> {
        if s == "auto" {
            return Some(BackendChoice::Auto);
        }
        BackendKind::from_name(s).map(BackendChoice::Named)
    }
}

/// Whether a backend can run here, and on what.
#[derive(Clone, Debug)]
pub struct BackendStatus {
    /// The backend.
    pub kind: BackendKind,
    /// `Ok(description of the device)` or `Err(why it cannot run)`.
    pub availability: std::result::Result<String, String>,
}

/// Opens a device of the named backend; the error says why the backend cannot run here.
pub fn open_backend(kind: BackendKind) -> Result<Box<dyn Device>> {
    match kind {
        BackendKind::Cpu => open_cpu(),
        BackendKind::Wgpu => open_wgpu(),
        BackendKind::Vulkan => open_vulkan(),
    }
}

/// Settings for opening a device that only some backends use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpenOptions {
    /// CPU worker threads (`None`: one per core), 1 to [`max_cpu_threads`]. Results do not
    /// depend on it. Only the CPU backend uses it.
    pub threads: Option<usize>,
}

impl OpenOptions {
    /// The options that a device of `kind` ignores, each as a sentence for a warning: a
    /// user who asked for 8 threads should hear that a GPU backend has no use for them.
    pub fn ignored_by(&self, kind: BackendKind) -> Vec<String> {
        let mut ignored = Vec::new();
        if let Some(n) = self.threads
            && kind != BackendKind::Cpu
        {
            ignored.push(format!(
                "the thread count ({n}) is ignored: only the CPU backend has worker threads, and the device is {kind}"
            ));
        }
        ignored
    }

    /// Checks the values themselves, whatever the backend.
    fn check(&self) -> Result<()> {
        if let Some(n) = self.threads {
            let max = max_cpu_threads();
            if n == 0 || n > max {
                return Err(Error::invalid(format!(
                    "{n} CPU worker threads asked for; give 1 to {max} (this machine has {} cores; results do not depend on the count)",
                    available_cores()
                )));
            }
        }
        Ok(())
    }
}

/// The most CPU worker threads a device may have: 1024, or four per core on machines with
/// more than 256 cores. Starting thousands of threads takes tens of seconds and, beyond
/// that, exhausts process ids; no launch gets faster past a few threads per core.
pub fn max_cpu_threads() -> usize {
    1024.max(4 * available_cores())
}

/// The cores this process may run on (`std::thread::available_parallelism`, 1 where the
/// system cannot tell): what "one per core" (the CPU backend's default) and "all threads"
/// (the benchmarks' and the CLI's) mean.
pub fn available_cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Opens a device: a named backend, or the automatic choice ([`auto_choice`]).
pub fn open(choice: BackendChoice) -> Result<Box<dyn Device>> {
    open_with(choice, &OpenOptions::default())
}

/// Opens a device with options. The options are checked whatever the backend; those the
/// chosen backend ignores are listed by [`OpenOptions::ignored_by`].
pub fn open_with(choice: BackendChoice, options: &OpenOptions) -> Result<Box<dyn Device>> {
    options.check()?;
    let open_one = |kind| match kind {
        BackendKind::Cpu => open_cpu_with(options.threads),
        other => open_backend(other),
    };
    match choice {
        BackendChoice::Named(kind) => open_one(kind),
        BackendChoice::Auto => {
            let pick = auto_choice();
            let mut reasons = Vec::new();
            for kind in pick.order {
                match open_one(kind) {
                    Ok(d) => return Ok(d),
                    Err(e) => reasons.push(format!("{kind}: {}", e.message())),
                }
            }
            Err(Error::unsupported(format!(
                "no backend can run here ({})",
                reasons.join("; ")
            )))
        }
    }
}

/// Tries every backend and reports which can run here.
pub fn backend_statuses() -> Vec<BackendStatus> {
    BackendKind::ALL
        .into_iter()
        .map(|kind| BackendStatus {
            kind,
            availability: open_backend(kind)
                .map(|d| d.properties().device_name.clone())
                .map_err(|e| e.message().to_string()),
        })
        .collect()
}

#[cfg(not(all(feature = "cpu", feature = "wgpu", feature = "vulkan")))]
pub(crate) fn not_built(kind: BackendKind) -> Error {
    Error::unsupported(format!(
        "the {kind} backend was not compiled into this build (enable the `{kind}` feature of the optik crate)"
    ))
}

fn open_cpu() -> Result<Box<dyn Device>> {
    open_cpu_with(None)
}

#[cfg(feature = "cpu")]
fn open_cpu_with(threads: Option<usize>) -> Result<Box<dyn Device>> {
    optik_cpu::open_with_threads(threads)
}
#[cfg(not(feature = "cpu"))]
fn open_cpu_with(_threads: Option<usize>) -> Result<Box<dyn Device>> {
    Err(not_built(BackendKind::Cpu))
}

#[cfg(feature = "wgpu")]
fn open_wgpu() -> Result<Box<dyn Device>> {
    optik_wgpu::open()
}
#[cfg(not(feature = "wgpu"))]
fn open_wgpu() -> Result<Box<dyn Device>> {
    Err(not_built(BackendKind::Wgpu))
}

/// Opens the Vulkan device the environment asks for. Unless `OPTIK_VULKAN_DRIVER_TRIANGLES`
/// decides it, optik's check of the driver's triangle test ([`triangle_check`], cached per
/// driver build) decides whether the default accuracy uses the driver's triangles where they
/// can serve (docs/vulkan-backend.md §2.4); a check that cannot run keeps optik's triangles.
#[cfg(feature = "vulkan")]
fn open_vulkan() -> Result<Box<dyn Device>> {
    let options = optik_vulkan::VulkanOptions::from_env();
    let device = optik_vulkan::open_with(&options)?;
    if options.driver_triangles.is_none()
        && let Ok(check) = triangle_check::check_driver_triangles(&device)
    {
        device.set_driver_triangles(check.passed)?;
    }
    Ok(Box::new(device))
}
#[cfg(not(feature = "vulkan"))]
fn open_vulkan() -> Result<Box<dyn Device>> {
    Err(not_built(BackendKind::Vulkan))
}

/// The backend crates, for backend-specific settings (thread counts, adapter probes).
pub mod backends {
    #[cfg(feature = "cpu")]
    pub use optik_cpu as cpu;
    #[cfg(feature = "vulkan")]
    pub use optik_vulkan as vulkan;
    #[cfg(feature = "wgpu")]
    pub use optik_wgpu as wgpu;
}
