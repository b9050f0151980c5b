//! The comparator against OpenImageIO's `idiff` (installed at /usr/bin/idiff by the project's
//! setup): on crafted pairs, every finite pair gets the same verdict from both; pairs that
//! differ only by NaN pass idiff and fail our NaN/Inf gate. Both behaviours are asserted, so
//! a change in either shows up here.

use optik_conformance::compare::{IdiffOptions, Verdict, compare, idiff_compare};
use optik_conformance::exrio;
use optik_conformance::image::{Channel, ChannelKind, RecordImage};
use std::path::{Path, PathBuf};
use std::process::Command;

fn idiff_verdict(a: &Path, b: &Path, o: &IdiffOptions) -> Verdict {
    let out = Command::new("idiff")
        .args(o.idiff_args())
        .arg(a)
        .arg(b)
        .output()
        .expect("OpenImageIO's idiff must be installed (apt-get install openimageio-tools)");
    match out.status.code() {
        Some(0) => Verdict::Pass,
        Some(1) => Verdict::Warning,
        Some(2) => Verdict::Failure,
        Some(3) => Verdict::LayoutMismatch,
        other => panic!(
            "idiff exited with {other:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        ),
    }
}

fn floats(name: &str, w: usize, h: usize, f: impl Fn(usize) -> f32) -> Channel {
    Channel {
        name: name.into(),
        kind: ChannelKind::Float,
        values: (0..w * h).map(|i| f(i).to_bits()).collect(),
    }
}

fn uints(name: &str, w: usize, h: usize, f: impl Fn(usize) -> u32) -> Channel {
    Channel {
        name: name.into(),
        kind: ChannelKind::Uint,
        values: (0..w * h).map(f).collect(),
    }
}

fn rgba(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> RecordImage {
    RecordImage {
        width: w,
        height: h,
        channels: ["R", "G", "B", "A"]
            .iter()
            .enumerate()
            .map(|(c, n)| floats(n, w, h, |i| if c == 3 { 1.0 } else { f(i, c) }))
            .collect(),
    }
}

struct Pair {
    name: &'static str,
    a: RecordImage,
    b: RecordImage,
    options: IdiffOptions,
    /// What idiff must say.
    idiff: Verdict,
    /// What our comparator must say.
    ours: Verdict,
}

fn smooth(i: usize, c: usize) -> f32 {
    ((i * 7 + c * 13) % 97) as f32 / 97.0
}

fn pairs() -> Vec<Pair> {
    let (w, h) = (32, 16);
    let base = rgba(w, h, smooth);
    let with = |f: &dyn Fn(usize, usize, f32) -> f32| rgba(w, h, |i, c| f(i, c, smooth(i, c)));
    let det = IdiffOptions::I_DET;
    let mut v = vec![
        Pair {
            name: "identical",
            a: base.clone(),
            b: base.clone(),
            options: IdiffOptions::EXACT,
            idiff: Verdict::Pass,
            ours: Verdict::Pass,
        },
        Pair {
            name: "small noise under I-det",
            a: base.clone(),
            b: with(&|i, _, v| v + if i % 3 == 0 { 0.003 } else { -0.002 }),
            options: det,
            idiff: Verdict::Pass,
            ours: Verdict::Pass,
        },
        Pair {
            name: "one pixel over hardfail",
            a: base.clone(),
            b: with(&|i, c, v| if i == 77 && c == 1 { v + 0.05 } else { v }),
            options: det,
            idiff: Verdict::Failure,
            ours: Verdict::Failure,
        },
        Pair {
            name: "one pixel between fail and hardfail (within 0.02 %? no: 1/512 = 0.2 %)",
            a: base.clone(),
            b: with(&|i, c, v| if i == 5 && c == 0 { v + 0.006 } else { v }),
            options: det,
            idiff: Verdict::Failure,
            ours: Verdict::Failure,
        },
        Pair {
            name: "one pixel between fail and hardfail, 1 % allowed: warning",
            a: base.clone(),
            b: with(&|i, c, v| if i == 5 && c == 0 { v + 0.009 } else { v }),
            options: IdiffOptions {
                fail_percent: 1.0,
                ..det
            },
            idiff: Verdict::Warning,
            ours: Verdict::Warning,
        },
        Pair {
            name: "allowfailures beats hardfail",
            a: base.clone(),
            b: with(&|i, c, v| if i == 9 && c == 2 { v + 0.5 } else { v }),
            options: IdiffOptions {
                allow_failures: 1,
                ..det
            },
            idiff: Verdict::Pass,
            ours: Verdict::Pass,
        },
        Pair {
            name: "failrelative is an AND",
            a: rgba(w, h, |_, _| 0.5),
            b: rgba(w, h, |i, _| if i == 0 { 0.8 } else { 0.5 }),
            options: IdiffOptions {
                fail: 0.1,
                fail_relative: 0.5,
                ..IdiffOptions::IDIFF_DEFAULT
            },
            idiff: Verdict::Pass,
            ours: Verdict::Pass,
        },
        Pair {
            name: "failrelative exceeded",
            a: rgba(w, h, |_, _| 0.5),
            b: rgba(w, h, |i, _| if i == 0 { 0.8 } else { 0.5 }),
            options: IdiffOptions {
                fail: 0.1,
                fail_relative: 0.4,
                ..IdiffOptions::IDIFF_DEFAULT
            },
            idiff: Verdict::Failure,
            ours: Verdict::Failure,
        },
        Pair {
            name: "everything shifted by 0.01",
            a: base.clone(),
            b: with(&|_, _, v| v + 0.01),
            options: det,
            idiff: Verdict::Failure,
            ours: Verdict::Failure,
        },
        Pair {
            name: "size mismatch",
            a: base.clone(),
            b: rgba(w, h + 1, smooth),
            options: det,
            // idiff 2.4 compares over the union of the two data windows and fails; exit 3
            // is for channel-count mismatches only.
            idiff: Verdict::Failure,
            ours: Verdict::LayoutMismatch,
        },
        Pair {
            name: "NaN-only difference: idiff passes, the gate fails",
            a: base.clone(),
            b: with(&|i, c, v| if i == 100 && c == 0 { f32::NAN } else { v }),
            options: det,
            idiff: Verdict::Pass,
            ours: Verdict::Failure,
        },
        Pair {
            name: "NaN against NaN: idiff passes, the gate fails",
            a: with(&|i, c, v| if i == 3 && c == 2 { f32::NAN } else { v }),
            b: with(&|i, c, v| if i == 3 && c == 2 { f32::NAN } else { v }),
            options: IdiffOptions::EXACT,
            idiff: Verdict::Pass,
            ours: Verdict::Failure,
        },
        Pair {
            name: "NaN in every pixel of one channel: idiff passes, the gate fails",
            a: base.clone(),
            b: with(&|_, c, v| if c == 1 { f32::NAN } else { v }),
            options: IdiffOptions::EXACT,
            idiff: Verdict::Pass,
            ours: Verdict::Failure,
        },
    ];
    // Hit records: integer channels compared exactly.
    let rec = |prim: &dyn Fn(usize) -> u32, t: &dyn Fn(usize) -> f32| RecordImage {
        width: 16,
        height: 8,
        channels: vec![
            uints("hit", 16, 8, |i| (i % 5 != 0) as u32),
            uints("prim", 16, 8, prim),
            floats("t", 16, 8, t),
        ],
    };
    let r0 = rec(&|i| (i * 3 % 50) as u32, &|i| 1.0 + i as f32 * 0.25);
    v.push(Pair {
        name: "records: equal",
        a: r0.clone(),
        b: rec(&|i| (i * 3 % 50) as u32, &|i| 1.0 + i as f32 * 0.25),
        options: IdiffOptions::EXACT,
        idiff: Verdict::Pass,
        ours: Verdict::Pass,
    });
    v.push(Pair {
        name: "records: one primitive index off by one",
        a: r0.clone(),
        b: rec(&|i| (i * 3 % 50) as u32 + (i == 40) as u32, &|i| {
            1.0 + i as f32 * 0.25
        }),
        options: IdiffOptions::EXACT,
        idiff: Verdict::Failure,
        ours: Verdict::Failure,
    });
    v.push(Pair {
        name: "records: one t one ulp off",
        a: r0.clone(),
        b: rec(&|i| (i * 3 % 50) as u32, &|i| {
            let t = 1.0 + i as f32 * 0.25;
            if i == 7 {
                f32::from_bits(t.to_bits() + 1)
            } else {
                t
            }
        }),
        options: IdiffOptions::EXACT,
        idiff: Verdict::Failure,
        ours: Verdict::Failure,
    });
    v.push(Pair {
        name: "records: NaN t where the reference has a finite t",
        a: r0.clone(),
        b: rec(&|i| (i * 3 % 50) as u32, &|i| {
            if i == 9 {
                f32::NAN
            } else {
                1.0 + i as f32 * 0.25
            }
        }),
        options: IdiffOptions::EXACT,
        idiff: Verdict::Pass,
        ours: Verdict::Failure,
    });
    v
}

#[test]
fn comparator_agrees_with_idiff_on_crafted_pairs() {
    let dir: PathBuf = std::env::temp_dir().join(format!("optik-idiff-{}", std::process::id()));
    let mut problems = Vec::new();
    for (k, p) in pairs().into_iter().enumerate() {
        let (fa, fb) = (
            dir.join(format!("{k}-a.exr")),
            dir.join(format!("{k}-b.exr")),
        );
        exrio::write(&fa, &p.a).unwrap();
        exrio::write(&fb, &p.b).unwrap();
        // idiff's first argument is the output, the second the reference, as in `compare`.
        let theirs = idiff_verdict(&fb, &fa, &p.options);
        let ours = compare(&p.b, &p.a, &p.options).verdict;
        let idiff_model = match idiff_compare(&p.b, &p.a, &p.options).verdict {
            Verdict::LayoutMismatch if p.a.channels.len() == p.b.channels.len() => Verdict::Failure,
            v => v,
        };
        if theirs != p.idiff {
            problems.push(format!(
                "{}: idiff said {theirs:?}, expected {:?}",
                p.name, p.idiff
            ));
        }
        if ours != p.ours {
            problems.push(format!(
                "{}: our comparator said {ours:?}, expected {:?}",
                p.name, p.ours
            ));
        }
        if idiff_model != theirs {
            problems.push(format!(
                "{}: our model of idiff said {idiff_model:?}, idiff said {theirs:?}",
                p.name
            ));
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// idiff's thresholds for one tolerance class: the same acceptance as [`Tolerance::check`].
fn options_for(t: optik_conformance::tolerance::Tolerance) -> IdiffOptions {
    use optik_conformance::tolerance::{EPS, Tolerance};
    match t {
        Tolerance::Exact => IdiffOptions::EXACT,
        Tolerance::F6 => IdiffOptions::absolute(4.0 / 1_048_576.0),
        Tolerance::M3 => IdiffOptions::absolute(1e-3),
        Tolerance::Abs(x) => IdiffOptions::absolute(x),
        Tolerance::U16 { scale } => IdiffOptions {
            fail: 16.0 * EPS * scale,
            fail_relative: 16.0 * EPS,
            warn: 16.0 * EPS * scale,
            warn_relative: 16.0 * EPS,
            ..IdiffOptions::IDIFF_DEFAULT
        },
    }
}

/// The channels of `image` named in `names`.
fn subset(image: &RecordImage, names: &[String]) -> RecordImage {
    RecordImage {
        width: image.width,
        height: image.height,
        channels: image
            .channels
            .iter()
            .filter(|c| names.contains(&c.name))
            .cloned()
            .collect(),
    }
}

/// Hit records of real cases, perturbed at unambiguous records (a float within and beyond its
/// tolerance, an integer off by one), judged by our per-channel tolerance classes and by idiff
/// run per tolerance group (`U16` as `-fail 16ε·s -failrelative 16ε`): the verdicts agree.
/// Integer channels holding values of 2^24 or more are left out: OpenImageIO reads `UINT` as
/// normalised float and cannot tell such neighbours apart.
#[test]
fn case_records_agree_with_idiff() {
    use optik_conformance::case::Judgement;
    use optik_conformance::{catalog, judge, runner};
    let names = [
        "tri.t_plane",
        "tri.barycentrics",
        "tri.formats_indices",
        "builtin.ray_state_per_stage",
        "builtin.transforms",
        "aabb.attributes_max",
        "sbt.hit_index_grid",
        "numerics.huge_sphere_near",
        "numerics.shared_edge_far",
        "prim.spheres",
    ];
    let dir: PathBuf =
        std::env::temp_dir().join(format!("optik-idiff-cases-{}", std::process::id()));
    let mut problems = Vec::new();
    let (mut compared, mut failing, mut backend_outputs) = (0, 0, 0);
    let devices = runner::Devices::open(&optik::BackendKind::ALL);
    for case in catalog::all()
        .into_iter()
        .filter(|c| names.contains(&c.name.as_str()))
    {
        let Judgement::PerRecord = case.record.judgement else {
            continue;
        };
        let expected = runner::expectations(&case).unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let e = &expected[0];
        let reference = judge::canonical_image(&case, e);
        let clear: Vec<usize> = (0..e.admissible.len())
            .filter(|i| e.admissible[*i].len() == 1)
            .collect();
        // Tolerance groups, as idiff applies one threshold set per file.
        let mut groups: Vec<(optik_conformance::tolerance::Tolerance, Vec<String>)> = Vec::new();
        for c in &case.record.channels {
            let large = reference.channel(&c.name).is_some_and(|ch| {
                ch.kind == ChannelKind::Uint && ch.values.iter().any(|v| *v >= 1 << 24)
            });
            if large {
                continue;
            }
            match groups.iter_mut().find(|(t, _)| *t == c.tolerance) {
                Some((_, v)) => v.push(c.name.clone()),
                None => groups.push((c.tolerance, vec![c.name.clone()])),
            }
        }
        // Outputs to compare: the reference perturbed, and every available backend's output
        // (its ambiguous records copied into the reference, where any admissible answer is right).
        let mut outputs: Vec<(String, RecordImage, RecordImage)> = Vec::new();
        for (kind, device) in devices.iter() {
            let Ok(device) = device else { continue };
            let r = runner::run_on(&case, &Ok(expected.clone()), kind, device, None);
            if let Some(o) = r.launches.first().and_then(|l| l.output.clone()) {
                let mut masked = reference.clone();
                for (mc, oc) in masked.channels.iter_mut().zip(&o.channels) {
                    for i in 0..mc.values.len() {
                        if e.admissible[i].len() > 1 {
                            mc.values[i] = oc.values[i];
                        }
                    }
                }
                outputs.push((kind.name().to_string(), o, masked));
                backend_outputs += 1;
            }
        }
        for (tol, channels) in &groups {
            for (source, out, masked) in &outputs {
                let ours = channels.iter().all(|name| {
                    let spec = case
                        .record
                        .channels
                        .iter()
                        .find(|c| &c.name == name)
                        .expect("channel");
                    let (o, r) = (
                        out.channel(name).expect("o"),
                        masked.channel(name).expect("r"),
                    );
                    (0..o.values.len())
                        .all(|i| spec.tolerance.check(spec.kind, r.values[i], o.values[i]).0)
                });
                let (fo, fr) = (dir.join("out.exr"), dir.join("ref.exr"));
                exrio::write(&fo, &subset(out, channels)).unwrap();
                exrio::write(&fr, &subset(masked, channels)).unwrap();
                let theirs = idiff_verdict(&fo, &fr, &options_for(*tol)).passes();
                compared += 1;
                if ours != theirs {
                    problems.push(format!(
                        "{} on {source} {channels:?} ({}): ours {ours}, idiff {theirs}",
                        case.name,
                        tol.name()
                    ));
                }
            }
            for scenario in ["equal", "within", "beyond", "off_by_one"] {
                let mut out = reference.clone();
                let Some(&pixel) = clear.get(clear.len() / 3 + scenario.len()) else {
                    continue;
                };
                let Some(ch) = out.channels.iter_mut().find(|c| channels.contains(&c.name)) else {
                    continue;
                };
                let applies = match (scenario, ch.kind) {
                    ("equal", _) => true,
                    ("within" | "beyond", ChannelKind::Float) => {
                        let a = f32::from_bits(ch.values[pixel]) as f64;
                        let b = tol.bound(a, a);
                        if b == 0.0 && scenario == "within" {
                            false
                        } else {
                            let delta = if scenario == "within" {
                                0.5 * b
                            } else {
                                3.0 * b.max(1e-30) + (a.abs() * 1e-6)
                            };
                            ch.values[pixel] = ((a + delta) as f32).to_bits();
                            true
                        }
                    }
                    ("off_by_one", ChannelKind::Uint) => {
                        ch.values[pixel] = ch.values[pixel].wrapping_add(1);
                        true
                    }
                    _ => false,
                };
                if !applies {
                    continue;
                }
                let ours = channels.iter().all(|name| {
                    let spec = case
                        .record
                        .channels
                        .iter()
                        .find(|c| &c.name == name)
                        .expect("channel");
                    let (o, r) = (
                        out.channel(name).expect("o"),
                        reference.channel(name).expect("r"),
                    );
                    (0..o.values.len())
                        .all(|i| spec.tolerance.check(spec.kind, r.values[i], o.values[i]).0)
                });
                let (fo, fr) = (dir.join("out.exr"), dir.join("ref.exr"));
                exrio::write(&fo, &subset(&out, channels)).unwrap();
                exrio::write(&fr, &subset(&reference, channels)).unwrap();
                let theirs = idiff_verdict(&fo, &fr, &options_for(*tol)).passes();
                compared += 1;
                failing += usize::from(!ours);
                if ours != theirs {
                    problems.push(format!(
                        "{} {scenario} {channels:?} ({}): ours {ours}, idiff {theirs}",
                        case.name,
                        tol.name()
                    ));
                }
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    eprintln!(
        "{compared} comparisons, {failing} of them failing ones, {backend_outputs} backend outputs"
    );
    assert!(compared >= 30, "only {compared} comparisons ran");
    assert!(
        failing >= 10 && compared - failing >= 10,
        "{failing} failing of {compared}: both verdicts must be exercised"
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
