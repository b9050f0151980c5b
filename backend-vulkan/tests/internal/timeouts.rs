//! Launch deadlines on the GPU: a long (finite) program outlives its deadline, the launch
//! returns `ErrorKind::TimedOut` long before the program ends, and after the device is
//! dropped a new one in the same process runs launches normally. (lavapipe cannot abort a
//! running shader, so the program must end by itself: dropping the device waits for it.)

use crate::common::*;
use optik_api::*;
use std::time::{Duration, Instant};

/// `params.x` rounds of xorshift per launch index: as long as the test asks, and nothing a
/// compiler can fold.
const SPIN: &str = r#"
@group(0) @binding(0) var<uniform> params: vec4<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn raygen__rg() {
    var h = params.y + rt_launch_index().x;
    for (var i = 0u; i < params.x; i += 1u) {
        h ^= h << 13u;
        h ^= h >> 17u;
        h ^= h << 5u;
    }
    out[rt_launch_index().x] = h;
}
"#;

/// The host's answer for launch index `i`.
fn spin(rounds: u32, seed: u32, i: u32) -> u32 {
    let mut h = seed.wrapping_add(i);
    for _ in 0..rounds {
        h ^= h << 13;
        h ^= h >> 17;
        h ^= h << 5;
    }
    h
}

struct Spin {
    pipeline: Pipeline,
    sbt: ShaderBindingTable,
    out: Buffer,
}

const WIDTH: u32 = 4;

fn setup(dev: &TestDevice) -> Spin {
    let m = dev.module(SPIN);
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    Spin {
        pipeline: dev.pipeline(&[rg], 1),
        sbt: Table::new(rg).build(dev),
        out: dev.create_buffer(WIDTH as u64 * 4).unwrap(),
    }
}

fn launch(dev: &TestDevice, s: &Spin, rounds: u32, options: &LaunchOptions) -> Result<()> {
    let params: Vec<u8> = [rounds, 7, 0, 0]
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .collect();
    dev.launch_with(
        s.pipeline,
        &params,
        &[Resource::buffer(1, s.out)],
        &s.sbt,
        LaunchSize::new(WIDTH, 1, 1),
        options,
    )
}

#[test]
fn a_launch_past_its_deadline_times_out_and_a_new_device_works() {
    // Seconds of work on lavapipe (2.5 s on 2 cores); the deadline is 100 ms.
    let rounds = 150_000_000;
    let dev = device();
    let s = setup(&dev);
    let start = Instant::now();
    let e = launch(
        &dev,
        &s,
        rounds,
        &LaunchOptions::with_timeout(Duration::from_millis(100)),
    )
    .unwrap_err();
    let returned = start.elapsed();
    assert_eq!(e.kind(), ErrorKind::TimedOut, "{e}");
    assert!(e.message().contains("deadline"), "{e}");
    assert!(
        e.message().contains("stays usable") && e.message().contains("DeviceLost"),
        "the message says what became of the device and what to do: {e}"
    );
    // Dropping the device waits for the program to end.
    drop(dev);
    let ended = start.elapsed();
    eprintln!(
        "timed out after {:.3} s; the program ended after {:.3} s",
        returned.as_secs_f64(),
        ended.as_secs_f64()
    );
    assert!(
        returned < Duration::from_millis(600) && ended > returned * 2,
        "the launch returned after {returned:?}, its program ended after {ended:?}: the deadline did not cut the wait short"
    );

    let dev = device();
    let s = setup(&dev);
    launch(
        &dev,
        &s,
        1000,
        &LaunchOptions::with_timeout(Duration::from_secs(60)),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let expected: Vec<u32> = (0..WIDTH).map(|i| spin(1000, 7, i)).collect();
    assert_eq!(dev.read_u32(s.out), expected);
}

#[test]
fn a_cancelled_launch_returns_cancelled_and_the_device_goes_on() {
    let dev = device();
    let s = setup(&dev);
    let token = CancelToken::new();
    let canceller = {
        let token = token.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            token.cancel();
        })
    };
    let options = LaunchOptions {
        deadline: None,
        cancel: Some(token),
    };
    let start = Instant::now();
    let e = launch(&dev, &s, 100_000_000, &options).unwrap_err();
    let returned = start.elapsed();
    canceller.join().unwrap();
    assert_eq!(e.kind(), ErrorKind::Cancelled, "{e}");
    // The same device waits for the cancelled work, then runs the next launch.
    launch(&dev, &s, 10, &LaunchOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let expected: Vec<u32> = (0..WIDTH).map(|i| spin(10, 7, i)).collect();
    assert_eq!(dev.read_u32(s.out), expected);
    let ended = start.elapsed();
    assert!(
        ended > returned * 2,
        "cancelled after {returned:?}, the next launch ended after {ended:?}"
    );
}
