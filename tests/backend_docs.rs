//! The backend docs (docs/cpu-backend.md, wgpu-backend.md, vulkan-backend.md) in one section
//! order (DESIGN.md §1): each top-level section is `## N. <concept>…`, numbered from 1, and
//! the concepts come in the order of [`CONCEPTS`], so a reader finds a concept at the same
//! place in every backend's page. A backend may leave a concept out or give it several
//! sections in a row.

/// The concepts, in order; a section's title starts with one of the spellings of its concept.
const CONCEPTS: &[&[&str]] = &[
    &["Device"],
    &["Acceleration structures"],
    &["Pipelines"],
    &["Programs"],
    &["Traversal"],
    &["Exceptions"],
    &["The shader binding table"],
    &["Launches"],
    &["Specialisation"],
    &["Accuracy"],
    &["Errors"],
    &["Tests"],
    &["Performance"],
    &["Differences"],
    &["Environment"],
];

/// What is wrong with the section order of `text`, one line per problem.
fn order_problems(text: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let mut last = 0;
    for (k, title) in text
        .lines()
        .filter_map(|l| l.strip_prefix("## "))
        .enumerate()
    {
        let number = format!("{}. ", k + 1);
        let Some(rest) = title.strip_prefix(&number) else {
            problems.push(format!("`## {title}` should be numbered {}", k + 1));
            continue;
        };
        let Some(concept) = CONCEPTS
            .iter()
            .position(|spellings| spellings.iter().any(|s| rest.starts_with(s)))
        else {
            problems.push(format!("`## {title}` names no concept of the common order"));
            continue;
        };
        if concept < last {
            problems.push(format!(
                "`## {title}` comes after a section about {:?}",
                CONCEPTS[last][0]
            ));
        }
        last = concept;
    }
    problems
}

#[test]
fn backend_docs_share_one_section_order() {
    let root = env!("CARGO_MANIFEST_DIR");
    for doc in ["cpu-backend.md", "wgpu-backend.md", "vulkan-backend.md"] {
        let text = std::fs::read_to_string(format!("{root}/docs/{doc}"))
            .unwrap_or_else(|e| panic!("docs/{doc}: {e}"));
        assert_eq!(order_problems(&text), Vec::<String>::new(), "docs/{doc}");
    }
}

#[test]
fn the_order_check_catches_a_misplaced_or_unknown_section() {
    let good = "# t\n## 1. Device\n## 2. Traversal: a\n## 3. Traversal: b\n## 4. Tests\n";
    assert!(order_problems(good).is_empty());
    let swapped = "## 1. Traversal\n## 2. Programs\n";
    assert_eq!(order_problems(swapped).len(), 1);
    let unknown = "## 1. Device\n## 2. Miscellany\n";
    assert_eq!(order_problems(unknown).len(), 1);
    let misnumbered = "## 1. Device\n## 3. Tests\n";
    assert_eq!(order_problems(misnumbered).len(), 1);
}
