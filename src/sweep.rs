//! Sweeps: every grid point of a scenario times its trials, run in parallel (rayon) with per-trial
//! seeds, rows streamed to a sink in a fixed order, per-point statistics at the end.

use crate::scenario::{GridPoint, ScenarioError, ScenarioFile};
use crate::trial::{TrialOutcome, run_trial};
use rayon::prelude::*;

/// The metrics summarised per grid point and method.
pub const METRICS: &[&str] = &[
    "centre_error_mm",
    "rotation_error_deg",
    "translation_error_mm",
    "edge_angle_dev_deg",
    "edge_distance_mm",
    "sphere_radius_mm",
];

/// Which share of the trials to run: trial t belongs to shard k of n when t % n == k.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    pub const ALL: Shard = Shard { index: 0, count: 1 };
    pub fn owns(&self, trial: usize) -> bool {
        trial % self.count == self.index
    }
}

/// mean, RMS, standard deviation (n - 1), median and 95th percentile (nearest rank) of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stats {
    pub n: usize,
    pub mean: f64,
    pub rms: f64,
    pub std: f64,
    pub median: f64,
    pub p95: f64,
}

impl Stats {
    pub fn of(values: &[f64]) -> Stats {
        let n = values.len();
        if n == 0 {
            return Stats {
                n,
                mean: f64::NAN,
                rms: f64::NAN,
                std: f64::NAN,
                median: f64::NAN,
                p95: f64::NAN,
            };
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let rms = (values.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
        let std = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let mut s = values.to_vec();
        s.sort_by(f64::total_cmp);
        let rank = ((0.95 * n as f64).ceil() as usize).clamp(1, n);
        Stats {
            n,
            mean,
            rms,
            std,
            median: if n % 2 == 1 {
                s[n / 2]
            } else {
                0.5 * (s[n / 2 - 1] + s[n / 2])
            },
            p95: s[rank - 1],
        }
    }
}

/// Summary of one (grid point, method).
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryRow {
    pub point: usize,
    pub values: Vec<(String, toml::Value)>,
    pub method: String,
    pub trials: usize,
    pub failures: usize,
    /// One `Stats` per entry of `METRICS`.
    pub stats: Vec<Stats>,
}

/// A trial row as written to trials.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialRow {
    pub point: usize,
    pub values: Vec<(String, toml::Value)>,
    pub outcome: TrialOutcome,
}

impl TrialRow {
    /// The value of metric `k` (index into `METRICS`), when the trial succeeded.
    pub fn metric(&self, k: usize) -> Option<f64> {
        let s = self.outcome.result.as_ref().ok()?;
        match k {
            0 => s.centre_error_mm,
            1 => Some(s.error.rotation_error_deg),
            2 => Some(s.error.translation_error_mm),
            3 => s.edge_angle_dev_deg,
            4 => s.edge_distance_mm,
            _ => s.sphere_radius_mm,
        }
    }
}

#[derive(Debug, Clone)]
pub struct SweepPlan {
    pub points: Vec<GridPoint>,
    pub trials: usize,
    pub seed: u64,
    pub grid_keys: Vec<String>,
}

impl SweepPlan {
    /// The sweep a scenario file describes; `trials` overrides its trial count.
    pub fn new(
        sf: &ScenarioFile,
        trials: Option<usize>,
        seed: Option<u64>,
    ) -> Result<SweepPlan, ScenarioError> {
        let points = sf.grid()?;
        let trials = trials
            .or(sf.scenario.sweep.as_ref().map(|s| s.trials))
            .unwrap_or(1);
        let grid_keys = points
            .first()
            .map(|p| p.values.iter().map(|v| v.0.clone()).collect())
            .unwrap_or_default();
        Ok(SweepPlan {
            points,
            trials,
            seed: seed.unwrap_or(sf.scenario.seed),
            grid_keys,
        })
    }

    /// Trials this shard runs, over all points and methods.
    pub fn work(&self, shard: Shard) -> usize {
        let per_point = (0..self.trials).filter(|t| shard.owns(*t)).count();
        self.points
            .iter()
            .map(|p| p.scenario.methods.len() * per_point)
            .sum()
    }
}

/// Run the sweep: for each grid point (in order) build the experiment once, run this shard's trials
/// in parallel chunks, and hand each chunk's rows, in trial order, to `sink`. `progress` is told
/// how many trials are done.
pub fn run(
    plan: &SweepPlan,
    file: &str,
    shard: Shard,
    mut sink: impl FnMut(&[TrialRow]) -> std::io::Result<()>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<SummaryRow>, SweepError> {
    const CHUNK: usize = 512;
    let mut summary = Vec::new();
    let mut done = 0;
    for point in &plan.points {
        let setup = point.scenario.build(file).map_err(SweepError::Scenario)?;
        for method in &point.scenario.methods {
            let mine: Vec<usize> = (0..plan.trials).filter(|t| shard.owns(*t)).collect();
            let mut metrics: Vec<Vec<f64>> = vec![Vec::new(); METRICS.len()];
            let mut failures = 0;
            for chunk in mine.chunks(CHUNK) {
                let rows: Vec<TrialRow> = chunk
                    .par_iter()
                    .map(|&t| TrialRow {
                        point: point.index,
                        values: point.values.clone(),
                        outcome: run_trial(&setup, method, plan.seed, t as u64),
                    })
                    .collect();
                for r in &rows {
                    match r.outcome.result {
                        Ok(_) => (0..METRICS.len()).for_each(|k| metrics[k].extend(r.metric(k))),
                        Err(_) => failures += 1,
                    }
                }
                sink(&rows).map_err(|e| SweepError::Io(e.to_string()))?;
                done += rows.len();
                progress(done);
            }
            summary.push(SummaryRow {
                point: point.index,
                values: point.values.clone(),
                method: method.clone(),
                trials: mine.len(),
                failures,
                stats: metrics.iter().map(|m| Stats::of(m)).collect(),
            });
        }
    }
    Ok(summary)
}

/// The per-trial numbers a summary needs (what trials.csv holds).
#[derive(Debug, Clone, PartialEq)]
pub struct MetricRow {
    pub point: usize,
    pub method: String,
    pub trial: u64,
    pub ok: bool,
    pub metrics: [Option<f64>; 6],
}

impl From<&TrialRow> for MetricRow {
    fn from(r: &TrialRow) -> MetricRow {
        MetricRow {
            point: r.point,
            method: r.outcome.method.clone(),
            trial: r.outcome.trial,
            ok: r.outcome.result.is_ok(),
            metrics: std::array::from_fn(|k| r.metric(k)),
        }
    }
}

/// Summaries from metric rows in run order (point, method, trial), e.g. merged shards; equal to
/// what `run` computes for the same rows.
pub fn summarise_metrics(rows: &[MetricRow], points: &[GridPoint]) -> Vec<SummaryRow> {
    let mut out: Vec<SummaryRow> = Vec::new();
    let mut start = 0;
    while start < rows.len() {
        let (p, m) = (rows[start].point, &rows[start].method);
        let mut end = start;
        while end < rows.len() && rows[end].point == p && &rows[end].method == m {
            end += 1;
        }
        let g = &rows[start..end];
        out.push(SummaryRow {
            point: p,
            values: points
                .get(p)
                .map(|gp| gp.values.clone())
                .unwrap_or_default(),
            method: m.clone(),
            trials: g.len(),
            failures: g.iter().filter(|r| !r.ok).count(),
            stats: (0..METRICS.len())
                .map(|k| {
                    Stats::of(
                        &g.iter()
                            .filter(|r| r.ok)
                            .filter_map(|r| r.metrics[k])
                            .collect::<Vec<_>>(),
                    )
                })
                .collect(),
        });
        start = end;
    }
    out
}

/// Summaries from trial rows (for merging shards): groups by (point, method) in first-seen order,
/// which is the run order when the rows are.
pub fn summarise(rows: &[TrialRow]) -> Vec<SummaryRow> {
    let mut keys: Vec<(usize, String)> = Vec::new();
    let mut groups: std::collections::HashMap<(usize, String), Vec<&TrialRow>> =
        std::collections::HashMap::new();
    for r in rows {
        let k = (r.point, r.outcome.method.clone());
        if !groups.contains_key(&k) {
            keys.push(k.clone());
        }
        groups.entry(k).or_default().push(r);
    }
    keys.into_iter()
        .map(|k| {
            let g = &groups[&k];
            let stats = (0..METRICS.len())
                .map(|m| Stats::of(&g.iter().filter_map(|r| r.metric(m)).collect::<Vec<_>>()))
                .collect();
            SummaryRow {
                point: k.0,
                values: g[0].values.clone(),
                method: k.1,
                trials: g.len(),
                failures: g.iter().filter(|r| r.outcome.result.is_err()).count(),
                stats,
            }
        })
        .collect()
}

#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error(transparent)]
    Scenario(ScenarioError),
    #[error("writing results: {0}")]
    Io(String),
}
