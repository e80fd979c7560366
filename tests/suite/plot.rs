//! Plots a paper would print: tick labels without float noise, axis labels in words with units,
//! the papers' published points overlaid in their curves' colours.

use lasercal::io::plot::{Figure, Series, axis_words, svg, tick};

#[test]
fn ticks_are_short_and_axes_are_words_with_units() {
    assert_eq!(tick(0.30000000000000004), "0.3");
    assert_eq!(tick(0.1 + 0.2), "0.3");
    assert_eq!(tick(0.002), "0.002");
    assert_eq!(tick(150.0), "150");
    assert_eq!(tick(2.5e-7), "2.5e-7");
    assert_eq!(
        axis_words("centre_error_mm_std"),
        "centre error, standard deviation (mm)"
    );
    assert_eq!(
        axis_words("rotation_error_deg_p95"),
        "rotation error, 95th percentile (deg)"
    );
    assert_eq!(axis_words("disk.sigma_mm"), "disk sigma (mm)");
    assert_eq!(axis_words("disk.chords"), "chords per scan m");
}

/// The Fig. 15 scenario and its figure with no curves yet (the published points only).
fn fig15() -> (lasercal::scenario::ScenarioFile, Figure) {
    let text = std::fs::read_to_string(format!(
        "{}/scenarios/chen2018-fig15.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let sf = lasercal::scenario::ScenarioFile::parse(&text, "fig15.toml").unwrap();
    let plot = sf.scenario.sweep.as_ref().unwrap().plot.clone().unwrap();
    let fig = lasercal::io::plot::from_summary(&[], &plot, "fig15");
    (sf, fig)
}

#[test]
fn a_reproduction_overlays_the_published_points() {
    let (_, fig) = fig15();
    assert_eq!(fig.reference.len(), 3, "{:?}", fig.reference);
    let pts: usize = fig.reference.iter().map(|s| s.points.len()).sum();
    assert_eq!(pts, 4);
    assert!(
        fig.reference
            .iter()
            .any(|s| s.points.contains(&(10.0, 0.591)))
    );
    let s = svg(&fig).unwrap();
    assert!(
        s.contains("Fig. 15") && s.contains("published"),
        "legend lacks the paper"
    );
    // Log axes: labels at 1-2-5 of each decade, no float noise.
    let log = Figure {
        title: "t".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        x_key: "x".into(),
        y_key: "y".into(),
        log_x: true,
        log_y: true,
        series: vec![Series {
            label: "s".into(),
            points: vec![(0.25, 0.003), (4.0, 0.6)],
        }],
        reference: vec![],
        note: None,
    };
    let s = svg(&log).unwrap();
    let labels: Vec<&str> = s
        .split("</text>")
        .filter_map(|t| t.rsplit('>').next())
        .map(str::trim)
        .collect();
    for label in ["0.005", "0.01", "0.02", "0.5", "1", "2"] {
        assert!(labels.contains(&label), "{label} missing from {labels:?}");
    }
    assert!(!s.contains("0000000"), "float noise in a label");
}

#[test]
fn published_points_take_their_curves_colours_and_the_level_is_explained() {
    let (sf, mut fig) = fig15();
    fig.series = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]
        .iter()
        .map(|s| Series {
            label: format!("disk sigma (mm) = {s}"),
            points: vec![(10.0, *s), (200.0, s / 4.0)],
        })
        .collect();
    let (curves, published) = lasercal::io::plot::colours(&fig);
    // Nine curves, nine colours.
    for (i, a) in curves.iter().enumerate() {
        assert!(curves[..i].iter().all(|b| b != a), "{curves:?}");
    }
    for (r, c) in fig.reference.iter().zip(&published) {
        let sigma: f64 = r.label.split("sigma = ").nth(1).unwrap()[..3]
            .parse()
            .unwrap();
        let k = (sigma * 10.0).round() as usize - 1;
        assert_eq!(*c, curves[k], "{}", r.label);
    }
    assert!(
        fig.note
            .as_deref()
            .is_some_and(|n| n.contains("3x") && n.contains("geometry"))
    );
    assert!(svg(&fig).unwrap().contains("scan geometry"));
    let report = lasercal::io::report::report(&sf.scenario, "fig15.toml", 1, 1, &[], &[], true);
    assert!(report.contains("scan geometry"), "{report}");
}
