//! Opens and drops the default Vulkan device `N` times (default 40), printing the process's
//! open file descriptors after each: a device must give back everything it took, or a long
//! test run eventually cannot create an instance. `cargo run -p optik-vulkan --example reopen`.

use optik_vulkan::{VulkanBackend, VulkanDevice, VulkanOptions};

fn open_fds() -> usize {
    std::fs::read_dir("/proc/self/fd").map_or(0, |d| d.count())
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(40);
    let validation = std::env::var_os("OPTIK_VALIDATION").is_some();
    println!("before: {} fds", open_fds());
    for i in 0..n {
        let options = VulkanOptions {
            validation,
            device: None,
            force_staging: false,
            pipeline_cache: false,
            cache_dir: None,
            max_dispatch_invocations: None,
            driver_triangles: None,
        };
        match VulkanBackend::open(&options).map(VulkanDevice::new) {
            Ok(dev) => drop(dev),
            Err(e) => {
                println!("open {i} failed: {e}");
                std::process::exit(1);
            }
        }
        println!("after open/drop {i}: {} fds", open_fds());
    }
}
