use super::common::{load_scenario, matrix_text, refinement, verdict_text};
use anyhow::{Result, bail};
use lasercal::math::pose_to_rows_mm;
use lasercal::method::MethodId;
use lasercal::metrics::Metric;
use lasercal::trial::run_trial;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML)
    scenario: PathBuf,
    /// Seed (default: the scenario's)
    #[arg(long)]
    seed: Option<u64>,
    /// Trial index (the noise draw)
    #[arg(long, default_value_t = 0)]
    trial: u64,
    /// Write the result as JSON
    #[arg(long)]
    json: Option<PathBuf>,
    /// Record the run (arm, specimen, laser fan, profiles, features, true and recovered sensor
    /// frames) into a Rerun .rrd file
    #[arg(long)]
    rerun: Option<PathBuf>,
    /// Open a Rerun viewer and stream the recording to it
    #[arg(long)]
    spawn: bool,
    /// Method to record with --rerun/--spawn (default: the scenario's first)
    #[arg(long)]
    rerun_method: Option<MethodId>,
}

#[cfg(feature = "rerun")]
fn record(
    a: &Args,
    recorders: &super::common::Recorders,
    setup: &lasercal::scenario::Setup,
    methods: &[MethodId],
    seed: u64,
    estimates: &[(MethodId, nalgebra::Isometry3<f64>, String)],
) -> Result<()> {
    let method = a.rerun_method.unwrap_or(methods[0]);
    let Some((_, est, summary)) = estimates.iter().find(|(m, _, _)| *m == method) else {
        bail!("--rerun-method {method}: no calibration of that method in this run");
    };
    let (caps, _) = lasercal::trial::trial_captures(setup, method.kind, seed, a.trial);
    let caps = caps?;
    for r in recorders {
        r.log_run(setup, &caps, est, summary)?;
    }
    super::common::warn_skipped_meshes(recorders);
    Ok(())
}

#[cfg(not(feature = "rerun"))]
fn record(
    _: &Args,
    _: &super::common::Recorders,
    _: &lasercal::scenario::Setup,
    _: &[MethodId],
    _: u64,
    _: &[(MethodId, nalgebra::Isometry3<f64>, String)],
) -> Result<()> {
    Ok(())
}

pub fn run(a: Args) -> Result<()> {
    let sf = load_scenario(&a.scenario)?;
    let sc = &sf.scenario;
    let setup = sc.build(&sf.file)?;
    if let Some(m) = a.rerun_method
        && !sc.methods.contains(&m)
    {
        bail!(
            "--rerun-method {m}: the scenario runs {}; record one of those",
            sc.methods
                .iter()
                .map(|m| m.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let recorders = super::common::open_recorders(a.rerun.as_deref(), a.spawn)?;
    let seed = a.seed.unwrap_or(sc.seed);
    let truth = pose_to_rows_mm(&setup.rig.flange_to_sensor);
    say!("scenario {} (seed {seed}, trial {})", sc.name, a.trial);
    say!("truth flange_to_sensor (mm):\n{}", matrix_text(&truth));
    let mut results = Vec::new();
    let mut estimates = Vec::new();
    let mut failed = false;
    for &method in &sc.methods {
        let out = run_trial(&setup, method, seed, a.trial);
        match &out.result {
            Ok(s) => {
                let error = s.error();
                let est = pose_to_rows_mm(&s.estimate);
                say!(
                    "\n{method}: recovered flange_to_sensor (mm):\n{}",
                    matrix_text(&est)
                );
                let mut line = format!(
                    "{method}: rotation error {:.6} deg, translation error {:.6} mm, |dR|_F {:.3e}",
                    error.rotation_error_deg, error.translation_error_mm, error.frobenius_rotation
                );
                // The verdict's own figures are printed with it, below.
                for (m, v) in s.metrics.present().skip(3).filter(|(m, _)| !m.is_verdict()) {
                    line += &format!(", {} {v:.4} {}", m.words(), m.unit());
                }
                if out.missed_profiles > 0 {
                    line += &format!(", {} profiles without the feature", out.missed_profiles);
                }
                say!("{line}");
                let refined = s.refined.as_ref().map(refinement);
                let quality = verdict_text(method, &s.judged, None)?;
                estimates.push((
                    method,
                    s.estimate,
                    super::common::summary_text(
                        &format!("scenario {} (seed {seed}, trial {})", sc.name, a.trial),
                        method,
                        &s.judged,
                        &line,
                        &s.estimate,
                    ),
                ));
                let mut doc = serde_json::json!({
                    "refinement": refined,
                    "quality": quality,
                    "method": method,
                    "flange_to_sensor": est,
                    "truth": truth,
                    "missed_profiles": out.missed_profiles,
                    "status": s.status,
                });
                for m in Metric::ALL {
                    doc[m.name()] = serde_json::json!(s.metrics.get(m));
                }
                results.push(doc);
            }
            Err(e) => {
                note!(
                    "{method}: calibration failed: {}",
                    super::common::without_kind(method, &e)
                );
                results.push(
                    serde_json::json!({ "method": method, "error": e.to_string(), "truth": truth }),
                );
                failed = true;
            }
        }
    }
    if let Some(path) = &a.json {
        // One method: a flat object; several: keyed by method.
        let doc = if results.len() == 1 {
            let mut r = results.remove(0);
            r["scenario"] = serde_json::json!(sc.name);
            r["seed"] = serde_json::json!(seed);
            r["trial"] = serde_json::json!(a.trial);
            r
        } else {
            serde_json::json!({ "scenario": sc.name, "seed": seed, "trial": a.trial, "methods": results })
        };
        lasercal::io::write(path, serde_json::to_string_pretty(&doc)?.as_bytes())?;
    }
    if !recorders.is_empty() {
        record(&a, &recorders, &setup, &sc.methods, seed, &estimates)?;
    }
    if failed {
        bail!("at least one method failed");
    }
    Ok(())
}
