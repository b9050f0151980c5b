//! Every case on every backend, one test per case and backend, in libtest's output format.
//!
//! `<case>::oracle` checks the case itself (its WGSL compiles, every program has a model,
//! the oracle evaluates it and its expectation does not depend on traversal order);
//! `<case>::<backend>` runs it on the backend and judges the records against the oracle and
//! the blessed reference. A backend that cannot open here is reported as ignored with the
//! reason, never as passed.
//!
//! Arguments: a substring filter (as libtest), `--list`, `--exact`; other flags are accepted
//! and ignored. `OPTIK_BACKENDS=cpu,vulkan` limits the backends opened (the others are
//! reported as ignored, with that reason).

use optik::BackendKind;
use optik_conformance::catalog;
use optik_conformance::runner::{self, Devices, Status};
use std::io::Write;

/// Cases a backend is known to fail, each with what is wrong: reported as ignored with the
/// reason (never as passed), and as a failure the day they pass, so the list cannot go stale.
/// Every entry is an open bug of that backend (issue 6 for Vulkan).
const KNOWN_FAILURES: &[(&str, &str, &str)] = &[];

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
    for case in &cases {
        let oracle_name = format!("{}::oracle", case.name);
        let wants_oracle = matches(&oracle_name);
        let wants_backend = backends
            .iter()
            .any(|b| matches(&format!("{}::{}", case.name, b.name())));
        if !wants_oracle && !wants_backend {
            continue;
        }
        // The structural and order-independence checks; their expectation serves the backends.
        let expected = runner::expectations(case);
        let checked = catalog::check_structure(case)
            .and_then(|_| catalog::check_expectation(case, &expected));
        if wants_oracle {
            print!("test {oracle_name} ... ");
            match &checked {
                Ok(stats) => {
                    println!(
                        "ok ({} records, {} ambiguous)",
                        stats.records, stats.ambiguous
                    );
                    passed += 1;
                }
                Err(e) => {
                    println!("FAILED");
                    failures.push((oracle_name.clone(), e.clone()));
                    failed += 1;
                }
            }
            std::io::stdout().flush().ok();
        }
        for (kind, device) in devices.iter() {
            let name = format!("{}::{}", case.name, kind.name());
            if !matches(&name) {
                continue;
            }
            print!("test {name} ... ");
            std::io::stdout().flush().ok();
            let device = match device {
                Ok(d) => d,
                Err(reason) => {
                    println!("ignored, {kind} cannot run here: {reason}");
                    ignored += 1;
                    continue;
                }
            };
            let r = runner::run_on(case, &expected, kind, device, Some(&references));
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
                    failures.push((name, r.detail));
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
