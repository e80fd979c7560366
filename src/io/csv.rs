//! trials.csv and summary.csv, written and read with the `csv` crate. Numbers are printed in
//! Rust's shortest round-trip form, so equal values always give equal bytes (merging shards
//! reproduces an unsharded run exactly). The columns come from `metrics::Metric`.

use super::FormatError;
use crate::method::MethodId;
use crate::metrics::{Metric, Metrics, Stat, column, parse_column};
use crate::sweep::{MetricRow, SummaryRow, TrialRow};
use std::io::{Read, Write};

/// A grid value as a cell: strings bare, floats in shortest form.
fn cell(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Float(f) => format!("{f}"),
        other => other.to_string(),
    }
}

fn num(x: f64) -> String {
    format!("{x}")
}

/// The columns of trials.csv after the point and the grid keys.
const TRIAL_HEAD: [&str; 3] = ["method", "trial", "ok"];
const TRIAL_TAIL: [&str; 2] = ["missed_profiles", "error"];

/// Header of trials.csv.
pub fn trials_header(grid_keys: &[String]) -> Vec<String> {
    let mut h = vec!["point".to_string()];
    h.extend(grid_keys.iter().cloned());
    h.extend(TRIAL_HEAD.map(String::from));
    h.extend(Metric::ALL.map(|m| m.name().to_string()));
    h.extend(TRIAL_TAIL.map(String::from));
    h
}

fn writer<W: Write>(w: W) -> csv::Writer<W> {
    csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(w)
}

fn csv_err(file: &str, e: csv::Error) -> FormatError {
    FormatError::Field {
        file: file.to_string(),
        at: e
            .position()
            .map(|p| format!("line {}", p.line()))
            .unwrap_or_else(|| "CSV".into()),
        message: e.to_string(),
    }
}

/// Streams trial rows to trials.csv.
pub struct TrialsWriter<W: Write> {
    w: csv::Writer<W>,
    file: String,
}

impl<W: Write> TrialsWriter<W> {
    /// Write the header; `file` names the output in errors.
    pub fn new(w: W, grid_keys: &[String], file: &str) -> Result<Self, FormatError> {
        let mut w = writer(w);
        w.write_record(trials_header(grid_keys))
            .map_err(|e| csv_err(file, e))?;
        Ok(TrialsWriter {
            w,
            file: file.to_string(),
        })
    }

    pub fn write(&mut self, r: &TrialRow) -> Result<(), FormatError> {
        self.w
            .write_record(trial_record(r))
            .map_err(|e| csv_err(&self.file, e))
    }

    /// Write a record read back from a shard as it is.
    pub fn write_raw(&mut self, record: &csv::StringRecord) -> Result<(), FormatError> {
        self.w
            .write_record(record)
            .map_err(|e| csv_err(&self.file, e))
    }

    pub fn finish(mut self) -> Result<W, FormatError> {
        self.w.flush().map_err(|e| FormatError::Field {
            file: self.file.clone(),
            at: "flush".into(),
            message: e.to_string(),
        })?;
        let file = self.file.clone();
        self.w.into_inner().map_err(|e| FormatError::Field {
            file,
            at: "flush".into(),
            message: e.to_string(),
        })
    }
}

/// One record of trials.csv.
fn trial_record(r: &TrialRow) -> Vec<String> {
    let mut c = vec![r.point.to_string()];
    c.extend(r.values.iter().map(|(_, v)| cell(v)));
    c.push(r.outcome.method.to_string());
    c.push(r.outcome.trial.to_string());
    match &r.outcome.result {
        Ok(s) => {
            c.push("true".into());
            c.extend(Metric::ALL.map(|m| s.metrics.get(m).map(num).unwrap_or_default()));
            c.push(r.outcome.missed_profiles.to_string());
            c.push(String::new());
        }
        Err(e) => {
            c.push("false".into());
            c.extend(Metric::ALL.map(|_| String::new()));
            c.push(r.outcome.missed_profiles.to_string());
            c.push(e.to_string());
        }
    }
    c
}

/// The whole summary.csv.
pub fn summary(grid_keys: &[String], rows: &[SummaryRow]) -> Result<Vec<u8>, FormatError> {
    let mut w = writer(Vec::new());
    let err = |e| csv_err("summary.csv", e);
    let mut h = vec!["point".to_string()];
    h.extend(grid_keys.iter().cloned());
    h.extend(["method", "trials", "failures"].map(String::from));
    // A metric no result has (a disk sweep's edge figures) leaves no columns of NaN behind.
    let kept: Vec<usize> = (0..Metric::SUMMARISED.len())
        .filter(|&m| {
            rows.iter().any(|r| {
                r.stats
                    .get(m)
                    .is_some_and(|s| Stat::ALL.iter().any(|&k| !s.get(k).is_nan()))
            })
        })
        .collect();
    h.extend(
        kept.iter()
            .flat_map(|&m| Stat::ALL.map(|s| column(Metric::SUMMARISED[m], s))),
    );
    w.write_record(&h).map_err(err)?;
    for r in rows {
        let mut c = vec![r.point.to_string()];
        c.extend(r.values.iter().map(|(_, v)| cell(v)));
        c.push(r.method.to_string());
        c.push(r.trials.to_string());
        c.push(r.failures.to_string());
        for &m in &kept {
            let s = &r.stats[m];
            c.extend(Stat::ALL.map(|k| num(s.get(k))));
        }
        w.write_record(&c).map_err(err)?;
    }
    w.into_inner().map_err(|e| FormatError::Field {
        file: "summary.csv".into(),
        at: "flush".into(),
        message: e.to_string(),
    })
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
    let (m, s) = parse_column(column)?;
    let k = Metric::SUMMARISED.iter().position(|x| *x == m)?;
    r.stats.get(k).map(|st| st.get(s))
}

/// Whether `column` names a summary column (for checking plot keys before a sweep runs).
pub fn is_summary_column(grid_keys: &[String], column: &str) -> bool {
    grid_keys.iter().any(|k| k == column)
        || matches!(column, "trials" | "failures")
        || parse_column(column).is_some_and(|(m, _)| Metric::SUMMARISED.contains(&m))
}

/// Read trials.csv back: each row's metrics and its record (to copy it unchanged). Errors name
/// the file, the line and the field.
pub fn read_trials<R: Read>(
    input: R,
    grid_keys: &[String],
    file: &str,
) -> Result<
    impl Iterator<Item = Result<(MetricRow, csv::StringRecord), FormatError>> + use<R>,
    FormatError,
> {
    let mut rd = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .from_reader(input);
    let header = rd.headers().map_err(|e| csv_err(file, e))?.clone();
    let want = trials_header(grid_keys);
    if header.iter().ne(want.iter().map(String::as_str)) {
        return Err(FormatError::Field {
            file: file.to_string(),
            at: "line 1".into(),
            message: format!(
                "the header does not match this scenario's grid ({})",
                grid_keys.join(", ")
            ),
        });
    }
    let g = grid_keys.len();
    let file = file.to_string();
    Ok(rd.into_records().map(move |rec| {
        let rec = rec.map_err(|e| csv_err(&file, e))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let bad = |what: &str, v: &str, expected: &str| FormatError::Field {
            file: file.clone(),
            at: format!("line {line}"),
            message: format!("{what} = '{v}': {expected}"),
        };
        let f = |k: usize| rec.get(k).unwrap_or("");
        let point = f(0)
            .parse::<usize>()
            .map_err(|_| bad("point", f(0), "not an index"))?;
        let method = f(g + 1)
            .parse::<MethodId>()
            .map_err(|e| bad("method", f(g + 1), &e.to_string()))?;
        let trial = f(g + 2)
            .parse::<u64>()
            .map_err(|_| bad("trial", f(g + 2), "not an index"))?;
        let ok = match f(g + 3) {
            "true" => true,
            "false" => false,
            v => return Err(bad("ok", v, "expected true or false")),
        };
        let mut metrics = Metrics::default();
        for (i, m) in Metric::ALL.into_iter().enumerate() {
            let v = f(g + 4 + i);
            if !v.is_empty() {
                let x = v
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| bad(m.name(), v, "not a finite number"))?;
                metrics.set(m, Some(x));
            }
        }
        Ok((
            MetricRow {
                point,
                method,
                trial,
                ok,
                metrics,
            },
            rec,
        ))
    }))
}

/// The pose-list keys a CSV header can stand for (`[<section>.poses] csv = "..."`), by its
/// columns (case and spaces ignored).
const POSE_LISTS: [(&str, [&str; 7]); 5] = [
    (
        "tcp_mm_wxyz",
        ["x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz"],
    ),
    (
        "tcp_mm_wpr_deg",
        ["x_mm", "y_mm", "z_mm", "w_deg", "p_deg", "r_deg", ""],
    ),
    (
        "tcp_mm_abc_deg",
        ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg", ""],
    ),
    (
        "tcp_mm_rotvec_rad",
        ["x_mm", "y_mm", "z_mm", "rx_rad", "ry_rad", "rz_rad", ""],
    ),
    (
        "joints_deg",
        [
            "j1_deg", "j2_deg", "j3_deg", "j4_deg", "j5_deg", "j6_deg", "",
        ],
    ),
];

/// Most rows a pose list may hold (as the scenario's own lists).
const MAX_POSES: usize = 10_000;

/// A pose list from CSV: its header names the convention (one of `POSE_LISTS`), each row one
/// pose. Returns the scenario key it stands for and its rows.
pub fn pose_list<R: Read>(
    reader: R,
    file: &str,
) -> Result<(&'static str, Vec<Vec<f64>>), FormatError> {
    let field = |at: String, message: String| FormatError::Field {
        file: file.to_string(),
        at,
        message,
    };
    let mut r = ::csv::ReaderBuilder::new()
        .trim(::csv::Trim::All)
        .from_reader(reader);
    let head: Vec<String> = r
        .headers()
        .map_err(|e| field("line 1".into(), e.to_string()))?
        .iter()
        .map(|h| h.to_lowercase())
        .collect();
    let (key, cols) = POSE_LISTS
        .iter()
        .find(|(_, cols)| {
            let want: Vec<&str> = cols.iter().copied().filter(|c| !c.is_empty()).collect();
            head.len() == want.len() && head.iter().zip(&want).all(|(h, w)| h == w)
        })
        .ok_or_else(|| {
            field(
                "line 1".into(),
                format!(
                    "header {:?} is no pose list; give one of: {}",
                    head.join(","),
                    POSE_LISTS
                        .iter()
                        .map(|(_, c)| c
                            .iter()
                            .filter(|c| !c.is_empty())
                            .copied()
                            .collect::<Vec<_>>()
                            .join(","))
                        .collect::<Vec<_>>()
                        .join(" | ")
                ),
            )
        })?;
    let width = cols.iter().filter(|c| !c.is_empty()).count();
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let line = format!("line {}", i + 2);
        let rec = rec.map_err(|e| field(line.clone(), e.to_string()))?;
        if rows.len() == MAX_POSES {
            return Err(field(line, format!("more than {MAX_POSES} poses")));
        }
        if rec.len() != width {
            return Err(field(
                line,
                format!("{} values; the header has {width}", rec.len()),
            ));
        }
        let row = rec
            .iter()
            .enumerate()
            .map(|(k, v)| {
                v.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        field(
                            format!("{line}, {}", head[k]),
                            format!("{v:?} is not a finite number"),
                        )
                    })
            })
            .collect::<Result<Vec<f64>, _>>()?;
        rows.push(row);
    }
    Ok((key, rows))
}
