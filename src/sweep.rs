//! Sweeps: every grid point of a scenario times its trials, run in parallel (rayon) with per-trial
//! seeds, rows streamed to a sink in a fixed order, per-point statistics at the end.

use crate::error::Error;
use crate::method::MethodId;
use crate::metrics::{Metric, Metrics, Stat};
use crate::scenario::ScenarioFile;
use crate::trial::{TrialOutcome, run_trial};
use rayon::prelude::*;

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

    pub fn get(&self, s: Stat) -> f64 {
        match s {
            Stat::Mean => self.mean,
            Stat::Rms => self.rms,
            Stat::Std => self.std,
            Stat::Median => self.median,
            Stat::P95 => self.p95,
        }
    }
}

/// Summary of one (grid point, method).
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryRow {
    pub point: usize,
    pub values: Vec<(String, toml::Value)>,
    pub method: MethodId,
    pub trials: usize,
    pub failures: usize,
    /// One `Stats` per entry of `Metric::SUMMARISED`.
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
    /// The value of a metric, when the trial succeeded and the method reports it.
    pub fn metric(&self, m: Metric) -> Option<f64> {
        self.outcome.result.as_ref().ok()?.metrics.get(m)
    }
}

/// A sweep: the scenario file (whose grid points are built one at a time), each point's grid
/// values (for the summaries), the trials and the seed. Its memory does not grow with the grid
/// beyond the values.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    pub sf: ScenarioFile,
    /// Each grid point's (key, value) overrides, in grid order.
    pub values: Vec<Vec<(String, toml::Value)>>,
    /// Each grid point's method count.
    methods: Vec<usize>,
    pub trials: usize,
    pub seed: u64,
    pub grid_keys: Vec<String>,
}

impl SweepPlan {
    /// The sweep a scenario file describes; `trials` overrides its trial count.
    pub fn new(sf: &ScenarioFile, trials: Option<usize>, seed: Option<u64>) -> SweepPlan {
        let (mut values, mut methods) = (Vec::new(), Vec::new());
        // Validated at load: every point builds.
        for p in sf.points().flatten() {
            methods.push(p.scenario.methods.len());
            values.push(p.values);
        }
        let trials = trials
            .or(sf.scenario.sweep.as_ref().map(|s| s.trials))
            .unwrap_or(1);
        let grid_keys = values
            .first()
            .map(|v| v.iter().map(|v| v.0.clone()).collect())
            .unwrap_or_default();
        SweepPlan {
            sf: sf.clone(),
            values,
            methods,
            trials,
            seed: seed.unwrap_or(sf.scenario.seed),
            grid_keys,
        }
    }

    /// Grid points.
    pub fn n_points(&self) -> usize {
        self.values.len()
    }

    /// Trials this shard runs, over all points and methods.
    pub fn work(&self, shard: Shard) -> usize {
        let per_point = (0..self.trials).filter(|t| shard.owns(*t)).count();
        self.methods.iter().map(|m| m * per_point).sum()
    }
}

/// Accumulates one (point, method)'s summarised metrics.
struct Accumulator {
    values: Vec<Vec<f64>>,
    trials: usize,
    failures: usize,
}

impl Accumulator {
    fn new() -> Accumulator {
        Accumulator {
            values: vec![Vec::new(); Metric::SUMMARISED.len()],
            trials: 0,
            failures: 0,
        }
    }

    fn add(&mut self, ok: bool, metrics: &Metrics) {
        self.trials += 1;
        if !ok {
            self.failures += 1;
            return;
        }
        for (k, m) in Metric::SUMMARISED.into_iter().enumerate() {
            self.values[k].extend(metrics.get(m));
        }
    }

    fn finish(
        self,
        point: usize,
        values: Vec<(String, toml::Value)>,
        method: MethodId,
    ) -> SummaryRow {
        SummaryRow {
            point,
            values,
            method,
            trials: self.trials,
            failures: self.failures,
            stats: self.values.iter().map(|v| Stats::of(v)).collect(),
        }
    }
}

/// The seed of a grid point's trials: the sweep's, or with independent draws one derived from the
/// point's grid values (not its index, so a reordered grid keeps each point's draws).
pub fn point_seed(plan: &SweepPlan, values: &[(String, toml::Value)]) -> u64 {
    let draws = plan.sf.scenario.sweep.as_ref().map(|s| s.draws);
    if draws != Some(crate::schema::Draws::Independent) {
        return plan.seed;
    }
    let text: String = values.iter().map(|(k, v)| format!("{k}={v};")).collect();
    crate::rng::derive(
        plan.seed,
        &[crate::rng::tag::GRID_POINT, crate::rng::text_hash(&text)],
    )
}

/// One chunk of a (point, method)'s trials, in trial order; the last one carries what its
/// summary row is keyed by.
struct Chunk {
    rows: Vec<TrialRow>,
    end: Option<(usize, Vec<(String, toml::Value)>, MethodId)>,
}

/// Run the sweep: for each grid point (in order) build the experiment once, run this shard's trials
/// in parallel chunks, and hand each chunk's rows, in trial order, to `sink`. `progress` is told
/// how many trials are done.
///
/// The trials are computed on a thread of their own (rayon's pool under it) while this one
/// hands the previous chunk to `sink`: writing rows no longer leaves a core idle between grid
/// points. The rows and their order are the same.
pub fn run(
    plan: &SweepPlan,
    file: &str,
    shard: Shard,
    mut sink: impl FnMut(&[TrialRow]) -> Result<(), Error>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<SummaryRow>, Error> {
    let mine: Vec<usize> = (0..plan.trials).filter(|t| shard.owns(*t)).collect();
    std::thread::scope(|s| {
        // Two chunks ahead at most: a slow sink holds the trials back, not memory.
        let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Chunk, Error>>(2);
        s.spawn(move || {
            if let Err(e) = produce(plan, file, &mine, &tx) {
                // The receiver may be gone already (the sink failed first).
                let _ = tx.send(Err(e));
            }
        });
        let (mut summary, mut acc, mut done) = (Vec::new(), Accumulator::new(), 0);
        for chunk in rx {
            let chunk = chunk?;
            for r in &chunk.rows {
                let m = r.outcome.result.as_ref().map(|s| s.metrics);
                acc.add(m.is_ok(), &m.unwrap_or_default());
            }
            if !chunk.rows.is_empty() {
                sink(&chunk.rows)?;
                done += chunk.rows.len();
                progress(done);
            }
            if let Some((point, values, method)) = chunk.end {
                let finished = std::mem::replace(&mut acc, Accumulator::new());
                summary.push(finished.finish(point, values, method));
            }
        }
        Ok(summary)
    })
}

/// Every (point, method)'s trials of `mine` in chunks, in order, into `tx`; stops early when
/// the receiver is gone.
fn produce(
    plan: &SweepPlan,
    file: &str,
    mine: &[usize],
    tx: &std::sync::mpsc::SyncSender<Result<Chunk, Error>>,
) -> Result<(), Error> {
    const CHUNK: usize = 512;
    for point in plan.sf.points() {
        let point = point?;
        let setup = point.scenario.build(file)?;
        let seed = point_seed(plan, &point.values);
        for &method in &point.scenario.methods {
            let n = mine.len().div_ceil(CHUNK).max(1);
            for k in 0..n {
                let chunk = &mine[(k * CHUNK).min(mine.len())..((k + 1) * CHUNK).min(mine.len())];
                let rows: Vec<TrialRow> = chunk
                    .par_iter()
                    .map(|&t| TrialRow {
                        point: point.index,
                        values: point.values.clone(),
                        outcome: run_trial(&setup, method, seed, t as u64),
                    })
                    .collect();
                let end = (k + 1 == n).then(|| (point.index, point.values.clone(), method));
                if tx.send(Ok(Chunk { rows, end })).is_err() {
                    return Ok(());
                }
            }
        }
    }
    Ok(())
}

/// The per-trial numbers a summary needs (what trials.csv holds).
#[derive(Debug, Clone, PartialEq)]
pub struct MetricRow {
    pub point: usize,
    pub method: MethodId,
    pub trial: u64,
    pub ok: bool,
    pub metrics: Metrics,
}

/// Summaries built from metric rows fed one at a time in run order (point, method, trial): what
/// `merge` streams through, holding only the current (point, method)'s values.
pub struct Summariser<'a> {
    points: &'a [Vec<(String, toml::Value)>],
    current: Option<(usize, MethodId, Accumulator)>,
    done: Vec<SummaryRow>,
}

impl<'a> Summariser<'a> {
    pub fn new(points: &'a [Vec<(String, toml::Value)>]) -> Summariser<'a> {
        Summariser {
            points,
            current: None,
            done: Vec::new(),
        }
    }

    pub fn add(&mut self, r: &MetricRow) {
        if self
            .current
            .as_ref()
            .is_none_or(|(p, m, _)| (*p, *m) != (r.point, r.method))
        {
            self.close();
            self.current = Some((r.point, r.method, Accumulator::new()));
        }
        if let Some((_, _, acc)) = &mut self.current {
            acc.add(r.ok, &r.metrics);
        }
    }

    fn close(&mut self) {
        if let Some((p, m, acc)) = self.current.take() {
            let values = self.points.get(p).cloned().unwrap_or_default();
            self.done.push(acc.finish(p, values, m));
        }
    }

    pub fn finish(mut self) -> Vec<SummaryRow> {
        self.close();
        self.done
    }
}

/// Summaries from metric rows in run order (point, method, trial), e.g. merged shards; equal to
/// what `run` computes for the same rows.
pub fn summarise_metrics(
    rows: &[MetricRow],
    points: &[Vec<(String, toml::Value)>],
) -> Vec<SummaryRow> {
    let mut s = Summariser::new(points);
    for r in rows {
        s.add(r);
    }
    s.finish()
}
