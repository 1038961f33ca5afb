//! The log-log plot: error against the wall time of the run, one panel per problem and measure,
//! one line per integrator. Drawn with plotters' SVG backend (no fonts needed to draw it).

use std::path::Path;

use plotters::prelude::*;

use super::Report;
use crate::physics::Integrator;

const WIDTH: u32 = 1200;
const PANEL_HEIGHT: u32 = 400;
/// Errors are drawn no lower than this (exact answers are at rounding level).
const LOWEST_ERROR: f64 = 1e-16;

fn colour(integrator: Integrator) -> RGBColor {
    match integrator {
        Integrator::ExplicitEuler => RGBColor(214, 39, 40),
        Integrator::SemiImplicitEuler => RGBColor(255, 127, 14),
        Integrator::Leapfrog => RGBColor(44, 160, 44),
        Integrator::Rk4 => RGBColor(31, 119, 180),
        Integrator::Yoshida4 => RGBColor(148, 103, 189),
    }
}

pub fn draw(report: &Report, path: &Path) -> Result<(), String> {
    let panels = report.panels();
    let rows = panels.len().div_ceil(2) as u32;
    let root = SVGBackend::new(path, (WIDTH, rows * PANEL_HEIGHT + 50)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root
        .titled(
            "ballfield accuracy: error against wall time (log-log; lower left is better)",
            ("sans-serif", 26).into_font().color(&BLACK),
        )
        .map_err(|e| e.to_string())?;
    let areas = root.split_evenly((rows as usize, 2));
    for (area, (problem, measure)) in areas.iter().zip(&panels) {
        let series: Vec<(Integrator, Vec<(f64, f64)>)> = report
            .config
            .integrators
            .iter()
            .map(|&i| {
                let pts = report
                    .series(problem, measure.name, i)
                    .into_iter()
                    .filter(|r| r.error.is_finite() && r.wall_seconds > 0.0)
                    .map(|r| (r.wall_seconds, r.error.max(LOWEST_ERROR)))
                    .collect();
                (i, pts)
            })
            .collect();
        let all: Vec<(f64, f64)> = series.iter().flat_map(|(_, p)| p.iter().copied()).collect();
        if all.is_empty() {
            continue;
        }
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in &all {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        // Pad by a factor on each side, and clip runaway errors so the asymptotic range stays readable.
        let (x0, x1) = (x0 / 1.5, x1 * 1.5);
        // At least two decades of wall time, so that the log axis gets readable labels.
        let widen = ((100.0 / (x1 / x0)).max(1.0)).sqrt();
        let (x0, x1) = (x0 / widen, x1 * widen);
        let y1 = (y1 * 3.0).min(1e2);
        let y0 = (y0 / 3.0).min(y1 / 100.0);
        let fit_text = |i: Integrator| match report.fit(problem, measure.name, i) {
            Some(f) => match f.fit {
                Some(o) => format!(" (order {:.2})", o.order),
                None if f.theory.is_none() => " (exact)".to_string(),
                None => String::new(),
            },
            None => String::new(),
        };
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{problem} — {}", measure.name), ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(70)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("wall time of the run (s)")
            .y_desc("error")
            .x_label_formatter(&|x| format!("{x:.0e}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 15))
            .light_line_style(WHITE.mix(0.0))
            .bold_line_style(BLACK.mix(0.12))
            .draw()
            .map_err(|e| e.to_string())?;
        for (integrator, pts) in &series {
            let c = colour(*integrator);
            let clipped: Vec<(f64, f64)> = pts.iter().map(|&(x, y)| (x, y.min(y1))).collect();
            chart
                .draw_series(LineSeries::new(clipped.iter().copied(), c.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(format!("{}{}", integrator.name(), fit_text(*integrator)))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(3)));
            chart.draw_series(clipped.iter().map(|&p| Circle::new(p, 3, c.filled()))).map_err(|e| e.to_string())?;
        }
        // The legend goes in the corner quadrant (in log coordinates) with the fewest points.
        let (xm, ym) = ((x0 * x1).sqrt(), (y0 * y1).sqrt());
        // Quadrants as (right of the middle?, above the middle?).
        let corners = [
            (SeriesLabelPosition::UpperRight, (true, true)),
            (SeriesLabelPosition::LowerLeft, (false, false)),
            (SeriesLabelPosition::UpperLeft, (false, true)),
            (SeriesLabelPosition::LowerRight, (true, false)),
        ];
        let legend_at = corners
            .into_iter()
            .min_by_key(|&(_, quadrant)| all.iter().filter(|&&(x, y)| (x > xm, y.min(y1) > ym) == quadrant).count())
            .map(|(corner, _)| corner)
            .unwrap_or(SeriesLabelPosition::UpperRight);
        chart
            .configure_series_labels()
            .position(legend_at)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}
