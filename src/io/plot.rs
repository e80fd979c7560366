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
    /// The keys the labels say in words (a grid key and a summary column), for Rerun's paths.
    pub x_key: String,
    pub y_key: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
    /// Published points (a paper's figure or table), drawn as hollow triangles in the colour of
    /// the curve they belong to.
    pub reference: Vec<Series>,
    /// A remark printed under the legend (why a reproduction's level differs from the paper's).
    pub note: Option<String>,
}

/// A tick label: at most four significant digits, no float noise (0.30000000000000004 -> 0.3).
pub fn tick(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{v:.1e}");
    }
    let decimals = (3 - mag).clamp(0, 8) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// An axis key in words with its unit: a grid key (`disk.sigma_mm` -> "disk sigma (mm)") or a
/// summary column (`centre_error_mm_std` -> "centre error, std (mm)").
pub fn axis_words(key: &str) -> String {
    if let Some((m, st)) = crate::metrics::parse_column(key) {
        let unit = m.unit();
        let stat = match st.name() {
            "p95" => "95th percentile",
            "std" => "standard deviation",
            other => other,
        };
        return if unit.is_empty() {
            format!("{}, {stat}", m.words())
        } else {
            format!("{}, {stat} ({unit})", m.words())
        };
    }
    let units = [
        ("_mm", "mm"),
        ("_deg", "deg"),
        ("_rad", "rad"),
        ("_hz", "Hz"),
        ("_ms", "ms"),
        ("_kg", "kg"),
    ];
    let words = |k: &str| k.replace(['_', '.'], " ");
    for (suffix, unit) in units {
        if let Some(stem) = key.strip_suffix(suffix) {
            return format!("{} ({unit})", words(stem));
        }
    }
    match key {
        "disk.chords" => "chords per scan m".into(),
        "ball.arcs" => "arcs per pose m".into(),
        "edge.rotations" => "flange rotations".into(),
        "causes.scale" => "cause magnitude (x paper level)".into(),
        k if k.ends_with("poses.count") => "number of poses".into(),
        k => words(k),
    }
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
    // The title over everything, the legend beside the data, never over it.
    let body = root.titled(&f.title, ("sans-serif", 18)).map_err(e)?;
    let (plot_area, legend_area) = body.split_horizontally(660);
    let mut with_ref = f.clone();
    with_ref.series.extend(f.reference.iter().cloned());
    let ((x0, x1), (y0, y1)) = bounds(&with_ref);
    let mut b = ChartBuilder::on(&plot_area);
    b.margin(12).x_label_area_size(45).y_label_area_size(70);
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            let fmt = |v: &f64| tick(*v);
            chart
                .configure_mesh()
                .x_desc(&f.x_label)
                .y_desc(&f.y_label)
                .x_labels(10)
                .y_labels(10)
                .light_line_style(RGBColor(238, 238, 238))
                .x_label_formatter(&fmt)
                .y_label_formatter(&fmt)
                .label_style(("sans-serif", 13))
                .axis_desc_style(("sans-serif", 15))
                .draw()
                .map_err(e)?;
            for (i, s) in f.series.iter().enumerate() {
                let color = curve_color(i);
                // Past the palette, curves are dashed: colour alone never tells two apart.
                if i < PALETTE.len() {
                    chart
                        .draw_series(LineSeries::new(
                            s.points.iter().copied(),
                            color.stroke_width(2),
                        ))
                        .map_err(e)?;
                } else {
                    chart
                        .draw_series(DashedLineSeries::new(
                            s.points.iter().copied(),
                            6,
                            4,
                            color.stroke_width(2),
                        ))
                        .map_err(e)?;
                }
                chart
                    .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, color.filled())))
                    .map_err(e)?;
            }
            for s in &f.reference {
                let color = reference_color(f, s);
                chart
                    .draw_series(
                        s.points
                            .iter()
                            .map(|&p| TriangleMarker::new(p, 7, color.stroke_width(2))),
                    )
                    .map_err(e)?;
            }
        }};
    }
    use plotters::coord::combinators::BindKeyPoints;
    // Log axes labelled at 1, 2 and 5 of every decade.
    let (kx, ky) = (log_keys(x0, x1), log_keys(y0, y1));
    match (f.log_x, f.log_y) {
        (false, false) => body!(b.build_cartesian_2d(x0..x1, y0..y1).map_err(e)?),
        (true, false) => body!(
            b.build_cartesian_2d((x0..x1).log_scale().with_key_points(kx), y0..y1)
                .map_err(e)?
        ),
        (false, true) => body!(
            b.build_cartesian_2d(x0..x1, (y0..y1).log_scale().with_key_points(ky))
                .map_err(e)?
        ),
        (true, true) => body!(
            b.build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(kx),
                (y0..y1).log_scale().with_key_points(ky)
            )
            .map_err(e)?
        ),
    }
    // The legend: one row per curve, then the published points.
    let font = ("sans-serif", 12).into_font();
    let mut y = 40;
    let rows = f
        .series
        .iter()
        .enumerate()
        .map(|(i, s)| (s.label.as_str(), curve_color(i), Some(i >= PALETTE.len())))
        .chain(
            f.reference
                .iter()
                .map(|s| (s.label.as_str(), reference_color(f, s), None)),
        );
    for (label, color, dashed) in rows {
        if dashed.is_none() {
            legend_area
                .draw(&TriangleMarker::new((16, y), 6, color.stroke_width(2)))
                .map_err(e)?;
        } else if dashed == Some(true) {
            for x in [6, 18] {
                legend_area
                    .draw(&PathElement::new(
                        vec![(x, y), (x + 6, y)],
                        color.stroke_width(2),
                    ))
                    .map_err(e)?;
            }
        } else {
            legend_area
                .draw(&PathElement::new(
                    vec![(6, y), (26, y)],
                    color.stroke_width(2),
                ))
                .map_err(e)?;
        }
        for l in wrap(label, 28) {
            legend_area
                .draw(&Text::new(l, (32, y - 7), font.clone()))
                .map_err(e)?;
            y += 16;
        }
        y += 4;
    }
    if let Some(note) = &f.note {
        y += 8;
        for l in wrap(note, 34) {
            legend_area
                .draw(&Text::new(l, (6, y - 7), font.clone()))
                .map_err(e)?;
            y += 15;
        }
    }
    root.present().map_err(e)?;
    Ok(())
}

/// 1, 2 and 5 times every power of ten within (lo, hi), lo > 0.
fn log_keys(lo: f64, hi: f64) -> Vec<f64> {
    let mut out = Vec::new();
    if !(lo > 0.0 && hi > lo) {
        return out;
    }
    let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    for d in d0..=d1.min(d0 + 30) {
        for m in [1.0, 2.0, 5.0] {
            let v = m * 10f64.powi(d);
            if v >= lo && v <= hi {
                out.push(v);
            }
        }
    }
    out
}

/// Words wrapped at about `width` characters.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut line = String::new();
    let mut lines = Vec::new();
    for w in text.split(' ') {
        if !line.is_empty() && line.len() + w.len() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line += w;
    }
    lines.push(line);
    lines
}

/// Okabe and Ito's colour-blind-safe palette (black last: it is the published points' colour
/// when they match no curve), and a grey.
const PALETTE: [RGBColor; 9] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(213, 94, 0),
    RGBColor(86, 180, 233),
    RGBColor(204, 121, 167),
    RGBColor(240, 228, 66),
    RGBColor(153, 153, 153),
    RGBColor(0, 0, 0),
];

/// Curve `i`'s colour (the palette again, dashed, past its end).
fn curve_color(i: usize) -> RGBAColor {
    PALETTE[i % PALETTE.len()].to_rgba()
}

/// Each published series' colour and each curve's, as RGB (for tests and other renderers).
pub fn colours(f: &Figure) -> (Vec<[u8; 3]>, Vec<[u8; 3]>) {
    let rgb = |c: RGBAColor| [c.0, c.1, c.2];
    (
        (0..f.series.len()).map(|i| rgb(curve_color(i))).collect(),
        f.reference
            .iter()
            .map(|r| rgb(reference_color(f, r)))
            .collect(),
    )
}

/// The value a label names after its last "= " ("disk sigma (mm) = 0.1" -> "0.1").
fn label_value(label: &str) -> Option<&str> {
    let (_, v) = label.rsplit_once("= ")?;
    v.split(' ').next().filter(|v| !v.is_empty())
}

/// Published points take the colour of the curve they belong to: the one whose value their label
/// names ("sigma = 0.1", "parallel-bar"); black when none does.
fn reference_color(f: &Figure, r: &Series) -> RGBAColor {
    let names = |v: &str| {
        label_value(&r.label) == Some(v)
            || r.label.contains(&format!(", {v} "))
            || r.label.contains(&format!(", {v},"))
    };
    f.series
        .iter()
        .position(|s| label_value(&s.label).is_some_and(names))
        .map_or(BLACK.to_rgba(), curve_color)
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
                "{} = {}",
                axis_words(k),
                r.values
                    .iter()
                    .find(|(kk, _)| kk == k)
                    .map(|(_, v)| v.as_str().map_or_else(|| v.to_string(), str::to_string))
                    .unwrap_or_default()
            ),
            None => axis_words(&plot.y),
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
        x_label: axis_words(&plot.x),
        y_label: axis_words(&plot.y),
        x_key: plot.x.clone(),
        y_key: plot.y.clone(),
        log_x: plot.log_x,
        log_y: plot.log_y,
        series,
        reference: plot.paper.map(published).unwrap_or_default(),
        note: plot.paper.and_then(paper_note),
    }
}

/// Why a reproduction's curves may sit off the published points.
pub fn paper_note(p: crate::schema::PaperFigure) -> Option<String> {
    use crate::schema::PaperFigure;
    match p {
        PaperFigure::Chen2018Fig15 => Some(
            "The published points lie about 3x above the curves: the paper does not publish its \
             scan geometry, which sets the level; the slopes (x sigma, 1 / sqrt(m)) agree. See \
             docs/results.md."
                .into(),
        ),
        PaperFigure::Xu2021Table1 => Some(
            "The published values come from a real rig (robot error, vibration, real specimens); the \
             simulated rig here has only the sensor's noise. See docs/results.md."
                .into(),
        ),
    }
}

/// A paper's published points, one series per curve of the figure.
fn published(p: crate::schema::PaperFigure) -> Vec<Series> {
    use crate::schema::PaperFigure;
    match p {
        PaperFigure::Chen2018Fig15 => {
            let mut out: Vec<Series> = Vec::new();
            for (sigma, m, e) in crate::papers::chen2018::FIG15_POINTS {
                let label = format!("Chen et al. 2018 Fig. 15, sigma = {sigma} (published)");
                match out.iter_mut().find(|s| s.label == label) {
                    Some(s) => s.points.push((m as f64, e)),
                    None => out.push(Series {
                        label,
                        points: vec![(m as f64, e)],
                    }),
                }
            }
            out
        }
        PaperFigure::Xu2021Table1 => crate::papers::xu2021::TABLE1_SPECIMENS
            .iter()
            .enumerate()
            .map(|(k, name)| Series {
                label: format!("Xu et al. Table 1, {name} (published, |mean|)"),
                points: crate::papers::xu2021::TABLE1_MEAN_DEG
                    .iter()
                    .map(|(n, v)| (*n as f64, v[k].abs()))
                    .collect(),
            })
            .collect(),
    }
}
