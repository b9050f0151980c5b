//! Stopping runaway programs: a WGSL program that never ends is stopped by a launch's
//! deadline, by a cancel token and by the process-wide interrupt (Ctrl-C in the `optik`
//! command), with a clear error; the device then runs the next launch normally.
//!
//! One test: the interrupt is process-wide, so nothing else may launch while it is set.

use optik_api::*;
use optik_cpu::{CpuBackend, CpuDevice};
use std::time::{Duration, Instant};

const RUNAWAY: &str = r#"
@group(0) @binding(0) var<uniform> params: vec4<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn spin(start: u32) -> u32 {
    var x = start;
    // Never ends while params.x is 0; the compiler cannot know.
    loop {
        x = x * 1664525u + 1013904223u;
        if params.x != 0u && x == params.y { break; }
    }
    return x;
}

fn raygen__main() {
    let i = rt_launch_index().x;
    if params.z != 0u {
        out[i] = i + 1u;
        return;
    }
    var n = 0u;
    while n < 2u {
        out[i] = spin(n);
        n += 0u;
    }
}
"#;

struct Runaway {
    dev: CpuDevice,
    pipeline: Pipeline,
    sbt: ShaderBindingTable,
    out: Buffer,
}

impl Runaway {
    fn new() -> Runaway {
        Runaway::of(2, "runaway.wgsl", RUNAWAY, 64)
    }

    /// A device of `threads` threads with a pipeline of `source`'s `raygen__main` alone and
    /// an output buffer of `out_words` words at binding 1.
    fn of(threads: usize, name: &str, source: &str, out_words: u64) -> Runaway {
        let dev = CpuBackend::with_threads(threads)
            .map(CpuDevice::new)
            .unwrap();
        let options = PipelineCompileOptions::default();
        let (module, _) = dev
            .create_module(
                &ModuleCompileOptions::default(),
                &options,
                &ProgramSource::new(name, source),
            )
            .unwrap();
        let groups = dev
            .create_program_groups(&[ProgramGroupDesc::Raygen(ProgramRef::new(
                module,
                "raygen__main",
            ))])
            .unwrap();
        let pipeline = dev
            .create_pipeline(&options, &PipelineLinkOptions::default(), &groups)
            .unwrap();
        let sbt_buffer = dev.create_buffer(32).unwrap();
        dev.write_buffer(
            sbt_buffer,
            0,
            &dev.sbt_record_pack_header(groups[0]).unwrap(),
        )
        .unwrap();
        let sbt = ShaderBindingTable {
            raygen: SbtRecord {
                buffer: sbt_buffer,
                offset: 0,
            },
            exception: None,
            miss: None,
            hitgroup: None,
            callables: None,
        };
        let out = dev.create_buffer(out_words * 4).unwrap();
        Runaway {
            dev,
            pipeline,
            sbt,
            out,
        }
    }

    /// Launches 64 invocations; `finite` makes the program end at once.
    fn launch(&self, finite: bool, options: &LaunchOptions) -> Result<()> {
        let params: [u32; 4] = [0, 0, finite as u32, 0];
        self.dev.launch_with(
            self.pipeline,
            bytemuck::cast_slice(&params),
            &[Resource::buffer(1, self.out)],
            &self.sbt,
            LaunchSize::new(64, 1, 1),
            options,
        )
    }

    /// A finite launch runs to the end: the device is usable.
    fn still_works(&self) {
        self.launch(true, &LaunchOptions::default()).unwrap();
        let mut bytes = vec![0u8; 64 * 4];
        self.dev.read_buffer(self.out, 0, &mut bytes).unwrap();
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        assert!(
            words.iter().enumerate().all(|(i, &w)| w == i as u32 + 1),
            "{words:?}"
        );
    }
}

/// Cancels `token` (or interrupts every launch) after `after`.
fn later(after: Duration, f: impl FnOnce() + Send + 'static) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        std::thread::sleep(after);
        f();
    })
}

#[test]
fn runaway_programs_stop_on_a_deadline_a_token_and_an_interrupt() {
    let _launches = crate::exclusive();
    let r = Runaway::new();

    let start = Instant::now();
    let e = r
        .launch(
            false,
            &LaunchOptions::with_timeout(Duration::from_millis(150)),
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::TimedOut, "{e}");
    assert!(e.message().contains("deadline"), "{e}");
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );
    r.still_works();

    let token = CancelToken::new();
    let canceller = later(Duration::from_millis(100), {
        let token = token.clone();
        move || token.cancel()
    });
    let e = r
        .launch(
            false,
            &LaunchOptions {
                deadline: None,
                cancel: Some(token.clone()),
            },
        )
        .unwrap_err();
    canceller.join().unwrap();
    assert_eq!(e.kind(), ErrorKind::Cancelled, "{e}");
    assert!(e.message().contains("cancelled"), "{e}");
    // A cancelled token stays cancelled: the next launch with it does not start.
    let e = r
        .launch(
            true,
            &LaunchOptions {
                deadline: None,
                cancel: Some(token),
            },
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Cancelled, "{e}");
    r.still_works();

    // Ctrl-C in the CLI: a plain launch, no options.
    let interrupter = later(Duration::from_millis(100), interrupt_launches);
    let e = r.launch(false, &LaunchOptions::default()).unwrap_err();
    interrupter.join().unwrap();
    assert_eq!(e.kind(), ErrorKind::Cancelled, "{e}");
    assert!(launches_interrupted());
    clear_interrupt();
    r.still_works();
}

/// A loop whose trip count is read at run time (so it is not unrolled): each iteration
/// runs the back-edge check.
const HOT_LOOP: &str = r#"
@group(0) @binding(0) var<uniform> params: vec4<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn raygen__main() {
    let i = rt_launch_index().x;
    var h = i;
    var acc = 0.0;
    for (var k = 0u; k < params.x; k++) {
        h = h * 747796405u + 2891336453u;
        acc = acc * 0.999 + f32(h >> 20u);
    }
    out[i % arrayLength(&out)] = h ^ bitcast<u32>(acc);
}
"#;

/// What the back-edge check costs in a tight loop: run once with and once without
/// `OPTIK_JIT_STOP_CHECKS=0` and compare the printed times.
#[test]
#[ignore = "a measurement, not a check: run with --ignored --nocapture, with and without OPTIK_JIT_STOP_CHECKS=0"]
fn back_edge_check_cost() {
    let _launches = crate::shared();
    let Runaway {
        dev,
        pipeline,
        sbt,
        out,
    } = Runaway::of(1, "hot.wgsl", HOT_LOOP, 1024);
    let params: [u32; 4] = [1000, 0, 0, 0];
    let mut best = f64::INFINITY;
    for _ in 0..15 {
        let t = Instant::now();
        dev.launch(
            pipeline,
            bytemuck::cast_slice(&params),
            &[Resource::buffer(1, out)],
            &sbt,
            LaunchSize::new(4096, 1, 1),
        )
        .unwrap();
        best = best.min(t.elapsed().as_secs_f64());
    }
    let checks = std::env::var("OPTIK_JIT_STOP_CHECKS").unwrap_or_default() != "0";
    println!(
        "back-edge checks {}: {:.3} ns per iteration (best of 15 launches of 4096 x 1000 iterations)",
        if checks { "on" } else { "off" },
        best * 1e9 / 4096e3
    );
}
