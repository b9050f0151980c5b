//! Running cases on backends: opening devices, running each case, judging its launches
//! against the oracle and the references, and keeping the images for reports.

use crate::case::Case;
use crate::exrio;
use crate::image::RecordImage;
use crate::judge;
use crate::oracle::{self, Expectation};
use optik::{BackendKind, Device, ErrorKind};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

/// The outcome of a case on a backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Every launch matched.
    Pass,
    /// Something did not match, or the backend failed.
    Fail,
    /// The backend cannot run here, or does not support what the case needs.
    Skip,
}

impl Status {
    /// `pass`, `fail` or `skip`, as the JSON report spells them.
    pub fn name(self) -> &'static str {
        match self {
            Status::Pass => "pass",
            Status::Fail => "fail",
            Status::Skip => "skip",
        }
    }
}

/// The images of one launch, for reports.
#[derive(Clone, Debug)]
pub struct LaunchImages {
    /// The reference file stem (`tri.t_plane`, `launch.index_dims.launch3`).
    pub stem: String,
    /// The oracle's canonical image.
    pub expected: RecordImage,
    /// The backend's output.
    pub output: Option<RecordImage>,
    /// The reference, when one exists.
    pub reference: Option<RecordImage>,
    /// The difference image (see [`judge::difference_image`]).
    pub diff: Option<RecordImage>,
}

/// One case on one backend.
#[derive(Clone, Debug)]
pub struct CaseResult {
    /// Case name.
    pub name: String,
    /// Group name.
    pub group: String,
    /// Backend.
    pub backend: BackendKind,
    /// Outcome.
    pub status: Status,
    /// Why, or a short account.
    pub detail: String,
    /// Worst error against the tolerance (fraction of it), when it ran.
    pub max_error: Option<f64>,
    /// Images per launch.
    pub launches: Vec<LaunchImages>,
}

/// The source tree's folder of blessed references: where `bless` writes by default, and what
/// was embedded in this build ([`References::Embedded`]).
pub fn default_references_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("references")
}

/// The references embedded at build time: (file name, EXR bytes), sorted by name.
static EMBEDDED: &[(&str, &[u8])] = include!(concat!(env!("OUT_DIR"), "/references.rs"));

/// Where a run reads its references from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum References {
    /// The references compiled into this build, so a copied binary keeps them.
    Embedded,
    /// A folder of `<case>[.launchK][.backend].exr` files (`--references DIR`).
    Dir(PathBuf),
}

impl References {
    /// Where references come from, for messages.
    pub fn describe(&self) -> String {
        match self {
            References::Embedded => {
                format!("the {} references built into this binary", EMBEDDED.len())
            }
            References::Dir(dir) => dir.display().to_string(),
        }
    }

    /// The names of the references there, sorted.
    pub fn names(&self) -> Result<Vec<String>, String> {
        match self {
            References::Embedded => Ok(EMBEDDED.iter().map(|(n, _)| n.to_string()).collect()),
            References::Dir(dir) => {
                let entries = std::fs::read_dir(dir)
                    .map_err(|e| format!("cannot list {}: {e}", dir.display()))?;
                let mut names: Vec<String> = entries
                    .flatten()
                    .filter_map(|e| e.file_name().into_string().ok())
                    .filter(|n| n.ends_with(".exr"))
                    .collect();
                names.sort();
                Ok(names)
            }
        }
    }

    /// Whether a reference named `name` exists.
    fn has(&self, name: &str) -> bool {
        match self {
            References::Embedded => EMBEDDED.iter().any(|(n, _)| *n == name),
            References::Dir(dir) => dir.join(name).exists(),
        }
    }

    /// Reads the reference `name`: `Ok(None)` when there is none, `Err` when it exists but
    /// cannot be read or decoded.
    pub fn read(&self, name: &str) -> Result<Option<RecordImage>, String> {
        match self {
            References::Embedded => EMBEDDED
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(n, bytes)| exrio::read_bytes(bytes, &format!("the embedded reference {n}")))
                .transpose(),
            References::Dir(dir) => {
                let path = dir.join(name);
                if path.exists() {
                    exrio::read(&path).map(Some)
                } else {
                    Ok(None)
                }
            }
        }
    }

    /// The file name of launch `k`'s reference for `backend`: the backend's own file where the
    /// case allows one and it exists, else the common one.
    pub fn name_for(&self, case: &Case, k: usize, backend: Option<BackendKind>) -> String {
        let stem = case.launch_stem(k);
        if let Some(b) = backend.filter(|b| case.backend_specific.iter().any(|(kind, _)| kind == b))
        {
            let own = format!("{stem}.{}.exr", b.name());
            if self.has(&own) {
                return own;
            }
        }
        format!("{stem}.exr")
    }
}

/// A device, or why its backend cannot run here.
type Opened = Result<Box<dyn Device>, String>;

/// Devices opened at most once per backend.
pub struct Devices {
    opened: Vec<(BackendKind, Opened)>,
}

impl Devices {
    /// Opens each backend (a failure to open is kept as the reason to skip).
    pub fn open(kinds: &[BackendKind]) -> Self {
        let opened = kinds
            .iter()
            .map(|k| {
                let r = catch_unwind(|| optik::open_backend(*k))
                    .map_err(|_| format!("opening the {k} backend panicked"))
                    .and_then(|r| r.map_err(|e| e.message().to_string()));
                (*k, r)
            })
            .collect();
        Devices { opened }
    }

    /// The backends, with their device or the reason they cannot run.
    pub fn iter(&self) -> impl Iterator<Item = (BackendKind, Result<&dyn Device, &str>)> {
        self.opened
            .iter()
            .map(|(k, r)| (*k, r.as_ref().map(|d| d.as_ref()).map_err(|e| e.as_str())))
    }

    /// The backends that opened.
    pub fn available(&self) -> Vec<BackendKind> {
        self.opened
            .iter()
            .filter(|(_, r)| r.is_ok())
            .map(|(k, _)| *k)
            .collect()
    }
}

/// The oracle's expectation of a case (launch by launch).
pub fn expectations(case: &Case) -> Result<Vec<Expectation>, String> {
    catch_unwind(AssertUnwindSafe(|| oracle::expect(case)))
        .unwrap_or_else(|_| Err("the oracle panicked on this case".into()))
}

/// Runs one case on one device and judges it: against the oracle, and against `references`
/// unless it is `None` (blessing), where a missing or unreadable reference fails the case.
/// A driver diagnostic (a Vulkan validation message) during the case fails it, whatever its
/// records say.
pub fn run_on(
    case: &Case,
    expected: &Result<Vec<Expectation>, String>,
    backend: BackendKind,
    device: &dyn Device,
    references: Option<&References>,
) -> CaseResult {
    // Anything reported before the case belongs to whoever used the device before it.
    let earlier = device.take_diagnostics();
    let result = judged_run(case, expected, backend, device, references);
    let result = failed_by_diagnostics(result, &device.take_diagnostics());
    if !earlier.is_empty() {
        eprintln!(
            "note: {} driver diagnostic(s) were pending before {} on {}; the first: {}",
            earlier.len(),
            case.name,
            backend.name(),
            earlier[0]
        );
    }
    result
}

/// `result`, failed when the driver reported anything during the case (the messages lead
/// its detail).
fn failed_by_diagnostics(mut result: CaseResult, messages: &[String]) -> CaseResult {
    if messages.is_empty() {
        return result;
    }
    result.status = Status::Fail;
    let shown: Vec<&str> = messages.iter().take(3).map(String::as_str).collect();
    let more = if messages.len() > shown.len() {
        " | …"
    } else {
        ""
    };
    let then = if result.detail.is_empty() {
        String::new()
    } else {
        format!("; {}", result.detail)
    };
    result.detail = format!(
        "{} driver diagnostic(s) (validation layer) during the case: {}{more}{then}",
        messages.len(),
        shown.join(" | "),
    );
    result
}

fn judged_run(
    case: &Case,
    expected: &Result<Vec<Expectation>, String>,
    backend: BackendKind,
    device: &dyn Device,
    references: Option<&References>,
) -> CaseResult {
    let mut result = CaseResult {
        name: case.name.clone(),
        group: case.group.name().into(),
        backend,
        status: Status::Fail,
        detail: String::new(),
        max_error: None,
        launches: Vec::new(),
    };
    let expected = match expected {
        Ok(e) => e,
        Err(e) => {
            result.detail = format!("the oracle cannot evaluate this case: {e}");
            return result;
        }
    };
    let outputs = catch_unwind(AssertUnwindSafe(|| {
        crate::device_run::run_case(device, case)
    }));
    let outputs = match outputs {
        Err(_) => {
            result.detail = "the backend panicked".into();
            return result;
        }
        Ok(Err(e)) if e.kind() == ErrorKind::Unsupported => {
            result.status = Status::Skip;
            result.detail = e.message().to_string();
            return result;
        }
        Ok(Err(e)) => {
            result.detail = format!("error: {e}");
            return result;
        }
        Ok(Ok(o)) => o,
    };
    let mut pass = true;
    let mut details = Vec::new();
    let mut max_error: f64 = 0.0;
    for (k, (e, words)) in expected.iter().zip(&outputs).enumerate() {
        let output = judge::image_from_words(case, e.width, e.height, words);
        // Judged against the oracle always; against the reference unless blessing, where a
        // missing or unreadable reference is itself a failure.
        let (reference, reference_problem) = match references {
            None => (None, None),
            Some(refs) => {
                let name = refs.name_for(case, k, Some(backend));
                match refs.read(&name) {
                    Ok(Some(image)) => (Some(image), None),
                    Ok(None) => (
                        None,
                        Some(format!(
                            "no reference {name} in {} (`optik conformance bless` writes it)",
                            refs.describe()
                        )),
                    ),
                    Err(e) => (None, Some(format!("unreadable reference: {e}"))),
                }
            }
        };
        let v = judge::judge(case, e, &output, reference.as_ref());
        max_error = max_error.max(v.max_error);
        let launch = |text: &str| {
            if expected.len() > 1 {
                format!("launch {k}: {text}")
            } else {
                text.to_string()
            }
        };
        if !v.pass {
            pass = false;
            details.push(launch(&v.detail));
        }
        if let Some(problem) = reference_problem {
            pass = false;
            details.push(launch(&problem));
        }
        result.launches.push(LaunchImages {
            stem: case.launch_stem(k),
            expected: judge::canonical_image(case, e),
            diff: v
                .pixel_state
                .iter()
                .any(|s| *s != 0)
                .then(|| judge::difference_image(&v, e.width, e.height)),
            output: Some(output),
            reference,
        });
    }
    if outputs.len() != expected.len() {
        pass = false;
        details.push(format!(
            "{} launches ran, {} expected",
            outputs.len(),
            expected.len()
        ));
    }
    result.status = if pass { Status::Pass } else { Status::Fail };
    result.max_error = Some(max_error);
    result.detail = if pass {
        format!(
            "{} launch(es) match the oracle{}",
            outputs.len(),
            if references.is_some() {
                " and the references"
            } else {
                ""
            }
        )
    } else {
        details.join("; ")
    };
    result
}

/// Runs every case on every backend of `devices`.
pub fn run_all(
    cases: &[Case],
    devices: &Devices,
    references: Option<&References>,
    mut progress: impl FnMut(&CaseResult),
) -> Vec<CaseResult> {
    let mut results = Vec::new();
    for case in cases {
        let expected = expectations(case);
        for (backend, device) in devices.iter() {
            let r = match device {
                Ok(d) => run_on(case, &expected, backend, d, references),
                Err(reason) => CaseResult {
                    name: case.name.clone(),
                    group: case.group.name().into(),
                    backend,
                    status: Status::Skip,
                    detail: reason.to_string(),
                    max_error: None,
                    launches: expected
                        .as_ref()
                        .map(|es| {
                            es.iter()
                                .enumerate()
                                .map(|(k, e)| LaunchImages {
                                    stem: case.launch_stem(k),
                                    expected: judge::canonical_image(case, e),
                                    output: None,
                                    reference: references.and_then(|refs| {
                                        refs.read(&refs.name_for(case, k, None)).ok().flatten()
                                    }),
                                    diff: None,
                                })
                                .collect()
                        })
                        .unwrap_or_default(),
                },
            };
            progress(&r);
            results.push(r);
        }
    }
    results
}

/// Whether `name` matches a glob of `*` (any run) and `?` (one character). A pattern without
/// wildcards or dots names a group (`sbt` is `sbt.*`); several patterns may be given,
/// separated by commas.
pub fn filter_matches(filter: &str, name: &str) -> bool {
    filter
        .split(',')
        .map(str::trim)
        .filter(|p| !p.is_empty())
        .any(|p| {
            if !p.contains(['*', '?', '.']) {
                return glob(&format!("{p}.*"), name);
            }
            glob(p, name)
        })
}

fn glob(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    let (mut pi, mut ni) = (0, 0);
    let (mut star, mut mark) = (None, 0);
    while ni < n.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == n[ni]) {
            pi += 1;
            ni += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some(pi);
            mark = ni;
            pi += 1;
        } else if let Some(s) = star {
            pi = s + 1;
            mark += 1;
            ni = mark;
        } else {
            return false;
        }
    }
    while pi < p.len() && p[pi] == '*' {
        pi += 1;
    }
    pi == p.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(filter_matches("sbt.*", "sbt.hit_index_grid"));
        assert!(filter_matches("sbt", "sbt.hit_index_grid"));
        assert!(!filter_matches("sbt", "tri.t_plane"));
        assert!(filter_matches("*.closed_*", "tri.closed_fan"));
        assert!(filter_matches("tri.t_plane", "tri.t_plane"));
        assert!(!filter_matches("tri.t_plane", "tri.t_planes"));
        assert!(filter_matches("x.*, tri.?_plane", "tri.t_plane"));
        assert!(filter_matches("*", "anything.at_all"));
    }

    #[test]
    fn a_driver_diagnostic_fails_a_passing_case() {
        let passed = CaseResult {
            name: "tri.t_plane".into(),
            group: "tri".into(),
            backend: BackendKind::Vulkan,
            status: Status::Pass,
            detail: "1 launch(es) match the oracle and the references".into(),
            max_error: Some(0.0),
            launches: Vec::new(),
        };
        let quiet = failed_by_diagnostics(passed.clone(), &[]);
        assert_eq!(quiet.status, Status::Pass);
        let messages: Vec<String> = (0..5).map(|k| format!("VUID-{k}")).collect();
        let failed = failed_by_diagnostics(passed, &messages);
        assert_eq!(failed.status, Status::Fail);
        assert!(
            failed.detail.starts_with("5 driver diagnostic(s)")
                && failed.detail.contains("VUID-0 | VUID-1 | VUID-2 | …")
                && !failed.detail.contains("VUID-3"),
            "{}",
            failed.detail
        );
    }
}
