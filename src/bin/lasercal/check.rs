use super::common::{load_scenario, progress};
use anyhow::{Result, bail};
use lasercal::trial::run_trial;
use rayon::prelude::*;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (its base values; a sweep grid is ignored)
    scenario: PathBuf,
    /// Largest allowed rotation error (deg) at the percentile
    #[arg(long)]
    max_rotation_deg: f64,
    /// Largest allowed translation error (mm) at the percentile
    #[arg(long)]
    max_translation_mm: f64,
    /// Number of trials
    #[arg(long, default_value_t = 100)]
    trials: usize,
    /// Percentile of the errors compared with the bounds (nearest rank)
    #[arg(long, default_value_t = 95.0)]
    percentile: f64,
    /// Seed (default: the scenario's)
    #[arg(long)]
    seed: Option<u64>,
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let rank = ((p / 100.0 * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[rank - 1]
}

/// Exit code 0: within bounds; 1: a bound is exceeded (or a trial failed); 2: bad input (main).
pub fn run(a: Args) -> Result<i32> {
    let mut a = a;
    a.trials = super::common::trials_cap(a.trials);
    if !(a.max_rotation_deg > 0.0 && a.max_translation_mm > 0.0) {
        bail!("--max-rotation-deg and --max-translation-mm must be positive");
    }
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
    let setup = sf.scenario.build(&sf.file)?;
    let seed = a.seed.unwrap_or(sf.scenario.seed);
    let mut code = 0;
    for &method in &sf.scenario.methods {
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
        let mut rot: Vec<f64> = outs
            .iter()
            .filter_map(|o| o.result.as_ref().ok().map(|s| s.error().rotation_error_deg))
            .collect();
        let mut tr: Vec<f64> = outs
            .iter()
            .filter_map(|o| {
                o.result
                    .as_ref()
                    .ok()
                    .map(|s| s.error().translation_error_mm)
            })
            .collect();
        if !failed.is_empty() {
            say!(
                "FAIL {method}: {} of {} trials did not calibrate (first: trial {}: {})",
                failed.len(),
                a.trials,
                failed[0].0,
                failed[0].1
            );
            code = 1;
            continue;
        }
        let (r, t) = (
            percentile(&mut rot, a.percentile),
            percentile(&mut tr, a.percentile),
        );
        let p = a.percentile;
        let mut ok = true;
        if r > a.max_rotation_deg {
            say!(
                "FAIL {method}: p{p} rotation error {r:.6} deg exceeds {} deg by {:.6} deg",
                a.max_rotation_deg,
                r - a.max_rotation_deg
            );
            ok = false;
        }
        if t > a.max_translation_mm {
            say!(
                "FAIL {method}: p{p} translation error {t:.6} mm exceeds {} mm by {:.6} mm",
                a.max_translation_mm,
                t - a.max_translation_mm
            );
            ok = false;
        }
        if ok {
            say!(
                "ok {method}: p{p} rotation error {r:.6} deg <= {}, translation error {t:.6} mm <= {} ({} trials)",
                a.max_rotation_deg,
                a.max_translation_mm,
                a.trials
            );
        } else {
            code = 1;
        }
    }
    Ok(code)
}
