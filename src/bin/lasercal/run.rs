use super::common::{load_scenario, matrix_text};
use anyhow::{Result, bail};
use lasercal::math::pose_to_rows_mm;
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
}

pub fn run(a: Args) -> Result<()> {
    let sf = load_scenario(&a.scenario)?;
    let sc = &sf.scenario;
    let setup = sc.build(&sf.file)?;
    let seed = a.seed.unwrap_or(sc.seed);
    let truth = pose_to_rows_mm(&setup.rig.flange_to_sensor);
    println!("scenario {} (seed {seed}, trial {})", sc.name, a.trial);
    println!("truth flange_to_sensor (mm):\n{}", matrix_text(&truth));
    let mut results = Vec::new();
    let mut failed = false;
    for method in &sc.methods {
        let out = run_trial(&setup, method, seed, a.trial);
        match &out.result {
            Ok(s) => {
                let est = pose_to_rows_mm(&s.estimate);
                println!(
                    "\n{method}: recovered flange_to_sensor (mm):\n{}",
                    matrix_text(&est)
                );
                let mut line = format!(
                    "{method}: rotation error {:.6} deg, translation error {:.6} mm, |dR|_F {:.3e}",
                    s.error.rotation_error_deg,
                    s.error.translation_error_mm,
                    s.error.frobenius_rotation
                );
                for (name, v, unit) in [
                    ("centre error", s.centre_error_mm, "mm"),
                    ("centre spread (accuracy)", s.accuracy_mm, "mm"),
                    ("mean edge-direction deviation", s.edge_angle_dev_deg, "deg"),
                    ("mean point-to-edge distance", s.edge_distance_mm, "mm"),
                    ("reconstructed ball radius", s.sphere_radius_mm, "mm"),
                ] {
                    if let Some(v) = v {
                        line += &format!(", {name} {v:.4} {unit}");
                    }
                }
                if out.missed_profiles > 0 {
                    line += &format!(", {} profiles without the feature", out.missed_profiles);
                }
                println!("{line}");
                results.push(serde_json::json!({
                    "method": method,
                    "flange_to_sensor": est,
                    "truth": truth,
                    "rotation_error_deg": s.error.rotation_error_deg,
                    "translation_error_mm": s.error.translation_error_mm,
                    "frobenius_rotation": s.error.frobenius_rotation,
                    "centre_error_mm": s.centre_error_mm,
                    "accuracy_mm": s.accuracy_mm,
                    "edge_angle_dev_deg": s.edge_angle_dev_deg,
                    "edge_distance_mm": s.edge_distance_mm,
                    "sphere_radius_mm": s.sphere_radius_mm,
                    "missed_profiles": out.missed_profiles,
                    "status": s.status,
                }));
            }
            Err(e) => {
                eprintln!("{method}: calibration failed: {e}");
                results.push(serde_json::json!({ "method": method, "error": e, "truth": truth }));
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
        lasercal::io::write(path, serde_json::to_string_pretty(&doc)?.as_bytes())
            .map_err(anyhow::Error::msg)?;
    }
    if failed {
        bail!("at least one method failed");
    }
    Ok(())
}
