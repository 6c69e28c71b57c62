//! The convergence figure of `lgc bounds --convergence`: bound / reference
//! against subdivision depth, one line per method, as PNG or SVG.

use super::super::plot::{self, legend, line_with_dots, plot_error, register, Figure};
use lgc::bounds::Convergence;
use plotters::prelude::*;
use std::path::Path;

/// Colours of the lines of the methods that apply, in [`lgc::bounds::Method::ALL`]
/// order (at most five apply: Bernstein and Taylor never both).
const COLOURS: [RGBColor; 5] = [
    RGBColor(200, 60, 40),
    RGBColor(40, 110, 200),
    RGBColor(30, 150, 70),
    RGBColor(150, 80, 180),
    RGBColor(20, 20, 20),
];

/// Draws the figure into `path` (`.png` or `.svg`), through a temporary file
/// renamed into place.
pub fn write(path: &Path, title: &str, c: &Convergence) -> anyhow::Result<()> {
    plot::write(path, "a convergence plot", &ConvergenceFigure { title, c })
}

/// The convergence figure of one formula.
struct ConvergenceFigure<'a> {
    title: &'a str,
    c: &'a Convergence,
}

impl Figure for ConvergenceFigure<'_> {
    fn draw<B: DrawingBackend>(&self, backend: B) -> anyhow::Result<()>
    where
        B::ErrorType: 'static,
    {
        draw(backend, self.title, self.c)
    }
}

fn draw<B: DrawingBackend>(backend: B, title: &str, c: &Convergence) -> anyhow::Result<()>
where
    B::ErrorType: 'static,
{
    register()?;
    let root = backend.into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    let ratios: Vec<(lgc::bounds::Method, Vec<f64>)> = c
        .methods
        .iter()
        .map(|(m, v)| (*m, v.iter().map(|l| l / c.reference).collect()))
        .collect();
    let top = ratios
        .iter()
        .flat_map(|(_, v)| v.iter().copied())
        .filter(|r| r.is_finite())
        .fold(1.0f64, f64::max);
    let max_depth = c.depths.last().copied().unwrap_or(0);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(16)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(
            0f64..f64::from(max_depth),
            (0.98f64..(top * 1.1).max(1.1)).log_scale(),
        )
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .x_desc("subdivision depth d (8^d boxes)")
        .y_desc("L / max |grad f|  (log scale)")
        .x_labels(max_depth as usize + 1)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| format!("{y:.2}"))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(plot_error)?;
    for (k, (m, v)) in ratios.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let points: Vec<(f64, f64)> = c
            .depths
            .iter()
            .zip(v)
            .filter(|(_, r)| r.is_finite())
            .map(|(&d, &r)| (f64::from(d), r))
            .collect();
        // The best method is drawn thin, over the one it equals.
        let width = if k == ratios.len() - 1 { 1 } else { 3 };
        line_with_dots(&mut chart, &points, (colour, width), m.name())?;
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}
