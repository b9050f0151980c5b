//! `optik info`: which backends run here, on what.

/// Runs the command; returns the exit status.
pub fn run() -> u8 {
    println!("backends:");
    for s in optik::backend_statuses() {
        match &s.availability {
            Ok(device) => println!("  {:<7} available: {device}", s.kind.name()),
            Err(why) => println!("  {:<7} not available: {why}", s.kind.name()),
        }
    }
    println!();
    match optik::backends::vulkan::probe() {
        Ok(devices) => {
            println!("Vulkan devices ({}):", devices.len());
            for d in &devices {
                for line in d.to_string().lines() {
                    println!("  {line}");
                }
            }
        }
        Err(e) => println!("Vulkan devices: none ({})", e.message()),
    }
    println!();
    let adapters = optik::backends::wgpu::probe();
    println!("wgpu adapters ({}):", adapters.len());
    for a in &adapters {
        for line in a.to_string().lines() {
            println!("  {line}");
        }
    }
    0
}
