//! `optik info`: which backends run here, on what, and which one `--backend auto` picks.

/// Runs the command; returns the exit status.
pub fn run() -> u8 {
    outln!("backends:");
    for s in optik::backend_statuses() {
        match &s.availability {
            Ok(device) => outln!("  {:<7} available: {device}", s.kind.name()),
            Err(why) => outln!("  {:<7} not available: {why}", s.kind.name()),
        }
    }
    let auto = optik::auto_choice();
    outln!("  auto    picks {}: {}", auto.kind(), auto.reason);
    driver_triangles();
    outln!();
    match optik::backends::vulkan::probe() {
        Ok(devices) => {
            outln!("Vulkan devices ({}):", devices.len());
            for d in &devices {
                for line in d.to_string().lines() {
                    outln!("  {line}");
                }
            }
        }
        Err(e) => outln!("Vulkan devices: none ({})", e.message()),
    }
    outln!();
    let adapters = optik::backends::wgpu::probe();
    outln!("wgpu adapters ({}):", adapters.len());
    for a in &adapters {
        for line in a.to_string().lines() {
            outln!("  {line}");
        }
    }
    0
}

/// The Vulkan driver's triangle test against optik's watertightness check (cached per driver
/// build; docs/vulkan-backend.md, "The driver's triangles").
fn driver_triangles() {
    let Ok(device) = optik::open_backend(optik::BackendKind::Vulkan) else {
        return;
    };
    // OPTIK_VULKAN_DRIVER_TRIANGLES decides instead of the check where it is set.
    let forced = optik::backends::vulkan::VulkanOptions::from_env().driver_triangles;
    match optik::triangle_check::check_driver_triangles(device.as_ref()) {
        Ok(check) => outln!(
            "  vulkan  the driver's triangles (TriangleTest::Driver) {check}; the default (watertight) uses {}{}",
            if forced.unwrap_or(check.passed) {
                "the driver's triangles where they can serve and optik's for the rest (motion, micromaps, face-culling records, under motion transforms)"
            } else {
                "optik's triangle stage for every triangle"
            },
            if forced.is_some() {
                " (as OPTIK_VULKAN_DRIVER_TRIANGLES says)"
            } else {
                ""
            }
        ),
        Err(e) => outln!("  vulkan  the driver's triangles could not be checked: {e}"),
    }
}
