//! Every case on every backend, one test per case and backend, in libtest's output format.
//!
//! `<case>::oracle` checks the case itself (its WGSL compiles, every program has a model,
//! the oracle evaluates it and its expectation does not depend on traversal order);
//! `<case>::<backend>` runs it on the backend and judges the records against the oracle and
//! the blessed reference. A backend that cannot open here is reported as ignored with the
//! reason, never as passed. The backends run their cases side by side, each on as many threads
//! as [`threads_for`] gives it (each thread with a device of its own); lines are printed in
//! catalog order, then each thread's count of cases and seconds.
//!
//! Arguments: a substring filter (as libtest), `--list`, `--exact`; other flags are accepted
//! and ignored. `OPTIK_BACKENDS=cpu,vulkan` limits the backends opened (the others are
//! reported as ignored, with that reason).

use optik::BackendKind;
use optik_conformance::case::Case;
use optik_conformance::catalog;
use optik_conformance::runner::{self, Devices, Status};
use std::io::Write;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Cases a backend is known to fail, each with what is wrong: reported as ignored with the
/// reason (never as passed), and as a failure the day they pass, so the list cannot go stale.
/// Every entry is an open bug of that backend (issue 6 for Vulkan).
const KNOWN_FAILURES: &[(&str, &str, &str)] = &[];

/// Threads, each with a device of its own, that run a backend's cases. On a two-core machine
/// with lavapipe (CI), a cold run of all 380 tests took 614 s one case at a time, 432 s with
/// one thread a backend (the wgpu cases alone then taking all of it) and 338 s with these
/// (docs/cpu-backend.md, "the conformance cases side by side").
fn threads_for(kind: BackendKind) -> usize {
    match kind {
        // Its launches use every core.
        BackendKind::Cpu => 1,
        // Every device of the process shares one validated instance, whose debug messengers
        // each receive every device's messages: with two devices, one case's validation
        // message would also fail the case the other device was running.
        BackendKind::Vulkan => 1,
        // The slowest to compile (its megakernels); it reports no driver diagnostics.
        BackendKind::Wgpu => 2,
    }
}

/// What a backend's thread answers for a case: its result, or why there is none.
type CaseOutcome = Result<optik_conformance::runner::CaseResult, String>;

/// A backend's share of the cases, which each of its threads runs on a device of its own:
/// every thread takes the next case not taken until none is left, and sets its outcome.
struct CaseWork<'a, R: Fn(&Case, BackendKind) -> bool> {
    kind: BackendKind,
    plan: &'a [&'a Case],
    oracles: &'a [OnceLock<Oracle>],
    results: &'a [OnceLock<CaseOutcome>],
    next: &'a AtomicUsize,
    references: &'a runner::References,
    runs_on: &'a R,
}

impl<R: Fn(&Case, BackendKind) -> bool> CaseWork<'_, R> {
    /// Runs cases on `device` until none is left; answers how many it ran and in how many
    /// seconds.
    fn run(&self, device: &dyn optik::Device) -> (usize, f64) {
        let started = std::time::Instant::now();
        let mut ran = 0;
        loop {
            let i = self.next.fetch_add(1, Ordering::Relaxed);
            let Some(case) = self.plan.get(i) else { break };
            if !(self.runs_on)(case, self.kind) {
                continue;
            }
            let expected = &self.oracles[i].wait().expected;
            // (`run_on` catches the backend's panics; this catches the runner's own, so the
            // main thread, which waits for every case's outcome, always gets one.)
            let outcome = catch_unwind(AssertUnwindSafe(|| {
                runner::run_on(case, expected, self.kind, device, Some(self.references))
            }))
            .map_err(|_| format!("running {} on {} panicked", case.name, self.kind));
            let _ = self.results[i].set(outcome);
            ran += 1;
        }
        (ran, started.elapsed().as_secs_f64())
    }
}

/// Starts a thread of `kind`'s cases in `scope` (`None` when the system cannot start one).
fn spawn<'scope, F>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    kind: BackendKind,
    run: F,
) -> Option<std::thread::ScopedJoinHandle<'scope, (usize, f64)>>
where
    F: FnOnce() -> (usize, f64) + Send + 'scope,
{
    std::thread::Builder::new()
        .name(format!("cases-{}", kind.name()))
        // The main thread's stack size, where the cases ran one after another.
        .stack_size(8 << 20)
        .spawn_scoped(scope, run)
        .ok()
}

/// A case's oracle.
struct Oracle {
    /// What every backend's run is judged against.
    expected: Result<Vec<optik_conformance::oracle::Expectation>, String>,
    /// The oracle's own verdict on the case (structure and order independence).
    checked: Result<catalog::CaseStats, String>,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let list = args.iter().any(|a| a == "--list");
    let exact = args.iter().any(|a| a == "--exact");
    let filter = args.iter().find(|a| !a.starts_with('-')).cloned();
    let matches = |name: &str| match &filter {
        None => true,
        Some(f) if exact => name == f,
        Some(f) => name.contains(f.as_str()),
    };
    let cases = catalog::all();
    let backends = BackendKind::ALL;
    let mut names = Vec::new();
    for c in &cases {
        names.push(format!("{}::oracle", c.name));
        for b in backends {
            names.push(format!("{}::{}", c.name, b.name()));
        }
    }
    if list {
        for n in names.iter().filter(|n| matches(n)) {
            println!("{n}: test");
        }
        return;
    }
    let selected = names.iter().filter(|n| matches(n)).count();
    let filtered_out = names.len() - selected;
    println!("\nrunning {selected} tests");
    let any_backend = names.iter().any(|n| matches(n) && !n.ends_with("::oracle"));
    let chosen: Vec<BackendKind> = match std::env::var("OPTIK_BACKENDS") {
        Ok(list) => backends
            .into_iter()
            .filter(|b| list.split(',').any(|n| n.trim() == b.name()))
            .collect(),
        Err(_) => backends.to_vec(),
    };
    let devices = if any_backend {
        Devices::open(&chosen)
    } else {
        Devices::open(&[])
    };
    let references = runner::References::Embedded;
    let (mut passed, mut failed, mut ignored) = (0usize, 0usize, 0usize);
    let mut failures: Vec<(String, String)> = Vec::new();
    let start = std::time::Instant::now();
    // The cases to visit; each one's oracle (its verdict and the expectation every backend's
    // run is judged against) is computed on this thread while the backends' threads run the
    // cases before it.
    let runs_on =
        |case: &Case, kind: BackendKind| matches(&format!("{}::{}", case.name, kind.name()));
    let plan: Vec<&Case> = cases
        .iter()
        .filter(|case| {
            matches(&format!("{}::oracle", case.name)) || backends.iter().any(|b| runs_on(case, *b))
        })
        .collect();
    let oracles: Vec<OnceLock<Oracle>> = plan.iter().map(|_| OnceLock::new()).collect();
    // Each backend's results in catalog order, set by its threads as they finish a case.
    let results: Vec<Vec<OnceLock<CaseOutcome>>> = devices
        .iter()
        .map(|_| plan.iter().map(|_| OnceLock::new()).collect())
        .collect();
    // Each backend's next case not taken.
    let next_case: Vec<AtomicUsize> = devices.iter().map(|_| AtomicUsize::new(0)).collect();
    let works: Vec<CaseWork<_>> = devices
        .iter()
        .zip(results.iter().zip(&next_case))
        .map(|((kind, _), (results, next))| CaseWork {
            kind,
            plan: &plan,
            oracles: &oracles,
            results,
            next,
            references: &references,
            runs_on: &runs_on,
        })
        .collect();
    std::thread::scope(|scope| {
        // Each opened backend runs its cases on threads of its own (`threads_for`, each with a
        // device of its own) while the others run theirs: on lavapipe most of a cold run is
        // LLVM compiling pipelines, one core per pipeline. A thread takes the next case not
        // taken; results are printed in the catalog's order whatever the order they finish in.
        let threads: Vec<Vec<_>> = devices
            .iter()
            .zip(&works)
            .map(|((kind, device), work)| {
                let Ok(device) = device else {
                    return Vec::new();
                };
                let mut started: Vec<_> = spawn(scope, kind, move || work.run(device))
                    .into_iter()
                    .collect();
                // The other threads open their devices themselves (none where this backend
                // runs no case); one that cannot leaves the cases to the others.
                if plan.iter().any(|case| runs_on(case, kind)) {
                    for _ in 1..threads_for(kind) {
                        started.extend(spawn(scope, kind, move || {
                            match Devices::open(&[kind]).iter().next() {
                                Some((_, Ok(own))) => work.run(own),
                                _ => (0, 0.0),
                            }
                        }));
                    }
                }
                started
            })
            .collect();
        for (case, oracle) in plan.iter().zip(&oracles) {
            // Panics are caught (`expectations` catches the oracle's): every cell is set, so no
            // backend's thread waits forever.
            let expected = runner::expectations(case);
            let checked = catch_unwind(AssertUnwindSafe(|| {
                catalog::check_structure(case)
                    .and_then(|_| catalog::check_expectation(case, &expected))
            }))
            .unwrap_or_else(|_| Err(format!("{}: checking the case panicked", case.name)));
            let _ = oracle.set(Oracle { expected, checked });
        }
        for (i, (case, oracle)) in plan.iter().zip(&oracles).enumerate() {
            let oracle = oracle.wait();
            let oracle_name = format!("{}::oracle", case.name);
            if matches(&oracle_name) {
                match &oracle.checked {
                    Ok(stats) => {
                        println!(
                            "test {oracle_name} ... ok ({} records, {} ambiguous)",
                            stats.records, stats.ambiguous
                        );
                        passed += 1;
                    }
                    Err(e) => {
                        println!("test {oracle_name} ... FAILED");
                        failures.push((oracle_name.clone(), e.clone()));
                        failed += 1;
                    }
                }
                std::io::stdout().flush().ok();
            }
            for (((kind, device), results), threads) in devices.iter().zip(&results).zip(&threads) {
                let name = format!("{}::{}", case.name, kind.name());
                if !matches(&name) {
                    continue;
                }
                print!("test {name} ... ");
                std::io::stdout().flush().ok();
                if let Err(reason) = device {
                    println!("ignored, {kind} cannot run here: {reason}");
                    ignored += 1;
                    continue;
                }
                let outcome = if threads.is_empty() {
                    Err(format!(
                        "no thread could be started to run the {kind} backend's cases"
                    ))
                } else {
                    results[i].wait().as_ref().map_err(Clone::clone)
                };
                // (A result is checked to be this case's on this backend: a mix-up between the
                // threads' results would fail here, not pass as another case's verdict.)
                let r = match outcome.and_then(|r| {
                    if r.name == case.name && r.backend == kind {
                        Ok(r)
                    } else {
                        Err(format!(
                            "the result delivered was {}'s on {}",
                            r.name, r.backend
                        ))
                    }
                }) {
                    Ok(r) => r,
                    Err(why) => {
                        println!("FAILED");
                        failures.push((name, why));
                        failed += 1;
                        continue;
                    }
                };
                let known = KNOWN_FAILURES
                    .iter()
                    .find(|(c, b, _)| *c == case.name && *b == kind.name());
                match (r.status, known) {
                    (Status::Fail, Some((_, _, why))) => {
                        println!("ignored, known failure: {why}\n{}", r.detail);
                        ignored += 1;
                    }
                    (Status::Pass, Some(_)) => {
                        println!("FAILED");
                        failures.push((
                            name,
                            "listed in KNOWN_FAILURES but passes now: take it off the list".into(),
                        ));
                        failed += 1;
                    }
                    (Status::Pass, None) => {
                        println!("ok");
                        passed += 1;
                    }
                    (Status::Skip, _) => {
                        println!("ignored, {}", r.detail);
                        ignored += 1;
                    }
                    (Status::Fail, None) => {
                        println!("FAILED");
                        failures.push((name, r.detail.clone()));
                        failed += 1;
                    }
                }
            }
            // Backends not opened at all.
            for b in backends {
                let name = format!("{}::{}", case.name, b.name());
                if matches(&name) && !devices.iter().any(|(k, _)| k == b) {
                    println!("test {name} ... ignored, not selected by OPTIK_BACKENDS");
                    ignored += 1;
                }
            }
        }
        // Where the time went (a cold CI run's budget is mostly these threads'), after the
        // tests' lines so that no line of theirs is split.
        for (kind, threads) in devices.iter().map(|(k, _)| k).zip(threads) {
            for thread in threads {
                if let Ok((ran @ 1.., seconds)) = thread.join() {
                    let plural = if ran == 1 { "" } else { "s" };
                    println!("cases: a {kind} device ran {ran} case{plural} in {seconds:.1} s");
                }
            }
        }
    });
    if !failures.is_empty() {
        println!("\nfailures:\n");
        for (name, detail) in &failures {
            println!("---- {name} ----\n{detail}\n");
        }
        println!("failures:");
        for (name, _) in &failures {
            println!("    {name}");
        }
    }
    let verdict = if failed == 0 { "ok" } else { "FAILED" };
    println!(
        "\ntest result: {verdict}. {passed} passed; {failed} failed; {ignored} ignored; 0 measured; {filtered_out} filtered out; finished in {:.2}s\n",
        start.elapsed().as_secs_f64()
    );
    if failed > 0 {
        std::process::exit(101);
    }
}
