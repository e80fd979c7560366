//! Line plots (SVG and PNG) in the style of the papers' figures. The font is bundled so no system
//! font is needed.

use super::FormatError;
use plotters::prelude::*;
use std::path::Path;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The bundled font is valid; a failure would only lose the text.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct Figure {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
}

fn bounds(f: &Figure) -> ((f64, f64), (f64, f64)) {
    let pts = f
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|p| p.0.is_finite() && p.1.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        return ((0.0, 1.0), (0.0, 1.0));
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    if f.log_y {
        y0 = (y0 * 0.8).max(1e-12);
        y1 *= 1.25;
    } else {
        y0 = 0.0f64.min(y0);
        y1 = if y1 > y0 { y1 * 1.08 } else { y0 + 1.0 };
    }
    if f.log_x {
        x0 = (x0 * 0.9).max(1e-12);
        x1 *= 1.1;
    }
    ((x0, x1), (y0, y1))
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    f: &Figure,
) -> Result<(), FormatError>
where
    DB::ErrorType: 'static,
{
    register_font();
    let e = |err: DrawingAreaErrorKind<DB::ErrorType>| FormatError::Render {
        what: "plot".into(),
        message: format!("{err:?}"),
    };
    root.fill(&WHITE).map_err(e)?;
    let ((x0, x1), (y0, y1)) = bounds(f);
    let mut b = ChartBuilder::on(&root);
    b.caption(&f.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60);
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(&f.x_label)
                .y_desc(&f.y_label)
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(e)?;
            for (i, s) in f.series.iter().enumerate() {
                let color = Palette99::pick(i).to_rgba();
                chart
                    .draw_series(LineSeries::new(
                        s.points.iter().copied(),
                        color.stroke_width(2),
                    ))
                    .map_err(e)?
                    .label(s.label.clone())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                    });
                chart
                    .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, color.filled())))
                    .map_err(e)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .label_font(("sans-serif", 12))
                .draw()
                .map_err(e)?;
        }};
    }
    match (f.log_x, f.log_y) {
        (false, false) => body!(b.build_cartesian_2d(x0..x1, y0..y1).map_err(e)?),
        (true, false) => body!(
            b.build_cartesian_2d((x0..x1).log_scale(), y0..y1)
                .map_err(e)?
        ),
        (false, true) => body!(
            b.build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(e)?
        ),
        (true, true) => body!(
            b.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                .map_err(e)?
        ),
    }
    root.present().map_err(e)?;
    Ok(())
}

/// The figure as SVG text.
pub fn svg(f: &Figure) -> Result<String, FormatError> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 600)).into_drawing_area();
        draw(root, f)?;
    }
    Ok(out)
}

/// Write the figure as a PNG file.
pub fn png(f: &Figure, path: &Path) -> Result<(), FormatError> {
    // Drawn under a partial name (ending .png: the backend picks the format by it), then renamed:
    // a full disk leaves no half image under the real name.
    let stem = path
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{stem}.partial.png"));
    let drawn = draw(BitMapBackend::new(&tmp, (900, 600)).into_drawing_area(), f);
    let renamed = drawn.and_then(|_| {
        std::fs::rename(&tmp, path).map_err(|e| FormatError::Field {
            file: path.display().to_string(),
            at: "plot".into(),
            message: format!("cannot write: {e}"),
        })
    });
    if renamed.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    renamed
}

/// A figure from sweep summaries: x from a grid key, one curve per value of the series key (and per
/// method when there are several), y a summary column.
pub fn from_summary(
    rows: &[crate::sweep::SummaryRow],
    plot: &crate::scenario::PlotSection,
    scenario: &str,
) -> Figure {
    use crate::io::csv::summary_value;
    let methods: Vec<crate::method::MethodId> = {
        let mut m: Vec<_> = rows.iter().map(|r| r.method).collect();
        m.sort();
        m.dedup();
        m
    };
    let mut series: Vec<Series> = Vec::new();
    for r in rows {
        let (Some(x), Some(y)) = (summary_value(r, &plot.x), summary_value(r, &plot.y)) else {
            continue;
        };
        let mut label = match &plot.series {
            Some(k) => format!(
                "{k} = {}",
                r.values
                    .iter()
                    .find(|(kk, _)| kk == k)
                    .map(|(_, v)| v.to_string())
                    .unwrap_or_default()
            ),
            None => plot.y.clone(),
        };
        if methods.len() > 1 {
            label = format!("{} {label}", r.method);
        }
        match series.iter_mut().find(|s| s.label == label) {
            Some(s) => s.points.push((x, y)),
            None => series.push(Series {
                label,
                points: vec![(x, y)],
            }),
        }
    }
    for s in &mut series {
        s.points.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    Figure {
        title: plot
            .title
            .clone()
            .unwrap_or_else(|| format!("{scenario}: {} vs {}", plot.y, plot.x)),
        x_label: plot.x.clone(),
        y_label: plot.y.clone(),
        log_x: plot.log_x,
        log_y: plot.log_y,
        series,
    }
}
