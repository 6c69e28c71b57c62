//! Figures the commands draw (`bounds --convergence`, `bench --plot`), as PNG
//! or SVG by the file's extension, with an embedded font.

use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::Path;

/// DejaVu Sans Mono (licence in `bounds/fonts/DejaVu-LICENSE.txt`): embedded,
/// so plots need no system font library.
static FONT: &[u8] = include_bytes!("bounds/fonts/DejaVuSansMono.ttf");

/// Every figure's size in pixels.
pub const SIZE: (u32, u32) = (800, 520);

/// A figure that draws itself on any plotters backend.
pub trait Figure {
    /// Draws the figure on `backend`.
    fn draw<B: DrawingBackend>(&self, backend: B) -> anyhow::Result<()>
    where
        B::ErrorType: 'static;
}

/// Makes the embedded font the plots' `sans-serif` (registering it twice
/// replaces the same bytes: harmless).
pub fn register() -> anyhow::Result<()> {
    register_font("sans-serif", FontStyle::Normal, FONT)
        .map_err(|_| anyhow::anyhow!("the embedded font does not load"))
}

/// Draws `figure` into `path` (`.png` or `.svg`), through a temporary file
/// renamed into place; `what` names it in the error for another extension.
pub fn write<F: Figure>(path: &Path, what: &str, figure: &F) -> anyhow::Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("svg") => {
            let mut svg = String::new();
            figure.draw(SVGBackend::with_string(&mut svg, SIZE))?;
            write_atomically(path, svg.as_bytes())
        }
        Some("png") => {
            let pending = lgc::render::PendingImage::create(path)?;
            let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
            figure.draw(BitMapBackend::with_buffer(&mut rgb, SIZE))?;
            pending.finish(SIZE.0, SIZE.1, &rgb)?;
            Ok(())
        }
        _ => anyhow::bail!("cannot write `{}`: {what} is .png or .svg", path.display()),
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

/// A plotters error as the command's error.
pub fn plot_error<E: std::error::Error + Send + Sync + 'static>(e: E) -> anyhow::Error {
    anyhow::anyhow!("cannot draw the plot: {e}")
}

/// Draws `points` as a line of `width` with a dot at each, labelled `label`
/// in the legend.
pub fn line_with_dots<DB, X, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    points: &[(f64, f64)],
    (colour, width): (RGBColor, u32),
    label: &str,
) -> anyhow::Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    chart
        .draw_series(LineSeries::new(points.to_vec(), colour.stroke_width(width)))
        .map_err(plot_error)?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(3)));
    chart
        .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
        .map_err(plot_error)?;
    Ok(())
}

/// Draws the legend of `chart`'s labelled series at `position`.
pub fn legend<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    position: SeriesLabelPosition,
) -> anyhow::Result<()>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(plot_error)
}
