use super::common::{matrix_text, refinement, verdict_text};
use anyhow::{Result, bail};
use lasercal::calib::PoseError;
use lasercal::captures::Captures;
use lasercal::math::pose_to_rows_mm;
use lasercal::method::{MethodId, verdict};
use lasercal::metrics::Metric;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture file (JSON, docs/captures.md), from a real rig or `lasercal simulate`
    file: PathBuf,
    /// Method: by default every variant the file supports is run and judged, and the best kept;
    /// or one of them: the closed form (disk, ball, edge), its refinement (disk-refined,
    /// ball-refined, edge-refined), the any-pose estimator (ball-, disk-, edge-, plane-any-pose:
    /// any poses, no groups or signs), disk-full, edge-full (every face point too; raw profiles)
    #[arg(long)]
    method: Option<MethodId>,
    /// How far apart (deg) the captures a protocol wants at one orientation may be (a
    /// controller's jitter); overrides the file's orientation_tolerance_deg [default: 0.1]
    #[arg(long)]
    orientation_tolerance_deg: Option<f64>,
    /// The largest acceptable 95 % error bound on the rotation (deg); a larger one is judged
    /// imprecise (exit 4). Overrides the file's tolerance_deg [default: 0.5]
    #[arg(long, allow_negative_numbers = true)]
    tolerance_deg: Option<f64>,
    /// The same for the translation (mm); overrides the file's tolerance_mm [default: 0.5]
    #[arg(long, allow_negative_numbers = true)]
    tolerance_mm: Option<f64>,
    /// The robot's pose accuracy (mm, one standard deviation of a point's offset) that the
    /// residual test allows beside the sensor's noise; overrides the file's robot_accuracy_mm
    /// [default: 0.5]
    #[arg(long, allow_negative_numbers = true)]
    robot_accuracy_mm: Option<f64>,
    /// The robot's repeatability (mm, one standard deviation per axis of each pose's own error,
    /// about a data sheet's pose repeatability RP / 3.6): the residual test allows it with the
    /// accuracy, and the bound takes it as independent from pose to pose; overrides the file's
    /// robot_repeatability_mm [default: 0]
    #[arg(long, allow_negative_numbers = true)]
    robot_repeatability_mm: Option<f64>,
    /// The arm that took the poses (irb120, irb2600 or a URDF file's path): every pose is
    /// checked to be within its reach, and with --link-error-mm or --joint-offset-error-deg the
    /// bounds carry the arm's kinematic error through each pose's joint configuration;
    /// overrides the file's robot
    #[arg(long)]
    robot: Option<String>,
    /// One standard deviation of each joint origin's offset along each axis (mm, a link-length
    /// error of an arm whose kinematics are not calibrated); overrides the file's link_error_mm
    #[arg(long, allow_negative_numbers = true)]
    link_error_mm: Option<f64>,
    /// One standard deviation of each joint's zero (deg); overrides the file's
    /// joint_offset_error_deg
    #[arg(long, allow_negative_numbers = true)]
    joint_offset_error_deg: Option<f64>,
    /// One standard deviation of the disk's or ball's true radius about the stated one (mm, a
    /// certificate's standard uncertainty): the bounds then include what it moves the result;
    /// overrides the file's specimen.radius_tolerance_mm [default: 0, the radius exact]
    #[arg(long, allow_negative_numbers = true)]
    radius_tolerance_mm: Option<f64>,
    /// A straight edge's straightness tolerance (mm, peak to valley over the file's
    /// specimen.edge_length_mm, else over the span the profiles see): the bounds then include
    /// what such a bow moves the result; overrides the file's specimen.straightness_mm
    /// [default: 0, the edge straight]
    #[arg(long, allow_negative_numbers = true)]
    straightness_mm: Option<f64>,
    /// Profiles placed by time stamps on a pose_stream: take their clock offset as stated
    /// (profile_clock_offset_s) instead of estimating it with the transform; overrides the file's
    /// estimate_clock_offset
    #[arg(long)]
    hold_clock_offset: bool,
    /// With the clock offset estimated: estimate a drift of the profiler's clock against the
    /// controller's too (s per s); overrides the file's estimate_clock_drift
    #[arg(long, conflicts_with = "hold_clock_offset")]
    estimate_clock_drift: bool,
    /// Write the result as JSON
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the transform as easy_handeye-style YAML (metres, quaternion x y z w, covariance)
    #[arg(long)]
    yaml: Option<PathBuf>,
    /// Write the sensor link and its fixed joint on the flange as a URDF fragment
    #[arg(long)]
    urdf: Option<PathBuf>,
    /// Print the ROS 2 static_transform_publisher command for the transform, alone on standard
    /// output (the report goes to standard error): `$(lasercal calibrate FILE --ros2)` is the
    /// command
    #[arg(long)]
    ros2: bool,
    /// The flange frame's name in the exports
    #[arg(long, default_value = "tool0")]
    parent_frame: String,
    /// The sensor frame's name in the exports
    #[arg(long, default_value = "laser_sensor")]
    child_frame: String,
    /// Record the result into a Rerun .rrd file: every profile mapped into the base frame with
    /// the recovered transform, coloured by its distance from the specimen fitted there
    #[arg(long)]
    rerun: Option<PathBuf>,
    /// Open a Rerun viewer and stream the same recording to it
    #[arg(long)]
    spawn: bool,
}

/// Exit status of a calibration judged suspect (docs/verdict.md, "Exit codes").
pub const SUSPECT: i32 = 3;
/// Exit status of a calibration judged consistent but imprecise (its 95 % bound beyond the
/// tolerance).
pub const IMPRECISE: i32 = 4;

pub fn run(a: Args) -> Result<i32> {
    if a.ros2 {
        crate::REPORT_TO_STDERR.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    let name = a.file.display().to_string();
    lasercal::io::export::check_frame(&a.parent_frame, "--parent-frame")?;
    lasercal::io::export::check_frame(&a.child_frame, "--child-frame")?;
    let recorders = super::common::open_recorders(a.rerun.as_deref(), a.spawn)?;
    let stage = super::common::Stage::start(&format!("reading {name}"));
    let (mut caps, sensor) = lasercal::io::captures::read(&a.file)?;
    apply_flags(&a, &mut caps, &name)?;
    let known: Vec<String> = caps
        .method
        .estimators()
        .iter()
        .map(|&e| MethodId::new(caps.method, e).to_string())
        .collect();
    if let Some(m) = a.method
        && m.kind != caps.method
    {
        bail!(
            "--method {m}: {name} holds {} captures; use {}",
            caps.method,
            known.join(", ")
        );
    }
    // Every variant the file supports, unless one is asked for; the best judged result is kept
    // and tested against the rest (docs/verdict.md).
    stage.next(&format!(
        "calibrating {} profiles ({})",
        caps.profiles.len(),
        a.method
            .map_or("every variant".to_string(), |m| m.to_string())
    ));
    let decision = super::common::decide(&name, &caps, &sensor, a.method);
    stage.done();
    let decision = decision?;
    let variants = variants_table(&a, &name, &caps, &decision)?;
    let method = decision.method();
    let chosen = decision.assessed();
    if a.method.is_none() {
        say!(
            "chosen: {method} (the smallest 95 % error bound among the variants judged ok, else \
             not suspect; --method to choose another)"
        );
    }
    let judged = &decision.judged;
    let loo = decision.leave_one_out.as_ref();
    let cal = &chosen.calibration;
    let est = pose_to_rows_mm(&cal.flange_to_sensor);
    say!(
        "{method}: recovered flange_to_sensor (mm) from {} profiles:\n{}",
        caps.profiles.len(),
        matrix_text(&est)
    );
    for line in lasercal::method::GroupReport::summarise(&cal.groups) {
        say!("{line}");
    }
    let mut doc = serde_json::json!({
        "method": method,
        "flange_to_sensor": est,
        "centre_in_base_mm": cal.centre_in_base.map(|c| [c.x * 1e3, c.y * 1e3, c.z * 1e3]),
        "missed_profiles": cal.missed,
        "groups_left_out": cal.groups.iter().filter(|g| g.left_out).map(|g| g.group).collect::<Vec<_>>(),
        "status": cal.status,
        "variants": variants,
    });
    for m in [Metric::Accuracy, Metric::EdgeAngleDev, Metric::EdgeDistance] {
        doc[m.name()] = serde_json::json!(cal.figures.get(m));
    }
    if let Some(r) = &chosen.refined {
        doc["refinement"] = refinement(r);
    }
    doc["quality"] = verdict_text(method, judged, loo)?;
    // The truth-free figure another transform can be compared by (`lasercal compare`).
    if let Some(p) = cal
        .problem(method.estimator)
        .and_then(|p| p.predict(&cal.flange_to_sensor))
    {
        say!(
            "{method}: each pose predicted from the others (the specimen refitted without it, \
             the transform held): RMS {:.4} mm, worst pose {:.4} mm (pose {} of {}); `lasercal \
             compare {name} OTHER` scores another transform the same way",
            p.rms * 1e3,
            p.worst * 1e3,
            p.worst_pose + 1,
            p.poses
        );
        doc["prediction"] = super::compare::prediction_json(&p);
    }
    if let Some(t) = &caps.truth {
        let e = PoseError::between(&cal.flange_to_sensor, t);
        say!(
            "against the file's truth: rotation error {:.6} deg, translation error {:.6} mm",
            e.rotation_error_deg,
            e.translation_error_mm
        );
        doc["truth"] = serde_json::json!(pose_to_rows_mm(t));
        doc["rotation_error_deg"] = serde_json::json!(e.rotation_error_deg);
        doc["translation_error_mm"] = serde_json::json!(e.translation_error_mm);
    }
    if let Some(p) = &a.json {
        lasercal::io::write(p, serde_json::to_string_pretty(&doc)?.as_bytes())?;
    }
    export(&a, &cal.flange_to_sensor, judged)?;
    if !recorders.is_empty() {
        let summary = summary(&name, &caps, method, cal, judged);
        record(&recorders, &caps, &sensor, &cal.flange_to_sensor, &summary)?;
    }
    Ok(match judged.verdict {
        verdict::Verdict::Suspect => SUSPECT,
        verdict::Verdict::Imprecise => IMPRECISE,
        verdict::Verdict::Ok => 0,
    })
}

/// The flags that override the capture file's own fields, each checked as the file's is.
fn apply_flags(a: &Args, caps: &mut Captures, name: &str) -> Result<()> {
    if let Some(t) = a.orientation_tolerance_deg {
        caps.orientation_tolerance_deg =
            lasercal::io::captures::orientation_tolerance(t, name, "--orientation-tolerance-deg")?;
    }
    if let Some(t) = a.tolerance_deg {
        caps.judging.tolerance_deg = lasercal::io::captures::tolerance(t, name, "--tolerance-deg")?;
    }
    if let Some(t) = a.tolerance_mm {
        caps.judging.tolerance_mm = lasercal::io::captures::tolerance(t, name, "--tolerance-mm")?;
    }
    if let Some(r) = a.robot_accuracy_mm {
        caps.judging.robot_accuracy =
            lasercal::io::captures::robot_accuracy(r, name, "--robot-accuracy-mm")?;
    }
    if let Some(r) = a.robot_repeatability_mm {
        caps.judging.robot_repeatability =
            lasercal::io::captures::robot_repeatability(r, name, "--robot-repeatability-mm")?;
    }
    with_stated_arm(a, caps, name)?;
    if let Some(t) = a.radius_tolerance_mm {
        caps.judging.radius_tolerance = lasercal::io::captures::radius_tolerance(
            t,
            caps.specimen_radius.map(|r| r * 1e3),
            name,
            "--radius-tolerance-mm",
        )?;
    }
    if let Some(t) = a.straightness_mm {
        caps.judging.straightness =
            lasercal::io::captures::straightness(t, name, "--straightness-mm")?;
    }
    if a.hold_clock_offset || a.estimate_clock_drift {
        match caps.timing.as_mut() {
            Some(t) if a.hold_clock_offset => t.estimate_offset = false,
            Some(t) => t.estimate_drift = true,
            None => anyhow::bail!(
                "--hold-clock-offset / --estimate-clock-drift: {name} places no profile by its \
                 time stamp (no pose_stream and t_s): there is no profiler clock to hold or \
                 estimate; leave the flag out"
            ),
        }
    }
    Ok(())
}

/// Every variant's verdict, bounds and noise ratio, printed as a table when no `--method` was
/// asked for, and as the JSON rows of `variants`.
fn variants_table(
    a: &Args,
    name: &str,
    caps: &Captures,
    decision: &lasercal::method::verdict::Decision,
) -> Result<Vec<serde_json::Value>> {
    let mut variants = Vec::new();
    if a.method.is_none() {
        say!(
            "{name}: {} captures, {} groups, {} profiles; every variant:",
            caps.method,
            caps.groups.len(),
            caps.profiles.len()
        );
        say!(
            "  {:<15} {:<8} {:>12} {:>12} {:>13}",
            "variant",
            "verdict",
            "bound deg",
            "bound mm",
            "noise ratio"
        );
    }
    for (id, r) in &decision.results {
        let row = match r {
            Ok(x) => {
                let (br, bt) = x.judged.quality.error_bound();
                let nr = x.judged.quality.noise_ratio;
                if a.method.is_none() {
                    say!(
                        "  {:<15} {:<8} {br:>12.4} {bt:>12.4} {:>13}",
                        id.to_string(),
                        x.judged.verdict.to_string(),
                        nr.map_or("-".to_string(), |v| format!("{v:.2}"))
                    );
                }
                serde_json::json!({ "method": id, "verdict": x.judged.verdict,
                    "error_bound_deg": br, "error_bound_mm": bt, "noise_ratio": nr,
                    "flange_to_sensor": pose_to_rows_mm(&x.calibration.flange_to_sensor) })
            }
            Err(e) => {
                if a.method.is_none() {
                    // The first clause: the whole (per-group counts) is in --json.
                    let e = e.to_string();
                    let short = e.split(" | ").next().unwrap_or(&e);
                    let more = if short.len() < e.len() { " ..." } else { "" };
                    say!("  {:<15} cannot run: {short}{more}", id.to_string());
                }
                serde_json::json!({ "method": id, "error": e.to_string() })
            }
        };
        variants.push(row);
    }
    Ok(variants)
}

/// The transform out as the flags ask: YAML, a URDF fragment, the ROS 2 command.
fn export(
    a: &Args,
    flange_to_sensor: &nalgebra::Isometry3<f64>,
    judged: &verdict::Judged,
) -> Result<()> {
    let exported = lasercal::io::export::Exported {
        parent_frame: a.parent_frame.clone(),
        child_frame: a.child_frame.clone(),
        flange_to_sensor: *flange_to_sensor,
        covariance: judged.quality.covariance,
    };
    if let Some(p) = &a.yaml {
        lasercal::io::write(p, lasercal::io::export::to_yaml(&exported)?.as_bytes())?;
    }
    if let Some(p) = &a.urdf {
        lasercal::io::write(p, lasercal::io::export::to_urdf(&exported).as_bytes())?;
    }
    if a.ros2 {
        use std::io::Write as _;
        writeln!(
            std::io::stdout(),
            "{}",
            lasercal::io::export::ros2_command(&exported)
        )
        .map_err(|e| anyhow::anyhow!("cannot write to standard output: {e}"))?;
    }
    Ok(())
}

/// The recording's summary text: the file, the verdict, the profiles used and, where the file
/// has the truth, the error against it.
fn summary(
    name: &str,
    caps: &lasercal::captures::Captures,
    method: MethodId,
    cal: &lasercal::method::Calibration,
    judged: &verdict::Judged,
) -> String {
    let mut line = format!(
        "{} profiles, {} without the feature",
        caps.profiles.len(),
        cal.missed
    );
    if let Some(t) = &caps.truth {
        let e = PoseError::between(&cal.flange_to_sensor, t);
        line += &format!(
            "; against the file's truth: rotation error {:.6} deg, translation error {:.6} mm",
            e.rotation_error_deg, e.translation_error_mm
        );
    }
    super::common::summary_text(
        &format!("{name}: {} captures", caps.method),
        method,
        judged,
        &line,
        &cal.flange_to_sensor,
    )
}

#[cfg(feature = "rerun")]
fn record(
    recorders: &super::common::Recorders,
    caps: &lasercal::captures::Captures,
    sensor: &lasercal::sensor::SensorModel,
    flange_to_sensor: &nalgebra::Isometry3<f64>,
    summary: &str,
) -> Result<()> {
    let what = lasercal::io::rerun::Recorded {
        robot: None,
        scene: None,
        sensor,
        truth: caps.truth,
        summary,
    };
    for r in recorders {
        r.log_captures(&what, caps, flange_to_sensor)?;
    }
    Ok(())
}

#[cfg(not(feature = "rerun"))]
fn record(
    _: &super::common::Recorders,
    _: &lasercal::captures::Captures,
    _: &lasercal::sensor::SensorModel,
    _: &nalgebra::Isometry3<f64>,
    _: &str,
) -> Result<()> {
    Ok(())
}

/// The flags' arm and kinematic error over the file's (each flag over its own field), checked
/// against the poses as the file's are.
fn with_stated_arm(
    a: &Args,
    caps: &mut lasercal::captures::Captures,
    name: &str,
) -> anyhow::Result<()> {
    if a.robot.is_none() && a.link_error_mm.is_none() && a.joint_offset_error_deg.is_none() {
        return Ok(());
    }
    let k = caps.kinematic.as_ref();
    let stated = lasercal::io::captures::Stated {
        robot: a.robot.as_deref().or(k.map(|k| k.robot_name.as_str())),
        // The file's errors where it states them (an arm named alone states none).
        link_error_mm: (a.link_error_mm).or(k.filter(|k| k.errors_stated).map(|k| k.link_sd * 1e3)),
        joint_offset_error_deg: (a.joint_offset_error_deg).or(k
            .filter(|k| k.errors_stated)
            .map(|k| k.joint_zero_sd.to_degrees())),
        flags: true,
    };
    let kinematic = lasercal::io::captures::kinematic_of(
        &stated,
        caps.profiles.iter().map(|p| {
            (
                &p.base_to_flange,
                k.and_then(|k| k.joints_given(&p.base_to_flange)),
            )
        }),
        name,
        a.file.parent(),
    )?;
    caps.kinematic = kinematic;
    Ok(())
}
