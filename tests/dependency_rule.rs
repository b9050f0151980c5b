//! The crate graph's dependency rule (DESIGN.md §1), read from `cargo metadata`:
//!
//! - `optik-api` at the bottom: it depends on no optik crate;
//! - `optik-accel` and `optik-core` on `optik-api` only;
//! - the backends (`optik-cpu`, `optik-wgpu`, `optik-vulkan`) on `optik-api`, `optik-accel`
//!   and `optik-core`, never on one another;
//! - the facade (`optik`) on the backends and below;
//! - `optik-conformance`, `optik-benches`, `optik-render` and `optik-io` on the facade or below;
//! - `optik-cli`, and the course examples (`optik-examples`) and fuzz targets (`optik-fuzz`)
//!   beside it, on top.
//!
//! Every kind of dependency counts (normal, build and dev): a test or example that pulls a
//! backend into another backend's build ties them together as much as code does. A new
//! optik crate fails the test until it is given a place here.

use std::collections::BTreeMap;
use std::process::Command;

/// The crates each layer may depend on, by layer; a crate's own layer is allowed only where
/// listed.
fn allowed(package: &str) -> Option<&'static [&'static str]> {
    const BOTTOM: &[&str] = &[];
    const SHARED: &[&str] = &["optik-api"];
    const BACKEND: &[&str] = &["optik-api", "optik-accel", "optik-core"];
    const FACADE: &[&str] = &[
        "optik-api",
        "optik-accel",
        "optik-core",
        "optik-cpu",
        "optik-wgpu",
        "optik-vulkan",
    ];
    const ON_FACADE: &[&str] = &[
        "optik-api",
        "optik-accel",
        "optik-core",
        "optik-cpu",
        "optik-wgpu",
        "optik-vulkan",
        "optik",
        // The renderer reads scenes through the scene IO crate.
        "optik-io",
    ];
    const TOP: &[&str] = &[
        "optik-api",
        "optik-accel",
        "optik-core",
        "optik-cpu",
        "optik-wgpu",
        "optik-vulkan",
        "optik",
        "optik-io",
        "optik-conformance",
        "optik-benches",
        "optik-render",
    ];
    Some(match package {
        "optik-api" => BOTTOM,
        "optik-accel" | "optik-core" => SHARED,
        "optik-cpu" | "optik-wgpu" | "optik-vulkan" => BACKEND,
        "optik" => FACADE,
        "optik-conformance" | "optik-benches" | "optik-render" | "optik-io" => ON_FACADE,
        "optik-cli" | "optik-examples" | "optik-fuzz" => TOP,
        _ => return None,
    })
}

/// Each workspace package's optik dependencies, as (dependency, kind).
fn workspace_graph() -> BTreeMap<String, Vec<(String, String)>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("metadata is JSON");
    let mut graph = BTreeMap::new();
    for p in meta["packages"].as_array().expect("packages") {
        let name = p["name"].as_str().expect("package name").to_string();
        let deps = p["dependencies"]
            .as_array()
            .expect("dependencies")
            .iter()
            .filter_map(|d| {
                let dep = d["name"].as_str()?;
                let is_optik = dep == "optik" || dep.starts_with("optik-");
                is_optik.then(|| {
                    (
                        dep.to_string(),
                        d["kind"].as_str().unwrap_or("normal").to_string(),
                    )
                })
            })
            .collect();
        graph.insert(name, deps);
    }
    graph
}

/// The rule's violations in `graph`, one line each.
fn violations(graph: &BTreeMap<String, Vec<(String, String)>>) -> Vec<String> {
    let mut bad = Vec::new();
    for (package, deps) in graph {
        let Some(ok) = allowed(package) else {
            bad.push(format!(
                "{package} has no place in the dependency rule (tests/dependency_rule.rs, DESIGN.md §1)"
            ));
            continue;
        };
        for (dep, kind) in deps {
            if !ok.contains(&dep.as_str()) {
                bad.push(format!(
                    "{package} depends on {dep} ({kind}), which the rule forbids; it may depend on {ok:?}"
                ));
            }
        }
    }
    bad
}

#[test]
fn the_crate_graph_follows_the_dependency_rule() {
    let graph = workspace_graph();
    for expected in [
        "optik-api",
        "optik-accel",
        "optik-cpu",
        "optik-wgpu",
        "optik-vulkan",
    ] {
        assert!(
            graph.contains_key(expected),
            "{expected} is a workspace member"
        );
    }
    let bad = violations(&graph);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn the_rule_catches_a_backend_on_a_backend_and_api_on_anything() {
    let graph = BTreeMap::from([
        (
            "optik-wgpu".to_string(),
            vec![("optik-cpu".to_string(), "normal".to_string())],
        ),
        (
            "optik-api".to_string(),
            vec![("optik-accel".to_string(), "dev".to_string())],
        ),
        (
            "optik-core".to_string(),
            vec![("optik-api".to_string(), "normal".to_string())],
        ),
        ("optik-newcomer".to_string(), Vec::new()),
    ]);
    let bad = violations(&graph);
    assert_eq!(bad.len(), 3, "{bad:#?}");
    assert!(bad[0].starts_with("optik-api depends on optik-accel (dev)"));
    assert!(bad[1].starts_with("optik-newcomer has no place"));
    assert!(bad[2].starts_with("optik-wgpu depends on optik-cpu (normal)"));
}
