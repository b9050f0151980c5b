//! `optik render`'s modes on the shipped Cornell box (32×32) on the CPU backend: `--features`
//! prints the plan the library builds, `--benchmark` reports a ratio and agreeing images,
//! `--convergence` prints figures and writes a plot, `--denoise` names its denoiser, the
//! progress bar stays off when stderr is not a terminal, and the README documents every option.

use std::path::PathBuf;
use std::process::Command;

fn cbox() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../render/validation/scenes/cbox.xml")
        .to_string_lossy()
        .into_owned()
}

fn optik(args: &[&str], env: &[(&str, &str)]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_optik"))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("run optik");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn features_prints_the_plan_the_library_builds() {
    let (code, out, err) = optik(&["render", &cbox(), "--features", "--backend", "cpu"], &[]);
    assert_eq!(code, Some(0), "{err}");
    let scene = optik_render::scene::load(std::path::Path::new(&cbox()), &[]).unwrap();
    let plan = optik_render::PipelinePlan::new(&scene, false, optik_render::Effects::Scene);
    assert!(
        out.contains(&format!("programs: {}\n", plan.programs.join(", "))),
        "{out}"
    );
    assert!(out.contains(plan.describe().trim_end()), "{out}");
    assert!(
        out.contains("programs: raygen__path, miss__radiance, miss__shadow, closesthit__diffuse"),
        "{out}"
    );
    let compiled = out
        .lines()
        .find(|l| l.starts_with("compiled on cpu:"))
        .unwrap_or_else(|| panic!("no compiled line: {out}"));
    assert!(
        compiled.contains("triangles") && compiled.contains("single-gas"),
        "{compiled}"
    );
    // With --aovs the payload grows to hold albedo and normal.
    let (_, out, _) = optik(
        &[
            "render",
            &cbox(),
            "--features",
            "--aovs",
            "--backend",
            "cpu",
        ],
        &[],
    );
    assert!(out.contains("payload registers: 32"), "{out}");
}

#[test]
fn benchmark_reports_the_ratio_and_agreeing_images() {
    let (code, out, err) = optik(
        &[
            "render",
            &cbox(),
            "--benchmark",
            "--backend",
            "cpu",
            "--spp",
            "4",
            "--rounds",
            "2",
        ],
        &[],
    );
    assert_eq!(code, Some(0), "{err}");
    let line = out
        .lines()
        .find(|l| l.starts_with("cpu: all-effects / specialised time "))
        .unwrap_or_else(|| panic!("no ratio line: {out}"));
    let ratio: f64 = line
        .split_whitespace()
        .nth(5)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no ratio in `{line}`"));
    assert!(ratio > 0.0 && ratio.is_finite(), "{line}");
    assert!(line.contains("images agree: pass"), "{line}");
    assert!(out.contains("all-effects on cpu: raygen__path"), "{out}");
    for (args, says) in [
        (
            vec!["--benchmark", "--out", "x.png"],
            "--benchmark writes no image",
        ),
        (vec!["--benchmark", "--rounds", "0"], "--rounds 0"),
        (
            vec!["--benchmark", "--backend", "cpu,gpu"],
            "comma-separated list",
        ),
        (
            vec!["--backend", "cpu,wgpu", "--features"],
            "one backend renders",
        ),
    ] {
        let mut a = vec!["render", cbox().leak() as &str];
        a.extend(args.iter().copied());
        let (code, _, err) = optik(&a, &[]);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

#[test]
fn convergence_prints_figures_and_writes_the_plot() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("ref.exr");
    let plot = dir.path().join("plot.png");
    let (code, _, err) = optik(
        &[
            "render",
            &cbox(),
            "--out",
            &reference.to_string_lossy(),
            "--spp",
            "256",
            "--seed",
            "5",
            "--backend",
            "cpu",
        ],
        &[],
    );
    assert_eq!(code, Some(0), "{err}");
    let (code, out, err) = optik(
        &[
            "render",
            &cbox(),
            "--convergence",
            &reference.to_string_lossy(),
            "--out",
            &plot.to_string_lossy(),
            "--spp",
            "8",
            "--backend",
            "cpu",
        ],
        &[],
    );
    assert_eq!(code, Some(0), "{err}");
    // Four settings on the CPU (the driver's triangles are Vulkan's), four counts each.
    let rows: Vec<&str> = out.lines().filter(|l| l.starts_with("cpu ")).collect();
    assert_eq!(rows.len(), 16, "{out}");
    let first: Vec<&str> = rows[0].split_whitespace().collect();
    assert_eq!(first[1..3], ["watertight+conservative", "1"], "{out}");
    assert!(err.contains("does not run driver+conservative"), "{err}");
    assert!(
        out.contains("blue circles: cpu watertight+conservative"),
        "{out}"
    );
    assert!(std::fs::metadata(&plot).unwrap().len() > 1000);
    // A reference of another size is refused, naming both sizes.
    let (code, _, err) = optik(
        &[
            "render",
            &cbox(),
            "-D",
            "res=16",
            "--convergence",
            &reference.to_string_lossy(),
            "--backend",
            "cpu",
        ],
        &[],
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("the reference is 32x32, the scene's film 16x16"),
        "{err}"
    );
    let (code, _, err) = optik(&["render", &cbox(), "--convergence", "/no/such.exr"], &[]);
    assert_eq!(code, Some(2), "{err}");
}

#[test]
fn denoise_names_the_denoiser_and_progress_stays_quiet_off_a_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("d.exr");
    // No OIDN here (a library path that does not exist): the à-trous filter, with the reason.
    let (code, out, err) = optik(
        &[
            "render",
            &cbox(),
            "--out",
            &out_path.to_string_lossy(),
            "--spp",
            "2",
            "--denoise",
            "--backend",
            "cpu",
        ],
        &[("OPTIK_OIDN_LIB", "/nonexistent/libOpenImageDenoise.so")],
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("denoised with edge-aware à-trous filter"),
        "{out}"
    );
    assert!(out.contains("OIDN not used"), "{out}");
    assert!(out_path.exists());
    // stderr is a pipe here: no progress bar.
    assert!(!err.contains("spp,") && !err.contains("Mrays/s"), "{err}");
}

#[test]
fn the_readme_documents_every_render_option() {
    let (code, help, _) = optik(&["render", "--help"], &[]);
    assert_eq!(code, Some(0));
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md")).unwrap();
    let section = readme
        .split("### `optik render`")
        .nth(1)
        .and_then(|s| s.split("\n### ").next())
        .expect("README.md has an `optik render` section");
    let options = help
        .split("Options:")
        .nth(1)
        .unwrap_or_default()
        .split_whitespace()
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(|w| {
            w.trim_end_matches(|c: char| !c.is_alphanumeric())
                .to_string()
        })
        .filter(|w| w != "--help" && w != "--version");
    for option in options {
        assert!(
            section.contains(&option),
            "README.md's `optik render` section does not mention {option}"
        );
    }
}
