//! SVG line charts for the experiments' figures (plotters, SVG backend).

use std::path::Path;

use plotters::prelude::*;

use crate::error::WriteError;

/// One named polyline.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// Points `(x, y)`; non-finite values are skipped.
    pub points: Vec<(f64, f64)>,
}

/// Reference points drawn beside the lines: a short gray tick at each point
/// (labelled ones get their label to the right), one legend entry for all.
#[derive(Debug, Clone, Default)]
pub struct Marks {
    /// Legend label of the marks.
    pub name: String,
    /// Points `(x, y)` with an optional label; non-finite points are
    /// skipped.
    pub points: Vec<(f64, f64, Option<String>)>,
}

/// Writes a line chart with one line per series to `path` (SVG).
///
/// # Errors
/// [`WriteError`] when the file cannot be written.
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), WriteError> {
    line_chart_with_marks(path, title, x_label, y_label, series, &Marks::default())
}

/// Writes a line chart as [`line_chart`] does, with reference `marks`
/// (the published success rates beside our success curves); no marks
/// draw nothing and add no legend entry.
///
/// # Errors
/// [`WriteError`] when the file cannot be written.
pub fn line_chart_with_marks(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    marks: &Marks,
) -> Result<(), WriteError> {
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().filter(finite).copied())
        .chain(
            marks
                .points
                .iter()
                .map(|&(x, y, _)| (x, y))
                .filter(|p| finite(&p)),
        )
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in &all {
        x0 = x0.min(*x);
        x1 = x1.max(*x);
        y0 = y0.min(*y);
        y1 = y1.max(*y);
    }
    if all.is_empty() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    if y1 <= y0 {
        y1 = y0 + 1.0;
    }
    let pad = 0.05 * (y1 - y0);
    let io = |e: String| WriteError::new(path, std::io::Error::other(e));
    // drawn in memory, then written beside the old file and renamed over
    // it: a killed run never leaves half a figure in place of a whole one
    let mut svg = String::new();
    draw(
        &mut svg,
        title,
        x_label,
        y_label,
        series,
        marks,
        (x0, x1, y0 - pad, y1 + pad),
    )
    .map_err(io)?;
    crate::write::write_text(path, &svg)
}

/// Draws the chart into `svg` on the ranges `(x0, x1, y0, y1)`.
fn draw(
    svg: &mut String,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    marks: &Marks,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
) -> Result<(), String> {
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let root = SVGBackend::with_string(svg, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, s) in series.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                s.points.iter().filter(finite).copied(),
                colour.stroke_width(2),
            ))
            .map_err(|e| e.to_string())?
            .label(s.name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    let points: Vec<&(f64, f64, Option<String>)> = marks
        .points
        .iter()
        .filter(|(x, y, _)| x.is_finite() && y.is_finite())
        .collect();
    if !points.is_empty() {
        let gray = RGBColor(90, 90, 90);
        let half = 0.012 * (x1 - x0);
        chart
            .draw_series(points.iter().map(|&&(x, y, _)| {
                PathElement::new(vec![(x - half, y), (x + half, y)], gray.stroke_width(2))
            }))
            .map_err(|e| e.to_string())?
            .label(marks.name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x + 5, y), (x + 13, y)], gray.stroke_width(2))
            });
        chart
            .draw_series(points.iter().filter_map(|(x, y, label)| {
                let label = label.as_ref()?;
                Some(Text::new(
                    label.clone(),
                    (x + 1.5 * half, *y),
                    ("sans-serif", 11).into_font().color(&gray),
                ))
            }))
            .map_err(|e| e.to_string())?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_an_svg() {
        let dir = std::env::temp_dir().join(format!("bayestrack-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.svg");
        line_chart(
            &path,
            "t",
            "x",
            "y",
            &[Series {
                name: "a".into(),
                points: vec![(0.0, 1.0), (1.0, f64::NAN), (2.0, 3.0)],
            }],
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("<svg") && text.contains("polyline"));
        assert!(!text.contains("#5A5A5A"));
        // reference marks: a tick per finite point, the labelled ones named
        let marks = Marks {
            name: "published".into(),
            points: vec![
                (0.5, 0.9, Some("MUSTer 0.900".into())),
                (0.5, 0.2, None),
                (0.5, f64::NAN, Some("skipped".into())),
            ],
        };
        line_chart_with_marks(&path, "t", "x", "y", &[], &marks).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.contains("MUSTer 0.900") && text.contains("published"),
            "{text}"
        );
        assert!(!text.contains("skipped"));
        // two ticks and the legend's
        assert_eq!(text.matches(r##"stroke="#5A5A5A""##).count(), 3, "{text}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
