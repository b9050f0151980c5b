//! optik-fuzz: fuzzing on stable Rust, without coverage instrumentation.
//!
//! A [`Target`] is one small function from bytes to an [`Outcome`] plus seed inputs and a
//! dictionary of tokens. [`run`] feeds it a deterministic stream of mutated seeds: input
//! `i` of a run is a pure function of the run's seed and `i` ([`input`]), so any input can
//! be regenerated from its index (`optik-fuzz TARGET --start I --inputs 1 --save DIR`).
//! Each input runs under `catch_unwind`; a panic is a finding, saved with its index. A
//! watchdog thread ends the process when one input runs past the time limit (a hang),
//! after writing the input to disk. An abort (a stack overflow, an allocation failure)
//! ends the process by itself: rerun from the last progress line with `--save-each` to
//! capture the input.
//!
//! Findings become regression tests: put the input in `fuzz/regressions/<target>/`; the
//! `regressions` test replays every file there.

pub mod targets;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What one input did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The code under test accepted the input and went through every stage.
    Accepted,
    /// The input was rejected with an error (the expected answer to most mutated inputs).
    Rejected,
    /// Something that is not a crash but is wrong: an internal error for an input an
    /// earlier stage accepted. Counted and saved like a panic.
    Finding(String),
}

/// A fuzz target: one function over bytes with its starting inputs.
pub struct Target {
    /// The name on the command line and in `fuzz/regressions/`.
    pub name: &'static str,
    /// Starting inputs (mutations start from these).
    pub seeds: fn() -> Vec<Vec<u8>>,
    /// Tokens mutations insert (keywords, magic numbers).
    pub dictionary: &'static [&'static [u8]],
    /// Runs one input.
    pub run: fn(&[u8]) -> Outcome,
}

/// Settings of one run.
#[derive(Clone, Debug)]
pub struct Settings {
    /// The run's seed: with the index, it decides every input.
    pub seed: u64,
    /// The first input index.
    pub start: u64,
    /// How many inputs to run at most.
    pub inputs: u64,
    /// Stop after this long even if inputs remain.
    pub time: Option<Duration>,
    /// One input running longer than this is a hang: the input is saved and the process
    /// exits with status 3.
    pub per_input: Duration,
    /// Where findings are written (`<dir>/<target>-<index>.bin`); `None`: not written.
    pub save: Option<PathBuf>,
    /// Write each input to `<save>/<target>-current.bin` before running it (to capture the
    /// input of an abort; slow).
    pub save_each: bool,
    /// Print a progress line every this many inputs (0: never).
    pub progress: u64,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            seed: 1,
            start: 0,
            inputs: 1000,
            time: None,
            per_input: Duration::from_secs(10),
            save: None,
            save_each: false,
            progress: 0,
        }
    }
}

/// A panic or finding: the input's index, what happened and the input.
#[derive(Clone, Debug)]
pub struct Crash {
    /// The input index (regenerate it with [`input`]).
    pub index: u64,
    /// The panic message or the finding.
    pub message: String,
    /// The input.
    pub input: Vec<u8>,
}

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Inputs run.
    pub inputs: u64,
    /// Of those, accepted by every stage.
    pub accepted: u64,
    /// Of those, rejected with an error.
    pub rejected: u64,
    /// Panics and findings.
    pub crashes: Vec<Crash>,
    /// Wall time.
    pub seconds: f64,
    /// The slowest input's time.
    pub slowest_seconds: f64,
}

impl Report {
    /// The report as one JSON object.
    pub fn json(&self, target: &str) -> serde_json::Value {
        serde_json::json!({
            "target": target,
            "inputs": self.inputs,
            "accepted": self.accepted,
            "rejected": self.rejected,
            "crashes": self.crashes.len(),
            "seconds": self.seconds,
            "inputs_per_second": if self.seconds > 0.0 { self.inputs as f64 / self.seconds } else { 0.0 },
            "slowest_input_seconds": self.slowest_seconds,
        })
    }
}

/// SplitMix64: small, fast and good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A value in `0..n` (`n` > 0).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Input `index` of a run with `seed` over `seeds`: a seed (or, rarely, random bytes) with
/// one to eight mutations. Inputs are capped at 64 KiB.
pub fn input(seeds: &[Vec<u8>], dictionary: &[&[u8]], seed: u64, index: u64) -> Vec<u8> {
    const MAX: usize = 1 << 16;
    let mut rng = Rng(seed ^ index.wrapping_mul(0xD6E8_FEB8_6659_FD93));
    rng.next();
    // Inputs 0..seeds.len() of every run are the seeds themselves.
    if let Some(s) = usize::try_from(index).ok().and_then(|i| seeds.get(i)) {
        return s.clone();
    }
    if seeds.is_empty() || rng.below(32) == 0 {
        let n = rng.below(256);
        return (0..n).map(|_| rng.next() as u8).collect();
    }
    let mut data = seeds[rng.below(seeds.len())].clone();
    // Mostly one or two mutations: text formats break with every edit, and an input the
    // parser accepts reaches the deeper stages.
    let rounds = match rng.below(4) {
        0 | 1 => 1,
        2 => 2,
        _ => 1 + rng.below(8),
    };
    for _ in 0..rounds {
        let len = data.len();
        match rng.below(10) {
            0 if len > 0 => {
                let i = rng.below(len);
                data[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                data[i] = rng.next() as u8;
            }
            2 => {
                let i = rng.below(len + 1);
                let n = 1 + rng.below(8);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                data.splice(i..i, bytes);
            }
            3 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                data.drain(i..i + n);
            }
            4 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                let chunk = data[i..i + n].to_vec();
                let at = rng.below(len + 1);
                data.splice(at..at, chunk);
            }
            5 | 6 if !dictionary.is_empty() => {
                let token = dictionary[rng.below(dictionary.len())];
                let i = rng.below(len + 1);
                if rng.below(2) == 0 || len == 0 {
                    data.splice(i..i, token.iter().copied());
                } else {
                    let end = (i + token.len()).min(len);
                    data.splice(i..end, token.iter().copied());
                }
            }
            7 => {
                // Splice a piece of another seed in.
                let other = &seeds[rng.below(seeds.len())];
                if !other.is_empty() {
                    let i = rng.below(other.len());
                    let n = 1 + rng.below((other.len() - i).min(256));
                    let at = rng.below(len + 1);
                    data.splice(at..at, other[i..i + n].iter().copied());
                }
            }
            8 if len > 0 && rng.below(4) == 0 => {
                data.truncate(rng.below(len));
            }
            8 | 9 if len > 0 && rng.below(2) == 0 => {
                // Another digit near a random place: numbers change, the syntax survives.
                let from = rng.below(len);
                if let Some(i) = (from..len.min(from + 256)).find(|&i| data[i].is_ascii_digit()) {
                    data[i] = b'0' + rng.below(10) as u8;
                }
            }
            _ if len >= 4 => {
                // An interesting little-endian word (a count, an offset, a size).
                const WORDS: [u32; 8] = [0, 1, 3, 0xFF, 0xFFFF, 0x7FFF_FFFF, 0x8000_0000, u32::MAX];
                let i = rng.below(len - 3);
                let w = WORDS[rng.below(WORDS.len())].to_le_bytes();
                data[i..i + 4].copy_from_slice(&w);
            }
            _ => {}
        }
    }
    data.truncate(MAX);
    data
}

/// The message of a panic payload.
fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic with a non-string payload".into()
    }
}

fn save(dir: &Path, name: &str, bytes: &[u8]) {
    let _ = std::fs::create_dir_all(dir);
    let _ = std::fs::write(dir.join(name), bytes);
}

/// Runs `target` under `settings`.
pub fn run(target: &Target, settings: &Settings) -> Report {
    let seeds = (target.seeds)();
    // The watchdog reads what runs now: the start time (ms since `origin`, 0: idle) and
    // the input.
    let origin = Instant::now();
    let started = Arc::new(AtomicU64::new(0));
    let current: Arc<Mutex<(u64, Vec<u8>)>> = Arc::new(Mutex::new((0, Vec::new())));
    let done = Arc::new(AtomicU64::new(0));
    let watchdog = {
        let (started, current, done) = (started.clone(), current.clone(), done.clone());
        let limit = settings.per_input;
        let save_dir = settings.save.clone();
        let name = target.name;
        std::thread::spawn(move || {
            while done.load(Ordering::SeqCst) == 0 {
                std::thread::sleep(Duration::from_millis(50));
                let at = started.load(Ordering::SeqCst);
                if at == 0 {
                    continue;
                }
                let now = origin.elapsed().as_millis() as u64;
                if now.saturating_sub(at) > limit.as_millis() as u64 {
                    let (index, bytes) = current
                        .lock()
                        .map(|c| c.clone())
                        .unwrap_or_else(|e| e.into_inner().clone());
                    if let Some(dir) = &save_dir {
                        save(dir, &format!("{name}-{index}-hang.bin"), &bytes);
                    }
                    eprintln!(
                        "optik-fuzz: {name}: input {index} ran longer than {:.1} s: a hang",
                        limit.as_secs_f64()
                    );
                    std::process::exit(3);
                }
            }
        })
    };
    let mut report = Report::default();
    let t0 = Instant::now();
    for index in settings.start..settings.start.saturating_add(settings.inputs) {
        if settings.time.is_some_and(|t| t0.elapsed() >= t) {
            break;
        }
        let data = input(&seeds, target.dictionary, settings.seed, index);
        if let Ok(mut c) = current.lock() {
            c.0 = index;
            c.1.clone_from(&data);
        }
        if settings.save_each
            && let Some(dir) = &settings.save
        {
            save(dir, &format!("{}-current.bin", target.name), &data);
        }
        let one = Instant::now();
        started.store(origin.elapsed().as_millis() as u64 + 1, Ordering::SeqCst);
        let outcome = catch_unwind(AssertUnwindSafe(|| (target.run)(&data)));
        started.store(0, Ordering::SeqCst);
        report.slowest_seconds = report.slowest_seconds.max(one.elapsed().as_secs_f64());
        report.inputs += 1;
        let crash = match outcome {
            Ok(Outcome::Accepted) => {
                report.accepted += 1;
                None
            }
            Ok(Outcome::Rejected) => {
                report.rejected += 1;
                None
            }
            Ok(Outcome::Finding(m)) => Some(m),
            Err(p) => Some(format!("panic: {}", panic_message(p.as_ref()))),
        };
        if let Some(message) = crash {
            if let Some(dir) = &settings.save {
                save(dir, &format!("{}-{index}.bin", target.name), &data);
            }
            report.crashes.push(Crash {
                index,
                message,
                input: data,
            });
        }
        if settings.progress > 0 && report.inputs.is_multiple_of(settings.progress) {
            eprintln!(
                "optik-fuzz: {}: {} inputs (next index {}), {} accepted, {} crashes, {:.1} s",
                target.name,
                report.inputs,
                index + 1,
                report.accepted,
                report.crashes.len(),
                t0.elapsed().as_secs_f64()
            );
        }
    }
    report.seconds = t0.elapsed().as_secs_f64();
    done.store(1, Ordering::SeqCst);
    let _ = watchdog.join();
    report
}

/// The target named `name`.
pub fn target(name: &str) -> Option<&'static Target> {
    targets::ALL.iter().find(|t| t.name == name)
}
