//! report.md beside a sweep's CSVs: scenario, seed, software version, grid, plot, summary.
//! Deterministic (no dates), so a merged sharded run writes the same bytes.

use crate::io::csv::summary_value;
use crate::metrics::{Metric, Stat, column};
use crate::scenario::Scenario;
use crate::sweep::SummaryRow;

pub fn report(
    sc: &Scenario,
    file_name: &str,
    seed: u64,
    trials: usize,
    grid_keys: &[String],
    rows: &[SummaryRow],
    has_plot: bool,
) -> String {
    let mut s = format!("# Sweep report: {}\n\n{}\n\n", sc.name, sc.description);
    s += &format!(
        "- scenario file: `{file_name}`\n- seed: {seed}\n- trials per grid point: {trials}\n- methods: {}\n",
        sc.methods
            .iter()
            .map(|m| m.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    s += &format!("- software: lasercal {}\n", env!("CARGO_PKG_VERSION"));
    if let Some(sw) = &sc.sweep {
        for (k, v) in &sw.grid {
            s += &format!("- grid `{k}` = {v}\n");
        }
    }
    s += "\nFiles: `trials.csv` (one row per trial), `summary.csv` (mean, RMS, std, median, p95 per grid point and method)";
    if has_plot {
        s += ", `plot.svg`, `plot.png`.\n\n![plot](plot.svg)\n";
        let paper = sc
            .sweep
            .as_ref()
            .and_then(|sw| sw.plot.as_ref())
            .and_then(|p| p.paper);
        if let Some(note) = paper.and_then(crate::io::plot::paper_note) {
            s += &format!("\n{note}\n");
        }
    } else {
        s += ".\n";
    }
    s += "\n## Summary\n\n| ";
    let cols: Vec<String> = [
        (Metric::CentreError, Stat::Std),
        (Metric::RotationError, Stat::Median),
        (Metric::RotationError, Stat::P95),
        (Metric::TranslationError, Stat::Median),
        (Metric::TranslationError, Stat::P95),
    ]
    .iter()
    .map(|&(m, s)| column(m, s))
    .collect();
    let mut head: Vec<String> = grid_keys.to_vec();
    head.extend(["method", "trials", "failures"].map(String::from));
    head.extend(cols.iter().map(|c| c.to_string()));
    s += &head.join(" | ");
    s += " |\n|";
    s += &"---|".repeat(head.len());
    s += "\n";
    for r in rows {
        let mut c: Vec<String> = r.values.iter().map(|(_, v)| v.to_string()).collect();
        c.push(r.method.to_string());
        c.push(r.trials.to_string());
        c.push(r.failures.to_string());
        for k in &cols {
            c.push(
                summary_value(r, k)
                    .filter(|x| x.is_finite())
                    .map(|x| format!("{x:.4}"))
                    .unwrap_or_else(|| "-".into()),
            );
        }
        s += &format!("| {} |\n", c.join(" | "));
    }
    s
}
