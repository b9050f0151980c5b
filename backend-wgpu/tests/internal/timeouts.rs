//! Launch deadlines and cancellation on the GPU: a long (finite) program outlives its
//! deadline, the launch returns `ErrorKind::TimedOut` long before the program ends, and after
//! the device is dropped a new one in the same process runs launches normally. (lavapipe
//! cannot abort a running shader, so the program must end by itself.)

use crate::common::*;
use optik_api::*;
use std::time::{Duration, Instant};

/// `params.a` rounds of xorshift per launch index: as long as the test asks, and nothing a
/// compiler can fold.
const SPIN: &str = r#"
fn raygen__spin() {
    var h = params.b + rt_launch_index().x;
    for (var i = 0u; i < params.a; i += 1u) {
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

const WIDTH: u32 = 4;

struct Spin {
    dev: Box<dyn Device>,
    pipeline: Pipeline,
    table: ShaderBindingTable,
    out: Buffer,
}

impl Spin {
    fn new() -> Spin {
        let dev = device();
        let d = dev.as_ref();
        let m = module(d, &format!("{HEADER}{SPIN}"));
        let g = groups(d, &[raygen(m, "raygen__spin")]);
        let pipeline = pipeline(d, &g, 1);
        let table = sbt(d, &g, &[]);
        let out = d.create_buffer(WIDTH as u64 * 4).unwrap();
        Spin {
            dev,
            pipeline,
            table,
            out,
        }
    }

    fn launch(&self, rounds: u32, options: &LaunchOptions) -> Result<()> {
        self.dev.launch_with(
            self.pipeline,
            &params(TraversableHandle::NULL, &[rounds, 7]),
            &[Resource::buffer(1, self.out)],
            &self.table,
            LaunchSize::new(WIDTH, 1, 1),
            options,
        )
    }

    fn check(&self, rounds: u32) {
        let expected: Vec<u32> = (0..WIDTH).map(|i| spin(rounds, 7, i)).collect();
        assert_eq!(read::<u32>(self.dev.as_ref(), self.out), expected);
    }
}

#[test]
fn a_launch_past_its_deadline_times_out_and_a_new_device_works() {
    // Seconds of work on lavapipe (2.5 s on 2 cores); the deadline is 100 ms.
    let s = Spin::new();
    let start = Instant::now();
    let e = s
        .launch(
            150_000_000,
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
    // Waiting for the device shows how long the program ran on.
    s.dev.synchronize().unwrap();
    let ended = start.elapsed();
    drop(s);
    eprintln!(
        "timed out after {:.3} s; the program ended after {:.3} s",
        returned.as_secs_f64(),
        ended.as_secs_f64()
    );
    assert!(
        returned < Duration::from_millis(600) && ended > returned * 2,
        "the launch returned after {returned:?}, its program ended after {ended:?}: the deadline did not cut the wait short"
    );

    let s = Spin::new();
    s.launch(1000, &LaunchOptions::with_timeout(Duration::from_secs(60)))
        .unwrap_or_else(|e| panic!("{e}"));
    s.check(1000);
}

#[test]
fn a_cancelled_launch_returns_cancelled_and_the_device_goes_on() {
    let s = Spin::new();
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
    let e = s.launch(100_000_000, &options).unwrap_err();
    let returned = start.elapsed();
    canceller.join().unwrap();
    assert_eq!(e.kind(), ErrorKind::Cancelled, "{e}");
    // The same device waits for the cancelled work, then runs the next launch.
    s.launch(10, &LaunchOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    s.check(10);
    let ended = start.elapsed();
    assert!(
        ended > returned * 2,
        "cancelled after {returned:?}, the next launch ended after {ended:?}"
    );
}
