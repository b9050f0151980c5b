//! The `--out` report: per case and backend the output, reference and difference images as
//! EXR and PNG, and an index.html table that shows them. Built here from real cases with
//! synthetic backend results (a pass, a failure with a difference image, a skip), since the
//! report must be right before any backend runs. Set `OPTIK_REPORT_DIR` to keep the folder.

use optik::BackendKind;
use optik_conformance::runner::{CaseResult, LaunchImages, Status};
use optik_conformance::{catalog, judge, report, runner};

#[test]
fn html_report_shows_outputs_references_and_differences() {
    let dir = std::env::var("OPTIK_REPORT_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|_| {
            std::env::temp_dir().join(format!("optik-report-{}", std::process::id()))
        });
    let mut results = Vec::new();
    for case in catalog::all().into_iter().filter(|c| {
        [
            "tri.t_plane",
            "tri.complex_mesh_hitrate",
            "img.course_scenes",
        ]
        .contains(&c.name.as_str())
    }) {
        let expected = runner::expectations(&case).unwrap();
        for (backend, status) in [
            (BackendKind::Cpu, Status::Pass),
            (BackendKind::Wgpu, Status::Fail),
            (BackendKind::Vulkan, Status::Skip),
        ] {
            let mut launches = Vec::new();
            let mut detail = String::from("no backend: skipped");
            let mut max_error = None;
            for (k, e) in expected.iter().enumerate() {
                let canonical = judge::canonical_image(&case, e);
                let (output, diff) = match status {
                    Status::Skip => (None, None),
                    _ => {
                        let mut out = canonical.clone();
                        if status == Status::Fail {
                            // Break every 7th record: its first channel off by one (or by 0.5).
                            let ch = &mut out.channels[0];
                            let float = ch.kind == optik_conformance::image::ChannelKind::Float;
                            for (i, v) in ch.values.iter_mut().enumerate() {
                                if i % 7 == 0 {
                                    *v = if float {
                                        (f32::from_bits(*v) + 0.5).to_bits()
                                    } else {
                                        *v ^ 1
                                    };
                                }
                            }
                        }
                        let v = judge::judge(&case, e, &out, None);
                        assert_eq!(
                            v.pass,
                            status == Status::Pass,
                            "{}: {}",
                            case.name,
                            v.detail
                        );
                        detail = v.detail.clone();
                        max_error = Some(v.max_error);
                        let diff = v
                            .pixel_state
                            .iter()
                            .any(|s| *s != 0)
                            .then(|| judge::difference_image(&v, e.width, e.height));
                        (Some(out), diff)
                    }
                };
                launches.push(LaunchImages {
                    stem: case.launch_stem(k),
                    expected: canonical.clone(),
                    output,
                    reference: Some(canonical),
                    diff,
                });
            }
            results.push(CaseResult {
                name: case.name.clone(),
                group: case.group.name().into(),
                backend,
                status,
                detail,
                max_error,
                launches,
            });
        }
    }
    report::write_out_dir(&dir, &results, &BackendKind::ALL).unwrap();
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    assert!(
        html.contains("FAIL") && html.contains("skip") && html.contains("pass"),
        "{html}"
    );
    for f in [
        "tri.t_plane/cpu.png",
        "tri.t_plane/wgpu.exr",
        "tri.t_plane/diff-wgpu.png",
        "tri.t_plane/reference.exr",
        "img.course_scenes/diff-wgpu.launch4.png",
    ] {
        assert!(dir.join(f).exists(), "{f} missing");
        assert!(
            html.contains(f.replace(".exr", ".png").as_str()) || f.ends_with(".exr"),
            "{f} not shown"
        );
    }
    assert!(
        !dir.join("tri.t_plane/diff-cpu.png").exists(),
        "no difference image for an exact pass"
    );
    let table = report::table(&results, &BackendKind::ALL);
    assert!(
        table.contains("FAIL") && table.contains("skipped:") && table.contains("failures:"),
        "{table}"
    );
    let json = report::json(&results);
    assert_eq!(json["failed"], 3);
    assert_eq!(json["skipped"], 3);
    if std::env::var("OPTIK_REPORT_DIR").is_err() {
        std::fs::remove_dir_all(&dir).ok();
    }
}
