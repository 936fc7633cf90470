//! Plots like the paper's figures, written as PNG and SVG with plotters. Text uses the
//! Ubuntu Light font embedded from the `epaint_default_fonts` crate, so no system font is
//! needed.

use std::path::Path;
use std::sync::Once;

use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

/// Line colours, in order of use.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 90, 181),
    RGBColor(220, 50, 32),
    RGBColor(0, 150, 80),
    RGBColor(150, 80, 180),
    RGBColor(230, 140, 0),
    RGBColor(90, 90, 90),
];

/// One curve.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// (x, y) points; non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: RGBColor,
    /// Dashed (the paper's convention for measured data) or solid (model).
    pub dashed: bool,
}

impl Series {
    /// A solid curve.
    pub fn solid(name: impl Into<String>, points: Vec<(f64, f64)>, color: RGBColor) -> Self {
        Series {
            name: name.into(),
            points,
            color,
            dashed: false,
        }
    }

    /// A dashed curve.
    pub fn dashed(name: impl Into<String>, points: Vec<(f64, f64)>, color: RGBColor) -> Self {
        Series {
            name: name.into(),
            points,
            color,
            dashed: true,
        }
    }
}

/// One panel.
#[derive(Debug, Clone)]
pub struct Chart {
    /// Title above the panel.
    pub title: String,
    /// x-axis label, with unit.
    pub x_label: String,
    /// y-axis label, with unit.
    pub y_label: String,
    /// Curves.
    pub series: Vec<Series>,
}

fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Failure leaves text unrendered; the drawing itself reports it as an error.
        let _ = register_font(
            "sans-serif",
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        );
    });
}

/// Keeps at most `max` points, evenly strided (plots of 10⁵-sample records stay small).
pub fn thin(points: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max == 0 {
        return points;
    }
    let stride = points.len().div_ceil(max);
    points.into_iter().step_by(stride).collect()
}

fn bounds(charts: &Chart) -> Option<((f64, f64), (f64, f64))> {
    let mut it = charts
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let &(x0, y0) = it.next()?;
    let (mut xl, mut xh, mut yl, mut yh) = (x0, x0, y0, y0);
    for &(x, y) in it {
        xl = xl.min(x);
        xh = xh.max(x);
        yl = yl.min(y);
        yh = yh.max(y);
    }
    let pad = |lo: f64, hi: f64| {
        let span = if hi > lo { hi - lo } else { lo.abs().max(1.0) };
        (lo - 0.05 * span, hi + 0.05 * span)
    };
    Some((pad(xl, xh), pad(yl, yh)))
}

fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, chart: &Chart) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let Some(((x0, x1), (y0, y1))) = bounds(chart) else {
        return Ok(());
    };
    let mut ctx = ChartBuilder::on(area)
        .caption(&chart.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| anyhow!("chart: {e}"))?;
    ctx.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| anyhow!("mesh: {e}"))?;
    for s in &chart.series {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        let style = ShapeStyle::from(&s.color).stroke_width(2);
        let legend_color = s.color;
        let anno = if s.dashed {
            ctx.draw_series(DashedLineSeries::new(pts, 6, 4, style))
                .map_err(|e| anyhow!("series: {e}"))?
        } else {
            ctx.draw_series(LineSeries::new(pts, style))
                .map_err(|e| anyhow!("series: {e}"))?
        };
        anno.label(&s.name).legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 20, y)], legend_color.stroke_width(2))
        });
    }
    ctx.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|e| anyhow!("legend: {e}"))?;
    Ok(())
}

fn render<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, charts: &[Chart]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("fill: {e}"))?;
    let panels = root.split_evenly((charts.len().max(1), 1));
    for (area, chart) in panels.iter().zip(charts) {
        draw(area, chart)?;
    }
    root.present().map_err(|e| anyhow!("write: {e}"))?;
    Ok(())
}

/// Writes `charts` stacked vertically to `<base>.png` and `<base>.svg`.
///
/// # Errors
/// If a file cannot be written or the drawing fails.
pub fn save(charts: &[Chart], base: &Path) -> Result<()> {
    register_fonts();
    let height = 420 * charts.len().max(1) as u32;
    let png = base.with_extension("png");
    let svg = base.with_extension("svg");
    // (The two files are drawn in parallel.)
    let (png_done, svg_done) = rayon::join(
        || {
            render(
                BitMapBackend::new(&png, (900, height)).into_drawing_area(),
                charts,
            )
            .with_context(|| format!("drawing {}", png.display()))
        },
        || {
            render(
                SVGBackend::new(&svg, (900, height)).into_drawing_area(),
                charts,
            )
            .with_context(|| format!("drawing {}", svg.display()))
        },
    );
    png_done?;
    svg_done?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_png_and_svg() {
        let dir = tempfile::tempdir().unwrap();
        let base = dir.path().join("sine");
        let pts: Vec<(f64, f64)> = (0..200)
            .map(|i| (i as f64 * 0.01, (i as f64 * 0.05).sin()))
            .collect();
        let chart = Chart {
            title: "test".into(),
            x_label: "t [s]".into(),
            y_label: "F [N]".into(),
            series: vec![
                Series::dashed("measured", pts.clone(), PALETTE[0]),
                Series::solid("model", pts, PALETTE[1]),
            ],
        };
        save(&[chart.clone(), chart], &base).unwrap();
        let png = std::fs::metadata(base.with_extension("png")).unwrap();
        let svg = std::fs::read_to_string(base.with_extension("svg")).unwrap();
        assert!(png.len() > 10_000);
        assert!(svg.contains("measured") && svg.contains("<svg"));
    }

    #[test]
    fn thin_keeps_at_most_max_points() {
        let pts: Vec<(f64, f64)> = (0..10_001).map(|i| (i as f64, 0.0)).collect();
        assert!(thin(pts, 1000).len() <= 1000);
    }
}
