use super::common::{load_scenario, progress};
use anyhow::{Context, Result, bail};
use lasercal::method::MethodId;
use lasercal::trial::run_trial;
use rayon::prelude::*;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (its base values; a sweep grid is ignored)
    scenario: PathBuf,
    /// Largest allowed rotation error (deg) at the percentile, for every method without its own
    /// --bound
    #[arg(long, allow_negative_numbers = true)]
    max_rotation_deg: Option<f64>,
    /// Largest allowed translation error (mm) at the percentile, for every method without its own
    /// --bound
    #[arg(long, allow_negative_numbers = true)]
    max_translation_mm: Option<f64>,
    /// One method's bounds, METHOD=ROTATION_DEG,TRANSLATION_MM (e.g. disk-refined=0.02,0.03);
    /// repeat for each method
    #[arg(long = "bound", value_name = "METHOD=DEG,MM")]
    bounds: Vec<String>,
    /// Number of trials
    #[arg(long, default_value_t = 100)]
    trials: usize,
    /// Percentile of the errors compared with the bounds (nearest rank)
    #[arg(long, default_value_t = 95.0, allow_negative_numbers = true)]
    percentile: f64,
    /// Seed (default: the scenario's)
    #[arg(long)]
    seed: Option<u64>,
    /// Write each method's figures, bounds and outcome as JSON
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write a JUnit XML report (one test case per method) for a CI system to show
    #[arg(long)]
    junit: Option<PathBuf>,
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let rank = ((p / 100.0 * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[rank - 1]
}

/// A method's bounds: deg, mm.
type Bound = (f64, f64);

/// Each of the scenario's methods with its bounds: its own --bound, else the common ones.
fn bounds_of(a: &Args, methods: &[MethodId]) -> Result<Vec<(MethodId, Bound)>> {
    let positive = |v: f64, what: &str| -> Result<f64> {
        if v > 0.0 && v.is_finite() {
            Ok(v)
        } else {
            bail!("{what} {v}: a bound must be a positive number")
        }
    };
    let mut own: Vec<(MethodId, Bound)> = Vec::new();
    for b in &a.bounds {
        let bad = || {
            format!("--bound {b}: write METHOD=ROTATION_DEG,TRANSLATION_MM, e.g. disk=0.06,0.05")
        };
        let (m, v) = b.split_once('=').with_context(bad)?;
        let id: MethodId = m
            .trim()
            .parse()
            .map_err(|e| anyhow::anyhow!("--bound {b}: {e}"))?;
        if !methods.contains(&id) {
            bail!(
                "--bound {b}: the scenario does not run {id} (it runs {})",
                names(methods)
            );
        }
        let (r, t) = v.split_once(',').with_context(bad)?;
        let num = |s: &str| s.trim().parse::<f64>().with_context(bad);
        own.push((
            id,
            (
                positive(num(r)?, &format!("--bound {b}: rotation"))?,
                positive(num(t)?, &format!("--bound {b}: translation"))?,
            ),
        ));
    }
    let common = match (a.max_rotation_deg, a.max_translation_mm) {
        (Some(r), Some(t)) => Some((
            positive(r, "--max-rotation-deg")?,
            positive(t, "--max-translation-mm")?,
        )),
        (None, None) => None,
        _ => bail!("give both --max-rotation-deg and --max-translation-mm, or neither"),
    };
    methods
        .iter()
        .map(|&m| match own.iter().rev().find(|(id, _)| *id == m) {
            Some(&(_, b)) => Ok((m, b)),
            None => common.map(|b| (m, b)).with_context(|| {
                format!(
                    "{m} has no bounds: give --max-rotation-deg and --max-translation-mm, or \
                     --bound {m}=DEG,MM"
                )
            }),
        })
        .collect()
}

fn names(methods: &[MethodId]) -> String {
    methods
        .iter()
        .map(|m| m.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// One method's outcome.
struct Outcome {
    method: MethodId,
    bound: Bound,
    /// The percentile's rotation (deg) and translation (mm) errors; None when trials failed.
    figures: Option<(f64, f64)>,
    failed_trials: usize,
    first_failure: Option<String>,
    line: String,
}

impl Outcome {
    fn passed(&self) -> bool {
        self.figures
            .is_some_and(|(r, t)| r <= self.bound.0 && t <= self.bound.1)
    }
}

/// Exit code 0: within bounds; 1: a bound is exceeded (or a trial failed); 2: bad input (main).
pub fn run(a: Args) -> Result<i32> {
    let mut a = a;
    a.trials = super::common::trials_cap(a.trials);
    let max = lasercal::schema::validator::MAX_TRIALS;
    if a.trials == 0 || a.trials > max || !(a.percentile > 0.0 && a.percentile <= 100.0) {
        bail!(
            "--trials {} --percentile {}: --trials must be from 1 to {max} and --percentile in \
             (0, 100]",
            a.trials,
            a.percentile
        );
    }
    let sf = load_scenario(&a.scenario)?;
    let bounds = bounds_of(&a, &sf.scenario.methods)?;
    let setup = sf.scenario.build(&sf.file)?;
    let seed = a.seed.unwrap_or(sf.scenario.seed);
    let p = a.percentile;
    let mut outcomes = Vec::new();
    for &(method, bound) in &bounds {
        let pb = progress(a.trials as u64, &method.to_string());
        let outs: Vec<_> = (0..a.trials as u64)
            .into_par_iter()
            .map(|t| {
                let o = run_trial(&setup, method, seed, t);
                pb.inc(1);
                o
            })
            .collect();
        pb.finish_and_clear();
        let failed: Vec<_> = outs
            .iter()
            .filter_map(|o| o.result.as_ref().err().map(|e| (o.trial, e)))
            .collect();
        let errors = |f: &dyn Fn(&lasercal::calib::PoseError) -> f64| -> Vec<f64> {
            outs.iter()
                .filter_map(|o| o.result.as_ref().ok().map(|s| f(&s.error())))
                .collect()
        };
        let (mut rot, mut tr) = (
            errors(&|e| e.rotation_error_deg),
            errors(&|e| e.translation_error_mm),
        );
        let first_failure = failed.first().map(|(t, e)| format!("trial {t}: {e}"));
        let figures =
            (failed.is_empty()).then(|| (percentile(&mut rot, p), percentile(&mut tr, p)));
        let line = match figures {
            None => format!(
                "FAIL {method}: {} of {} trials did not calibrate (first: {})",
                failed.len(),
                a.trials,
                first_failure.as_deref().unwrap_or("")
            ),
            Some((r, t)) => {
                // Both figures on every line, each against its bound.
                let part = |v: f64, b: f64, unit: &str| {
                    if v <= b {
                        format!("{v:.6} {unit} <= {b}")
                    } else {
                        format!("{v:.6} {unit} exceeds {b} by {:.6}", v - b)
                    }
                };
                let ok = r <= bound.0 && t <= bound.1;
                format!(
                    "{} {method}: p{p} rotation error {}, translation error {} ({} trials)",
                    if ok { "ok" } else { "FAIL" },
                    part(r, bound.0, "deg"),
                    part(t, bound.1, "mm"),
                    a.trials
                )
            }
        };
        say!("{line}");
        outcomes.push(Outcome {
            method,
            bound,
            figures,
            failed_trials: failed.len(),
            first_failure,
            line,
        });
    }
    let name = a.scenario.display().to_string();
    if let Some(path) = &a.json {
        let doc = serde_json::json!({
            "scenario": name,
            "seed": seed,
            "trials": a.trials,
            "percentile": p,
            "passed": outcomes.iter().all(Outcome::passed),
            "methods": outcomes.iter().map(|o| serde_json::json!({
                "method": o.method.to_string(),
                "passed": o.passed(),
                "rotation_error_deg": o.figures.map(|f| f.0),
                "translation_error_mm": o.figures.map(|f| f.1),
                "max_rotation_deg": o.bound.0,
                "max_translation_mm": o.bound.1,
                "failed_trials": o.failed_trials,
                "first_failure": o.first_failure,
            })).collect::<Vec<_>>(),
        });
        lasercal::io::write(path, serde_json::to_string_pretty(&doc)?.as_bytes())?;
    }
    if let Some(path) = &a.junit {
        lasercal::io::write(path, junit(&name, &outcomes).as_bytes())?;
    }
    Ok(if outcomes.iter().all(Outcome::passed) {
        0
    } else {
        1
    })
}

/// A JUnit XML report: one test suite for the scenario, one test case per method, a failure
/// carrying the line `check` printed.
fn junit(scenario: &str, outcomes: &[Outcome]) -> String {
    let esc = |s: &str| {
        s.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('"', "&quot;")
    };
    let failures = outcomes.iter().filter(|o| !o.passed()).count();
    let mut x = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites>\n  <testsuite name=\"lasercal \
         check {}\" tests=\"{}\" failures=\"{failures}\">\n",
        esc(scenario),
        outcomes.len()
    );
    for o in outcomes {
        x += &format!(
            "    <testcase classname=\"lasercal.check\" name=\"{}\">",
            esc(&o.method.to_string())
        );
        if o.passed() {
            x += &format!("<system-out>{}</system-out></testcase>\n", esc(&o.line));
        } else {
            x += &format!(
                "<failure message=\"{}\">{}</failure></testcase>\n",
                esc(&o.line),
                esc(&o.line)
            );
        }
    }
    x + "  </testsuite>\n</testsuites>\n"
}
