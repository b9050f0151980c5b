//! The convergence plot: relative MSE against render time, both axes logarithmic, drawn with
//! `plotters` into an RGB buffer and written as a PNG.
//!
//! The plot has no text: plotters draws text only through system fonts (`ttf`, which needs
//! fontconfig) or a font file the program supplies (`ab_glyph`), and optik ships neither.
//! The legend is fixed instead, and [`PlotLegend`] says it in words for the command to print:
//! grid lines at every power of ten on both axes; one colour per accuracy setting (in the
//! order of [`ACCURACY_COLOURS`]); one marker per backend (cpu ●, wgpu ▲, vulkan ■).

use super::convergence::{ConvergenceCurve, accuracy_name};
use crate::error::RenderError;
use optik::BackendKind;
use plotters::prelude::*;
use std::path::Path;

/// Plot size in pixels.
pub const PLOT_SIZE: (u32, u32) = (800, 600);

/// Colours of the accuracy settings, in the order of
/// [`accuracy_settings`](super::convergence::accuracy_settings), with their names.
pub const ACCURACY_COLOURS: [(RGBColor, &str); 6] = [
    (RGBColor(31, 119, 180), "blue"),
    (RGBColor(255, 127, 14), "orange"),
    (RGBColor(44, 160, 44), "green"),
    (RGBColor(214, 39, 40), "red"),
    (RGBColor(148, 103, 189), "purple"),
    (RGBColor(140, 86, 75), "brown"),
];

/// What the plot shows, in words (the image has no text).
#[derive(Clone, Debug, PartialEq)]
pub struct PlotLegend {
    /// The x axis range in seconds (powers of ten).
    pub seconds: (f64, f64),
    /// The y axis range of relative MSE (powers of ten).
    pub rel_mse: (f64, f64),
    /// One line per curve: `colour marker: backend accuracy`.
    pub curves: Vec<String>,
}

impl std::fmt::Display for PlotLegend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "x: render time {:e} s to {:e} s, y: relative MSE {:e} to {:e}; both logarithmic, \
             grid lines at powers of ten",
            self.seconds.0, self.seconds.1, self.rel_mse.0, self.rel_mse.1
        )?;
        for c in &self.curves {
            writeln!(f, "  {c}")?;
        }
        Ok(())
    }
}

fn marker_name(b: BackendKind) -> &'static str {
    match b {
        BackendKind::Cpu => "circles",
        BackendKind::Wgpu => "triangles",
        BackendKind::Vulkan => "squares",
    }
}

/// The colour of `accuracy` (its index among all settings).
fn colour(accuracy: optik::Accuracy) -> (RGBColor, &'static str) {
    let all = super::convergence::accuracy_settings();
    let i = all.iter().position(|a| *a == accuracy).unwrap_or(0);
    ACCURACY_COLOURS[i % ACCURACY_COLOURS.len()]
}

/// The powers of ten around the positive finite values in `v`.
fn decades(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v.filter(|x| x.is_finite() && *x > 0.0) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if lo > hi {
        return (1.0, 10.0);
    }
    let (a, mut b) = (lo.log10().floor(), hi.log10().ceil());
    if b <= a {
        b = a + 1.0;
    }
    (10f64.powf(a), 10f64.powf(b))
}

/// Draws `curves` into an RGB buffer of [`PLOT_SIZE`]; returns it with its legend.
pub fn plot_rgb(curves: &[ConvergenceCurve]) -> Result<(Vec<u8>, PlotLegend), RenderError> {
    let points = || curves.iter().flat_map(|c| c.points.iter());
    let (x0, x1) = decades(points().map(|p| p.seconds));
    let (y0, y1) = decades(points().map(|p| p.rel_mse));
    let (w, h) = PLOT_SIZE;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    let err = |e: String| RenderError::Output(format!("drawing the convergence plot: {e}"));
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .margin(20)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| err(e.to_string()))?;
        let grey = RGBColor(200, 200, 200);
        let mut x = x0;
        while x <= x1 * 1.0001 {
            chart
                .draw_series(LineSeries::new([(x, y0), (x, y1)], grey))
                .map_err(|e| err(e.to_string()))?;
            x *= 10.0;
        }
        let mut y = y0;
        while y <= y1 * 1.0001 {
            chart
                .draw_series(LineSeries::new([(x0, y), (x1, y)], grey))
                .map_err(|e| err(e.to_string()))?;
            y *= 10.0;
        }
        chart
            .plotting_area()
            .draw(&Rectangle::new(
                [(x0, y0), (x1, y1)],
                ShapeStyle::from(&BLACK).stroke_width(2),
            ))
            .map_err(|e| err(e.to_string()))?;
        for c in curves {
            let (rgb, _) = colour(c.accuracy);
            let line: Vec<(f64, f64)> = c
                .points
                .iter()
                .filter(|p| p.seconds > 0.0 && p.rel_mse > 0.0)
                .map(|p| (p.seconds, p.rel_mse))
                .collect();
            chart
                .draw_series(LineSeries::new(
                    line.iter().copied(),
                    ShapeStyle::from(&rgb).stroke_width(2),
                ))
                .map_err(|e| err(e.to_string()))?;
            let style = ShapeStyle::from(&rgb).filled();
            match c.backend {
                BackendKind::Cpu => chart
                    .draw_series(line.iter().map(|&(x, y)| Circle::new((x, y), 5, style)))
                    .map(|_| ()),
                BackendKind::Wgpu => chart
                    .draw_series(
                        line.iter()
                            .map(|&(x, y)| TriangleMarker::new((x, y), 6, style)),
                    )
                    .map(|_| ()),
                BackendKind::Vulkan => chart
                    .draw_series(line.iter().map(|&(x, y)| {
                        EmptyElement::at((x, y)) + Rectangle::new([(-5, -5), (5, 5)], style)
                    }))
                    .map(|_| ()),
            }
            .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    let legend = PlotLegend {
        seconds: (x0, x1),
        rel_mse: (y0, y1),
        curves: curves
            .iter()
            .map(|c| {
                format!(
                    "{} {}: {} {}",
                    colour(c.accuracy).1,
                    marker_name(c.backend),
                    c.backend,
                    accuracy_name(c.accuracy)
                )
            })
            .collect(),
    };
    Ok((buf, legend))
}

/// Draws `curves` and writes the plot to `path` as a PNG; returns its legend.
pub fn plot_png(curves: &[ConvergenceCurve], path: &Path) -> Result<PlotLegend, RenderError> {
    let (rgb, legend) = plot_rgb(curves)?;
    let (w, h) = PLOT_SIZE;
    let mut bytes = Vec::new();
    {
        let enc_err = |e: png::EncodingError| RenderError::Output(format!("encoding PNG: {e}"));
        let mut enc = png::Encoder::new(&mut bytes, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(enc_err)?;
        writer.write_image_data(&rgb).map_err(enc_err)?;
    }
    std::fs::write(path, bytes)
        .map_err(|e| RenderError::Output(format!("{}: {e}", path.display())))?;
    Ok(legend)
}
