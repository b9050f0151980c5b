//! Golden tests: the SPIR-V each intrinsic lowers to, disassembled with `spirv-dis` and
//! pinned in `src/program/golden/`. They catch changes in naga's output shape that the
//! post-pass depends on (a naga upgrade may change it) and changes of the lowering itself. After an
//! intended change, bless with `OPTIK_BLESS=1 cargo test -p optik-vulkan --lib golden`.

use super::intrinsic::Intrinsic;
use super::tests::{EVERYTHING, largest_config, spirv_tool, user_roles};
use super::*;
use std::collections::HashMap;

/// `spirv-dis` of `words`.
fn disassemble(words: &[u32], what: &str) -> String {
    let out = spirv_tool("spirv-dis", &["--no-color"], words, what);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The function `name` of a disassembly, with the global lines (variables, pointer types,
/// decorations) of the ids it uses, and numeric ids renumbered in order of appearance.
fn function_golden(dis: &str, name: &str) -> Option<String> {
    let lines: Vec<&str> = dis.lines().map(str::trim).collect();
    let start = lines
        .iter()
        .position(|l| l.starts_with(&format!("%{name} = OpFunction ")))?;
    let end = start + lines[start..].iter().position(|l| *l == "OpFunctionEnd")?;
    let body = &lines[start..=end];
    let is_numeric =
        |t: &str| t.len() > 1 && t.starts_with('%') && t[1..].chars().all(|c| c.is_ascii_digit());
    let used: Vec<&str> = body
        .iter()
        .flat_map(|l| l.split_whitespace())
        .filter(|t| is_numeric(t))
        .collect();
    let mut globals = Vec::new();
    for l in &lines[..start] {
        let defines = l.split(" = ").next().filter(|d| used.contains(d)).is_some();
        let decorates = (l.starts_with("OpDecorate ") || l.starts_with("OpMemberDecorate "))
            && l.split_whitespace()
                .nth(1)
                .is_some_and(|t| used.contains(&t));
        if (defines
            && (l.contains("OpVariable")
                || l.contains("OpTypePointer")
                || l.contains("OpTypeStruct")
                || l.contains("OpTypeArray")))
            || decorates
        {
            globals.push(*l);
        }
    }
    let mut numbers: HashMap<String, usize> = HashMap::new();
    let mut out = String::new();
    for l in globals.iter().chain(body) {
        let renamed: Vec<String> = l
            .split_whitespace()
            .map(|t| {
                if is_numeric(t) {
                    let n = numbers.len();
                    format!("%id{}", numbers.entry(t.to_string()).or_insert(n))
                } else {
                    t.to_string()
                }
            })
            .collect();
        out.push_str(&without_numbered_names(&renamed.join(" ")));
        out.push('\n');
    }
    Some(out)
}

/// spirv-dis names unnamed structs `_struct_<id>`; the id is not stable.
fn without_numbered_names(line: &str) -> String {
    let mut out = String::new();
    let mut rest = line;
    while let Some(at) = rest.find("_struct_") {
        out.push_str(&rest[..at + "_struct_".len()]);
        rest = rest[at + "_struct_".len()..].trim_start_matches(|c: char| c.is_ascii_digit());
        out.push('#');
    }
    out.push_str(rest);
    out
}

#[test]
fn every_intrinsic_lowers_as_pinned() {
    let roles = user_roles(EVERYTHING);
    // The largest configuration, then the smallest for what it replaces (`_optik_ray_flags`
    // is only used when rays do not carry their flags in the state).
    let smallest = LoweringConfig {
        continuation_calls: true,
        ..LoweringConfig::default()
    };
    let mut dis: Vec<(String, VkStage, String)> = Vec::new();
    for config in [largest_config(), smallest] {
        for s in lower_stages(ModuleText::User(EVERYTHING), &config, &roles, None).unwrap() {
            dis.push((
                s.entry_name.clone(),
                s.stage,
                disassemble(&s.spirv, &s.entry_name),
            ));
        }
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/program/golden");
    let bless = std::env::var("OPTIK_BLESS").is_ok_and(|v| v == "1");
    let mut cases: Vec<(String, String)> = Vec::new();
    for i in Intrinsic::ALL {
        let found = dis.iter().find_map(|(_, stage, d)| {
            // Payload access is pinned in a hit stage; the callable variant separately.
            if matches!(i, Intrinsic::PayloadGet | Intrinsic::PayloadSet)
                && *stage == VkStage::Callable
            {
                return None;
            }
            function_golden(d, i.name())
        });
        cases.push((
            i.name().trim_start_matches('_').to_string(),
            found.unwrap_or_else(|| panic!("no stage lowers {}", i.name())),
        ));
    }
    let callable = dis
        .iter()
        .find(|(n, _, _)| n == "direct_callable__dc")
        .map(|(_, _, d)| d)
        .unwrap();
    cases.push((
        "optik_payload_get_callable".into(),
        function_golden(callable, "_optik_payload_get").unwrap(),
    ));
    let mut mismatches = Vec::new();
    for (name, text) in cases {
        let path = dir.join(format!("{name}.spvasm"));
        if bless {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, &text).unwrap();
            continue;
        }
        match std::fs::read_to_string(&path) {
            Ok(golden) if golden == text => {}
            Ok(golden) => mismatches.push(format!("{name}: expected\n{golden}\ngot\n{text}")),
            Err(_) => mismatches.push(format!(
                "{name}: no golden file {} (bless with OPTIK_BLESS=1)",
                path.display()
            )),
        }
    }
    assert!(
        mismatches.is_empty(),
        "lowering changed:\n{}",
        mismatches.join("\n")
    );
}
