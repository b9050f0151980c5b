//! The automatic backend choice (DESIGN.md §2): the fastest real device here. Vulkan ray
//! tracing on a GPU, else wgpu on a GPU, else the CPU backend. Software Vulkan and wgpu
//! devices (lavapipe, llvmpipe) run ray tracing correctly but hundreds of times slower than
//! the CPU backend on the same machine, so they run only when their backend is named.

#[cfg(not(all(feature = "wgpu", feature = "vulkan")))]
use crate::not_built;
use optik_api::BackendKind;

/// What [`BackendChoice::Auto`] picks here, and why.
///
/// [`BackendChoice::Auto`]: crate::BackendChoice::Auto
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AutoChoice {
    /// The backends to try, best first; the CPU backend is always last. The first that opens
    /// is used.
    pub order: Vec<BackendKind>,
    /// Why the first one: what was found on each GPU backend.
    pub reason: String,
}

impl AutoChoice {
    /// The backend picked (the first of [`AutoChoice::order`]).
    pub fn kind(&self) -> BackendKind {
        self.order.first().copied().unwrap_or(BackendKind::Cpu)
    }
}

/// A device a GPU backend found, as the automatic choice sees it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FoundDevice {
    /// The device's or adapter's name.
    pub name: String,
    /// A GPU (discrete, integrated or virtual); `false` for software devices such as
    /// lavapipe (Vulkan device type CPU) and llvmpipe (wgpu `DeviceType::Cpu`).
    pub gpu: bool,
    /// `Err(what optik lacks)` when the backend cannot use it.
    pub usable: std::result::Result<(), String>,
}

/// Decides the automatic choice from what each GPU backend found (`Err`: why the backend
/// found nothing). The rule (DESIGN.md §2): Vulkan on a usable GPU, else wgpu on a GPU, else
/// CPU; a software device is never picked automatically.
pub fn decide_auto(
    vulkan: std::result::Result<Vec<FoundDevice>, String>,
    wgpu: std::result::Result<Vec<FoundDevice>, String>,
) -> AutoChoice {
    let mut order = Vec::new();
    let mut why = Vec::new();
    for (kind, found) in [(BackendKind::Vulkan, vulkan), (BackendKind::Wgpu, wgpu)] {
        let devices = match found {
            Ok(d) => d,
            Err(e) => {
                why.push(format!("{kind}: {e}"));
                continue;
            }
        };
        if let Some(d) = devices.iter().find(|d| d.gpu && d.usable.is_ok()) {
            why.push(format!("{kind}: {} is a GPU optik can use", d.name));
            order.push(kind);
        } else if devices.is_empty() {
            why.push(format!("{kind}: no device"));
        } else {
            let each: Vec<String> = devices
                .iter()
                .map(|d| match &d.usable {
                    _ if !d.gpu => format!("{} is a software device", d.name),
                    Err(lacks) => format!("{} lacks {lacks}", d.name),
                    Ok(()) => format!("{} is usable", d.name),
                })
                .collect();
            why.push(format!("{kind}: {}", each.join(", ")));
        }
    }
    order.push(BackendKind::Cpu);
    let reason = match order[0] {
        BackendKind::Cpu => format!(
            "no GPU found ({}); software Vulkan and wgpu devices are far slower than the CPU backend and run only when their backend is named",
            why.join("; ")
        ),
        // The chosen backend's line first; the others say what else is here.
        first => {
            why.sort_by_key(|w| !w.starts_with(first.name()));
            why.join("; ")
        }
    };
    AutoChoice { order, reason }
}

/// What [`BackendChoice::Auto`] picks on this machine, from the Vulkan and wgpu probes
/// (no device is opened).
///
/// [`BackendChoice::Auto`]: crate::BackendChoice::Auto
pub fn auto_choice() -> AutoChoice {
    decide_auto(vulkan_found(), wgpu_found())
}

#[cfg(feature = "vulkan")]
fn vulkan_found() -> std::result::Result<Vec<FoundDevice>, String> {
    let devices = std::panic::catch_unwind(optik_vulkan::probe)
        .map_err(|_| "probing Vulkan devices panicked".to_string())?
        .map_err(|e| e.message().to_string())?;
    Ok(devices
        .iter()
        .map(|d| FoundDevice {
            name: d.name.clone(),
            gpu: d.is_gpu(),
            usable: if d.usable() {
                Ok(())
            } else {
                Err(d.missing.join(", "))
            },
        })
        .collect())
}
#[cfg(not(feature = "vulkan"))]
fn vulkan_found() -> std::result::Result<Vec<FoundDevice>, String> {
    Err(not_built(BackendKind::Vulkan).message().to_string())
}

#[cfg(feature = "wgpu")]
fn wgpu_found() -> std::result::Result<Vec<FoundDevice>, String> {
    let adapters = std::panic::catch_unwind(optik_wgpu::probe)
        .map_err(|_| "probing wgpu adapters panicked".to_string())?;
    Ok(adapters
        .into_iter()
        .map(|a| FoundDevice {
            name: a.name,
            gpu: a.gpu,
            usable: Ok(()),
        })
        .collect())
}
#[cfg(not(feature = "wgpu"))]
fn wgpu_found() -> std::result::Result<Vec<FoundDevice>, String> {
    Err(not_built(BackendKind::Wgpu).message().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dev(name: &str, gpu: bool, usable: std::result::Result<(), &str>) -> FoundDevice {
        FoundDevice {
            name: name.into(),
            gpu,
            usable: usable.map_err(str::to_string),
        }
    }

    #[test]
    fn software_devices_leave_the_choice_to_the_cpu() {
        let pick = decide_auto(
            Ok(vec![dev("llvmpipe (LLVM 19)", false, Ok(()))]),
            Ok(vec![dev("llvmpipe (LLVM 19)", false, Ok(()))]),
        );
        assert_eq!(pick.order, vec![BackendKind::Cpu]);
        assert!(
            pick.reason
                .contains("vulkan: llvmpipe (LLVM 19) is a software device")
                && pick
                    .reason
                    .contains("wgpu: llvmpipe (LLVM 19) is a software device"),
            "{}",
            pick.reason
        );
    }

    #[test]
    fn a_ray_tracing_gpu_picks_vulkan_with_wgpu_as_fallback() {
        let pick = decide_auto(
            Ok(vec![
                dev("llvmpipe", false, Ok(())),
                dev("NVIDIA H200", true, Ok(())),
            ]),
            Ok(vec![dev("NVIDIA H200", true, Ok(()))]),
        );
        assert_eq!(
            pick.order,
            vec![BackendKind::Vulkan, BackendKind::Wgpu, BackendKind::Cpu]
        );
        assert!(
            pick.reason
                .starts_with("vulkan: NVIDIA H200 is a GPU optik can use"),
            "{}",
            pick.reason
        );
    }

    #[test]
    fn a_gpu_without_ray_tracing_picks_wgpu() {
        let pick = decide_auto(
            Ok(vec![dev(
                "Intel UHD 620",
                true,
                Err("VK_KHR_ray_tracing_pipeline"),
            )]),
            Ok(vec![
                dev("llvmpipe", false, Ok(())),
                dev("Intel UHD 620", true, Ok(())),
            ]),
        );
        assert_eq!(pick.order, vec![BackendKind::Wgpu, BackendKind::Cpu]);
        assert!(
            pick.reason.starts_with("wgpu: Intel UHD 620 is a GPU")
                && pick
                    .reason
                    .contains("vulkan: Intel UHD 620 lacks VK_KHR_ray_tracing_pipeline"),
            "{}",
            pick.reason
        );
    }

    #[test]
    fn no_driver_at_all_picks_the_cpu() {
        let pick = decide_auto(Err("no Vulkan loader found".into()), Ok(vec![]));
        assert_eq!(pick.kind(), BackendKind::Cpu);
        assert!(
            pick.reason.contains("vulkan: no Vulkan loader found")
                && pick.reason.contains("wgpu: no device"),
            "{}",
            pick.reason
        );
    }
}
