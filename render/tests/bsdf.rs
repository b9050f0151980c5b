//! optik's BSDFs against Mitsuba 3.9.1's, through `optik_render::probe` (the renderer's own WGSL
//! BSDF code):
//! - `eval` and `pdf` at the fixed random direction pairs of render/validation/bsdf/*.json
//!   (written by render/validation/make_bsdf_values.py with Mitsuba);
//! - a chi-square test of each BSDF's sampling routine, after Mitsuba's `mitsuba.chi2`: the
//!   sphere of directions is cut into bins, the histogram of sampled directions is compared with
//!   the expected counts from integrating optik's `pdf` over each bin; and each sample's weight
//!   must equal `eval / pdf` at the sampled direction.
//!
//! They run on the CPU backend: the probe compiles the same WGSL on every backend, and the image
//! tests (tests/mitsuba.rs) cover the BSDFs on the others.

use optik::BackendKind;
use optik_render::probe::{self, BsdfQuery};
use optik_render::scene::{Bsdf, Microfacet, Roughness, Texture};
use serde_json::Value;
use std::path::Path;

/// Every BSDF Mitsuba's values were written for (render/validation/bsdf/<name>.json).
const NAMES: [&str; 18] = [
    "diffuse",
    "twosided_diffuse",
    "roughconductor_beckmann",
    "roughconductor_ggx",
    "roughconductor_ggx_anisotropic",
    "roughconductor_beckmann_no_visible",
    "roughdielectric_beckmann",
    "roughdielectric_ggx",
    "plastic",
    "plastic_nonlinear",
    "roughplastic_beckmann",
    "roughplastic_ggx_nonlinear",
    "conductor_mirror",
    "conductor_au",
    "conductor_eta_k",
    "twosided_conductor",
    "dielectric",
    "thindielectric",
];

fn load(name: &str) -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("validation/bsdf/{name}.json"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn num(v: &Value, key: &str) -> f32 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("expected a number `{key}` in {v}")) as f32
}

fn rgb(v: &Value, key: &str) -> glam::Vec3 {
    let c = &v[key];
    assert_eq!(c["type"], "rgb", "expected an rgb `{key}` in {v}");
    let x = |i: usize| {
        c["value"][i]
            .as_f64()
            .unwrap_or_else(|| panic!("bad rgb {c}")) as f32
    };
    glam::Vec3::new(x(0), x(1), x(2))
}

fn tex(v: &Value, key: &str) -> Texture {
    Texture::Constant(rgb(v, key))
}

fn roughness(v: &Value) -> Roughness {
    let distribution = match v["distribution"].as_str() {
        Some("beckmann") => Microfacet::Beckmann,
        Some("ggx") => Microfacet::Ggx,
        other => panic!("unknown distribution {other:?}"),
    };
    let (alpha_u, alpha_v) = if v.get("alpha").is_some() {
        (num(v, "alpha"), num(v, "alpha"))
    } else {
        (num(v, "alpha_u"), num(v, "alpha_v"))
    };
    Roughness {
        distribution,
        alpha_u,
        alpha_v,
    }
}

fn flag(v: &Value, key: &str) -> bool {
    v[key]
        .as_bool()
        .unwrap_or_else(|| panic!("expected a boolean `{key}` in {v}"))
}

/// optik's BSDF for one of make_bsdf_values.py's dictionaries (every parameter given there).
fn bsdf(v: &Value) -> Bsdf {
    match v["type"].as_str() {
        Some("diffuse") => Bsdf::Diffuse {
            reflectance: tex(v, "reflectance"),
        },
        Some("twosided") => {
            let inner = Box::new(bsdf(&v["bsdf"]));
            Bsdf::TwoSided {
                front: inner.clone(),
                back: inner,
            }
        }
        Some("conductor") => {
            // Mitsuba's conductor: a named material, explicit eta and k, or the default mirror.
            let (eta, k) = match v["material"].as_str() {
                Some(m) => optik_render::scene::mitsuba::named_conductor(m)
                    .unwrap_or_else(|| panic!("unknown conductor {m}")),
                None if v.get("eta").is_some() => (rgb(v, "eta"), rgb(v, "k")),
                None => (glam::Vec3::ZERO, glam::Vec3::ONE),
            };
            let specular_reflectance = if v.get("specular_reflectance").is_some() {
                tex(v, "specular_reflectance")
            } else {
                Texture::Constant(glam::Vec3::ONE)
            };
            Bsdf::Conductor {
                eta,
                k,
                specular_reflectance,
            }
        }
        Some(kind @ ("dielectric" | "thindielectric")) => {
            let (int_ior, ext_ior) = (num(v, "int_ior"), num(v, "ext_ior"));
            let (specular_reflectance, specular_transmittance) = (
                tex(v, "specular_reflectance"),
                tex(v, "specular_transmittance"),
            );
            if kind == "dielectric" {
                Bsdf::Dielectric {
                    int_ior,
                    ext_ior,
                    specular_reflectance,
                    specular_transmittance,
                }
            } else {
                Bsdf::ThinDielectric {
                    int_ior,
                    ext_ior,
                    specular_reflectance,
                    specular_transmittance,
                }
            }
        }
        Some("roughconductor") => Bsdf::RoughConductor {
            eta: rgb(v, "eta"),
            k: rgb(v, "k"),
            roughness: roughness(v),
            specular_reflectance: tex(v, "specular_reflectance"),
            sample_visible: flag(v, "sample_visible"),
        },
        Some("roughdielectric") => Bsdf::RoughDielectric {
            int_ior: num(v, "int_ior"),
            ext_ior: num(v, "ext_ior"),
            roughness: roughness(v),
            specular_reflectance: tex(v, "specular_reflectance"),
            specular_transmittance: tex(v, "specular_transmittance"),
            sample_visible: flag(v, "sample_visible"),
        },
        Some("plastic") => Bsdf::Plastic {
            diffuse_reflectance: tex(v, "diffuse_reflectance"),
            specular_reflectance: tex(v, "specular_reflectance"),
            int_ior: num(v, "int_ior"),
            ext_ior: num(v, "ext_ior"),
            nonlinear: flag(v, "nonlinear"),
        },
        Some("roughplastic") => Bsdf::RoughPlastic {
            diffuse_reflectance: tex(v, "diffuse_reflectance"),
            specular_reflectance: tex(v, "specular_reflectance"),
            int_ior: num(v, "int_ior"),
            ext_ior: num(v, "ext_ior"),
            nonlinear: flag(v, "nonlinear"),
            roughness: roughness(v),
        },
        other => panic!("no optik BSDF for Mitsuba's {other:?}"),
    }
}

fn vec3(v: &Value) -> [f32; 3] {
    let x = |i: usize| v[i].as_f64().unwrap_or_else(|| panic!("bad vector {v}")) as f32;
    [x(0), x(1), x(2)]
}

fn cpu() -> Box<dyn optik::Device> {
    optik::open_backend(BackendKind::Cpu).unwrap_or_else(|e| panic!("CPU backend: {}", e.message()))
}

/// Whether `a` (optik) agrees with `b` (Mitsuba): both are float32 evaluations of the same
/// formulas, so they differ by rounding, which grows where the formulas divide by small cosines.
fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 2e-3 * a.abs().max(b.abs()) + 1e-5
}

/// `eval` and `pdf` of optik's BSDF `name` at Mitsuba's queries.
fn eval_and_pdf_match(name: &str) {
    let data = load(name);
    let b = bsdf(&data["bsdf"]);
    let queries: Vec<(BsdfQuery, [f32; 3], f32)> = data["queries"]
        .as_array()
        .unwrap_or_else(|| panic!("{name}: no queries"))
        .iter()
        .map(|q| {
            let query = BsdfQuery {
                wi: vec3(&q["wi"]),
                wo: vec3(&q["wo"]),
                uv: [0.5, 0.5],
            };
            (query, vec3(&q["eval"]), num(q, "pdf"))
        })
        .collect();
    let device = cpu();
    let asked: Vec<BsdfQuery> = queries.iter().map(|q| q.0).collect();
    let got = probe::bsdf(device.as_ref(), &b, &asked).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut wrong = Vec::new();
    for ((query, eval, pdf), value) in queries.iter().zip(&got) {
        let ok = (0..3).all(|c| close(value.value[c], eval[c])) && close(value.pdf, *pdf);
        if !ok {
            wrong.push(format!(
                "  wi {:?} wo {:?}: optik eval {:?} pdf {}, Mitsuba eval {eval:?} pdf {pdf}",
                query.wi, query.wo, value.value, value.pdf
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "{name}: {} of {} queries differ:\n{}",
        wrong.len(),
        got.len(),
        wrong.join("\n")
    );
}

macro_rules! eval_tests {
    ($($name:ident $(= $ignore:literal)?),* $(,)?) => {
        mod eval_pdf {
            $(
                $(#[ignore = $ignore])?
                #[test]
                fn $name() {
                    super::eval_and_pdf_match(stringify!($name));
                }
            )*
        }
    };
}

eval_tests!(
    diffuse,
    twosided_diffuse,
    roughconductor_beckmann,
    roughconductor_ggx,
    roughconductor_ggx_anisotropic,
    roughconductor_beckmann_no_visible,
    roughdielectric_beckmann,
    roughdielectric_ggx,
    plastic,
    plastic_nonlinear,
    roughplastic_beckmann,
    roughplastic_ggx_nonlinear,
    conductor_mirror,
    conductor_au,
    conductor_eta_k,
    twosided_conductor,
    dielectric,
    thindielectric,
);

/// Mitsuba's `sample` at the same incident directions and sample values: the sampled lobe, its
/// direction, probability (pdf), weight and relative index must agree. Samples on either side
/// of a lobe-selection threshold may land in different lobes through float rounding, and
/// Beckmann's visible-normal sampling inverts erf numerically (optik's erf/erfinv differ from
/// Dr.Jit's in the last bits), so up to `allowed_mismatches` samples may differ.
fn samples_match(name: &str, allowed_mismatches: usize) {
    let data = load(name);
    let b = bsdf(&data["bsdf"]);
    let device = cpu();
    let mut wrong = Vec::new();
    let samples = data["samples"]
        .as_array()
        .unwrap_or_else(|| panic!("{name}: no samples"));
    let items: Vec<([f32; 3], [f32; 3])> = samples
        .iter()
        .map(|s| (vec3(&s["wi"]), vec3(&s["u"])))
        .collect();
    let all = probe::bsdf_sample_each(device.as_ref(), &b, [0.5, 0.5], &items)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    for ((s, got), (wi, u)) in samples.iter().zip(all).zip(items) {
        let lobe = s["lobe"].as_str().unwrap_or("?");
        let weight = vec3(&s["weight"]);
        let ok = if lobe == "none" {
            got.weight.iter().all(|w| *w == 0.0) || got.pdf == 0.0
        } else {
            let wo = vec3(&s["wo"]);
            let same_lobe = match lobe {
                "delta" => got.delta && !got.null,
                "null" => got.delta && got.null,
                _ => !got.delta && !got.null,
            };
            same_lobe
                && (0..3).all(|c| (got.wo[c] - wo[c]).abs() <= 1e-3)
                && (0..3).all(|c| close(got.weight[c], weight[c]))
                && close(got.pdf, num(s, "pdf"))
                && close(got.eta, num(s, "eta"))
        };
        if !ok {
            wrong.push(format!(
                "  wi {wi:?} u {u:?}: optik {got:?}, Mitsuba lobe {lobe} wo {:?} weight {weight:?} \
                 pdf {} eta {}",
                vec3(&s["wo"]),
                num(s, "pdf"),
                num(s, "eta")
            ));
        }
    }
    assert!(
        wrong.len() <= allowed_mismatches,
        "{name}: {} of {} samples differ from Mitsuba's:\n{}",
        wrong.len(),
        samples.len(),
        wrong.join("\n")
    );
}

macro_rules! sample_tests {
    ($($name:ident $(= $allowed:literal)?),* $(,)?) => {
        mod sample {
            $(
                #[test]
                fn $name() {
                    super::samples_match(stringify!($name), 0 $(+ $allowed)?);
                }
            )*
        }
    };
}

sample_tests!(
    diffuse,
    twosided_diffuse,
    roughconductor_beckmann = 2,
    roughconductor_ggx,
    roughconductor_ggx_anisotropic,
    roughconductor_beckmann_no_visible,
    roughdielectric_beckmann = 2,
    roughdielectric_ggx,
    plastic,
    plastic_nonlinear,
    roughplastic_beckmann = 2,
    roughplastic_ggx_nonlinear,
    conductor_mirror,
    conductor_au,
    conductor_eta_k,
    twosided_conductor,
    dielectric,
    thindielectric,
);

/// The discrete lobes of a delta BSDF from `wi`: over many samples, each lobe is chosen with the
/// probability the sample reports (its `pdf`), within binomial noise, and every sample's
/// weight is its lobe's.
fn discrete_lobes_match(name: &str, wi: [f32; 3]) {
    let data = load(name);
    let b = bsdf(&data["bsdf"]);
    let device = cpu();
    let n = 20_000u32;
    let samples: Vec<[f32; 3]> = (0..n)
        .map(|i| [uniform(3 * i), uniform(3 * i + 1), uniform(3 * i + 2)])
        .collect();
    let drawn = probe::bsdf_sample(device.as_ref(), &b, wi, [0.5, 0.5], &samples)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    // Group by direction: each discrete lobe has one outgoing direction.
    let mut lobes: Vec<(probe::BsdfSampled, u32)> = Vec::new();
    for s in &drawn {
        assert!(s.delta, "{name}: a smooth sample {s:?} from a delta BSDF");
        match lobes
            .iter_mut()
            .find(|(l, _)| (0..3).all(|c| (l.wo[c] - s.wo[c]).abs() < 1e-6))
        {
            Some((l, count)) => {
                assert_eq!(
                    (l.weight, l.pdf, l.eta),
                    (s.weight, s.pdf, s.eta),
                    "{name}: two samples of one lobe differ"
                );
                *count += 1;
            }
            None => lobes.push((*s, 1)),
        }
    }
    let total: f32 = lobes.iter().map(|(l, _)| l.pdf).sum();
    assert!(
        (total - 1.0).abs() < 1e-5,
        "{name}: lobe probabilities sum to {total}"
    );
    for (l, count) in &lobes {
        let p = f64::from(l.pdf);
        let sd = (f64::from(n) * p * (1.0 - p)).sqrt().max(1.0);
        let z = (f64::from(*count) - f64::from(n) * p).abs() / sd;
        assert!(
            z < 4.5,
            "{name}: lobe {:?} chosen {count} times of {n}, expected {:.0} (z = {z:.1})",
            l.wo,
            f64::from(n) * p
        );
    }
}

#[test]
fn delta_lobes_are_chosen_with_their_probabilities() {
    for wi in [
        [0.1, 0.05, 1.0],
        [0.6, -0.3, 0.7],
        [0.95, 0.2, 0.12],
        [0.3, 0.2, -0.8],
    ] {
        let wi = normalized(wi);
        discrete_lobes_match("dielectric", wi);
        discrete_lobes_match("thindielectric", wi);
        discrete_lobes_match("twosided_conductor", wi);
        if wi[2] > 0.0 {
            discrete_lobes_match("conductor_au", wi);
        }
    }
}

#[test]
fn every_bsdf_file_has_a_test() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/bsdf");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| {
            e.ok()?
                .file_name()
                .to_str()?
                .strip_suffix(".json")
                .map(str::to_string)
        })
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = NAMES.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed);
}

// ---- chi-square test of sampling ----

/// Bins of the sphere: `THETA_BINS` in cos θ ∈ [-1, 1] (equal solid angle) × `PHI_BINS` in φ.
const THETA_BINS: usize = 20;
const PHI_BINS: usize = 40;
/// Sub-samples per bin side when integrating the pdf over a bin (midpoint rule).
const SUB: usize = 8;
/// Sub-samples per bin side where the pdf varies strongly inside a bin.
const FINE: usize = 48;
const SAMPLES: usize = 200_000;

fn bin_of(w: [f32; 3]) -> usize {
    let z = w[2].clamp(-1.0, 1.0);
    let t = (((z + 1.0) * 0.5 * THETA_BINS as f32) as usize).min(THETA_BINS - 1);
    let phi = w[1].atan2(w[0]).rem_euclid(std::f32::consts::TAU);
    let p = ((phi / std::f32::consts::TAU * PHI_BINS as f32) as usize).min(PHI_BINS - 1);
    t * PHI_BINS + p
}

/// The direction at fractional bin coordinates (`u` along cos θ, `v` along φ).
fn direction(u: f32, v: f32) -> [f32; 3] {
    let z = -1.0 + 2.0 * u / THETA_BINS as f32;
    let phi = v / PHI_BINS as f32 * std::f32::consts::TAU;
    let r = (1.0 - z * z).max(0.0).sqrt();
    [r * phi.cos(), r * phi.sin(), z]
}

/// A small counter-based generator (PCG hash) for sample values in [0, 1).
fn uniform(i: u32) -> f32 {
    let mut s = i.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    s = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277_803_737);
    s = (s >> 22) ^ s;
    (s >> 8) as f32 / (1u32 << 24) as f32
}

/// Upper tail of the chi-square distribution with `dof` degrees of freedom at `x`, by the
/// Wilson–Hilferty normal approximation (accurate to a few per cent of the tail probability for
/// the hundreds of degrees of freedom here, far finer than the 1e-3 level it is compared with).
fn chi2_upper_tail(x: f64, dof: f64) -> f64 {
    let k = 2.0 / (9.0 * dof);
    let z = ((x / dof).powf(1.0 / 3.0) - (1.0 - k)) / k.sqrt();
    0.5 * libm::erfc(z / std::f64::consts::SQRT_2)
}

/// Samples `name` from `wi`, compares the histogram with the integrated pdf, and checks the
/// sample weights against eval / pdf.
fn sampling_matches(name: &str, wi: [f32; 3]) {
    let data = load(name);
    let b = bsdf(&data["bsdf"]);
    let device = cpu();
    let dev = device.as_ref();
    let samples: Vec<[f32; 3]> = (0..SAMPLES as u32)
        .map(|i| [uniform(3 * i), uniform(3 * i + 1), uniform(3 * i + 2)])
        .collect();
    let drawn = probe::bsdf_sample(dev, &b, wi, [0.5, 0.5], &samples)
        .unwrap_or_else(|e| panic!("{name}: sampling: {e}"));
    let mut observed = vec![0.0f64; THETA_BINS * PHI_BINS];
    let mut smooth = Vec::new();
    for s in &drawn {
        // As Mitsuba's chi2 BSDFAdapter: samples of zero weight (e.g. a refraction that the
        // microfacet sends back to the incident side) do not count; pdf() excludes them too.
        if s.pdf > 0.0 && !s.delta && s.weight.iter().any(|w| *w != 0.0) {
            observed[bin_of(s.wo)] += 1.0;
            smooth.push(*s);
        }
    }
    // The expected histogram: the pdf integrated over each bin (each bin's solid angle is
    // 4π / bins, split into SUB × SUB equal parts), then again with FINE × FINE parts where the
    // pdf varies strongly inside a bin (narrow lobes, such as refraction through a smooth
    // interface; Mitsuba's chi2 integrates adaptively for the same reason).
    let integrate = |bins: &[usize], sub: usize| -> Vec<(f64, f64)> {
        let mut queries = Vec::with_capacity(bins.len() * sub * sub);
        for &bin in bins {
            let (t, p) = (bin / PHI_BINS, bin % PHI_BINS);
            for i in 0..sub {
                for j in 0..sub {
                    let u = t as f32 + (i as f32 + 0.5) / sub as f32;
                    let v = p as f32 + (j as f32 + 0.5) / sub as f32;
                    queries.push(BsdfQuery {
                        wi,
                        wo: direction(u, v),
                        uv: [0.5, 0.5],
                    });
                }
            }
        }
        let pdfs = probe::bsdf(dev, &b, &queries).unwrap_or_else(|e| panic!("{name}: pdf: {e}"));
        let part = 4.0 * std::f64::consts::PI / (THETA_BINS * PHI_BINS * sub * sub) as f64;
        pdfs.chunks_exact(sub * sub)
            .map(|c| {
                let sum = c.iter().map(|v| f64::from(v.pdf)).sum::<f64>() * part * SAMPLES as f64;
                let (lo, hi) = c.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
                    (lo.min(f64::from(v.pdf)), hi.max(f64::from(v.pdf)))
                });
                let mean = c.iter().map(|v| f64::from(v.pdf)).sum::<f64>() / c.len() as f64;
                (sum, (hi - lo) / mean.max(1e-30))
            })
            .collect()
    };
    let all: Vec<usize> = (0..THETA_BINS * PHI_BINS).collect();
    let coarse = integrate(&all, SUB);
    let mut expected: Vec<f64> = coarse.iter().map(|c| c.0).collect();
    let rough: Vec<usize> = all
        .iter()
        .copied()
        .filter(|&i| {
            // Bins that matter whose pdf varies by more than a fifth of its mean.
            let (sum, relative_spread) = coarse[i];
            sum > 0.5 && relative_spread > 0.2
        })
        .collect();
    if !rough.is_empty() {
        for (&i, fine) in rough.iter().zip(integrate(&rough, FINE)) {
            expected[i] = fine.0;
        }
    }
    // Pool bins expecting fewer than 5 samples (the chi-square approximation needs it), as
    // Mitsuba's chi2 does.
    let (mut stat, mut dof, mut pool_obs, mut pool_exp) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pool_obs += o;
            pool_exp += e;
        } else {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pool_exp > 0.0 {
        stat += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp.max(1.0);
        dof += 1;
    }
    assert!(
        dof > 10,
        "{name}: only {dof} usable bins; the pdf is zero almost everywhere?"
    );
    let p = chi2_upper_tail(stat, (dof - 1) as f64);
    // Mitsuba's level 0.01, Šidák-corrected over the tests of this file (about 30).
    let alpha = 1.0 - (1.0f64 - 0.01).powf(1.0 / 30.0);
    assert!(
        p > alpha,
        "{name}, wi {wi:?}: sampled directions do not follow the pdf: chi² = {stat:.1} with {} \
         degrees of freedom, p = {p:.2e} (level {alpha:.1e}); {} of {SAMPLES} samples smooth",
        dof - 1,
        smooth.len()
    );
    // Each smooth sample's weight is eval / pdf and its pdf the pdf at its direction.
    let check: Vec<_> = smooth
        .iter()
        .step_by(smooth.len().div_ceil(500).max(1))
        .collect();
    let at: Vec<BsdfQuery> = check
        .iter()
        .map(|s| BsdfQuery {
            wi,
            wo: s.wo,
            uv: [0.5, 0.5],
        })
        .collect();
    let values = probe::bsdf(dev, &b, &at).unwrap_or_else(|e| panic!("{name}: eval: {e}"));
    for (s, v) in check.iter().zip(&values) {
        assert!(
            close(s.pdf, v.pdf) || (s.pdf - v.pdf).abs() < 1e-3 * v.pdf.max(1.0),
            "{name}: sampled pdf {} but pdf() {} at {:?}",
            s.pdf,
            v.pdf,
            s.wo
        );
        for c in 0..3 {
            let w = v.value[c] / v.pdf;
            assert!(
                (s.weight[c] - w).abs() <= 2e-3 * w.abs().max(1.0),
                "{name}: weight {:?} but eval/pdf {:?} at {:?}",
                s.weight,
                v.value.map(|x| x / v.pdf),
                s.wo
            );
        }
    }
}

fn normalized(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

macro_rules! chi2_tests {
    ($($name:ident $(= $ignore:literal)?),* $(,)?) => {
        mod chi2 {
            use super::*;
            $(
                $(#[ignore = $ignore])?
                #[test]
                fn $name() {
                    // Near the normal, oblique, and grazing.
                    for wi in [[0.1, 0.05, 1.0], [0.6, -0.3, 0.7], [0.95, 0.2, 0.12]] {
                        sampling_matches(stringify!($name), normalized(wi));
                    }
                }
            )*
        }
    };
}

chi2_tests!(
    diffuse,
    twosided_diffuse,
    roughconductor_beckmann,
    roughconductor_ggx,
    roughconductor_ggx_anisotropic,
    roughconductor_beckmann_no_visible,
    roughdielectric_beckmann,
    roughdielectric_ggx,
    plastic,
    plastic_nonlinear,
    roughplastic_beckmann,
    roughplastic_ggx_nonlinear,
);

#[test]
fn transmission_is_sampled_from_below_too() {
    sampling_matches("roughdielectric_ggx", normalized([0.3, 0.2, -0.8]));
    sampling_matches("twosided_diffuse", normalized([0.3, 0.2, -0.8]));
}
