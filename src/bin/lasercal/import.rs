use anyhow::{Context, Result, bail};
use lasercal::io::import::{Header, ProfileSource, Timing, capture_file, flange_poses};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Poses, one per profile: a CSV whose header names the convention (x_mm,y_mm,z_mm with
    /// qw,qx,qy,qz (ABB) or qx,qy,qz,qw (ROS) or w_deg,p_deg,r_deg (FANUC, Yaskawa) or
    /// a_deg,b_deg,c_deg (KUKA) or rx_rad,ry_rad,rz_rad (UR); m00..m33 (4x4, translation
    /// m03_mm, m13_mm, m23_mm); or j1_deg..j6_deg with --robot); a FANUC .ls program (P[n]
    /// blocks); ABB RAPID robtargets; a JSON list or text lines of x y z w p r (mm, deg, FANUC
    /// W, P, R); or a folder of HALCON pose files (.dat, type 0, one per pose)
    #[arg(long)]
    poses: PathBuf,
    /// Profiles: a folder of one file per pose (natural name order = pose order): CSV
    /// (x_mm,z_mm), NPY float64 (n, 2), OpenCV YAML (.yml: an !!opencv-matrix or a list of
    /// (x, 0, z) per point) or two-row text (.txt: the x values, then the z values); or one CSV
    /// with pose,x_mm,z_mm (pose: 0-based row of the pose list) or one NPY (n, 3) likewise. NaN
    /// or an empty cell where a column has no point
    #[arg(long)]
    profiles: PathBuf,
    /// The z value (mm) the profiler writes where a column has no point (e.g. 0 or -999)
    #[arg(long, allow_negative_numbers = true)]
    missing_z_mm: Option<f64>,
    /// Sensor preset (gocator-2340, vlm350, ...), or a JSON file declaring the sensor (the
    /// record a capture file's `sensor` holds: name, columns, spacing, z_axis, apex_z_mm, ...;
    /// docs/sensors.md). Not given (or points-only): a sensor known only by its points
    #[arg(long, default_value = "points-only")]
    sensor: String,
    /// A points-only sensor's z axis: away (z grows away from the sensor, a distance) or toward
    /// (a height, as a Gocator's); a disk's or an edge's profiles need it, a ball's arcs show it
    #[arg(long, value_parser = ["away", "toward"])]
    z_axis: Option<String>,
    /// Specimen method: ball, disk, edge or plane
    #[arg(long)]
    method: String,
    /// Specimen kind (ball, disk-cylinder, disk-paper, parallel-bar, scale, knife-blade, plane)
    #[arg(long)]
    specimen: String,
    /// The specimen's radius (ball, disk), mm
    #[arg(long)]
    radius_mm: Option<f64>,
    /// The sensor's z noise, mm (one standard deviation, from its data sheet): the verdict's
    /// residual test compares with it
    #[arg(long)]
    z_sigma_mm: Option<f64>,
    /// The robot's pose accuracy, mm (one standard deviation of a measured point's offset that
    /// its pose error makes): the verdict's bound and residual test include it [default when
    /// not given: 0.5]
    #[arg(long, allow_negative_numbers = true)]
    robot_accuracy_mm: Option<f64>,
    /// The robot's repeatability, mm (one standard deviation per axis of each pose's own error,
    /// about a data sheet's pose repeatability RP / 3.6): the residual test allows it, and the
    /// bound takes it as independent from pose to pose [default when not given: 0]
    #[arg(long, allow_negative_numbers = true)]
    robot_repeatability_mm: Option<f64>,
    /// Robot (irb120, irb2600 or a URDF path): needed for a pose list of joint angles; written
    /// to the capture file, whose poses are then checked to be within its reach
    #[arg(long)]
    robot: Option<String>,
    /// The arm's kinematic error: one standard deviation of each joint origin's offset per axis
    /// (mm), which the verdict's bound carries through each pose's configuration (needs --robot)
    #[arg(long, allow_negative_numbers = true)]
    link_error_mm: Option<f64>,
    /// The same for each joint's zero (deg; needs --robot)
    #[arg(long, allow_negative_numbers = true)]
    joint_offset_error_deg: Option<f64>,
    /// Capture file to write (JSON)
    #[arg(long)]
    out: PathBuf,
    /// Store the profiles' points in a compressed array beside the file (NAME.points.npy.gz,
    /// float32: about a tenth of the size)
    #[arg(long)]
    compact: bool,
    /// Scanning on the move: a CSV with each profile's time stamp (s, column t_s; one row per
    /// profile in the profiles' order). The pose list is then the controller's log: its first
    /// column t_s, then the pose's columns; each profile's pose is interpolated at its time
    #[arg(long)]
    profile_times: Option<PathBuf>,
    /// Seconds to add to the profiles' time stamps to put them on the pose log's clock (the
    /// profiler's latency; default 0)
    #[arg(long, allow_negative_numbers = true, requires = "profile_times")]
    profile_clock_offset_s: Option<f64>,
}

pub fn run(a: Args) -> Result<()> {
    let pname = a.poses.display().to_string();
    let meta = std::fs::metadata(&a.poses).with_context(|| format!("{pname}: cannot read"))?;
    if meta.len() > 64 << 20 {
        bail!(
            "{pname}: {} bytes; a pose list is at most 64 MB",
            meta.len()
        );
    }
    let text = if meta.is_dir() {
        None
    } else {
        Some(std::fs::read_to_string(&a.poses).with_context(|| format!("{pname}: cannot read"))?)
    };
    // With time stamps the pose list is a log: its t_s column split off first.
    let (pose_times, text) = match (&a.profile_times, text) {
        (Some(_), Some(t)) => {
            let (times, rest) = lasercal::io::import::split_times(&t, &pname)?;
            (Some(times), Some(rest))
        }
        (Some(_), None) => bail!(
            "{pname}: with --profile-times the poses are a CSV log (t_s, then the pose's columns), \
             not a folder"
        ),
        (None, t) => (None, t),
    };
    let list = lasercal::io::import::pose_list(&a.poses, text.as_deref())?;
    let robot = a
        .robot
        .as_deref()
        .map(lasercal::robot::Robot::resolve)
        .transpose()?;
    let poses = flange_poses(list.key, &list.rows, &list.at, robot.as_ref(), &pname)?;
    note!("{pname}: {}", list.summary);
    for w in &list.warnings {
        eprintln!("warning: {w}");
    }
    for (v, name) in [(a.radius_mm, "--radius-mm"), (a.z_sigma_mm, "--z-sigma-mm")] {
        if let Some(x) = v
            && !(x > 0.0 && x <= 1e5)
        {
            bail!("{name} {x}: give a positive number of mm");
        }
    }
    if let Some(r) = a.robot_accuracy_mm {
        lasercal::io::captures::robot_accuracy(r, "lasercal import", "--robot-accuracy-mm")?;
    }
    if let Some(r) = a.robot_repeatability_mm {
        lasercal::io::captures::robot_repeatability(
            r,
            "lasercal import",
            "--robot-repeatability-mm",
        )?;
    }
    let source = profile_source(&a.profiles)?;
    let sensor = sensor_declaration(&a)?;
    let header = Header {
        method: &a.method,
        sensor,
        specimen: &a.specimen,
        radius_mm: a.radius_mm,
        feature_sigma_mm: None,
        z_sigma_mm: a.z_sigma_mm,
        robot_accuracy_mm: a.robot_accuracy_mm,
        robot_repeatability_mm: a.robot_repeatability_mm,
        robot: a.robot.as_deref(),
        joints_deg: (list.key == "joints_deg").then_some(&list.rows[..]),
        link_error_mm: a.link_error_mm,
        joint_offset_error_deg: a.joint_offset_error_deg,
        missing_z_mm: a.missing_z_mm,
    };
    let timing = match (&a.profile_times, pose_times) {
        (Some(path), Some(pose_times)) => {
            let name = path.display().to_string();
            let f = std::fs::File::open(path).with_context(|| format!("{name}: cannot read"))?;
            if let Some(o) = a.profile_clock_offset_s
                && !o.is_finite()
            {
                bail!("--profile-clock-offset-s {o}: give a number of seconds");
            }
            Some(Timing {
                pose_times,
                profile_times: lasercal::io::import::profile_times(f, &name)?,
                offset_s: a.profile_clock_offset_s,
            })
        }
        _ => None,
    };
    let text = capture_file(&header, &pname, &poses, source, timing.as_ref())?;
    lasercal::io::captures::write(&a.out, &text, a.compact)?;
    let what = match &timing {
        Some(t) => format!(
            "{} profiles placed by their time stamps on a log of {} poses ({})",
            t.profile_times.len(),
            poses.len(),
            list.key
        ),
        None => format!("{} poses ({}) with their profiles", poses.len(), list.key),
    };
    note!(
        "{}: {what}; calibrate it with `lasercal calibrate {}`",
        a.out.display(),
        a.out.display()
    );
    Ok(())
}

/// The profiles: one file per pose from a folder (in natural order of their names), or one
/// long file.
fn profile_source(profiles: &std::path::Path) -> Result<ProfileSource<'static>> {
    Ok(if profiles.is_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(&profiles)
            .with_context(|| format!("{}: cannot list", profiles.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.extension().is_some_and(|x| {
                    ["csv", "npy", "yml", "yaml", "txt"]
                        .iter()
                        .any(|e| x.eq_ignore_ascii_case(e))
                })
            })
            .collect();
        files.sort_by(|x, y| {
            lasercal::io::poses::natural_cmp(&x.to_string_lossy(), &y.to_string_lossy())
        });
        let mut readers: Vec<(String, Box<dyn std::io::Read>)> = Vec::new();
        for p in files {
            let name = p.display().to_string();
            let f = std::fs::File::open(&p).with_context(|| format!("{name}: cannot read"))?;
            readers.push((name, Box::new(f)));
        }
        ProfileSource::PerPose(readers)
    } else {
        let name = profiles.display().to_string();
        let f = std::fs::File::open(&profiles).with_context(|| format!("{name}: cannot read"))?;
        ProfileSource::Long(name, Box::new(f))
    })
}

/// The sensor as the capture file states it: a preset's name, a file declaring the sensor, or
/// points only (with `--z-axis`, which only that takes).
fn sensor_declaration(a: &Args) -> Result<serde_json::Value> {
    if a.z_axis.is_some() && a.sensor != lasercal::io::captures::POINTS_ONLY {
        bail!(
            "--z-axis is for a sensor known only by its points; {} states its own frame (drop \
             --z-axis, or --sensor)",
            a.sensor
        );
    }
    // A preset's name, a file declaring the sensor, or points only.
    Ok(if a.sensor == lasercal::io::captures::POINTS_ONLY {
        match &a.z_axis {
            Some(z) => serde_json::json!({ "points_only": { "z_axis": z } }),
            None => serde_json::json!({ "points_only": {} }),
        }
    } else if std::path::Path::new(&a.sensor).is_file() {
        let text = std::fs::read_to_string(&a.sensor)
            .with_context(|| format!("{}: cannot read", a.sensor))?;
        let v: serde_json::Value = serde_json::from_str(&text).with_context(|| {
            format!(
                "{}: not a sensor declaration (a JSON object as a capture file's \"sensor\"; \
                 docs/sensors.md)",
                a.sensor
            )
        })?;
        if !v.is_object() {
            bail!(
                "{}: a sensor declaration is a JSON object (name, columns, spacing, z_axis, \
                 apex_z_mm, ...; docs/sensors.md)",
                a.sensor
            );
        }
        v
    } else {
        serde_json::Value::String(a.sensor.clone())
    })
}
