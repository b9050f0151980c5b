//! Opening devices through the facade: the automatic choice on this machine, and the checks
//! on `OpenOptions`.

use optik::{BackendChoice, BackendKind, OpenOptions};

#[test]
fn auto_opens_what_auto_choice_names_and_never_a_software_device() {
    let pick = optik::auto_choice();
    let device = optik::open(BackendChoice::Auto).expect("the CPU backend always opens");
    assert_eq!(device.backend(), pick.kind(), "{}", pick.reason);
    let vulkan_gpu = optik::backends::vulkan::probe()
        .map(|ds| ds.iter().any(|d| d.is_gpu()))
        .unwrap_or(false);
    let wgpu_gpu = optik::backends::wgpu::probe().iter().any(|a| a.gpu);
    if !vulkan_gpu && !wgpu_gpu {
        // CI's machine: lavapipe and llvmpipe only, ~600x slower than the CPU backend.
        assert_eq!(device.backend(), BackendKind::Cpu, "{}", pick.reason);
        assert!(pick.reason.starts_with("no GPU found"), "{}", pick.reason);
    }
}

#[test]
fn thread_counts_are_bounded_before_any_thread_starts() {
    let max = optik::max_cpu_threads();
    for bad in [0, max + 1, 1_000_000] {
        let started = std::time::Instant::now();
        let e = optik::open_with(
            BackendChoice::Named(BackendKind::Cpu),
            &OpenOptions { threads: Some(bad) },
        )
        .err()
        .unwrap_or_else(|| panic!("{bad} threads were accepted"));
        assert_eq!(e.kind(), optik::ErrorKind::InvalidArgument, "{e}");
        assert!(
            e.message().contains(&format!(
                "{bad} CPU worker threads asked for; give 1 to {max}"
            )),
            "{e}"
        );
        assert!(started.elapsed().as_secs_f64() < 1.0, "rejected too slowly");
    }
    let two = optik::open_with(
        BackendChoice::Named(BackendKind::Cpu),
        &OpenOptions { threads: Some(2) },
    );
    assert!(two.is_ok(), "{:?}", two.err());
}

#[test]
fn threads_are_reported_as_ignored_by_gpu_backends() {
    let options = OpenOptions { threads: Some(4) };
    assert!(options.ignored_by(BackendKind::Cpu).is_empty());
    for kind in [BackendKind::Vulkan, BackendKind::Wgpu] {
        let ignored = options.ignored_by(kind);
        assert_eq!(ignored.len(), 1, "{ignored:?}");
        assert!(
            ignored[0].contains("thread count (4) is ignored") && ignored[0].contains(kind.name()),
            "{ignored:?}"
        );
    }
    assert!(
        OpenOptions::default()
            .ignored_by(BackendKind::Vulkan)
            .is_empty()
    );
}
