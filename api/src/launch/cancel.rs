//! Stopping launches early: a deadline or a [`CancelToken`] in [`LaunchOptions`], and a
//! process-wide interrupt ([`interrupt_launches`], what the `optik` command's Ctrl-C calls).
//!
//! A backend turns its options into a [`LaunchWatch`] for the length of the launch. The
//! watch owns one flag word ([`LaunchWatch::flag`]) that the backend's workers poll: the CPU
//! backend's compiled programs read it at every loop back-edge, so a program stuck in an
//! infinite loop ends. What sets the flag:
//! - [`CancelToken::cancel`] and [`interrupt_launches`] set it on the calling thread, at once;
//! - a deadline is set by one watchdog thread per process, started on the first launch that
//!   has a deadline and asleep whenever no such launch runs.
//!
//! Flags are set, never polled, so launches without a deadline cost a lock and a list push.

use crate::{Error, ErrorKind, Result};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};

/// How one launch may be stopped before it finishes (OptiX has no such option; a GPU
/// driver's watchdog plays the part there).
#[derive(Clone, Debug, Default)]
pub struct LaunchOptions {
    /// Give up once this instant passes: the launch returns an [`ErrorKind::TimedOut`] error
    /// and what it wrote is incomplete.
    pub deadline: Option<Instant>,
    /// Give up when this token is cancelled: the launch returns an
    /// [`ErrorKind::Cancelled`] error.
    pub cancel: Option<CancelToken>,
}

impl LaunchOptions {
    /// Options that stop the launch `timeout` from now.
    pub fn with_timeout(timeout: Duration) -> LaunchOptions {
        LaunchOptions {
            deadline: Instant::now().checked_add(timeout),
            cancel: None,
        }
    }
}

/// Cancels the launches given it, from any thread. A token stays cancelled: make a new one
/// for the next launch.
#[derive(Clone, Debug, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    /// A token not yet cancelled.
    pub fn new() -> CancelToken {
        CancelToken::default()
    }

    /// Cancels every running and later launch given this token.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
        let reg = registry();
        for w in &reg.watches {
            if w.token.as_ref().is_some_and(|t| Arc::ptr_eq(&t.0, &self.0)) {
                w.stop(Stop::Cancelled);
            }
        }
    }

    /// Whether [`CancelToken::cancel`] was called.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}

/// Set by [`interrupt_launches`]; cleared by [`clear_interrupt`].
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Cancels every launch running in this process on every device, and every later one
/// until [`clear_interrupt`]: what a Ctrl-C handler calls. Each returns an
/// [`ErrorKind::Cancelled`] error.
pub fn interrupt_launches() {
    INTERRUPTED.store(true, Ordering::SeqCst);
    for w in &registry().watches {
        w.stop(Stop::Cancelled);
    }
}

/// Lets launches run again after [`interrupt_launches`].
pub fn clear_interrupt() {
    INTERRUPTED.store(false, Ordering::SeqCst);
}

/// Whether [`interrupt_launches`] was called (and not cleared since).
pub fn launches_interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Why a watch's flag was set; the flag word holds one of these (0: running).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
enum Stop {
    Cancelled = 1,
    TimedOut = 2,
}

/// What the registry keeps of a running launch.
/// The flag word on a cache line of its own: every worker reads it for every launch index,
/// so a write to a neighbouring allocation (the `Arc`'s counts, another thread's heap data)
/// must not move the line between cores.
#[derive(Debug, Default)]
#[repr(align(64))]
struct StopFlag(AtomicU32);

// The point of the type: a line of its own.
const _: () = assert!(std::mem::align_of::<StopFlag>() == 64);

impl std::ops::Deref for StopFlag {
    type Target = AtomicU32;
    fn deref(&self) -> &AtomicU32 {
        &self.0
    }
}

#[derive(Debug)]
struct Watched {
    flag: StopFlag,
    token: Option<CancelToken>,
    deadline: Option<Instant>,
}

impl Watched {
    /// Sets the flag unless an earlier reason did.
    fn stop(&self, why: Stop) {
        let _ = self
            .flag
            .compare_exchange(0, why as u32, Ordering::SeqCst, Ordering::SeqCst);
    }
}

/// Running launches, for the setters and the watchdog.
#[derive(Default)]
struct Registry {
    watches: Vec<Arc<Watched>>,
    watchdog: bool,
}

fn registry_cell() -> &'static (Mutex<Registry>, Condvar) {
    static CELL: OnceLock<(Mutex<Registry>, Condvar)> = OnceLock::new();
    CELL.get_or_init(Default::default)
}

fn registry() -> MutexGuard<'static, Registry> {
    // The registry holds no invariant a panic could break half-way.
    registry_cell().0.lock().unwrap_or_else(|e| e.into_inner())
}

/// Sets the flags of launches whose deadline passed; sleeps until the next deadline.
fn watchdog() {
    let (lock, wake) = registry_cell();
    let mut reg = lock.lock().unwrap_or_else(|e| e.into_inner());
    loop {
        let now = Instant::now();
        let mut next: Option<Instant> = None;
        for w in &reg.watches {
            if let Some(d) = w.deadline
                && w.flag.load(Ordering::SeqCst) == 0
            {
                if d <= now {
                    w.stop(Stop::TimedOut);
                } else {
                    next = Some(next.map_or(d, |n| n.min(d)));
                }
            }
        }
        reg = match next {
            Some(n) => {
                wake.wait_timeout(reg, n.saturating_duration_since(now))
                    .unwrap_or_else(|e| e.into_inner())
                    .0
            }
            None => wake.wait(reg).unwrap_or_else(|e| e.into_inner()),
        };
    }
}

/// One launch's stop flag, registered while it lives. Backends make one per launch
/// ([`LaunchWatch::new`]), poll [`LaunchWatch::flag`] (or [`LaunchWatch::stopped`]) while
/// they work and end with [`LaunchWatch::finish`].
#[derive(Debug)]
pub struct LaunchWatch {
    watched: Arc<Watched>,
    started: Instant,
}

impl LaunchWatch {
    /// Registers a launch with `options`. Fails when the launch is cancelled before it
    /// starts (a cancelled token, an interrupt, a deadline already past) or when the
    /// watchdog thread a deadline needs cannot start.
    pub fn new(options: &LaunchOptions) -> Result<LaunchWatch> {
        let watch = LaunchWatch {
            watched: Arc::new(Watched {
                flag: StopFlag::default(),
                token: options.cancel.clone(),
                deadline: options.deadline,
            }),
            started: Instant::now(),
        };
        {
            let mut reg = registry();
            if options.deadline.is_some() && !reg.watchdog {
                std::thread::Builder::new()
                    .name("optik launch watchdog".into())
                    .spawn(watchdog)
                    .map_err(|e| {
                        Error::backend(format!(
                            "cannot start the thread that enforces launch deadlines: {e}"
                        ))
                    })?;
                reg.watchdog = true;
            }
            reg.watches.push(watch.watched.clone());
            // Checked under the lock: a cancel or an interrupt from now on finds the watch.
            if launches_interrupted() || options.cancel.as_ref().is_some_and(|t| t.is_cancelled()) {
                watch.watched.stop(Stop::Cancelled);
            }
        }
        if options.deadline.is_some() {
            registry_cell().1.notify_all();
        }
        watch.check()?;
        Ok(watch)
    }

    /// The flag word: 0 while the launch may go on, non-zero once it must stop. Compiled
    /// code may read it with plain loads; only this module writes it.
    pub fn flag(&self) -> &AtomicU32 {
        &self.watched.flag
    }

    /// Whether the launch must stop.
    pub fn stopped(&self) -> bool {
        self.watched.flag.load(Ordering::Relaxed) != 0
    }

    /// The error for a stopped launch; `Ok` while it may go on.
    pub fn check(&self) -> Result<()> {
        match self.watched.flag.load(Ordering::SeqCst) {
            0 => Ok(()),
            r if r == Stop::TimedOut as u32 => Err(Error::new(
                ErrorKind::TimedOut,
                format!(
                    "the launch passed its deadline (LaunchOptions::deadline) after {:.3} s and was stopped; what it wrote is incomplete",
                    self.started.elapsed().as_secs_f64()
                ),
            )),
            _ => Err(Error::new(
                ErrorKind::Cancelled,
                format!(
                    "the launch was cancelled after {:.3} s (a CancelToken or an interrupt such as Ctrl-C); what it wrote is incomplete",
                    self.started.elapsed().as_secs_f64()
                ),
            )),
        }
    }

    /// Time left before the deadline (`None`: no deadline).
    pub fn remaining(&self) -> Option<Duration> {
        self.watched
            .deadline
            .map(|d| d.saturating_duration_since(Instant::now()))
    }

    /// Unregisters the launch and returns [`LaunchWatch::check`]'s verdict.
    pub fn finish(self) -> Result<()> {
        let verdict = self.check();
        drop(self);
        verdict
    }
}

impl Drop for LaunchWatch {
    fn drop(&mut self) {
        registry()
            .watches
            .retain(|w| !Arc::ptr_eq(w, &self.watched));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_deadline_sets_the_flag_and_reports_a_timeout() {
        let w = LaunchWatch::new(&LaunchOptions::with_timeout(Duration::from_millis(20))).unwrap();
        let start = Instant::now();
        while !w.stopped() {
            assert!(start.elapsed() < Duration::from_secs(10), "no timeout");
            std::thread::sleep(Duration::from_millis(1));
        }
        let e = w.finish().unwrap_err();
        assert_eq!(e.kind(), ErrorKind::TimedOut, "{e}");
        assert!(e.message().contains("deadline"), "{e}");
    }

    #[test]
    fn a_token_cancels_running_and_later_launches() {
        let token = CancelToken::new();
        let options = LaunchOptions {
            deadline: None,
            cancel: Some(token.clone()),
        };
        let w = LaunchWatch::new(&options).unwrap();
        let other = LaunchWatch::new(&LaunchOptions::default()).unwrap();
        assert!(!w.stopped());
        token.cancel();
        assert!(w.stopped());
        assert!(!other.stopped(), "another launch's token");
        assert_eq!(w.finish().unwrap_err().kind(), ErrorKind::Cancelled);
        let e = LaunchWatch::new(&options).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Cancelled, "{e}");
        assert!(other.finish().is_ok());
    }

    #[test]
    fn a_launch_that_ends_in_time_is_fine() {
        let w = LaunchWatch::new(&LaunchOptions::with_timeout(Duration::from_secs(60))).unwrap();
        assert!(w.remaining().is_some_and(|r| r > Duration::from_secs(1)));
        let flag = w.watched.clone();
        assert!(w.finish().is_ok());
        assert!(
            !registry().watches.iter().any(|x| Arc::ptr_eq(x, &flag)),
            "a finished launch leaves the registry"
        );
    }
}
