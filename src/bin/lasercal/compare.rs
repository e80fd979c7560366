use anyhow::{Context, Result, bail};
use lasercal::calib::PoseError;
use lasercal::calib::refine::predict::Prediction;
use lasercal::math::pose_to_rows_mm;
use lasercal::method::MethodId;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture file (JSON, docs/captures.md)
    file: PathBuf,
    /// Transforms to score: easy_handeye YAML (`calibrate --yaml`), a JSON file with a 4x4
    /// matrix in mm (`calibrate --json`, or another tool's result holding one 4x4 array), or a
    /// text file of 16 numbers (a 4x4 matrix, row by row, mm)
    #[arg(required = true)]
    transforms: Vec<PathBuf>,
    /// The variant whose residual problem scores them; by default the one `calibrate` chooses
    #[arg(long)]
    method: Option<MethodId>,
    /// Write the table as JSON
    #[arg(long)]
    json: Option<PathBuf>,
}

/// A prediction's figures in mm, for JSON.
pub fn prediction_json(p: &Prediction) -> serde_json::Value {
    serde_json::json!({
        "rms_mm": p.rms * 1e3,
        "worst_mm": p.worst * 1e3,
        "worst_pose": p.worst_pose + 1,
        "poses": p.poses,
    })
}

pub fn run(a: Args) -> Result<()> {
    let name = a.file.display().to_string();
    let (caps, sensor) = lasercal::io::captures::read(&a.file)?;
    if let Some(m) = a.method
        && m.kind != caps.method
    {
        bail!("--method {m}: {name} holds {} captures", caps.method);
    }
    let mut others = Vec::new();
    for t in &a.transforms {
        let tname = t.display().to_string();
        let text = std::fs::read_to_string(t).with_context(|| format!("{tname}: cannot read"))?;
        others.push((
            tname.clone(),
            lasercal::io::export::read_transform(&text, &tname)?,
        ));
    }
    let decision = super::common::decide(&name, &caps, &sensor, a.method)?;
    let method = decision.method();
    let cal = &decision.assessed().calibration;
    let Some(problem) = cal.problem(method.estimator) else {
        bail!(
            "{name}: {method} has no residual problem to score transforms by (the file holds \
             reduced features); give raw profiles or arc points"
        );
    };
    let own = cal.flange_to_sensor;
    say!(
        "{name}: each transform scored by {method}'s residuals, every pose predicted from the \
         others (the specimen refitted without it, the transform held); lasercal's verdict: {}",
        decision.judged.verdict
    );
    say!(
        "  {:<32} {:>22} {:>15} {:>15}",
        "transform",
        "from lasercal's",
        "predicted mm",
        "worst pose mm"
    );
    let mut rows = Vec::new();
    let mut score = |label: &str, x: &nalgebra::Isometry3<f64>| -> Result<()> {
        let p = problem.predict(x);
        let d = PoseError::between(x, &own);
        let from = if label == "lasercal" {
            "-".to_string()
        } else {
            format!(
                "{:.3} deg / {:.3} mm",
                d.rotation_error_deg, d.translation_error_mm
            )
        };
        match &p {
            Some(p) => say!(
                "  {:<32} {:>22} {:>15.4} {:>15}",
                label,
                from,
                p.rms * 1e3,
                format!("{:.4} (pose {})", p.worst * 1e3, p.worst_pose + 1)
            ),
            None => say!(
                "  {label:<32} {from:>22} {:>15} (fewer than 3 or more than {} poses)",
                "-",
                lasercal::calib::refine::predict::MAX_POSES
            ),
        }
        rows.push(serde_json::json!({
            "transform": label,
            "flange_to_sensor": pose_to_rows_mm(x),
            "from_lasercal_deg": d.rotation_error_deg,
            "from_lasercal_mm": d.translation_error_mm,
            "prediction": p.as_ref().map(prediction_json),
        }));
        Ok(())
    };
    score("lasercal", &own)?;
    for (label, x) in &others {
        score(label, x)?;
    }
    if let Some(p) = &a.json {
        let doc = serde_json::json!({ "file": name, "method": method, "transforms": rows });
        lasercal::io::write(p, serde_json::to_string_pretty(&doc)?.as_bytes())?;
    }
    Ok(())
}
