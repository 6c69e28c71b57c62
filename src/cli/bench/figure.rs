//! The figure of `lgc bench --models … --plot`: render time against the
//! models' operation counts, lgc beside fidget, both axes logarithmic.

use super::super::plot::{legend, line_with_dots, plot_error, register, Figure};
use super::models::Timed;
use plotters::prelude::*;

const LGC: RGBColor = RGBColor(200, 60, 40);
const PEER: RGBColor = RGBColor(40, 110, 200);

/// One program's line: its label, colour and (operations, seconds) points.
type Series<'a> = (&'a str, RGBColor, Vec<(f64, f64)>);

/// Each model's times, lgc's and the peer's.
pub struct TimeFigure<'a> {
    pub title: String,
    pub timed: &'a [Timed],
}

impl Figure for TimeFigure<'_> {
    fn draw<B: DrawingBackend>(&self, backend: B) -> anyhow::Result<()>
    where
        B::ErrorType: 'static,
    {
        register()?;
        let root = backend.into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let mut points = self.timed.iter().collect::<Vec<_>>();
        points.sort_by_key(|t| t.operations);
        let times = points
            .iter()
            .flat_map(|t| [Some(t.lgc), t.peer])
            .flatten()
            .filter(|t| *t > 0.0);
        let (lo, hi) = times.fold((f64::INFINITY, 0.0f64), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
        let (lo, hi) = if lo <= hi {
            (lo / 2.0, hi * 2.0)
        } else {
            (0.01, 10.0)
        };
        let ops = points.iter().map(|t| t.operations.max(1) as f64);
        let (olo, ohi) = ops.fold((f64::INFINITY, 0.0f64), |(a, b), o| (a.min(o), b.max(o)));
        let (olo, ohi) = if olo <= ohi {
            (olo / 2.0, ohi * 2.0)
        } else {
            (1.0, 10.0)
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(&self.title, ("sans-serif", 18))
            .margin(16)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d((olo..ohi).log_scale(), (lo..hi).log_scale())
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc("operations in f (log scale)")
            .x_labels(6)
            .y_desc("seconds, whole process (log scale)")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|y| format!("{y:.2}"))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(plot_error)?;
        let series: [Series; 2] = [
            (
                "lgc",
                LGC,
                points
                    .iter()
                    .map(|t| (t.operations.max(1) as f64, t.lgc))
                    .collect(),
            ),
            (
                "fidget (best of JIT and VM)",
                PEER,
                points
                    .iter()
                    .filter_map(|t| Some((t.operations.max(1) as f64, t.peer?)))
                    .collect(),
            ),
        ];
        for (label, colour, line) in series {
            if line.is_empty() {
                continue;
            }
            line_with_dots(&mut chart, &line, (colour, 2), label)?;
        }
        // Each model named beside lgc's point.
        chart
            .draw_series(points.iter().map(|t| {
                Text::new(
                    t.name.clone(),
                    (t.operations.max(1) as f64, t.lgc),
                    ("sans-serif", 13).into_font(),
                )
            }))
            .map_err(plot_error)?;
        legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        root.present().map_err(plot_error)?;
        Ok(())
    }
}
