//! How optik's benchmarks time launches (DESIGN.md §8): one rule, used by the benchmark
//! report's ray caster (`optik::raycast`) and the wgpu backend's architecture bench.

use optik_api::Result;
use std::time::{Duration, Instant};

/// How long to launch untimed before timing: a GPU left idle drops its clocks and takes a
/// while of steady work to raise them. Between the benchmark report's measurements (host
/// work: building, uploading) the H200 idled at 345 of its 1980 MHz (nvidia-smi); launches
/// of Breakfast Room's incoherent rays then took ~10 ms for the first 120–190 ms of steady
/// work, ~6.8 ms (a middle clock) up to 320 ms, and 2.4 ms from there on. Timed cold, one
/// launch read 5–7× slow, and which of a report's rows came cold depended on what ran
/// before them. Twice the longest ramp seen.
pub const WARM_UP: Duration = Duration::from_millis(600);

/// Runs `launch` (a launch and its wait) until [`WARM_UP`] has passed, at least once.
pub fn warm_up(mut launch: impl FnMut() -> Result<()>) -> Result<()> {
    let start = Instant::now();
    loop {
        launch()?;
        if start.elapsed() >= WARM_UP {
            return Ok(());
        }
    }
}
