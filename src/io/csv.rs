//! CSV rows of sweeps. Numbers are printed in Rust's shortest round-trip form, so equal values
//! always give equal bytes (merging shards reproduces an unsharded run exactly).

use crate::sweep::{METRICS, SummaryRow, TrialRow};

fn cell(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Float(f) => format!("{f}"),
        other => other.to_string(),
    }
}

fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Header of trials.csv.
pub fn trials_header(grid_keys: &[String]) -> String {
    let mut h = vec!["point".to_string()];
    h.extend(grid_keys.iter().cloned());
    h.extend(
        [
            "method",
            "trial",
            "ok",
            "rotation_error_deg",
            "translation_error_mm",
            "frobenius_rotation",
            "centre_error_mm",
            "accuracy_mm",
            "edge_angle_dev_deg",
            "edge_distance_mm",
            "sphere_radius_mm",
            "missed_profiles",
            "error",
        ]
        .map(String::from),
    );
    h.join(",") + "\n"
}

/// One line of trials.csv.
pub fn trial_line(r: &TrialRow) -> String {
    let mut c = vec![r.point.to_string()];
    c.extend(r.values.iter().map(|(_, v)| quote(&cell(v))));
    c.push(r.outcome.method.clone());
    c.push(r.outcome.trial.to_string());
    match &r.outcome.result {
        Ok(s) => {
            c.push("true".into());
            for x in [
                s.error.rotation_error_deg,
                s.error.translation_error_mm,
                s.error.frobenius_rotation,
            ] {
                c.push(format!("{x}"));
            }
            for x in [
                s.centre_error_mm,
                s.accuracy_mm,
                s.edge_angle_dev_deg,
                s.edge_distance_mm,
                s.sphere_radius_mm,
            ] {
                c.push(x.map(|v| format!("{v}")).unwrap_or_default());
            }
            c.push(r.outcome.missed_profiles.to_string());
            c.push(String::new());
        }
        Err(e) => {
            c.push("false".into());
            c.extend(std::iter::repeat_n(String::new(), 8));
            c.push(r.outcome.missed_profiles.to_string());
            c.push(quote(e));
        }
    }
    c.join(",") + "\n"
}

/// The whole summary.csv.
pub fn summary(grid_keys: &[String], rows: &[SummaryRow]) -> String {
    let mut h = vec!["point".to_string()];
    h.extend(grid_keys.iter().cloned());
    h.extend(["method", "trials", "failures"].map(String::from));
    for m in METRICS {
        for s in ["mean", "rms", "std", "median", "p95"] {
            h.push(format!("{m}_{s}"));
        }
    }
    let mut out = h.join(",") + "\n";
    for r in rows {
        let mut c = vec![r.point.to_string()];
        c.extend(r.values.iter().map(|(_, v)| quote(&cell(v))));
        c.push(r.method.clone());
        c.push(r.trials.to_string());
        c.push(r.failures.to_string());
        for s in &r.stats {
            for x in [s.mean, s.rms, s.std, s.median, s.p95] {
                c.push(format!("{x}"));
            }
        }
        out += &(c.join(",") + "\n");
    }
    out
}

/// The value of a summary column for a row (grid keys, `trials`, `failures`, `<metric>_<stat>`).
pub fn summary_value(r: &SummaryRow, column: &str) -> Option<f64> {
    if let Some((_, v)) = r.values.iter().find(|(k, _)| k == column) {
        return match v {
            toml::Value::Float(f) => Some(*f),
            toml::Value::Integer(i) => Some(*i as f64),
            _ => None,
        };
    }
    match column {
        "trials" => return Some(r.trials as f64),
        "failures" => return Some(r.failures as f64),
        _ => {}
    }
    for (k, m) in METRICS.iter().enumerate() {
        if let Some(stat) = column.strip_prefix(m).and_then(|s| s.strip_prefix('_')) {
            let s = r.stats.get(k)?;
            return match stat {
                "mean" => Some(s.mean),
                "rms" => Some(s.rms),
                "std" => Some(s.std),
                "median" => Some(s.median),
                "p95" => Some(s.p95),
                _ => None,
            };
        }
    }
    None
}

/// Split one CSV line into fields (double-quoted fields may hold commas and doubled quotes).
pub fn split_line(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            (c, _) => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// Parse trials.csv back into the numbers a summary needs, keeping each line's text. Errors name
/// the line and the field.
pub fn parse_trials(
    text: &str,
    grid_keys: &[String],
    file: &str,
) -> Result<Vec<(crate::sweep::MetricRow, String)>, String> {
    let mut lines = text.lines();
    let header = lines.next().ok_or_else(|| format!("{file}: empty file"))?;
    if format!("{header}\n") != trials_header(grid_keys) {
        return Err(format!(
            "{file}: line 1: the header does not match this scenario's grid ({})",
            grid_keys.join(", ")
        ));
    }
    let g = grid_keys.len();
    let mut out = Vec::new();
    for (i, line) in lines.enumerate() {
        let n = i + 2;
        let f = split_line(line);
        if f.len() != g + 14 {
            return Err(format!(
                "{file}: line {n}: {} fields, expected {}",
                f.len(),
                g + 14
            ));
        }
        let num = |k: usize, what: &str| -> Result<Option<f64>, String> {
            if f[k].is_empty() {
                Ok(None)
            } else {
                f[k].parse::<f64>()
                    .map(Some)
                    .map_err(|_| format!("{file}: line {n}: {what} = '{}' is not a number", f[k]))
            }
        };
        let point = f[0]
            .parse::<usize>()
            .map_err(|_| format!("{file}: line {n}: point = '{}' is not an index", f[0]))?;
        let trial = f[g + 2]
            .parse::<u64>()
            .map_err(|_| format!("{file}: line {n}: trial = '{}' is not an index", f[g + 2]))?;
        let ok = match f[g + 3].as_str() {
            "true" => true,
            "false" => false,
            v => {
                return Err(format!(
                    "{file}: line {n}: ok = '{v}', expected true or false"
                ));
            }
        };
        let metrics = [
            num(g + 7, "centre_error_mm")?,
            num(g + 4, "rotation_error_deg")?,
            num(g + 5, "translation_error_mm")?,
            num(g + 9, "edge_angle_dev_deg")?,
            num(g + 10, "edge_distance_mm")?,
            num(g + 11, "sphere_radius_mm")?,
        ];
        out.push((
            crate::sweep::MetricRow {
                point,
                method: f[g + 1].clone(),
                trial,
                ok,
                metrics,
            },
            format!("{line}\n"),
        ));
    }
    Ok(out)
}
