//! The edge-aware à-trous wavelet filter (Dammertz, Sewtz, Hanika and Lensch, "Edge-Avoiding
//! À-Trous Wavelet Transform for fast Global Illumination Filtering", HPG 2010), with the
//! albedo demodulation and normal weight of SVGF (Schied et al. 2017): optik's denoiser where
//! Intel Open Image Denoise is absent.
//!
//! The colour is first divided by the albedo, so the filter smooths lighting and never texture:
//! an albedo edge survives untouched, whatever the noise. Five passes of the 5×5 B3-spline
//! kernel with holes (steps 1, 2, 4, 8, 16: a 125-pixel footprint) then average each pixel with
//! neighbours of similar normal, albedo and lighting; multiplying the albedo back gives the
//! result.

use super::{DenoiseError, check_sizes};

/// Passes of the filter (the kernel's step doubles each pass).
pub const ITERATIONS: u32 = 5;

/// The B3-spline kernel's taps.
const KERNEL: [f32; 5] = [1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];
/// Exponent of the normal weight `max(0, n_p · n_q)^σ_n` (SVGF's 128).
const SIGMA_NORMAL: i32 = 128;
/// Albedo differences beyond about this much stop the filter.
const SIGMA_ALBEDO: f32 = 0.1;
/// The lighting weight falls to 1/e at this many noise standard deviations (SVGF's σ_l).
const SIGMA_COLOR: f32 = 4.0;
/// Below this albedo a channel is not demodulated (dividing would amplify noise).
const MIN_ALBEDO: f32 = 1e-3;

fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

fn dist2(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|i| (a[i] - b[i]) * (a[i] - b[i])).sum()
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Replaces NaN and infinite values by 0, so one bad sample cannot spread over the footprint.
fn finite(c: [f32; 3]) -> [f32; 3] {
    c.map(|v| if v.is_finite() { v } else { 0.0 })
}

/// Each pixel's noise variance: the variance of luminance over its 5×5 neighbourhood (SVGF
/// estimates it the same way where it has no history). Real edges inflate it a little, which
/// only lets the filter smooth there a little more; normals and albedo guard those edges.
fn local_variance(light: &[[f32; 3]], width: usize, height: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity(light.len());
    for y in 0..height {
        for x in 0..width {
            let (mut sum, mut sum2, mut n) = (0.0f32, 0.0f32, 0.0f32);
            for qy in y.saturating_sub(2)..(y + 3).min(height) {
                for qx in x.saturating_sub(2)..(x + 3).min(width) {
                    let l = luminance(light[qy * width + qx]);
                    sum += l;
                    sum2 += l * l;
                    n += 1.0;
                }
            }
            let mean = sum / n;
            out.push((sum2 / n - mean * mean).max(0.0));
        }
    }
    out
}

/// How much pixel `q` counts towards pixel `p` given their normals: the SVGF normal weight;
/// pixels without a surface (zero normal, the background) count only among themselves.
fn normal_weight(np: [f32; 3], nq: [f32; 3]) -> f32 {
    let (p_none, q_none) = (dot(np, np) < 0.25, dot(nq, nq) < 0.25);
    match (p_none, q_none) {
        (true, true) => 1.0,
        (false, false) => {
            // Normals averaged over samples are shorter than 1 at silhouettes; compare
            // directions only.
            let cos = dot(np, nq) / (dot(np, np) * dot(nq, nq)).sqrt();
            cos.max(0.0).powi(SIGMA_NORMAL)
        }
        _ => 0.0,
    }
}

/// Filters `color` with the edge-aware à-trous filter guided by `albedo` and `normal` (all
/// `width × height` pixels, rows top to bottom).
pub fn atrous(
    color: &[[f32; 3]],
    albedo: &[[f32; 3]],
    normal: &[[f32; 3]],
    width: u32,
    height: u32,
) -> Result<Vec<[f32; 3]>, DenoiseError> {
    check_sizes(color, albedo, normal, width, height)?;
    let (w, h) = (width as usize, height as usize);
    let albedo: Vec<[f32; 3]> = albedo.iter().map(|a| finite(*a)).collect();
    let normal: Vec<[f32; 3]> = normal.iter().map(|n| finite(*n)).collect();
    // Lighting = colour / albedo per channel; `modulation` multiplies it back at the end.
    let modulation: Vec<[f32; 3]> = albedo
        .iter()
        .map(|a| a.map(|v| if v > MIN_ALBEDO { v } else { 1.0 }))
        .collect();
    let mut light: Vec<[f32; 3]> = color
        .iter()
        .zip(&modulation)
        .map(|(c, m)| {
            let c = finite(*c);
            [c[0] / m[0], c[1] / m[1], c[2] / m[2]]
        })
        .collect();
    let mut variance = local_variance(&light, w, h);
    // A floor under every deviation, so flat regions divide by something.
    let mean_luminance = light.iter().map(|l| luminance(*l)).sum::<f32>() / light.len() as f32;
    let epsilon = 1e-4 * mean_luminance.abs().max(1e-6);
    let mut next = light.clone();
    for pass in 0..ITERATIONS {
        let step = 1i64 << pass;
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                let (lp, np, ap) = (luminance(light[p]), normal[p], albedo[p]);
                let deviation = SIGMA_COLOR * variance[p].sqrt() + epsilon;
                let mut sum = [0.0f32; 3];
                let mut weights = 0.0f32;
                for (j, ky) in KERNEL.iter().enumerate() {
                    let qy = y as i64 + (j as i64 - 2) * step;
                    if qy < 0 || qy >= h as i64 {
                        continue;
                    }
                    for (i, kx) in KERNEL.iter().enumerate() {
                        let qx = x as i64 + (i as i64 - 2) * step;
                        if qx < 0 || qx >= w as i64 {
                            continue;
                        }
                        let q = qy as usize * w + qx as usize;
                        if q == p {
                            // The pixel itself always counts fully, so the sum of weights is
                            // never zero.
                            for c in 0..3 {
                                sum[c] += kx * ky * light[p][c];
                            }
                            weights += kx * ky;
                            continue;
                        }
                        let dl = luminance(light[q]) - lp;
                        let wc = (-dl.abs() / deviation).exp();
                        let wa = (-dist2(ap, albedo[q]) / (SIGMA_ALBEDO * SIGMA_ALBEDO)).exp();
                        let wn = normal_weight(np, normal[q]);
                        let wq = kx * ky * wc * wa * wn;
                        for c in 0..3 {
                            sum[c] += wq * light[q][c];
                        }
                        weights += wq;
                    }
                }
                next[p] = sum.map(|s| s / weights);
            }
        }
        std::mem::swap(&mut light, &mut next);
        // Each pass averages away most of the remaining noise; Dammertz et al. halve the
        // colour sigma per pass for the same reason.
        variance.iter_mut().for_each(|v| *v *= 0.5);
    }
    Ok(light
        .iter()
        .zip(&modulation)
        .map(|(l, m)| [l[0] * m[0], l[1] * m[1], l[2] * m[2]])
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::denoise::testimage::{TestImage, mse};

    #[test]
    fn atrous_reduces_error_against_the_converged_image() {
        let img = TestImage::new(64, 48, 4);
        let out = atrous(&img.noisy, &img.albedo, &img.normal, img.width, img.height).unwrap();
        let before = mse(&img.noisy, &img.converged);
        let after = mse(&out, &img.converged);
        println!("à-trous: MSE {before:.5} noisy -> {after:.5} filtered");
        assert!(
            after < before * 0.25,
            "the filter should remove most of the noise: MSE {before} -> {after}"
        );
    }

    #[test]
    fn atrous_preserves_an_albedo_edge() {
        let img = TestImage::new(64, 48, 4);
        let out = atrous(&img.noisy, &img.albedo, &img.normal, img.width, img.height).unwrap();
        // Columns on both sides of the albedo edge, in the fully lit part of the floor.
        let w = img.width as usize;
        for y in 30..46 {
            for x in [img.edge_x - 1, img.edge_x] {
                let p = y * w + x;
                let (got, want) = (out[p][1], img.converged[p][1]);
                assert!(
                    (got - want).abs() < 0.12 * want,
                    "pixel ({x}, {y}) beside the albedo edge: {got} (converged {want}); a blur \
                     across the edge would give about {}",
                    0.5 * (img.converged[p - 1][1] + img.converged[p + 1][1])
                );
            }
        }
    }

    #[test]
    fn atrous_keeps_a_clean_image_and_rejects_bad_sizes() {
        let img = TestImage::new(32, 24, 4);
        let out = atrous(
            &img.converged,
            &img.albedo,
            &img.normal,
            img.width,
            img.height,
        )
        .unwrap();
        assert!(mse(&out, &img.converged) < 1e-3, "a noise-free image stays");
        let err = atrous(&img.converged[1..], &img.albedo, &img.normal, 32, 24).unwrap_err();
        assert!(err.0.contains("colour buffer has 767 pixels"), "{err}");
        let err = atrous(&[], &[], &[], 0, 5).unwrap_err();
        assert!(err.0.contains("0x5"), "{err}");
    }

    #[test]
    fn atrous_survives_nan_and_infinite_samples() {
        let mut img = TestImage::new(32, 24, 4);
        img.noisy[100] = [f32::NAN, f32::INFINITY, 1.0];
        let out = atrous(&img.noisy, &img.albedo, &img.normal, 32, 24).unwrap();
        assert!(out.iter().flatten().all(|v| v.is_finite()));
    }
}
