use super::common::{matrix_text, refinement};
use anyhow::{Context, Result, bail};
use lasercal::calib::PoseError;
use lasercal::math::pose_to_rows_mm;
use lasercal::method::{Estimator, MethodId};
use lasercal::metrics::Metric;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture file (JSON, docs/captures.md), from a real rig or `lasercal simulate`
    file: PathBuf,
    /// Method: the file's specimen method (disk, ball or edge), closed form by default (any-pose
    /// for a file of free poses); its refined variant (disk-refined, ball-refined, edge-refined);
    /// its any-pose estimator (ball-, disk-, edge-any-pose: any poses, no groups or signs);
    /// disk-full, edge-full (every face point too; raw profiles); plane-any-pose for plane files
    #[arg(long)]
    method: Option<MethodId>,
    /// How far apart (deg) the captures a protocol wants at one orientation may be (a
    /// controller's jitter); overrides the file's orientation_tolerance_deg [default: 0.1]
    #[arg(long)]
    orientation_tolerance_deg: Option<f64>,
    /// Write the result as JSON
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<()> {
    let name = a.file.display().to_string();
    let text = std::fs::read_to_string(&a.file).with_context(|| format!("{name}: cannot read"))?;
    let (mut caps, sensor) = lasercal::io::captures::from_json(&text, &name)?;
    if let Some(t) = a.orientation_tolerance_deg {
        caps.orientation_tolerance_deg =
            lasercal::io::captures::orientation_tolerance(t, &name, "--orientation-tolerance-deg")?;
    }
    // Free poses (one profile each, no protocol groups): the any-pose estimator; else the paper's.
    let free = caps
        .groups
        .iter()
        .all(|g| g.role == lasercal::captures::Role::Pose);
    let default = match caps.method.estimators() {
        e if free && e.contains(&Estimator::AnyPose) => Estimator::AnyPose,
        e => e[0],
    };
    let method = a.method.unwrap_or(MethodId::new(caps.method, default));
    if a.method.is_none() && default == Estimator::AnyPose {
        eprintln!("{name}: free poses, so {method} (give --method to choose another)");
    }
    if method.kind != caps.method {
        let known: Vec<String> = caps
            .method
            .estimators()
            .iter()
            .map(|&e| MethodId::new(caps.method, e).to_string())
            .collect();
        bail!(
            "--method {method}: {name} holds {} captures; use {}",
            caps.method,
            known.join(", ")
        );
    }
    let (cal, refined) = lasercal::method::estimate(method, &caps, &sensor)
        .with_context(|| format!("{name}: {method} calibration failed"))?;
    let est = pose_to_rows_mm(&cal.flange_to_sensor);
    println!(
        "{method}: recovered flange_to_sensor (mm) from {} profiles:\n{}",
        caps.profiles.len(),
        matrix_text(&est)
    );
    if cal.missed > 0 {
        println!(
            "{} profiles did not show the feature and were left out",
            cal.missed
        );
    }
    for g in cal
        .groups
        .iter()
        .filter(|g| g.left_out || !g.rejected.is_empty())
    {
        println!("{}", g.describe());
    }
    let mut doc = serde_json::json!({
        "method": method,
        "flange_to_sensor": est,
        "centre_in_base_mm": cal.centre_in_base.map(|c| [c.x * 1e3, c.y * 1e3, c.z * 1e3]),
        "missed_profiles": cal.missed,
        "groups_left_out": cal.groups.iter().filter(|g| g.left_out).map(|g| g.group).collect::<Vec<_>>(),
        "status": cal.status,
    });
    for m in [Metric::Accuracy, Metric::EdgeAngleDev, Metric::EdgeDistance] {
        doc[m.name()] = serde_json::json!(cal.figures.get(m));
    }
    if let Some(r) = &refined {
        doc["refinement"] = refinement(method, r);
    }
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
        lasercal::io::write(p, serde_json::to_string_pretty(&doc)?.as_bytes())?;
    }
    Ok(())
}
