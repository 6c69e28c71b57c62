//! The convergence figure of `lgc bounds --convergence`: bound / reference
//! against subdivision depth, one line per method, as PNG or SVG.

use lgc::bounds::Convergence;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::Path;

/// DejaVu Sans Mono (licence in `fonts/DejaVu-LICENSE.txt`): embedded, so
/// plots need no system font library.
static FONT: &[u8] = include_bytes!("fonts/DejaVuSansMono.ttf");

const SIZE: (u32, u32) = (800, 520);

/// Colours of the methods' lines, in [`lgc::bounds::Method::ALL`] order.
const COLOURS: [RGBColor; 4] = [
    RGBColor(200, 60, 40),
    RGBColor(40, 110, 200),
    RGBColor(30, 150, 70),
    RGBColor(20, 20, 20),
];

/// Draws the figure into `path` (`.png` or `.svg`), through a temporary file
/// renamed into place.
pub fn write(path: &Path, title: &str, c: &Convergence) -> anyhow::Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("svg") => {
            let mut svg = String::new();
            draw(SVGBackend::with_string(&mut svg, SIZE), title, c)?;
            write_atomically(path, svg.as_bytes())
        }
        Some("png") => {
            let pending = lgc::render::PendingImage::create(path)?;
            let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
            draw(BitMapBackend::with_buffer(&mut rgb, SIZE), title, c)?;
            pending.finish(SIZE.0, SIZE.1, &rgb)?;
            Ok(())
        }
        _ => anyhow::bail!(
            "cannot write `{}`: a convergence plot is .png or .svg",
            path.display()
        ),
    }
}

fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let name = path
        .file_name()
        .ok_or_else(|| anyhow::anyhow!("cannot write `{}`: not a file name", path.display()))?;
    let temp = path.with_file_name(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = std::fs::write(&temp, bytes).and_then(|()| std::fs::rename(&temp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result.map_err(|e| anyhow::anyhow!("cannot write `{}`: {e}", path.display()))
}

fn draw<B: DrawingBackend>(backend: B, title: &str, c: &Convergence) -> anyhow::Result<()>
where
    B::ErrorType: 'static,
{
    // Registering twice replaces the same bytes: harmless.
    register_font("sans-serif", FontStyle::Normal, FONT)
        .map_err(|_| anyhow::anyhow!("the embedded font does not load"))?;
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
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(width)))
            .map_err(plot_error)?
            .label(m.name())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(3))
            });
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
            .map_err(plot_error)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

fn plot_error<E: std::error::Error + Send + Sync + 'static>(e: E) -> anyhow::Error {
    anyhow::anyhow!("cannot draw the plot: {e}")
}
