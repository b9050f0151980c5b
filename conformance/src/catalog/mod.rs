//! The catalog: every case, one module per group (the groups of [`crate::case::Group`], in
//! that order), and the checks every case must pass before it can judge a backend.

pub mod aabb;
pub mod ah;
pub mod r#as;
pub mod builtin;
pub mod call;
pub mod exc;
pub mod flags;
pub mod img;
pub mod inst;
pub mod launch;
pub mod motion;
pub mod numerics;
pub mod payload;
pub mod prim;
pub mod sbt;
pub mod trace;
pub mod tri;
pub mod util;

use crate::case::{Case, Group};
use crate::oracle;
use optik::{ProgramKind, ProgramSource};

/// A group module's `cases`: every case of the group, in catalog order.
pub type GroupCases = fn() -> Vec<Case>;

/// Each group with its module's `cases`, in [`Group::ALL`]'s order: the module of a group is
/// named after it (`catalog::tri` holds the `tri` group).
pub const GROUPS: [(Group, GroupCases); 17] = [
    (Group::Launch, launch::cases),
    (Group::Builtin, builtin::cases),
    (Group::Tri, tri::cases),
    (Group::Flags, flags::cases),
    (Group::Ah, ah::cases),
    (Group::Aabb, aabb::cases),
    (Group::Sbt, sbt::cases),
    (Group::Payload, payload::cases),
    (Group::Call, call::cases),
    (Group::Trace, trace::cases),
    (Group::Inst, inst::cases),
    (Group::Motion, motion::cases),
    (Group::Prim, prim::cases),
    (Group::As, r#as::cases),
    (Group::Exc, exc::cases),
    (Group::Img, img::cases),
    (Group::Numerics, numerics::cases),
];

/// Every case, in catalog order.
pub fn all() -> Vec<Case> {
    GROUPS.iter().flat_map(|(_, cases)| cases()).collect()
}

/// What [`check`] found out about a case.
#[derive(Clone, Debug, Default)]
pub struct CaseStats {
    /// Records over all launches.
    pub records: usize,
    /// Records the oracle finds ambiguous.
    pub ambiguous: usize,
}

/// Checks that a case is well formed and its expectation usable: [`check_structure`], then
/// the oracle (see [`check_expectation`]).
pub fn check(case: &Case) -> Result<CaseStats, String> {
    check_structure(case)?;
    check_expectation(case, &crate::runner::expectations(case))
}

/// Checks a case's structure: its name, that its WGSL compiles with optik's front end, that
/// every program it names exists with the right kind and has a model, and that its SBT
/// records name existing groups.
pub fn check_structure(case: &Case) -> Result<(), String> {
    let prefix = format!("{}.", case.group.name());
    if !case.name.starts_with(&prefix) {
        return Err(format!("{} is not named `{prefix}…`", case.name));
    }
    let p = &case.pipeline;
    let payload = p.compile.num_payload_values.or(32);
    let module = optik::frontend::compile(
        &ProgramSource::new(format!("{}.wgsl", case.name), p.wgsl.clone()),
        payload,
    )
    .map_err(|e| format!("{}: the WGSL does not compile: {e}", case.name))?;
    let mut named: Vec<(&str, ProgramKind)> = vec![(&p.raygen, ProgramKind::Raygen)];
    named.extend(
        p.miss
            .iter()
            .flatten()
            .map(|m| (m.as_str(), ProgramKind::Miss)),
    );
    for h in &p.hit {
        named.extend(
            h.closest_hit
                .iter()
                .map(|n| (n.as_str(), ProgramKind::ClosestHit)),
        );
        named.extend(h.any_hit.iter().map(|n| (n.as_str(), ProgramKind::AnyHit)));
        named.extend(
            h.intersection
                .iter()
                .map(|n| (n.as_str(), ProgramKind::Intersection)),
        );
    }
    for c in &p.callables {
        named.extend(
            c.direct
                .iter()
                .map(|n| (n.as_str(), ProgramKind::DirectCallable)),
        );
        named.extend(
            c.continuation
                .iter()
                .map(|n| (n.as_str(), ProgramKind::ContinuationCallable)),
        );
    }
    named.extend(
        p.exception
            .iter()
            .map(|n| (n.as_str(), ProgramKind::Exception)),
    );
    for (name, kind) in &named {
        let info = module
            .program(name)
            .ok_or_else(|| format!("{}: no program `{name}` in the WGSL", case.name))?;
        if info.kind != *kind {
            return Err(format!(
                "{}: `{name}` is a {} program, used as {}",
                case.name, info.kind, kind
            ));
        }
        if case.models.get(name).is_none() {
            return Err(format!("{}: `{name}` has no Rust model", case.name));
        }
    }
    let check_records = |region: &str, entries: &[crate::case::SbtEntry], groups: usize| {
        entries
            .iter()
            .find(|e| e.group >= groups)
            .map_or(Ok(()), |e| {
                Err(format!(
                    "{}: a {region} record names group {} of {groups}",
                    case.name, e.group
                ))
            })
    };
    check_records("miss", &case.sbt.miss, p.miss.len())?;
    check_records("hit", &case.sbt.hit, p.hit.len())?;
    check_records("callable", &case.sbt.callables, p.callables.len())?;
    Ok(())
}

/// Checks the oracle's expectation of a case: it evaluates, enumeration never stopped early,
/// and no record depends on the order candidates are visited in (which real traversals do
/// not fix; see [`oracle::expect`]).
pub fn check_expectation(
    case: &Case,
    expected: &Result<Vec<oracle::Expectation>, String>,
) -> Result<CaseStats, String> {
    let expected = expected
        .as_ref()
        .map_err(|e| format!("{}: oracle: {e}", case.name))?;
    let mut stats = CaseStats::default();
    for (k, e) in expected.iter().enumerate() {
        if let Some(i) = e.truncated.iter().position(|t| *t) {
            return Err(format!(
                "{}: launch {k}, record {i}: too many ambiguous outcomes to enumerate",
                case.name
            ));
        }
        stats.records += e.admissible.len();
        stats.ambiguous += e.ambiguous_count();
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names are unique and every case's WGSL, programs, models and SBT fit together (the
    /// oracle's part runs per case in `tests/cases.rs`).
    #[test]
    fn every_case_is_well_formed() {
        let cases = all();
        let mut names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
        names.sort();
        let before = names.len();
        names.dedup();
        assert_eq!(before, names.len(), "case names are unique");
        let problems: Vec<String> = cases
            .iter()
            .filter_map(|c| check_structure(c).err())
            .collect();
        assert!(problems.is_empty(), "{}", problems.join("\n"));
        let groups: std::collections::BTreeSet<_> = cases.iter().map(|c| c.group).collect();
        assert!(
            cases.len() >= 85 && groups.len() >= 11,
            "{} cases in {} groups",
            cases.len(),
            groups.len()
        );
        let numerics = cases
            .iter()
            .filter(|c| c.group == crate::case::Group::Numerics)
            .count();
        assert!(numerics >= 25, "{numerics} numerics cases");
    }

    /// One module per group, named after it, holding that group's cases and no other; no
    /// other files but this one and the shared `util`.
    #[test]
    fn each_group_has_its_own_file() {
        assert_eq!(GROUPS.map(|(g, _)| g), Group::ALL);
        for (group, cases) in GROUPS {
            let cases = cases();
            assert!(!cases.is_empty(), "{}: no cases", group.name());
            for c in &cases {
                assert_eq!(
                    c.group,
                    group,
                    "{} is in the file of `{}`",
                    c.name,
                    group.name()
                );
            }
        }
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/catalog");
        let mut files: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        files.sort();
        let mut expected: Vec<String> = Group::ALL
            .iter()
            .map(|g| format!("{}.rs", g.name()))
            .chain(["mod.rs".to_string(), "util.rs".to_string()])
            .collect();
        expected.sort();
        assert_eq!(files, expected);
    }

    /// Every rule of DESIGN.md §4 and §5 is guarded by at least one case.
    #[test]
    fn every_rule_has_a_case() {
        let cases = all();
        for rule in crate::case::Rule::ALL {
            assert!(
                cases.iter().any(|c| c.guards.contains(&rule)),
                "no case guards {rule:?}"
            );
        }
    }
}
