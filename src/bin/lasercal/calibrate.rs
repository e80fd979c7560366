use super::common::matrix_text;
use anyhow::{Context, Result, bail};
use lasercal::calib::PoseError;
use lasercal::math::pose_to_rows_mm;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture file (JSON, docs/captures.md), from a real rig or `lasercal simulate`
    file: PathBuf,
    /// Method: disk, ball or edge (must match the file's)
    #[arg(long)]
    method: Option<String>,
    /// Write the result as JSON
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<()> {
    let name = a.file.display().to_string();
    let text = std::fs::read_to_string(&a.file).with_context(|| format!("{name}: cannot read"))?;
    let (caps, sensor) =
        lasercal::io::captures::from_json(&text, &name).map_err(anyhow::Error::msg)?;
    if let Some(m) = &a.method
        && *m != caps.method
    {
        bail!("--method {m}: {name} holds {} captures", caps.method);
    }
    let cal = lasercal::captures::calibrate(&caps, &sensor)
        .map_err(|e| anyhow::anyhow!("{name}: {} calibration failed: {e}", caps.method))?;
    let est = pose_to_rows_mm(&cal.flange_to_sensor);
    println!(
        "{}: recovered flange_to_sensor (mm) from {} profiles:\n{}",
        caps.method,
        caps.profiles.len(),
        matrix_text(&est)
    );
    if cal.missed > 0 {
        println!(
            "{} profiles did not show the feature and were left out",
            cal.missed
        );
    }
    let mut doc = serde_json::json!({
        "method": caps.method,
        "flange_to_sensor": est,
        "centre_in_base_mm": cal.centre_in_base.map(|c| [c.x * 1e3, c.y * 1e3, c.z * 1e3]),
        "accuracy_mm": cal.accuracy.map(|x| x * 1e3),
        "edge_angle_dev_deg": cal.edge_angle_dev.map(f64::to_degrees),
        "edge_distance_mm": cal.edge_distance.map(|x| x * 1e3),
        "missed_profiles": cal.missed,
        "status": cal.status,
    });
    if let Some(t) = &caps.truth {
        let e = PoseError::between(&cal.flange_to_sensor, t);
        println!(
            "against the file's truth: rotation error {:.6} deg, translation error {:.6} mm",
            e.rotation_error_deg, e.translation_error_mm
        );
        doc["truth"] = serde_json::json!(pose_to_rows_mm(t));
        doc["rotation_error_deg"] = serde_json::json!(e.rotation_error_deg);
        doc["translation_error_mm"] = serde_json::json!(e.translation_error_mm);
    }
    if let Some(p) = &a.json {
        lasercal::io::write(p, serde_json::to_string_pretty(&doc)?.as_bytes())
            .map_err(anyhow::Error::msg)?;
    }
    Ok(())
}
