//! Reference estimates on disk and the artefacts written when a comparison fails.
//!
//! A reference `<scene>` in a folder is three files written by
//! `render/validation/make_references.py`: `<scene>_mean.exr` and `<scene>_var.exr` (RGB float
//! EXRs: the mean and the per-sample variance) and `<scene>.json` (`{"spp": N, ...}`, the
//! samples per pixel behind them).

use super::{Estimate, ValidateError, ZTestOutcome};
use exr::prelude::{self as x, WritableImage};
use std::path::{Path, PathBuf};

/// Reads the reference `<scene>` from `dir` (see the module documentation).
pub fn read_reference(dir: &Path, scene: &str) -> Result<Estimate, ValidateError> {
    let meta_path = dir.join(format!("{scene}.json"));
    let meta_text = std::fs::read_to_string(&meta_path)
        .map_err(|e| ValidateError(format!("cannot read {}: {e}", meta_path.display())))?;
    let meta: serde_json::Value = serde_json::from_str(&meta_text)
        .map_err(|e| ValidateError(format!("{}: not JSON: {e}", meta_path.display())))?;
    let samples = meta
        .get("spp")
        .and_then(serde_json::Value::as_u64)
        .and_then(|n| u32::try_from(n).ok())
        .filter(|n| *n > 0)
        .ok_or_else(|| {
            ValidateError(format!(
                "{}: expected a positive integer \"spp\" (the reference's samples per pixel)",
                meta_path.display()
            ))
        })?;
    let (w, h, mean) = read_rgb(&dir.join(format!("{scene}_mean.exr")))?;
    let (wv, hv, variance) = read_rgb(&dir.join(format!("{scene}_var.exr")))?;
    if (w, h) != (wv, hv) {
        return Err(ValidateError(format!(
            "reference {scene}: the mean is {w}×{h} but the variance {wv}×{hv}"
        )));
    }
    Estimate::new(w, h, mean, variance, samples)
}

/// Reads the R, G and B channels of a single-part EXR as interleaved floats, row 0 at the top.
pub fn read_rgb(path: &Path) -> Result<(u32, u32, Vec<f32>), ValidateError> {
    let image = x::read_all_flat_layers_from_file(path)
        .map_err(|e| ValidateError(format!("cannot read {}: {e}", path.display())))?;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| ValidateError(format!("{}: the file has no image part", path.display())))?;
    let (w, h) = (layer.size.0, layer.size.1);
    let channel = |name: &str| -> Result<Vec<f32>, ValidateError> {
        let found = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name);
        let c = found.ok_or_else(|| {
            let names: Vec<String> = layer
                .channel_data
                .list
                .iter()
                .map(|c| c.name.to_string())
                .collect();
            ValidateError(format!(
                "{}: expected an RGB image with channels R, G, B; it has {}",
                path.display(),
                names.join(", ")
            ))
        })?;
        Ok(c.sample_data.values_as_f32().collect())
    };
    let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
    let rgb = r
        .iter()
        .zip(&g)
        .zip(&b)
        .flat_map(|((r, g), b)| [*r, *g, *b])
        .collect();
    let width =
        u32::try_from(w).map_err(|_| ValidateError(format!("{}: too wide", path.display())))?;
    let height =
        u32::try_from(h).map_err(|_| ValidateError(format!("{}: too tall", path.display())))?;
    Ok((width, height, rgb))
}

/// Writes an interleaved RGB float image as an EXR with channels R, G, B.
pub fn write_rgb(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<(), ValidateError> {
    let size = (width as usize, height as usize);
    if rgb.len() != size.0 * size.1 * 3 {
        return Err(ValidateError(format!(
            "{}: a {width}×{height} RGB image needs {} values, got {}",
            path.display(),
            size.0 * size.1 * 3,
            rgb.len()
        )));
    }
    let at = |c: usize| move |p: x::Vec2<usize>| rgb[(p.y() * size.0 + p.x()) * 3 + c];
    let channels =
        x::SpecificChannels::rgb(move |p: x::Vec2<usize>| (at(0)(p), at(1)(p), at(2)(p)));
    x::Image::from_channels(size, channels)
        .write()
        .to_file(path)
        .map_err(|e| ValidateError(format!("cannot write {}: {e}", path.display())))
}

/// Writes what a failed comparison needs to be understood into `dir`: `<name>_optik.exr` and
/// `<name>_reference.exr` (the two means), `<name>_error_mask.exr` (1 where a pixel channel
/// failed), `<name>_p_values.exr`, and `<name>.txt` (the outcome). Returns the folder.
pub fn write_failure_artefacts(
    dir: &Path,
    name: &str,
    optik: &Estimate,
    reference: &Estimate,
    outcome: &ZTestOutcome,
) -> Result<PathBuf, ValidateError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| ValidateError(format!("cannot create {}: {e}", dir.display())))?;
    let (w, h) = (optik.width, optik.height);
    write_rgb(&dir.join(format!("{name}_optik.exr")), w, h, &optik.mean)?;
    write_rgb(
        &dir.join(format!("{name}_reference.exr")),
        w,
        h,
        &reference.mean,
    )?;
    let mask: Vec<f32> = outcome
        .p_values
        .iter()
        .map(|p| if *p <= outcome.alpha { 1.0 } else { 0.0 })
        .collect();
    write_rgb(&dir.join(format!("{name}_error_mask.exr")), w, h, &mask)?;
    let p: Vec<f32> = outcome.p_values.iter().map(|p| *p as f32).collect();
    write_rgb(&dir.join(format!("{name}_p_values.exr")), w, h, &p)?;
    let summary = format!(
        "{name}: {outcome}\noptik: {} spp, reference: {} spp\n",
        optik.samples, reference.samples
    );
    let text = dir.join(format!("{name}.txt"));
    std::fs::write(&text, summary)
        .map_err(|e| ValidateError(format!("cannot write {}: {e}", text.display())))?;
    Ok(dir.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::super::z_test;
    use super::*;

    fn temp_dir(tag: &str) -> PathBuf {
        std::env::temp_dir().join(format!("optik-validate-{tag}-{}", std::process::id()))
    }

    #[test]
    fn references_round_trip_through_exr_and_json() {
        let dir = temp_dir("ref");
        std::fs::create_dir_all(&dir).unwrap();
        let mean: Vec<f32> = (0..2 * 3 * 3).map(|i| i as f32 * 0.25).collect();
        let var: Vec<f32> = (0..2 * 3 * 3).map(|i| i as f32 * 0.5).collect();
        write_rgb(&dir.join("s_mean.exr"), 3, 2, &mean).unwrap();
        write_rgb(&dir.join("s_var.exr"), 3, 2, &var).unwrap();
        std::fs::write(
            dir.join("s.json"),
            r#"{"spp": 64, "variant": "scalar_rgb"}"#,
        )
        .unwrap();
        let e = read_reference(&dir, "s").unwrap();
        assert_eq!((e.width, e.height, e.samples), (3, 2, 64));
        assert_eq!(e.mean, mean);
        assert_eq!(e.variance, var);
        std::fs::write(dir.join("s.json"), r#"{"spp": 0}"#).unwrap();
        let err = read_reference(&dir, "s").unwrap_err();
        assert!(err.0.contains("positive integer \"spp\""), "{err}");
        let err = read_reference(&dir, "missing").unwrap_err();
        assert!(err.0.contains("missing.json"), "{err}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn every_validation_scene_has_a_sound_reference() {
        let validation = Path::new(env!("CARGO_MANIFEST_DIR")).join("validation");
        let mut scenes: Vec<String> = std::fs::read_dir(validation.join("scenes"))
            .unwrap()
            .filter_map(|e| {
                e.ok()?
                    .file_name()
                    .to_str()?
                    .strip_suffix(".xml")
                    .map(String::from)
            })
            .collect();
        scenes.sort();
        assert!(scenes.len() >= 11, "{scenes:?}");
        for scene in &scenes {
            let e = read_reference(&validation.join("references"), scene)
                .unwrap_or_else(|err| panic!("{scene}: {err}"));
            assert!(e.samples >= 1024, "{scene}: only {} spp", e.samples);
            assert!(
                e.mean.iter().all(|m| m.is_finite() && *m >= 0.0),
                "{scene}: bad mean"
            );
            assert!(
                e.variance.iter().all(|v| v.is_finite() && *v >= 0.0),
                "{scene}: bad variance"
            );
            // A reference with no light at all would make every comparison trivially pass.
            assert!(e.mean.iter().any(|m| *m > 0.01), "{scene}: black reference");
        }
    }

    #[test]
    fn failure_artefacts_hold_the_mask_and_p_values() {
        let dir = temp_dir("fail");
        let a = Estimate::new(2, 1, vec![1.0; 6], vec![0.01; 6], 100).unwrap();
        let mut b = a.clone();
        b.mean[4] = 2.0;
        let outcome = z_test(&a, &b).unwrap();
        assert!(!outcome.passed, "{outcome}");
        write_failure_artefacts(&dir, "t", &a, &b, &outcome).unwrap();
        let (w, h, mask) = read_rgb(&dir.join("t_error_mask.exr")).unwrap();
        assert_eq!((w, h), (2, 1));
        assert_eq!(mask, vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        let (_, _, p) = read_rgb(&dir.join("t_p_values.exr")).unwrap();
        assert_eq!(p[0], 1.0);
        assert!(p[4] < 1e-10, "{p:?}");
        let text = std::fs::read_to_string(dir.join("t.txt")).unwrap();
        assert!(
            text.contains("FAIL") && text.contains("channel G"),
            "{text}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
