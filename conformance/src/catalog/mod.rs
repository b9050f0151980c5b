//! The catalog: every case, by group (research/conformance.md §6 and the numerics group),
//! and the checks every case must pass before it can judge a backend.

pub mod numerics;
pub mod tri;
pub mod util;

use crate::case::Case;
use crate::oracle::{self, exec::Order};
use optik::{ProgramKind, ProgramSource};

/// Every case, in catalog order.
pub fn all() -> Vec<Case> {
    let mut v = Vec::new();
    v.extend(tri::cases());
    v.extend(numerics::cases());
    v
}

/// What [`check`] found out about a case.
#[derive(Clone, Debug, Default)]
pub struct CaseStats {
    /// Records over all launches.
    pub records: usize,
    /// Records the oracle finds ambiguous.
    pub ambiguous: usize,
}

/// Checks that a case is well formed: its WGSL compiles with optik's front end, every program
/// it names exists with the right kind and has a model, every model is used, and the oracle
/// evaluates it without stopping enumeration early and without depending on the order in
/// which candidates are visited (which real traversals do not fix).
pub fn check(case: &Case) -> Result<CaseStats, String> {
    let prefix = format!("{}.", case.group.name());
    if !case.name.starts_with(&prefix) {
        return Err(format!("{} is not named `{prefix}…`", case.name));
    }
    let p = &case.pipeline;
    let payload = p.compile.num_payload_values.or(32);
    let module = optik::frontend::compile(&ProgramSource::new(format!("{}.wgsl", case.name), p.wgsl.clone()), payload)
        .map_err(|e| format!("{}: the WGSL does not compile: {e}", case.name))?;
    let mut named: Vec<(&str, ProgramKind)> = vec![(&p.raygen, ProgramKind::Raygen)];
    named.extend(p.miss.iter().flatten().map(|m| (m.as_str(), ProgramKind::Miss)));
    for h in &p.hit {
        named.extend(h.closest_hit.iter().map(|n| (n.as_str(), ProgramKind::ClosestHit)));
        named.extend(h.any_hit.iter().map(|n| (n.as_str(), ProgramKind::AnyHit)));
        named.extend(h.intersection.iter().map(|n| (n.as_str(), ProgramKind::Intersection)));
    }
    for c in &p.callables {
        named.extend(c.direct.iter().map(|n| (n.as_str(), ProgramKind::DirectCallable)));
        named.extend(c.continuation.iter().map(|n| (n.as_str(), ProgramKind::ContinuationCallable)));
    }
    named.extend(p.exception.iter().map(|n| (n.as_str(), ProgramKind::Exception)));
    for (name, kind) in &named {
        let info = module.program(name).ok_or_else(|| format!("{}: no program `{name}` in the WGSL", case.name))?;
        if info.kind != *kind {
            return Err(format!("{}: `{name}` is a {} program, used as {}", case.name, info.kind, kind));
        }
        if case.models.get(name).is_none() {
            return Err(format!("{}: `{name}` has no Rust model", case.name));
        }
    }
    let check_records = |region: &str, entries: &[crate::case::SbtEntry], groups: usize| {
        entries.iter().find(|e| e.group >= groups).map_or(Ok(()), |e| {
            Err(format!("{}: a {region} record names group {} of {groups}", case.name, e.group))
        })
    };
    check_records("miss", &case.sbt.miss, p.miss.len())?;
    check_records("hit", &case.sbt.hit, p.hit.len())?;
    check_records("callable", &case.sbt.callables, p.callables.len())?;
    let up = oracle::expect(case, Order::Ascending).map_err(|e| format!("{}: oracle: {e}", case.name))?;
    let down = oracle::expect(case, Order::Descending).map_err(|e| format!("{}: oracle: {e}", case.name))?;
    let mut stats = CaseStats::default();
    for (k, (a, b)) in up.iter().zip(&down).enumerate() {
        for i in 0..a.admissible.len() {
            if a.truncated[i] {
                return Err(format!("{}: launch {k}, record {i}: too many ambiguous outcomes to enumerate", case.name));
            }
            let (mut sa, mut sb) = (a.admissible[i].clone(), b.admissible[i].clone());
            sa.sort();
            sb.sort();
            if sa != sb {
                return Err(format!(
                    "{}: launch {k}, record {i} depends on the traversal order: nearest-first gives {:?}, farthest-first {:?}",
                    case.name, a.admissible[i], b.admissible[i]
                ));
            }
        }
        stats.records += a.admissible.len();
        stats.ambiguous += a.ambiguous_count();
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_case_is_well_formed() {
        let cases = all();
        let mut names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
        names.sort();
        let before = names.len();
        names.dedup();
        assert_eq!(before, names.len(), "case names are unique");
        let mut problems = Vec::new();
        for c in &cases {
            let start = std::time::Instant::now();
            match check(c) {
                Ok(s) => eprintln!(
                    "{:40} {:6} records, {:5} ambiguous, {:.1} s",
                    c.name,
                    s.records,
                    s.ambiguous,
                    start.elapsed().as_secs_f64()
                ),
                Err(e) => problems.push(e),
            }
        }
        assert!(problems.is_empty(), "{}", problems.join("\n"));
    }
}
